"""The 2^n equilibria of the chain pendulum on a cart, found by Newton on (S^2)^n x R^2.

The chain pendulum on a cart has 2^n equilibria, each link pointing straight up or
straight down. Newton's method on the curved state space, started near each of them for
chains of one to six links, finds every one, each from its own start, exactly at rest and
exactly vertical; each has as many unstable directions as twice its number of upright
links, as paper 003's linearisation says. Without any guess, ``find_all_equilibria`` finds
the same 2^n (the critical points of the potential, by continuation from gravity's sign
patterns), each of index twice its number of upright links. Where no equilibrium exists (a
constant push) or the start is far, the solver says so instead of returning a wrong point.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from models.chain_cart import chain_cart, link_state
from models.chain_cart_reference import equilibrium
from models.relative_equilibria import stability_label
from workbench.equilibria import (
    RootStatus,
    enumerate_equilibria,
    find_all_equilibria,
    find_equilibrium,
)
from workbench.linear import eigenstructure, linearize, symmetry_directions
from workbench.study import Panel, Result, compare_rows, line_figure, spectrum_figure

TITLE = "Chain pendulum on a cart: the 2^n equilibria by Newton on the manifold, n = 1..6 " \
        "(paper 003 Sec. 3.1)"

PARAMS = {"m": 0.5, "masses": 0.1, "lengths": 0.1, "g": 9.81}
E3 = np.array([0.0, 0.0, 1.0])
PERTURBATION = 0.05
SEED = 20030
N_MAX = 6
MAX_STEP = 0.2
"""Largest tangent step of a Newton iteration. Without it, one of the 64 solves at n = 6
(pattern - + - - + -, links 0.1 m) took 27 iterations and ended with two folded links
swapped; with it every solve stays with its own pattern in at most 4 iterations."""


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        Up to n = 5 instead of 6 (the stability classification stays on for all).

    Returns
    -------
    Result

    Notes
    -----
    The model of paper 003 (12)-(13) (models.chain_cart with the Section 5 values m = 0.5,
    m_i = 0.1, l_i = 0.1, g = 9.81), n = 1..6. The structure of Section 3.1 names the
    candidates: every link vertical, q_i = s_i e3. For every sign pattern s the guess is the
    candidate *perturbed* (seeded: retracted along a random tangent vector with components
    of size 0.05, so every link is rotated by about 0.05 rad and the angular velocities, the
    cart position and velocity are of the same size), and
    workbench.equilibria._equilibria.enumerate_equilibria runs Newton on the manifold (the
    retraction keeps each q_i on S^2 and each omega_i tangent) from each guess, its tangent
    step limited to ``MAX_STEP``. Measured for
    every n: the number of distinct equilibria (2^n), that each solve converged to the
    equilibrium of its own sign pattern, the residual |f| and the alignment |q_i x e3|, zero
    velocities, the dimension of the equilibrium set at each point (2: the cart position is
    free, from the rank of the graph's Jacobian), the Newton iterations, and the unstable
    dimension of each equilibrium from the linearisation (reference: 2 #{i : s_i = -1}, the
    number of negative entries of G_qq in (16) times the two horizontal directions, by
    Sylvester's law of inertia since M is positive definite). Guess-free rows:
    ``find_all_equilibria`` (critical points of the potential on (S^2)^n x R^2, no
    guesses): the number of critical sets (2^n), their sign patterns against Newton's, the
    largest difference of the links' directions from Newton's equilibrium of the same
    pattern, and each set's Morse index against 2 #(s_i = -1).

    Hard cases: with a constant horizontal force on the cart there is no equilibrium (the
    momentum grows at the rate u); Newton reports that as a status (STAGNATED, a local
    minimum of |f| that is not a zero), not as a wrong answer. A start far from every
    equilibrium with a small iteration budget reports MAX_ITERATIONS.
    """
    res = Result("chain_equilibria", TITLE, quick=quick)
    rng = np.random.default_rng(SEED)
    n_max = 5 if quick else N_MAX
    per_n: dict[str, Any] = {}
    histories: dict[str, Any] = {}
    spectra: dict[str, Any] = {}
    spectra_sym: dict[str, Any] = {}
    for n in range(1, n_max + 1):
        model = chain_cart(n, **PARAMS)
        res.use(model)
        patterns = list(itertools.product((1, -1), repeat=n))
        # each candidate moved off by a random tangent vector (exactly on the manifold)
        guesses = [model.manifold.retract(equilibrium(n, s), PERTURBATION * rng.standard_normal(
            model.manifold.dim)) for s in patterns]
        with res.timed(f"n = {n}: Newton from {2 ** n} guesses"):
            found = enumerate_equilibria(model, guesses, tol=1e-12, max_step=MAX_STEP)
        eqs = found.equilibria
        signs = [tuple(np.sign(eq.x[4:].reshape(n, 6)[:, 2]).astype(int)) for eq in eqs]
        own = sum(1 for sg, src in zip(signs, found.sources)
                  if all(sg == patterns[i] for i in src))
        links = np.array([eq.x[4:].reshape(n, 6) for eq in eqs])
        align = float(np.max(np.abs(np.cross(links[:, :, :3], E3)))) if eqs else np.nan
        speed = float(max(np.max(np.abs(links[:, :, 3:])),
                          max(np.max(np.abs(eq.x[2:4])) for eq in eqs))) if eqs else np.nan
        with res.timed(f"n = {n}: stability"):
            labels = [stability_label(model, eq.x) for eq in eqs]
            lins = [linearize(model, eq.x) for eq in eqs]
            syms = [symmetry_directions(lin) for lin in lins]
        if n == 2:  # the figure: the four equilibria of the double chain
            for sg, lin, sym in zip(signs, lins, syms):
                title = "n = 2: " + ", ".join("up" if s_i < 0 else "down" for s_i in sg)
                spectra[title] = (eigenstructure(lin).eigenvalues, None)
                spectra_sym[title] = sym
        match = sum(1 for sg, lab in zip(signs, labels) if lab == (2 * sg.count(-1), 0))
        compare_rows(res, [
            (f"n = {n}: distinct equilibria found", 2**n, len(eqs), 0,
             "Sec. 3.1: 2^n vertical configurations"),
            (f"n = {n}: solves that converged to their own sign pattern", 2**n, own, 0,
             "nearest candidate"),
            (f"n = {n}: max |f(x_e, 0)|", 0.0, max(eq.residual for eq in eqs), 1e-10,
             "model graph"),
            (f"n = {n}: max |q_i x e3|", 0.0, align, 1e-12, "Sec. 3.1: q_i x e3 = 0"),
            (f"n = {n}: max |omega_i|, |v|", 0.0, speed, 1e-12, "equilibrium at rest"),
            (f"n = {n}: equilibria with a free cart position (set of dimension 2)", 2**n,
             sum(1 for eq in eqs if eq.local_dimension == 2), 0,
             "f does not depend on x (translation symmetry)"),
            (f"n = {n}: unstable dimension = 2 #(s_i = -1) at every equilibrium", 2**n, match,
             0, "(16): inertia of G_qq = diag(s_i ...) x I2, M > 0"),
            (f"n = {n}: zero eigenvalues not from a symmetry, all equilibria", 0,
             sum(np.nan if s.unexplained is None else s.unexplained for s in syms), 0,
             "cart translations: orbit + momentum each")])
        with res.timed(f"n = {n}: find_all_equilibria (no guess)"):
            crit = find_all_equilibria(model)
        by_sign = {sg: eq.x[4:].reshape(n, 6)[:, :3] for sg, eq in zip(signs, eqs)}
        free = {tuple(np.sign(st[4:].reshape(n, 6)[:, 2]).astype(int)): (st, ix)
                for st, ix in zip(crit.states, crit.indices)}
        same = [k for k in free if k in by_sign]
        compare_rows(res, [
            (f"n = {n}: critical sets found without a guess", 2**n, len(crit), 0,
             "find_all_equilibria: continuation from gravity's sign patterns"),
            (f"n = {n}: guess-free sign patterns also found by Newton", 2**n, len(same), 0,
             "the rows above"),
            (f"n = {n}: max |q_i - q_i(Newton)|, same pattern", 0.0, max(float(np.max(np.abs(
                free[k][0][4:].reshape(n, 6)[:, :3] - by_sign[k]))) for k in same), 1e-12,
             "two independent searches"),
            (f"n = {n}: guess-free sets of index 2 #(s_i = -1)", 2**n,
             sum(1 for k, (_, ix) in free.items() if ix == 2 * k.count(-1)), 0,
             "(16): the Hessian of V is G_qq")])
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
            "guess_free": {"sets": len(crit), "status": crit.status.code,
                           "wall_time": crit.wall_time, "evaluations": crit.evaluations},
        }
        histories[f"n = {n}"] = (  # one curve per n, the solves separated by NaN
            np.concatenate([np.r_[np.arange(len(eq.history)), np.nan] for eq in eqs]),
            np.concatenate([np.r_[np.maximum(eq.history, 1e-18), np.nan] for eq in eqs]))

    # hard cases
    model = chain_cart(2, **PARAMS)
    pushed = find_equilibrium(model, equilibrium(2, (1, 1)), u=[1.0, 0.0], raise_on_failure=False)
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
        "perturbation_tangent_coordinates": PERTURBATION,
        "seed": SEED,
        "per_n": per_n,
        "pushed": pushed.summary(), "far_start": capped.summary(),
    }
    res.figure("newton_convergence", line_figure([Panel(
        "Newton on (S^2)^n x R^2 from perturbed vertical configurations", histories,
        xlabel="Newton iteration", ylabel="max |f|", yscale="log")], ncols=1, size=(6.5, 3.8)),
        caption="Convergence of every Newton solve, one colour per chain length n: "
                "the residual of the equations of motion falls quadratically to rounding "
                "within a few iterations from each of the 2^n perturbed starting guesses.")
    res.figure("spectra_n2", spectrum_figure(spectra, ncols=2, size=(3.4, 3.0), tol=1e-8,
                                             symmetry=spectra_sym),
               caption="Eigenvalues of the linearisation at the four equilibria of the chain of "
                       "two links on a cart (links listed from the cart down: 'up' is upright). "
                       "Each upright link adds one unstable pair per horizontal direction; the "
                       "four zero eigenvalues are the cart's position (an orbit of the "
                       "translations) and its momentum (conserved), in x and in y.")
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
