"""What the swing-ups solved from the OCP's defaults share: their standard rows and figure.

The acrobot, Furuta, rail-pendulum and double-cartpole swing-ups are each solved by
``solve_ocp(ocp, method)`` alone (no guess, no handling) and reported the same way:

- :func:`solve_and_check`: the solve, the default strategy's attempts, the solution's row
  and the standard comparisons (converged, target residual, node manifold residual against
  the engine's ``MANIFOLD_TOL``, local defect against the solve's own limit, the input
  bound up to Ipopt's bound relaxation and, with ``T`` free, ``T`` inside its range);
- :func:`open_loop`: the open-loop re-simulation, reported (not compared) with the
  unstable rates of the equilibrium it ends near;
- :func:`work_energy`: the work of the input along the intervals against the energy gain
  in closed form (the energy theorem, which the optimiser does not impose);
- :func:`closed_loop`: a TVLQR design and its saturated Monte Carlo from perturbed starts;
- :func:`angle_figure`: the S^1 factors' angles over time, optimal and closed loop, and
  the input (and, optionally, snapshots of the mechanism).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from workbench.control import solve_ocp, tvlqr_along
from workbench.control.ocp import OCP, OCPSolution, Stepper
from workbench.control.ocp.solve import DEFECT_TOL, MANIFOLD_TOL
from workbench.control.ocp.study import dense, monte_carlo, solution_row
from workbench.linear import linearize
from workbench.study import Panel, Result, line_figure

__all__ = ["coordinates", "steps", "interval_flows", "solve_and_check", "open_loop",
           "work_energy", "closed_loop", "angle_figure", "BOUND_RELAXATION", "CLOSED_LOOP_TOL"]

BOUND_RELAXATION = 1e-8
"""Ipopt's ``bound_relax_factor``: a bound ``b`` may be crossed by it times ``max(1, |b|)``."""
CLOSED_LOOP_TOL = 1e-2
"""A closed-loop run succeeds when it ends within this of the target (chart max-norm)."""


def coordinates(model: Any, X: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """The factors ``names`` along states ``X`` (rows): S^1 angles unwrapped, R^1 values.

    An S^1 factor stored as ``(cos, sin)`` gives its angle ``atan2(sin, cos)``, unwrapped
    along the rows; a factor of one entry is returned as it is.

    Returns
    -------
    ndarray, shape=(len(X), len(names))
    """
    X = np.atleast_2d(X)
    sl = model.manifold.slices
    return np.column_stack([np.unwrap(np.arctan2(X[:, sl[n].start + 1], X[:, sl[n].start]))
                            if sl[n].stop - sl[n].start == 2 else X[:, sl[n].start]
                            for n in names])


def steps(model: Any, A: np.ndarray, B: np.ndarray, name: str) -> np.ndarray:
    """Increments of the factor ``name`` from the rows of ``A`` to those of ``B``.

    For an S^1 factor the increment is the angle from ``A`` to ``B`` in ``(-pi, pi]``
    (each step must turn less than half a turn); for a factor of one entry, ``B - A``.

    Returns
    -------
    ndarray, shape=(len(A),)
    """
    s = model.manifold.slices[name]
    a, b = np.atleast_2d(A)[:, s], np.atleast_2d(B)[:, s]
    if s.stop - s.start == 1:
        return b[:, 0] - a[:, 0]
    return np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])


def interval_flows(model: Any, X: np.ndarray, U: np.ndarray, T: float,
                   rtol: float = 1e-11) -> np.ndarray:
    """Each interval integrated from its own node with its held input (CVODES).

    Parameters
    ----------
    model : Model
    X : ndarray, shape=(N + 1, ambient_dim)
        The nodes.
    U : ndarray, shape=(N, m)
        The input held on each interval.
    T : float
        The horizon; the intervals are ``T / N`` long.
    rtol : float
        CVODES's relative and absolute tolerance.

    Returns
    -------
    ndarray, shape=(N, ambient_dim)
        The end of each interval's flow.
    """
    stepper = Stepper(model, rtol=rtol, atol=rtol)
    h = T / len(U)
    return np.array([stepper.step(x, u, h) for x, u in zip(X[:-1], U)])


