"""The 2^n equilibria of the chain pendulum on a cart, found by Newton on (S^2)^n x R^2.

The model of paper 003 (12)-(13) (models.chain_cart with the Section 5 values m = 0.5,
m_i = 0.1, l_i = 0.1, g = 9.81), n = 1..6. The structure of Section 3.1 names the
candidates: every link vertical, q_i = s_i e3. For every sign pattern s the guess is the
candidate *perturbed* (seeded: every link rotated by about 0.05 rad, angular velocities,
cart position and velocity of the same size), and workbench.equilibria._equilibria.enumerate_equilibria
runs Newton on the manifold (the retraction keeps each q_i on S^2 and each omega_i tangent)
from each guess. Measured for every n: the number of distinct equilibria (2^n), that each
solve converged to the equilibrium of its own sign pattern, the residual |f| and the
alignment |q_i x e3|, zero velocities, the dimension of the equilibrium set at each point
(2: the cart position is free, from the rank of the graph's Jacobian), the Newton
iterations, and the unstable dimension of each equilibrium from the linearisation
(reference: 2 #{i : s_i = -1}, the number of negative entries of G_qq in (16) times the two
horizontal directions, by Sylvester's law of inertia since M is positive definite).

Hard cases: with a constant horizontal force on the cart there is no equilibrium (the
momentum grows at the rate u); Newton reports that as a status (STAGNATED, a local minimum
of |f| that is not a zero), not as a wrong answer. A start far from every equilibrium with
a small iteration budget reports MAX_ITERATIONS.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from models.chain_cart import chain_cart, link_state
from models.relative_equilibria import stability_label
from workbench.core.manifolds import so3_exp
from workbench.equilibria import RootStatus, enumerate_equilibria, find_equilibrium
from workbench.study import Result

TITLE = "Chain pendulum on a cart: the 2^n equilibria by Newton on the manifold, n = 1..6 " \
        "(paper 003 Sec. 3.1)"

PARAMS = {"m": 0.5, "masses": 0.1, "lengths": 0.1, "g": 9.81}
E3 = np.array([0.0, 0.0, 1.0])
PERTURBATION = 0.05
SEED = 20030
N_MAX = 6


def perturbed_guess(s: tuple[int, ...], rng: np.random.Generator, size: float) -> np.ndarray:
    """The candidate ``q_i = s_i e3`` rotated by random small angles, with small velocities.

    Every part stays on its factor exactly (rotations of unit vectors, velocities taken
    tangent), so the guess needs no projection.
    """
    parts = [size * rng.standard_normal(2), size * rng.standard_normal(2)]
    for si in s:
        q = so3_exp(size * rng.standard_normal(3)) @ (si * E3)
        w = np.cross(size * rng.standard_normal(3), q)
        parts.append(link_state(q, w))
    return np.concatenate(parts)


def signs_of(x: np.ndarray, n: int) -> tuple[int, ...]:
    """Sign pattern ``s_i = sign(q_i . e3)`` of a chain state."""
    links = x[4:].reshape(n, 6)
    return tuple(int(np.sign(q[2])) for q in links[:, :3])


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        Up to n = 5 instead of 6 (the stability classification stays on for all).

    Returns
    -------
    Result
    """
    res = Result("chain_equilibria", TITLE, quick=quick)
    rng = np.random.default_rng(SEED)
    n_max = 5 if quick else N_MAX
    per_n: dict[str, Any] = {}
    histories: dict[int, list[list[float]]] = {}
    for n in range(1, n_max + 1):
        model = chain_cart(n, **PARAMS)
        res.use(model)
        patterns = list(itertools.product((1, -1), repeat=n))
        guesses = [perturbed_guess(s, rng, PERTURBATION) for s in patterns]
        with res.timed(f"n = {n}: Newton from {2 ** n} guesses"):
            found = enumerate_equilibria(model, guesses, tol=1e-12)
        eqs = found.equilibria
        own = sum(1 for eq, src in zip(eqs, found.sources)
                  if all(signs_of(eq.x, n) == patterns[i] for i in src))
        links = np.array([eq.x[4:].reshape(n, 6) for eq in eqs])
        align = float(np.max(np.abs(np.cross(links[:, :, :3], E3)))) if eqs else np.nan
        speed = float(max(np.max(np.abs(links[:, :, 3:])),
                          max(np.max(np.abs(eq.x[2:4])) for eq in eqs))) if eqs else np.nan
        with res.timed(f"n = {n}: stability"):
            labels = [stability_label(model, eq.x) for eq in eqs]
        match = sum(1 for eq, lab in zip(eqs, labels)
                    if lab[0] == 2 * signs_of(eq.x, n).count(-1) and lab[1] == 0)
        res.compare(f"n = {n}: distinct equilibria found", 2 ** n, len(eqs), tolerance=0,
                    source="Sec. 3.1: 2^n vertical configurations")
        res.compare(f"n = {n}: solves that converged to their own sign pattern", 2 ** n, own,
                    tolerance=0, source="nearest candidate")
        res.compare(f"n = {n}: max |f(x_e, 0)|", 0.0,
                    max(eq.residual for eq in eqs), tolerance=1e-10, source="model graph")
        res.compare(f"n = {n}: max |q_i x e3|", 0.0, align, tolerance=1e-12,
                    source="Sec. 3.1: q_i x e3 = 0")
        res.compare(f"n = {n}: max |omega_i|, |v|", 0.0, speed, tolerance=1e-12,
                    source="equilibrium at rest")
        res.compare(f"n = {n}: equilibria with a free cart position (set of dimension 2)",
                    2 ** n, sum(1 for eq in eqs if eq.local_dimension == 2), tolerance=0,
                    source="f does not depend on x (translation symmetry)")
        res.compare(f"n = {n}: unstable dimension = 2 #(s_i = -1) at every equilibrium",
                    2 ** n, match, tolerance=0,
                    source="(16): inertia of G_qq = diag(s_i ...) x I2, M > 0")
        iters = [eq.iterations for eq in eqs]
        per_n[str(n)] = {
            "equilibria": len(eqs),
            "failures": {str(i): f.message for i, f in found.failures.items()},
            "iterations": {"min": min(iters), "max": max(iters),
                           "mean": float(np.mean(iters))},
            "evaluations": int(sum(eq.evaluations for eq in eqs)),
            "wall_time": found.wall_time,
            "unstable_dimensions": sorted({lab[0] for lab in labels}),
            "rank": sorted({eq.rank for eq in eqs}),
            "local_dimension": sorted({eq.local_dimension for eq in eqs}),
        }
        histories[n] = [eq.history for eq in eqs]

    # hard cases
    model = chain_cart(2, **PARAMS)
    hanging = np.concatenate([np.zeros(4), link_state(E3), link_state(E3)])
    pushed = find_equilibrium(model, hanging, u=[1.0, 0.0], raise_on_failure=False)
    res.compare("constant push u = (1, 0): status STAGNATED (no equilibrium exists)", 1.0,
                float(pushed.status is RootStatus.STAGNATED), tolerance=0,
                source="dp_x/dt = u_x != 0")
    far = np.concatenate([np.zeros(2), [3.0, -2.0],
                          link_state([1.0, 0.0, 0.0], [0.0, 4.0, 0.0]),
                          link_state([0.0, 1.0, 0.0], [0.0, 0.0, -5.0])])
    capped = find_equilibrium(model, far, max_iterations=3, raise_on_failure=False)
    res.compare("far start, 3 iterations: status MAX_ITERATIONS (no wrong answer)", 1.0,
                float(capped.status is RootStatus.MAX_ITERATIONS), tolerance=0,
                source="status, not a point")
    res.values = {
        "params": PARAMS,
        "perturbation_rad": PERTURBATION,
        "seed": SEED,
        "per_n": per_n,
        "pushed": {"status": pushed.status.code, "message": pushed.message,
                   "residual": pushed.residual},
        "far_start": {"status": capped.status.code, "message": capped.message,
                      "residual": capped.residual},
    }
    res.figures["newton_convergence"] = _figure(histories)
    return res.finish()


def _figure(histories: dict[int, list[list[float]]]):  # noqa: ANN202
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.6))
    colours = plt.get_cmap("viridis")(np.linspace(0, 0.9, len(histories)))
    for (n, hs), col in zip(histories.items(), colours):
        for j, h in enumerate(hs):
            ax.semilogy(range(len(h)), np.maximum(h, 1e-18), color=col, lw=0.6, alpha=0.7,
                        label=f"n = {n}" if j == 0 else None)
    ax.set_xlabel("Newton iteration")
    ax.set_ylabel("max |f|")
    ax.set_title("Newton on (S^2)^n x R^2 from perturbed vertical configurations", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
