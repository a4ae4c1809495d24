"""Studies shared by the swing-up problems.

Speed-accuracy tables, closed-loop Monte Carlo runs, the classification of local minima by
their swings, and figures.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import casadi as ca
import numpy as np

from workbench.control._tvlqr import TVLQR, closed_loop, perturbed_starts
from workbench.control.ocp.guess import Guess
from workbench.control.ocp.problem import OCP, TargetPoint, TargetSet
from workbench.control.ocp.solve import OCPSolution, solve
from workbench.control.ocp.stepper import Stepper
from workbench.control.ocp.transcription import (
    Collocation,
    ManifoldHandling,
    Transcription,
    TranscriptionMethod,
)
from workbench.core.errors import ParameterError
from workbench.core.manifolds import ProductManifold

__all__ = ["swings", "speed_accuracy", "monte_carlo", "solution_row", "plot_swingup",
           "transcription_builds", "dense", "effort_time_ocp", "solve_row"]


def effort_time_ocp(model: Any, x0: np.ndarray, xf: np.ndarray, *, u_max: float,
                    T: Any, free: Sequence[str] = (), name: str, gauge: bool = True,
                    description: str = "") -> OCP:
    """The swing-ups' problem: minimise ``integral u^T u dt + T`` under ``|u_i| <= u_max``.

    Parameters
    ----------
    model : Model
        The dynamics.
    x0, xf : ndarray, shape=(ambient_dim,)
        Start and end state.
    u_max : float
        Bound of each input.
    T : float or (float, float)
        Horizon or its range.
    free : sequence of str
        Factors left free at the end (e.g. ``("x",)``: the cart anywhere): the target is
        then the set where the other factors equal those of ``xf`` (a
        :class:`~workbench.control.ocp.problem.TargetSet`).
    name : str
        Name of the OCP.
    gauge : bool
        Gauge a detected symmetry (see :class:`~workbench.control.ocp.problem.OCP`).
    description : str
        Words for the target.
    """
    man = model.manifold
    if free:
        unknown = sorted(set(free) - {n for n, _ in man.factors})
        if unknown:
            raise ParameterError(f"free must name factors of {man.describe()}; got {unknown}")
        kept = [(n, f) for n, f in man.factors if n not in free]
        target: Any = TargetSet(
            map=lambda x: ca.vertcat(*[x[man.slices[n]] for n, _ in kept]),
            manifold=ProductManifold(kept), value=np.concatenate(
                [np.asarray(xf)[man.slices[n]] for n, _ in kept]),
            witness=xf, description=description or f"{', '.join(free)} free, rest as x_f")
    else:
        target = TargetPoint(man, xf, description or "terminal point")
    return OCP(model, x0=x0, target=target, u_lower=-u_max, u_upper=u_max, T=T,
               running_cost=lambda x, u: ca.dot(u, u), terminal_cost=lambda x, T: T,
               name=name, gauge=gauge)


def solve_row(ocp: OCP, method: TranscriptionMethod, guess: Guess | OCPSolution, **options: Any
              ) -> tuple[OCPSolution, dict[str, Any]]:
    """Solve (never raising) and tabulate: the solution and its :func:`solution_row`."""
    sol = solve(ocp, method, guess=guess, raise_on_failure=False, **options)
    return sol, solution_row(sol, resimulate=sol.status.ok) | {"gauge": sol.gauge}


def transcription_builds(ocp: OCP) -> list[dict[str, Any]]:
    """Every transcription built for ``ocp`` (and problems sharing its cache): time, size."""
    return [{"transcription": tr.describe(), "build_seconds": tr.build_seconds,
             "nlp_graph_nodes": tr.n_nodes, "nlp_variables": tr.nw,
             "nlp_constraints": tr.ng} for tr in ocp._cache.values()
            if isinstance(tr, Transcription)]


def swings(height: np.ndarray, *, tol: float = 1e-3) -> dict[str, Any]:
    """Classify a swing-up by the turning points of a height along the trajectory.

    Parameters
    ----------
    height : ndarray, shape=(n,)
        Height of the pendulum (a centre of mass or a tip) at the nodes.
    tol : float
        Changes of direction smaller than this are ignored (noise).

    Returns
    -------
    dict
        ``turning_points`` (interior local extrema of the height), ``kind`` (``"direct"``
        when the height rises without turning back, else ``"pumping"``), ``swings``
        (number of interior maxima: the back-and-forth swings before the last rise).
    """
    h = np.asarray(height, float)
    ext, maxima = [], 0
    direction = 0
    anchor = h[0]
    for v in h[1:]:
        d = v - anchor
        if direction >= 0 and d < -tol:
            if direction > 0:
                ext.append("max")
                maxima += 1
            direction, anchor = -1, v
        elif direction <= 0 and d > tol:
            if direction < 0:
                ext.append("min")
            direction, anchor = 1, v
        elif (direction > 0 and v > anchor) or (direction < 0 and v < anchor):
            anchor = v
    return {"turning_points": len(ext), "swings": maxima,
            "kind": "direct" if not ext else "pumping"}


def solution_row(sol: OCPSolution, *, resimulate: bool = True, rtol: float = 1e-10,
                 height: Callable[[np.ndarray], np.ndarray] | None = None) -> dict[str, Any]:
    """One row of a table: transcription, status, cost, T, iterations, times, errors."""
    if resimulate and sol.status.ok:
        sol.resimulate(rtol=rtol, atol=rtol)
    row = {
        "transcription": sol.describe(),
        "status": sol.status.name,
        "ipopt_status": sol.ipopt_status,
        "objective": sol.objective,
        "T": sol.T,
        "iterations": sol.cost["iterations"],
        "solve_seconds": sol.cost["solve_seconds"],
        "solve_cpu_seconds": sol.cost["solve_cpu_seconds"],
        "build_seconds": sol.cost["first_build_seconds"],
        "nlp_variables": sol.cost["nlp_variables"],
        "constraint_violation": sol.error["constraint_violation"],
        "node_manifold_residual": sol.error["manifold_residual"],
        "local_defect": sol.error.get("local_defect", float("nan")),
        "resim_end_error": sol.error.get("resim_end_error", float("nan")),
        "resim_target_residual": sol.error.get("resim_target_residual", float("nan")),
    }
    if height is not None:
        row.update(swings(height(sol.x)))
    return row


def speed_accuracy(
    ocp: OCP,
    methods: Sequence[TranscriptionMethod],
    handlings: Sequence[ManifoldHandling],
    *,
    guess: Guess | OCPSolution,
    repeats: int = 1,
    height: Callable[[np.ndarray], np.ndarray] | None = None,
    **solve_options: Any,
) -> list[dict[str, Any]]:
    """Solve with every transcription and handling from one guess; tabulate cost and error.

    Every entry starts from the same guess, so all converge to the same local minimum and
    the rows compare like with like. Solve times are the median of ``repeats`` solves
    (the build is excluded and reported separately).
    """
    rows = []
    for method in methods:
        for handling in handlings:
            times, cpu = [], []
            sol = None
            for _ in range(max(1, repeats)):
                sol = solve(ocp, method, handling=handling, guess=guess,
                            raise_on_failure=False, **solve_options)
                times.append(sol.cost["solve_seconds"])
                cpu.append(sol.cost["solve_cpu_seconds"])
            assert sol is not None
            row = solution_row(sol, height=height)
            row["solve_seconds"] = float(np.median(times))
            row["solve_cpu_seconds"] = float(np.median(cpu))
            row["N"] = method.N
            row["handling"] = handling.value
            row["degree"] = method.degree if isinstance(method, Collocation) else None
            rows.append(row)
    return rows


def monte_carlo(controller: TVLQR, x0: np.ndarray, *, n: int, scale: Any, seed: int,
                hold: float, tol: float, u_bounds: Any = None,
                rtol: float = 1e-9) -> dict[str, Any]:
    """Closed loop from ``n`` seeded perturbed starts; success rate and errors."""
    model = controller.model
    starts = perturbed_starts(model, x0, n=n, scale=scale, seed=seed)
    stepper = Stepper(model, rtol=rtol, atol=rtol)
    runs = [closed_loop(controller, x, hold=hold, tol=tol, u_bounds=u_bounds,
                        stepper=stepper) for x in starts]
    errs = np.array([r.final_error for r in runs])
    return {
        "runs": runs,
        "n": n,
        "successes": int(sum(r.success for r in runs)),
        "success_rate": float(np.mean([r.success for r in runs])),
        "final_error_median": float(np.median(errs)),
        "final_error_max": float(np.max(errs)),
        "max_abs_u": float(max(r.max_abs_u for r in runs)),
        "perturbation_scale": np.broadcast_to(np.asarray(scale, float),
                                              (model.manifold.dim,)).tolist(),
        "seed": seed,
        "hold_seconds": hold,
        "tol": tol,
        "saturated_at": None if u_bounds is None else [np.asarray(b, float).tolist()
                                                       for b in u_bounds],
    }


def dense(sol: OCPSolution, *, substeps: int = 8) -> np.ndarray:
    """States between the nodes: each interval integrated from its own node (CVODES).

    Unlike an open-loop re-simulation of the whole horizon, this follows the optimal
    trajectory on unstable swing-ups (it restarts at every node).
    """
    stepper = Stepper(sol.ocp.model, rtol=1e-10, atol=1e-10)
    h = sol.T / (len(sol.x) - 1) / substeps
    out = []
    for k, (uk, uk1) in enumerate(sol.interval_inputs()):
        x = sol.x[k]
        out.append(x)
        for j in range(substeps - 1):
            a, b = j / substeps, (j + 1) / substeps
            u0 = uk if uk1 is None else (1 - a) * uk + a * uk1
            x = stepper.step(x, u0, h, u_end=None if uk1 is None else (1 - b) * uk + b * uk1)
            out.append(x)
    out.append(sol.x[-1])
    return np.array(out)


def plot_swingup(sol: OCPSolution, sphere_parts: Sequence[tuple[str, Callable]],
                 *, runs: Sequence[Any] = (), title: str = "") -> Any:
    """Figure: directions on unit spheres, and the controls over time.

    Parameters
    ----------
    sol : OCPSolution
        The optimal trajectory.
    sphere_parts : sequence of (label, callable)
        ``fn(x) -> (n, 3)`` unit vectors to draw on a sphere, one sphere each.
    runs : sequence of ClosedLoopRun
        Closed-loop runs drawn thin on the spheres.
    title : str
        Figure title.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    k = len(sphere_parts)
    fig = plt.figure(figsize=(4.2 * (k + 1), 4.0))
    u_sph = np.linspace(0, 2 * np.pi, 25)
    v_sph = np.linspace(0, np.pi, 13)
    dense_x = dense(sol, substeps=8)
    for i, (label, fn) in enumerate(sphere_parts):
        ax = fig.add_subplot(1, k + 1, i + 1, projection="3d")
        ax.plot_wireframe(np.outer(np.cos(u_sph), np.sin(v_sph)),
                          np.outer(np.sin(u_sph), np.sin(v_sph)),
                          np.outer(np.ones_like(u_sph), np.cos(v_sph)),
                          color="0.85", lw=0.4)
        for r in runs:
            d = fn(r.x)
            ax.plot(d[:, 0], d[:, 1], -d[:, 2], color="tab:green", lw=0.4, alpha=0.6)
        d = fn(dense_x)
        ax.plot(d[:, 0], d[:, 1], -d[:, 2], color="tab:blue", lw=1.5)
        ax.scatter(*[[c] for c in (d[0, 0], d[0, 1], -d[0, 2])], color="k", s=12)
        ax.scatter(*[[c] for c in (d[-1, 0], d[-1, 1], -d[-1, 2])], color="tab:red", s=12)
        ax.set_title(f"{label} (up = -e3)", fontsize=9)
        ax.set_box_aspect((1, 1, 1))
    ax = fig.add_subplot(1, k + 1, k + 1)
    t = sol.t if sol.first_order_hold else np.repeat(sol.t, 2)[1:-1]
    for j in range(sol.u.shape[1]):
        uj = sol.u[:, j] if sol.first_order_hold else np.repeat(sol.u[:, j], 2)
        ax.plot(t, uj, label=f"u_{j + 1}")
    ax.axhline(sol.ocp.u_upper[0], color="0.6", ls=":", lw=0.8)
    ax.axhline(sol.ocp.u_lower[0], color="0.6", ls=":", lw=0.8)
    ax.set_xlabel("t [s]")
    ax.set_title("optimal control", fontsize=9)
    ax.legend(fontsize=8)
    fig.suptitle(title or sol.describe(), fontsize=9)
    fig.tight_layout()
    return fig