def solve_and_check(res: Result, ocp: OCP, method: Any, *, cost: str, unit: str, target: str,
                    manifold: str, parameters: Mapping[str, float], symbol: str = "u",
                    defect_margin: float = 1.0, note: str = "") -> OCPSolution:
    """Solve ``ocp`` from the defaults and add the standard values, comparisons and note.

    Declares the model used (:meth:`Result.use`). Values: ``problem``, ``attempts`` (the
    default strategy's table), ``strategy``, ``solution``
    (:func:`~workbench.control.ocp.study.solution_row`, re-simulated open loop when
    solved) and ``diagnosis`` on failure.

    Parameters
    ----------
    res : Result
    ocp : OCP
        The problem; its inputs bounded by ``|u_i| <= ocp.u_upper``.
    method : TranscriptionMethod
    cost : str
        The cost in words (``"integral u^2 dt + T"``).
    unit : str
        The input's unit (``"N"``, ``"N m"``).
    target : str
        What the target residual measures, for the row's name.
    manifold : str
        The constraints the node manifold residual measures, for the row's source.
    parameters : mapping of str to float
        The model's parameters, recorded.
    symbol : str
        The input's symbol in the bound's row.
    defect_margin : float
        ``1``: the local defect is compared with the solve's limit; ``> 1``: the defect over
        the limit is compared with ``1 / defect_margin``.

    With ``T`` free (``ocp.T`` a range) a row checks that the optimal ``T`` is strictly
    inside it (by 1e-3 s): the effort-time trade-off sets it, not a bound of the range.
    note : str
        Appended to the standard note (solved from the defaults).

    Returns
    -------
    OCPSolution
    """
    res.use(ocp.model)
    with res.timed("solve from the defaults"):
        sol = solve_ocp(ocp, method, raise_on_failure=False)
    u_max = float(np.max(ocp.u_upper))
    res.values["problem"] = {
        "cost": cost, f"bound_{unit.replace(' ', '_')}": u_max,
        ("T_range_s" if np.ndim(ocp.T) else "T_s"): np.asarray(ocp.T, float).tolist(),
        "target": ocp.target.description, "transcription": sol.describe(),
        "parameters": dict(parameters), "solved_by": "solve_ocp(ocp, method): no guess, "
                                                      "no handling"}
    res.values["attempts"] = [dict(a) for a in sol.attempts]
    res.values["strategy"] = {"attempts": len(sol.attempts),
                              "cpu_seconds": sol.cost.get("strategy_cpu_seconds")}
    if sol.diagnosis is not None:
        res.values["diagnosis"] = str(sol.message)
    with res.timed("open-loop re-simulation"):
        res.values["solution"] = solution_row(sol, resimulate=sol.status.ok)
    res.compare(f"converged from the defaults ({sol.status.name} after {len(sol.attempts)} "
                "attempts)", 1.0, float(sol.status.ok), tolerance=0.0,
                source="Ipopt status, on the manifold, within defect_tol")
    res.compare(f"target residual ({target})", 0.0, sol.error["target_residual"],
                tolerance=1e-8, source="terminal chart = 0")
    res.compare("node manifold residual", 0.0, sol.error["manifold_residual"],
                tolerance=MANIFOLD_TOL, source=f"{manifold} (default manifold_tol)")
    limit = sol.error.get("defect_limit", DEFECT_TOL * max(1.0, float(np.max(np.abs(sol.x)))))
    defect = sol.error.get("local_defect", np.inf)
    if defect_margin == 1.0:
        res.compare("local defect against CVODES (limit: default defect_tol x max(1, max|x|))",
                    0.0, defect, tolerance=limit, source=sol.describe())
    else:
        res.compare("local defect against CVODES, relative to the default limit", 0.0,
                    defect / limit, tolerance=1.0 / defect_margin,
                    source=f"default defect_tol, with a margin of {defect_margin:g}")
    unit_text = f" {unit})" if unit == "N" else f") [{unit}]"
    res.compare(f"bound respected: max(0, max |{symbol}| - {u_max:g}{unit_text}", 0.0,
                max(0.0, float(np.max(np.abs(sol.u))) - u_max),
                tolerance=BOUND_RELAXATION * max(1.0, u_max),
                source="input bound, up to Ipopt's bound relaxation 1e-8 max(1, |bound|)")
    if np.ndim(ocp.T):  # T free: the effort-time trade-off sets it, not a bound of the range
        lo, hi = ocp.T
        res.compare(f"T = {sol.T:.3f} s strictly inside [{lo:g}, {hi:g}] s (1 = at a bound)",
                    0.0, float(not lo + 1e-3 < sol.T < hi - 1e-3), tolerance=0.0,
                    source="the range leaves the effort-time trade-off free")
    res.notes.append(f"Solved by solve_ocp(ocp, method) ({sol.describe()}) with no guess and "
                     f"no handling: the default strategy's attempts are listed under "
                     f"'attempts'. {note}".strip())
    return sol


