"""Studies shared by the swing-up problems.

Speed-accuracy tables, closed-loop Monte Carlo runs, the classification of local minima by
their swings, figures, and multistart on all cores: :func:`pumping_guess` (a guess that
swings ``k`` times, for the minima with several swings) and :func:`parallel_starts` (any
guesses in one forked pool, the builds inherited, optionally stopped at a known cost with
the stop reported).
"""

from __future__ import annotations

import inspect
import time
from collections.abc import Callable, Sequence
from typing import Any

import casadi as ca
import numpy as np

from workbench.control._tvlqr import TVLQR, closed_loop, perturbed_starts
from workbench.control.ocp.guess import Guess
from workbench.control.ocp.problem import OCP, TargetPoint, TargetSet
from workbench.control.ocp.solve import (
    DEFAULT_HANDLING,
    WARM_START,
    OCPSolution,
    _ipopt_options,
    solve,
    transcribe,
)
from workbench.control.ocp.stepper import Stepper
from workbench.control.ocp.strategies import _direct, _warm, coarse_to_fine
from workbench.control.ocp.transcription import (
    Collocation,
    ManifoldHandling,
    Transcription,
    TranscriptionMethod,
)
from workbench.core import validate
from workbench.core._model import Symbolic
from workbench.core.errors import ParameterError, SolverError
from workbench.core.manifolds import S2, TS2, ProductManifold, sphere_basis
from workbench.core.types import ArrayLike

__all__ = ["swings", "speed_accuracy", "monte_carlo", "solution_row", "plot_swingup",
           "transcription_builds", "dense", "effort_time_ocp", "solve_row", "pumping_guess",
           "parallel_starts"]

