"""Swing-up of the Furuta pendulum with a weak motor, from the OCP's defaults, + TVLQR.

Model: :func:`models.furuta.furuta` (Quanser's QUBE-Servo 2 arm and pendulum, no motor
dynamics or friction), the arm angle ``theta`` and the link angle ``alpha`` as S^1 factors.
From hanging at rest (``alpha = 0``, arm at ``theta = 0``) to upright at rest
(``alpha = pi``), minimising ``integral tau^2 dt + T`` under ``|tau| <= 0.01`` N m, T free
in [0.5, 4] s. The motor is too weak to lift the link in one go (the default strategy's
direct path asks for several times the bound): it must pump. The arm's final angle is
left free (a :class:`~workbench.control.ocp.problem.TargetSet`): the arm angle is cyclic
(turning the whole pendulum about the motor axis is a symmetry), so every arm angle is as
good an upright equilibrium as another; requiring the arm back at 0 would only add cost to
the swing-up (the balancing LQR holds the arm where the swing-up leaves it).

Solved by ``solve(ocp, Collocation(N=60, degree=3))`` with no guess and no handling: the
default strategy's attempts are listed. Checks: the target residual, the bound, the node
manifold residual, the local defect, the bang-bang structure of the torque, two balance
laws of the model that the optimiser does not impose (the motor's work equals the link's
energy gain ``mp g Lp``; the motor's angular impulse equals the change of the angular
momentum about the motor axis, zero from rest to rest) and a closed-loop Monte Carlo of
the TVLQR; the open-loop re-simulation is reported.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from models.furuta import QUBE_SERVO_2, furuta, hanging, upright
from workbench.control import tvlqr_along
from workbench.control.ocp import OCP, Collocation, OCPSolution
from workbench.control.ocp import solve as solve_ocp
from workbench.control.ocp.solve import DEFECT_TOL, MANIFOLD_TOL
from workbench.control.ocp.study import dense, effort_time_ocp, monte_carlo, solution_row
from workbench.linear import linearize
from workbench.study import Panel, Result, line_figure

TITLE = "Furuta pendulum swing-up, weak motor (|tau| <= 0.01 N m), from the OCP defaults + TVLQR"

U_MAX = 0.01
T_RANGE = (0.5, 4.0)
N = 60
Q_LQR = np.r_[10.0, 1.0, 100.0, 1.0]  # theta, theta_dot, alpha, alpha_dot (tangent coords)
R_LQR = 1e3
PERTURBATION = 1e-3  # saturated: the optimal torque is at the bound almost everywhere
PERTURBATION_UNSATURATED = 1e-2
BOUND_RELAXATION = 1e-8
"""Ipopt's ``bound_relax_factor``: bounds are relaxed by it times ``max(1, |bound|)``."""
CLOSED_LOOP_TOL = 1e-2
HOLD = 2.0  # seconds under the upright LQR after T (its slowest mode: about 0.3 s)


def problem() -> OCP:
    """The swing-up OCP: ``integral tau^2 dt + T``, hanging -> upright, arm angle free."""
    model = furuta()
    return effort_time_ocp(model, hanging(model), upright(model), u_max=U_MAX, T=T_RANGE,
                           free=("theta",), name="furuta",
                           description="link upright at rest, arm at rest at any angle")


def angles(model: Any, X: np.ndarray, names: tuple[str, ...] = ("theta", "alpha")
           ) -> np.ndarray:
    """Unwrapped angles [rad] of the S^1 factors ``names`` along states ``X`` (rows).

    Returns
    -------
    ndarray, shape=(len(X), len(names))
    """
    sl = model.manifold.slices
    return np.column_stack([np.unwrap(np.arctan2(X[:, sl[n].start + 1], X[:, sl[n].start]))
                            for n in names])


def balances(sol: OCPSolution) -> dict[str, float]:
    """The motor's work and angular impulse over the transcribed trajectory.

    With the torque held on each interval, ``int tau theta-dot dt = sum tau_k (theta_k+1 -
    theta_k)`` and ``int tau dt = sum tau_k h``: exact for a trajectory of the model, so
    their departure from ``E(x_T) - E(x_0)`` and ``L(x_T) - L(x_0)`` measures the
    transcription's error.
    """
    model = sol.ocp.model
    th = angles(model, sol.x)[:, 0]
    u = sol.u[:, 0]
    inv0, invT = model.invariants(sol.x[0]), model.invariants(sol.x[-1])
    return {"work": float(u @ np.diff(th)), "energy_gain": invT["energy"] - inv0["energy"],
            "impulse": float(np.sum(u * np.diff(sol.t))),
            "momentum_change": (invT["angular_momentum_theta"]
                                - inv0["angular_momentum_theta"])}