def open_loop(res: Result, sol: OCPSolution, x_eq: np.ndarray, what: str) -> None:
    """Report the open-loop re-simulation: its end error and the rates it is amplified by.

    Parameters
    ----------
    res : Result
    sol : OCPSolution
        Solved and re-simulated (:func:`solve_and_check`).
    x_eq : ndarray, shape=(ambient_dim,)
        The unstable equilibrium the swing-up ends at.
    what : str
        The equilibrium in words, for the note (``"the upright acrobot"``).
    """
    rates = np.linalg.eigvals(linearize(sol.ocp.model, x_eq).A).real
    unstable = sorted(float(r) for r in rates if r > 1e-9)
    res.values["open_loop"] = {
        "end_error": sol.error["resim_end_error"],
        "target_residual": sol.error["resim_target_residual"],
        "unstable_rates_upright_per_s": unstable,
        "why": "the optimal input replayed open loop from x0 (CVODES, rtol 1e-10) leaves the "
               "trajectory near an unstable equilibrium: the per-interval local defect "
               "measures the transcription, the TVLQR closed loop follows it"}
    res.notes.append(
        f"The open-loop re-simulation (CVODES, rtol 1e-10, the optimal input replayed) ends "
        f"{sol.error['resim_end_error']:.3g} from the transcribed end state: {what} "
        f"diverges at {max(unstable, default=0.0):.2f} /s, and the local defects (at most "
        f"{sol.error['local_defect']:.2g}) grow by that; it is reported, not compared. The "
        f"TVLQR closed loop is what follows the trajectory.")


def work_energy(res: Result, sol: OCPSolution, *, coordinate: str, gain: float, formula: str,
                work: str, tolerance: float, ends: np.ndarray | None = None) -> dict[str, float]:
    """The input's work along the intervals and the energy gain, against the closed form.

    With the input held on each interval and acting on the coordinate ``coordinate``, its
    work is ``sum u_k (c(end_k) - c(x_k))``: exact for a trajectory of the model (energy
    theorem, ``dE/dt = u c-dot``), which the optimiser does not impose; its departure
    from ``E(x_T) - E(x_0)`` measures the transcription's error.

    Parameters
    ----------
    res : Result
    sol : OCPSolution
    coordinate : str
        The factor the (single) input does work on (S^1 or R^1).
    gain : float
        ``E(x_T) - E(x_0)`` in closed form [J].
    formula : str
        The closed form in words, for the rows' names.
    work : str
        The name of the work's row.
    tolerance : float
        Relative tolerance of the work's row.
    ends : ndarray, shape=(N, ambient_dim), optional
        Where each interval ends: its flow from the node (:func:`interval_flows`); the
        next node if not given.

    Returns
    -------
    dict
        ``work``, ``energy_gain`` (from the model's ``energy`` invariant), ``closed_form``.
    """
    model = sol.ocp.model
    end = sol.x[1:] if ends is None else ends
    w = float(sol.u[:, 0] @ steps(model, sol.x[:-1], end, coordinate))
    e = model.invariants(sol.x[-1])["energy"] - model.invariants(sol.x[0])["energy"]
    res.compare(f"energy gain E(x_T) - E(x_0) = {formula} [J]", gain, e, tolerance=1e-9,
                relative=True, source="closed form (from rest to rest)")
    res.compare(work, gain, w, tolerance=tolerance, relative=True, source=(
        f"energy theorem dE/dt = u d{coordinate}/dt (not imposed), the input held along "
        + ("each interval's flow from its node" if ends is not None else "the nodes")))
    return {"work": w, "energy_gain": float(e), "closed_form": gain}


def closed_loop(res: Result, sol: OCPSolution, x_eq: np.ndarray | None, *, Q: np.ndarray,
                R: float, n: int, scale: Any, hold: float, design: Callable[[], Any] | None = None,
                x0: np.ndarray | None = None, where: str = "", seed: int = 0,
                **info: Any) -> tuple[Any, dict[str, Any]]:
    """Design a TVLQR and run its closed loop, saturated at the OCP's bounds, from ``n`` starts.

    Adds the value ``tvlqr`` (the Monte Carlo's summary, the design's information and
    cost, ``Q``, ``R`` and ``info``) and the row of the success rate (tolerance 0.1).

    Parameters
    ----------
    res : Result
    sol : OCPSolution
        The trajectory to follow; its OCP's input bounds saturate the closed loop.
    x_eq : ndarray, shape=(ambient_dim,), or None
        The equilibrium the TVLQR hands over to after ``T`` (``tvlqr_along(sol, x_eq, Q,
        R)``); None with ``design``.
    Q : ndarray
    R : float
        The design's weights.
    n, scale, hold, seed
        As :func:`~workbench.control.ocp.study.monte_carlo`.
    design : callable, optional
        ``design() -> TVLQR`` instead of ``tvlqr_along`` (e.g. on another model).
    x0 : ndarray, optional
        The start the perturbations are about; ``sol.ocp.x0`` if not given.
    where : str
        Appended to the row's name (``" (torque saturated)"``).
    **info
        More entries of the value ``tvlqr``.

    Returns
    -------
    (TVLQR, dict)
        The controller and the Monte Carlo (with its ``runs``).
    """
    ocp = sol.ocp
    with res.timed("TVLQR design + closed loop"):
        ctrl = design() if design is not None else tvlqr_along(sol, x_eq=x_eq, Q=Q, R=R)
        mc = monte_carlo(ctrl, ocp.x0 if x0 is None else x0, n=n, scale=scale, seed=seed,
                         hold=hold, tol=CLOSED_LOOP_TOL, u_bounds=(ocp.u_lower, ocp.u_upper))
    res.values["tvlqr"] = {k: v for k, v in mc.items() if k != "runs"} | dict(ctrl.info) | {
        "design": dict(ctrl.cost), "sample_period": ctrl.dt, "Q": np.asarray(Q).tolist(),
        "R": R} | info
    res.compare(f"TVLQR success rate from {mc['n']} perturbed starts{where}", 1.0,
                mc["success_rate"], tolerance=0.1,
                source=f"closed loop reaches the target within {CLOSED_LOOP_TOL:g} "
                       f"(chart max-norm)")
    return ctrl, mc