_OK = ("SUCCESS", "ACCEPTABLE")


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
    sol = _direct(ocp, method, guess=guess, raise_on_failure=False, **options)
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

    Every entry starts from the same guess, so the rows compare like with like when they
    reach the same local minimum; a finer transcription may move to another one from a
    coarse optimum (the 3D pendulum's N = 120 rows do: compare the costs). Solve
    times are the median of ``repeats`` solves (the build is excluded and reported
    separately).
    """
    rows = []
    for method in methods:
        for handling in handlings:
            times, cpu = [], []
            sol = None
            for _ in range(max(1, repeats)):
                sol = _direct(ocp, method, handling=handling, guess=guess,
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
    fig.set_layout_engine("tight")  # laid out when drawn, once, at its final size
    return fig


# multistart on all cores ------------------------------------------------------------------

def pumping_guess(ocp: OCP, *, half_swings: int, T: float | None = None,
                  axes: dict[str, ArrayLike] | None = None, samples: int = 201) -> Guess:
    """A swing-up guess that pumps: back and forth along a great circle, growing to the end.

    For every factor on S^2 (or TS^2) whose end direction is antipodal to its start (a
    link to be inverted), the direction ``q(s) = cos(th) q0 + sin(th) (a x q0)`` with
    ``th(s) = pi s cos(pi k (1 - s))``: ``k = half_swings`` reversals of growing amplitude,
    from hanging (``th = 0``) to inverted (``th = pi``) at ``s = 1``. The velocity of a TS^2
    factor follows ``q(s)`` over ``T`` in the model's own convention (``w = q-dot`` or
    ``q-dot = w x q``, read from the model's right-hand side at the start). The other
    factors follow :meth:`Guess.geodesic`; the controls are zero. Local minima of the
    swing-ups differ in their number of swings; a geodesic guess (``k = 0``) finds the
    direct ones, a pumping guess the ones with several swings.

    Parameters
    ----------
    ocp : OCP
        A swing-up problem (at least one antipodal S^2 or TS^2 factor).
    half_swings : int
        ``k >= 0``; 0 is the great circle itself.
    T : float, optional
        Final time of the guess (default: the middle of the allowed range).
    axes : dict of str to array-like, optional
        Rotation axis ``a`` of the great circle per factor name (default: the first
        vector of :func:`~workbench.core.manifolds.sphere_basis` of ``q0``).
    samples : int
        Number of samples.

    Returns
    -------
    Guess

    Raises
    ------
    ParameterError
        ``half_swings`` not an integer >= 0, an axis parallel to ``q0``, no antipodal
        factor, or a model whose TS^2 velocity is neither convention.
    """
    if isinstance(half_swings, bool) or not isinstance(half_swings, (int, np.integer)) or \
            half_swings < 0:
        raise ParameterError(f"half_swings must be an integer >= 0; got {half_swings!r}")
    man = ocp.model.manifold
    x0, xf = ocp.x0, ocp.target.witness
    ax: dict[str, np.ndarray] = {}
    for name, f in man.factors:
        q0, q1 = x0[man.slices[name]][:3], xf[man.slices[name]][:3]
        if isinstance(f, (S2, TS2)) and q0 @ q1 < -1 + 1e-9:
            a = np.asarray((axes or {}).get(name, sphere_basis(q0)[:, 0]), float).reshape(3)
            a = a / max(float(np.max(np.abs(a))), np.finfo(float).tiny)  # no underflow
            a = a - (a @ q0) * q0
            if not np.linalg.norm(a) > 1e-9:  # parallel to q0, or zero
                raise ParameterError(f"axes[{name!r}] must not be parallel to the start "
                                     f"direction {q0.tolist()}; got {axes[name]!r}")
            ax[name] = a / np.linalg.norm(a)
    if not ax:
        raise ParameterError(f"OCP {ocp.name!r}: no S^2 factor goes to its antipode; a "
                             f"pumping guess needs one (use Guess.geodesic)")
    unknown = sorted(set(axes or {}) - set(ax))
    if unknown:
        raise ParameterError(f"axes must name factors going to their antipode "
                             f"{sorted(ax)}; got {unknown}")
    g = Guess.geodesic(ocp, T=T, axes=ax, samples=samples)
    s, X, k = g.s, g.x.copy(), float(half_swings)
    th = np.pi * s * np.cos(np.pi * k * (1 - s))
    dth = (np.pi * np.cos(np.pi * k * (1 - s))
           + np.pi ** 2 * k * s * np.sin(np.pi * k * (1 - s))) / g.T
    for name, a in ax.items():
        sl = man.slices[name]
        q0 = x0[sl][:3]
        b = np.cross(a, q0)
        q = np.cos(th)[:, None] * q0 + np.sin(th)[:, None] * b
        X[:, sl.start: sl.start + 3] = q
        if isinstance(dict(man.factors)[name], TS2):
            qdot = (-np.sin(th)[:, None] * q0 + np.cos(th)[:, None] * b) * dth[:, None]
            X[:, sl.start + 3: sl.start + 6] = qdot if _velocity_is_qdot(ocp, name) \
                else np.cross(q, qdot)
    return Guess(s=s, x=X, u=np.zeros((len(s) - 1, ocp.model.n_inputs)), T=g.T,
                 local=g.local)


def _velocity_is_qdot(ocp: OCP, name: str) -> bool:
    """Whether the model's TS^2 factor ``name`` stores ``q-dot`` (else ``q-dot = w x q``)."""
    man, model = ocp.model.manifold, ocp.model
    sl = man.slices[name]
    x = ocp.x0.copy()
    q = x[sl][:3]
    w = sphere_basis(q) @ np.array([0.3, -0.7])
    x[sl.start + 3: sl.start + 6] = w
    xdot = np.asarray(model.function("f")(x, np.zeros(model.n_inputs), model.p), float).ravel()
    qdot = xdot[sl][:3]
    if np.allclose(qdot, w, rtol=1e-9, atol=1e-12):
        return True
    if np.allclose(qdot, np.cross(w, q), rtol=1e-9, atol=1e-12):
        return False
    raise ParameterError(f"{model.name}: factor {name!r} has q-dot = {qdot.tolist()} for "
                         f"(q, w) = ({q.tolist()}, {w.tolist()}): neither w nor w x q")


_STARTS: dict[str, Any] = {}
"""The job of :func:`parallel_starts`, inherited by the forked workers (never pickled)."""


def _start_worker(i: int) -> tuple[int, dict[str, Any], tuple]:
    """Start ``i``: the ladder from its guess; the record and the last primal-dual point."""
    job = _STARTS
    c0 = time.process_time()
    s, path = coarse_to_fine(job["ocp"], job["ladder"], guess=job["guesses"][i],
                             raise_on_failure=False, **job["options"])
    record = {"start": i, "status": s.status.name, "objective": s.objective, "T": s.T,
              "transcription": s.method.describe() if hasattr(s.method, "describe")
              else repr(s.method),
              "iterations": [p.cost["iterations"] for p in path],
              "solve_seconds": float(sum(p.cost["solve_seconds"] for p in path)),
              "cpu_seconds": time.process_time() - c0, "reached_ladder_end": len(path) ==
              len(job["ladder"])}
    return i, record, (s.method, s.w, s.lam_x, s.lam_g)


def parallel_starts(ocp: OCP, guesses: Sequence[Guess], ladder: Sequence[TranscriptionMethod],
                    *, workers: int, stop_below: float | None = None, rel_tol: float = 1e-6,
                    **solve_options: Any) -> tuple[OCPSolution, list[dict[str, Any]],
                                                   dict[str, Any]]:
    """Solve from several guesses in forked processes (one pool); keep the cheapest.

    Every transcription of ``ladder`` is built here first, so the workers (forked once,
    fed one start at a time, the order of ``guesses`` first) inherit the builds and
    return numbers only; each start goes through the ladder (see
    :func:`~workbench.control.ocp.coarse_to_fine`). The cheapest converged end point is
    re-solved here from its primal-dual vector (a warm start: a few iterations) into a
    complete solution. With ``stop_below``, the pool is stopped as soon as a start
    converges at a cost ``<= stop_below (1 + rel_tol)``: the starts not finished are
    listed with status ``"STOPPED"`` and the summary says so.

    Parameters
    ----------
    ocp : OCP
        The problem.
    guesses : sequence of Guess
        One start per guess.
    ladder : sequence of transcriptions
        From coarse to fine; the last is the one judged.
    workers : int
        Processes (>= 1).
    stop_below : float, optional
        A cost to stop at (e.g. the best known minimum); ``None`` runs every start.
    rel_tol : float
        Relative tolerance of ``stop_below`` and of "reached the best".
    **solve_options
        Passed to :func:`~workbench.control.ocp.solve` (``guess`` and
        ``raise_on_failure`` are not allowed).

    Returns
    -------
    (OCPSolution, list of dict, dict)
        The best solution, one record per start (status, cost, T, iterations per level,
        solve and CPU seconds, ``reached_best``), and a summary: starts given, finished,
        converged, reaching the best, whether and why it stopped early, wall seconds of
        the pool, build seconds of the ladder (transcriptions and Ipopt instances of
        these options, made before forking), seconds of the final warm re-solve.

    Raises
    ------
    ParameterError
        Bad ``workers``, ``guesses``, ``ladder`` or options.
    SolverError
        If no start converged.
    """
    import multiprocessing

    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1; got {workers!r}")
    guesses, ladder = list(guesses), list(ladder)
    if not guesses or not all(isinstance(g, Guess) for g in guesses):
        raise ParameterError(f"guesses must be a non-empty sequence of Guess; got "
                             f"{[type(g).__name__ for g in guesses]}")
    if not ladder:
        raise ParameterError("ladder must hold at least one transcription")
    for key in ("guess", "raise_on_failure"):
        if key in solve_options:
            raise ParameterError(f"{key} is set by parallel_starts; got {key}=...")
    if stop_below is not None and not np.isfinite(stop_below):
        raise ParameterError(f"stop_below must be a finite cost or None; got {stop_below!r}")
    rel_tol = validate.tolerance("rel_tol", rel_tol)
    handling = solve_options.get("handling") or DEFAULT_HANDLING
    graph = solve_options.get("graph", Symbolic.SX)
    t0 = time.perf_counter()
    defaults = inspect.signature(solve).parameters
    opts = _ipopt_options(*(solve_options.get(k, defaults[k].default)
                            for k in ("tol", "max_iter", "print_level", "ipopt_options")))
    for m in ladder:  # the solvers of these options too: a worker would create its own
        tr, _ = transcribe(ocp, m, handling=handling, graph=graph)
        tr.solver(opts, solve_options.get("compiled"))
    if solve_options.get("ipopt_options") is None:  # and that of the final warm re-solve
        tr.solver({**WARM_START, **opts}, solve_options.get("compiled"))
    build = time.perf_counter() - t0
    _STARTS.clear()
    _STARTS.update(ocp=ocp, guesses=guesses, ladder=ladder, options=solve_options)
    done: dict[int, tuple] = {}
    stopped = ""
    t1 = time.perf_counter()
    try:
        if workers == 1:
            it = map(_start_worker, range(len(guesses)))
            pool = None
        else:
            pool = multiprocessing.get_context("fork").Pool(min(workers, len(guesses)))
            it = pool.imap_unordered(_start_worker, range(len(guesses)))
        for i, record, end in it:
            done[i] = (record, end)
            if stop_below is not None and record["status"] in _OK and \
                    record["objective"] <= stop_below + rel_tol * max(1.0, abs(stop_below)):
                if len(done) < len(guesses):
                    stopped = (f"stopped after start {i} reached {record['objective']:.6g} "
                               f"<= stop_below {stop_below:.6g}")
                break
    finally:
        if pool is not None:
            pool.terminate()
            pool.join()
        _STARTS.clear()
    wall = time.perf_counter() - t1
    records = [done[i][0] if i in done else {"start": i, "status": "STOPPED"}
               for i in range(len(guesses))]
    ok = [(r["objective"], r["start"]) for r in records if r["status"] in _OK]
    if not ok:
        raise SolverError(f"OCP {ocp.name!r}: none of {len(done)} finished starts converged",
                          status=records[-1]["status"])
    best_cost, i_best = min(ok)
    m, w, lam_x, lam_g = done[i_best][1]
    t2 = time.perf_counter()
    best = _direct(ocp, m, guess=_warm(ocp, m, w, lam_x, lam_g, solve_options),
                 raise_on_failure=False, **solve_options)
    final = time.perf_counter() - t2
    for r in records:
        r["reached_best"] = bool(r["status"] in _OK and abs(r["objective"] - best_cost)
                                 <= rel_tol * max(1.0, abs(best_cost)))
    summary = {"starts": len(guesses), "finished": len(done), "converged": len(ok),
               "reached_best": sum(r["reached_best"] for r in records),
               "best_objective": best.objective, "stopped_early": stopped,
               "workers": int(workers), "wall_seconds": wall, "build_seconds": build,
               "final_resolve_seconds": final,
               "final_resolve_iterations": best.cost["iterations"]}
    return best, records, summary