def bang_bang(u: np.ndarray, bound: float) -> dict[str, int]:
    """Intervals at the bound, inside it, and inside it without a switch of sign.

    A switch of a bang-bang control falls inside one interval (its held value is then
    between the bounds) or on a node (neighbours at opposite bounds); an interval inside
    the bound whose neighbours are at the *same* bound holds no switch.
    """
    inside = np.flatnonzero(np.abs(u) < bound * (1 - 1e-6))
    lone = [k for k in inside if 0 < k < len(u) - 1 and np.sign(u[k - 1]) == np.sign(u[k + 1])]
    return {"at_bound": int(len(u) - len(inside)), "inside": int(len(inside)),
            "switches": int(np.sum(np.diff(np.sign(u)) != 0)),
            "inside_without_switch": len(lone)}


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        8 closed-loop runs instead of 24; the same OCP (it is cheap).

    Returns
    -------
    Result
    """
    res = Result("swingup_furuta", TITLE, quick=quick)
    ocp = problem()
    model = ocp.model
    res.use(model)
    res.label(theta="arm angle", alpha="link angle from hanging (pi: upright)",
              u="motor torque on the arm")
    with res.timed("OCP from the defaults"):
        sol = solve_ocp(ocp, Collocation(N=N, degree=3), raise_on_failure=False)
    res.values["problem"] = {
        "cost": "integral tau^2 dt + T", "bound_N_m": U_MAX, "T_range_s": list(T_RANGE),
        "target": ocp.target.description, "transcription": sol.describe(),
        "parameters": dict(QUBE_SERVO_2)}
    res.values["attempts"] = sol.attempts
    res.compare(f"converged from the defaults ({sol.status.name})", 1.0,
                float(sol.status.ok), tolerance=0.0, source="the default strategy's status")
    if not sol.status.ok:
        res.values["diagnosis"] = sol.diagnosis
        return res.finish()
    with res.timed("open-loop re-simulation"):
        row = solution_row(sol)
    theta_T = float(angles(model, sol.x)[-1, 0])
    x_up = upright(model, theta=theta_T)  # the upright equilibrium the swing-up ends at
    res.values["solution"] = row
    res.compare("target residual (link upright at rest, arm at rest)", 0.0,
                sol.error["target_residual"], tolerance=1e-8, source="terminal set = 0")
    res.compare("bound respected: max(0, max |tau| - 0.01) [N m]", 0.0,
                max(0.0, float(np.max(np.abs(sol.u))) - U_MAX), tolerance=BOUND_RELAXATION,
                source="control bound, up to Ipopt's bound relaxation 1e-8")
    res.compare("node manifold residual", 0.0, sol.error["manifold_residual"],
                tolerance=MANIFOLD_TOL, source="default manifold_tol")
    limit = DEFECT_TOL * max(1.0, float(np.max(np.abs(sol.x))))  # as solve() scales it
    res.compare("local defect against CVODES, relative to the default limit", 0.0,
                sol.error["local_defect"] / limit, tolerance=0.1,
                source="default defect_tol, with a margin of 10")
    rates = np.linalg.eigvals(linearize(model, x_up).A).real
    res.values["open_loop"] = {
        "end_error": sol.error["resim_end_error"],
        "unstable_rates_upright_per_s": sorted(float(r) for r in rates if r > 1e-9)}
    start = sol.attempts[-1]["guess"].split(":")[0]
    res.values["solved_from"] = start
    res.compare(f"solved from the energy-pumping start (solved from: {start})", 1.0,
                float(start == "energy pumping"), tolerance=0.0,
                source="a 0.01 N m motor cannot lift the link directly: it must pump")
    b = balances(sol)
    res.values["balances"] = b
    e_gain = QUBE_SERVO_2["mp"] * QUBE_SERVO_2["g"] * QUBE_SERVO_2["Lp"]
    res.compare("energy gain E(x_T) - E(x_0) = mp g Lp [J]", e_gain, b["energy_gain"],
                tolerance=1e-9, relative=True, source="closed form (upright at rest)")
    res.compare("motor work sum tau_k (theta_k+1 - theta_k) = mp g Lp [J]", e_gain,
                b["work"], tolerance=1e-2, relative=True,
                source="energy balance dE/dt = tau theta-dot (not imposed)")
    res.compare("motor angular impulse int tau dt = 0 [N m s]", 0.0, b["impulse"],
                tolerance=1e-3 * U_MAX * sol.T, source="dL/dt = tau, L = 0 at rest "
                                                         "(not imposed); tol 0.1% of the bound x T")
    bang = bang_bang(sol.u[:, 0], U_MAX)
    res.values["bang_bang"] = bang
    at_bound = bang["at_bound"] / len(sol.u)
    res.compare("bang-bang: intervals inside the bound that hold no switch", 0.0,
                bang["inside_without_switch"], tolerance=0.0,
                source="Pontryagin: tau = clip(-lambda.b / 2), |lambda.b| >> 2 |tau|max "
                       "except where lambda.b changes sign")
    with res.timed("TVLQR design + closed loop"):
        ctrl = tvlqr_along(sol, x_eq=x_up, Q=Q_LQR, R=R_LQR)
        mc = monte_carlo(ctrl, ocp.x0, n=8 if quick else 24, scale=PERTURBATION, seed=0,
                         hold=HOLD, tol=CLOSED_LOOP_TOL,
                         u_bounds=(ocp.u_lower, ocp.u_upper))
        free = monte_carlo(ctrl, ocp.x0, n=8, scale=PERTURBATION_UNSATURATED, seed=1,
                           hold=HOLD, tol=CLOSED_LOOP_TOL)
    res.values["tvlqr"] = {k: v for k, v in mc.items() if k != "runs"}
    res.values["tvlqr"].update(dict(ctrl.info), design=dict(ctrl.cost), sample_period=ctrl.dt,
                               Q=Q_LQR.tolist(), R=R_LQR, arm_angle_held_rad=theta_T)
    res.values["tvlqr_unsaturated"] = {k: v for k, v in free.items() if k != "runs"}
    res.compare(f"TVLQR success rate from {mc['n']} perturbed starts (torque saturated)", 1.0,
                mc["success_rate"], tolerance=0.1,
                source="closed loop reaches the upright equilibrium")
    res.figure("swingup", angle_figure(sol, mc["runs"][:8], ("theta", "alpha"), res.labels),
               caption=(
        f"The optimal swing-up (cost {sol.objective:.4f}, T = {sol.T:.3f} s): the arm and "
        f"link angles (each interval integrated from its node) and the torque, at the bound "
        f"on {100 * at_bound:.0f}% of the intervals; thin lines: TVLQR closed-loop runs "
        f"from perturbed starts, the torque saturated at the bound."))
    res.notes.append(
        f"The optimal torque is bang-bang (Pontryagin, the bound far below the unconstrained "
        f"optimum): at the bound on {bang['at_bound']} of {len(sol.u)} intervals, "
        f"{bang['switches']} switches. So the TVLQR has almost no authority left: with the "
        f"torque saturated its Monte Carlo uses starts perturbed by {PERTURBATION:g} "
        f"(tangent coordinates); unsaturated, from starts perturbed by "
        f"{PERTURBATION_UNSATURATED:g}, it reaches upright in "
        f"{free['successes']}/{free['n']} runs using up to {free['max_abs_u']:.4g} N m.")
    res.notes.append(
        f"The open-loop re-simulation (CVODES, rtol 1e-10, the optimal torque replayed) ends "
        f"{sol.error['resim_end_error']:.3g} from the transcribed end state: the upright "
        f"link diverges at {max(rates):.1f} /s and the local defects (at most "
        f"{sol.error['local_defect']:.2g}) grow by that; it is reported, not compared. The "
        f"TVLQR closed loop is what follows the trajectory.")
    res.notes.append(
        "No guess and no handling are given: the default strategy's attempts are listed in "
        "'attempts' (the energy-pumping feedback simulated under the bound is the start "
        "that solves it). The arm angle is free at the end: the momentum symmetry makes "
        "every arm angle an equivalent upright equilibrium; the TVLQR hands over to the LQR "
        "of the upright equilibrium at the arm angle the swing-up ends at.")
    return res.finish()


def angle_figure(sol: OCPSolution, runs: list[Any], names: tuple[str, ...],
                 labels: dict[str, str]) -> Any:
    """Figure: the angles ``names`` over time and the input, optimal and closed loop.

    The optimal trajectory is drawn between the nodes too (each interval integrated from its
    node, :func:`~workbench.control.ocp.study.dense`); the closed-loop runs thin, under it.
    """
    model = sol.ocp.model
    X = dense(sol, substeps=4)
    t = np.linspace(0.0, sol.T, len(X))
    a = angles(model, X, names)
    curves: dict[str, Any] = {}
    inputs: dict[str, Any] = {}
    if runs:  # drawn first, under the optimal trajectory
        n = min(len(r.x) for r in runs)
        tr = runs[0].t[:n]
        curves["closed loop"] = (tr, np.column_stack([angles(model, r.x[:n], names)
                                                      for r in runs]))
        m = min(len(r.u) for r in runs)
        inputs["closed loop"] = (tr[:m], np.column_stack([r.u[:m, 0] for r in runs]))
    curves |= {name: (t, a[:, i]) for i, name in enumerate(names)}
    inputs["optimal"] = (np.repeat(sol.t, 2)[1:-1], np.repeat(sol.u[:, 0], 2))
    return line_figure([
        Panel("angles", curves, xlabel="t [s]", ylabel="angle [rad]"),
        Panel("input", inputs, xlabel="t [s]", ylabel="u [N m]")], labels=labels)


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