def angle_figure(sol: OCPSolution, runs: Sequence[Any], names: Sequence[str],
                 labels: Mapping[str, str] | None, *, title: str, input_title: str, unit: str,
                 sketch: Callable[[np.ndarray], np.ndarray] | None = None) -> Any:
    """Figure: the coordinates ``names`` over time and the input, optimal and closed loop.

    The optimal trajectory is drawn between the nodes too (each interval integrated from
    its node, :func:`~workbench.control.ocp.study.dense`); the closed-loop runs thin and
    grey, under it.

    Parameters
    ----------
    sol : OCPSolution
    runs : sequence of ClosedLoopRun
    names : sequence of str
        Factors of the state (:func:`coordinates`).
    labels : mapping of str to str, optional
        Words for the codes (:meth:`Result.label`).
    title : str
        What the figure shows, for its title (with the cost, ``T`` and the attempts).
    input_title, unit : str
        The input panel's title and the input's unit.
    sketch : callable, optional
        ``sketch(x) -> (k, 2)``: the mechanism at state ``x`` as a chain of points in the
        plane (horizontal, height), its base first; a first panel draws it at 11 times,
        light to dark, the base as a square.
    """
    model = sol.ocp.model
    X = dense(sol, substeps=4)
    t = np.linspace(0.0, sol.T, len(X))
    curves: dict[str, Any] = {}
    inputs: dict[str, Any] = {}
    if runs:  # drawn first, under the optimal trajectory
        n = min(len(r.x) for r in runs)
        tr = runs[0].t[:n]
        curves["closed loop"] = (tr, np.column_stack([coordinates(model, r.x[:n], names)
                                                      for r in runs]))
        m = min(len(r.u) for r in runs)
        inputs["closed loop"] = (tr[:m], np.column_stack([r.u[:m, 0] for r in runs]))
    a = coordinates(model, X, names)
    curves |= {name: (t, a[:, i]) for i, name in enumerate(names)}
    inputs["optimal"] = (np.repeat(sol.t, 2)[1:-1], np.repeat(sol.u[:, 0], 2))
    panels = [Panel("angles", curves, xlabel="t [s]", ylabel="angle [rad]"),
              Panel(input_title, inputs, xlabel="t [s]", ylabel=f"u [{unit}]")]
    if sketch is not None:
        panels.insert(0, Panel("the mechanism, light to dark in time", xlabel="e1 [m]",
                               ylabel="height (-e3) [m]"))
    fig = line_figure(panels, ncols=len(panels), labels=labels)
    for ax, k in zip(fig.axes[-2:], (len(runs) * len(names), len(runs))):
        for i, line in enumerate(ax.get_lines()):  # the closed loop thin and grey, under
            line.set(**({"color": "0.6", "lw": 0.5, "alpha": 0.6} if i < k else
                        {"color": f"C{i - k}"}))
        ax.legend(fontsize=8)
    if sketch is not None:
        import matplotlib.pyplot as plt

        ax = fig.axes[0]
        picks = np.linspace(0, len(sol.x) - 1, 11).round().astype(int)
        for j, k in enumerate(picks):
            c, pts = plt.cm.viridis(0.15 + 0.8 * j / (len(picks) - 1)), sketch(sol.x[k])
            ax.plot(pts[:, 0], pts[:, 1], "-o", color=c, ms=2.5, lw=1.2)
            ax.plot(pts[0, 0], pts[0, 1], "s", color=c, ms=7)
        ax.set_aspect("equal")
    fig.suptitle(f"{title} from the defaults: cost {sol.objective:.4f}, T = {sol.T:.3f} s, "
                 f"{len(sol.attempts)} attempts", fontsize=9)
    return fig
