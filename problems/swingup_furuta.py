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

import numpy as np

from models.furuta import QUBE_SERVO_2, furuta, hanging, upright
from problems import _swingup as sw
from workbench.control.ocp import OCP, Collocation
from workbench.control.ocp.study import effort_time_ocp, monte_carlo
from workbench.study import Result

TITLE = "Furuta pendulum swing-up, weak motor (|tau| <= 0.01 N m), from the OCP defaults + TVLQR"

U_MAX = 0.01
T_RANGE = (0.5, 4.0)
N = 60
Q_LQR = np.r_[10.0, 1.0, 100.0, 1.0]  # theta, theta_dot, alpha, alpha_dot (tangent coords)
R_LQR = 1e3
PERTURBATION = 1e-3  # saturated: the optimal torque is at the bound almost everywhere
PERTURBATION_UNSATURATED = 1e-2
HOLD = 2.0  # seconds under the upright LQR after T (its slowest mode: about 0.3 s)


def problem() -> OCP:
    """The swing-up OCP: ``integral tau^2 dt + T``, hanging -> upright, arm angle free."""
    model = furuta()
    return effort_time_ocp(model, hanging(model), upright(model), u_max=U_MAX, T=T_RANGE,
                           free=("theta",), name="furuta",
                           description="link upright at rest, arm at rest at any angle")


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
    res.label(theta="arm angle", alpha="link angle from hanging (pi: upright)",
              u="motor torque on the arm")
    sol = sw.solve_and_check(
        res, ocp, Collocation(N=N, degree=3), cost="integral tau^2 dt + T", unit="N m",
        target="link upright at rest, arm at rest", manifold="cos^2 + sin^2 = 1",
        parameters=QUBE_SERVO_2, symbol="tau", defect_margin=10.0, note=(
            "The energy-pumping feedback simulated under the bound is the start that solves "
            "it. The arm angle is free at the end: the momentum symmetry makes every arm "
            "angle an equivalent upright equilibrium; the TVLQR hands over to the LQR of the "
            "upright equilibrium at the arm angle the swing-up ends at."))
    if not sol.status.ok:
        return res.finish()
    theta_T = float(sw.coordinates(model, sol.x, ["theta"])[-1, 0])
    x_up = upright(model, theta=theta_T)  # the upright equilibrium the swing-up ends at
    sw.open_loop(res, sol, x_up, "the upright link")
    start = sol.attempts[-1]["guess"].split(":")[0]
    res.values["solved_from"] = start
    res.compare(f"solved from the energy-pumping start (solved from: {start})", 1.0,
                float(start == "energy pumping"), tolerance=0.0,
                source="a 0.01 N m motor cannot lift the link directly: it must pump")
    P = QUBE_SERVO_2
    b = sw.work_energy(res, sol, coordinate="theta", gain=P["mp"] * P["g"] * P["Lp"],
                       formula="mp g Lp", tolerance=1e-2,
                       work="motor work sum tau_k (theta_k+1 - theta_k) = mp g Lp [J]")
    inv0, invT = model.invariants(sol.x[0]), model.invariants(sol.x[-1])
    b |= {"impulse": float(np.sum(sol.u[:, 0] * np.diff(sol.t))),
          "momentum_change": invT["angular_momentum_theta"] - inv0["angular_momentum_theta"]}
    res.values["balances"] = b
    res.compare("motor angular impulse int tau dt = 0 [N m s]", 0.0, b["impulse"],
                tolerance=1e-3 * U_MAX * sol.T, source="dL/dt = tau, L = 0 at rest "
                                                         "(not imposed); tol 0.1% of the bound x T")
    bang = res.values["bang_bang"] = bang_bang(sol.u[:, 0], U_MAX)
    res.compare("bang-bang: intervals inside the bound that hold no switch", 0.0,
                bang["inside_without_switch"], tolerance=0.0,
                source="Pontryagin: tau = clip(-lambda.b / 2), |lambda.b| >> 2 |tau|max "
                       "except where lambda.b changes sign")
    ctrl, mc = sw.closed_loop(res, sol, x_up, Q=Q_LQR, R=R_LQR, n=8 if quick else 24,
                              scale=PERTURBATION, hold=HOLD, where=" (torque saturated)",
                              arm_angle_held_rad=theta_T)
    with res.timed("TVLQR closed loop, unsaturated"):
        free = monte_carlo(ctrl, ocp.x0, n=8, scale=PERTURBATION_UNSATURATED, seed=1,
                           hold=HOLD, tol=sw.CLOSED_LOOP_TOL)
    res.values["tvlqr_unsaturated"] = {k: v for k, v in free.items() if k != "runs"}
    res.figure("swingup", sw.angle_figure(
        sol, mc["runs"][:8], ("theta", "alpha"), res.labels, title="Furuta pendulum",
        input_title="input", unit="N m"), caption=(
        f"The optimal swing-up (cost {sol.objective:.4f}, T = {sol.T:.3f} s): the arm and "
        f"link angles (each interval integrated from its node) and the torque, at the bound "
        f"on {100 * bang['at_bound'] / len(sol.u):.0f}% of the intervals; thin lines: TVLQR "
        f"closed-loop runs from perturbed starts, the torque saturated at the bound."))
    res.notes.append(
        f"The optimal torque is bang-bang (Pontryagin, the bound far below the unconstrained "
        f"optimum): at the bound on {bang['at_bound']} of {len(sol.u)} intervals, "
        f"{bang['switches']} switches. So the TVLQR has almost no authority left: with the "
        f"torque saturated its Monte Carlo uses starts perturbed by {PERTURBATION:g} "
        f"(tangent coordinates); unsaturated, from starts perturbed by "
        f"{PERTURBATION_UNSATURATED:g}, it reaches upright in "
        f"{free['successes']}/{free['n']} runs using up to {free['max_abs_u']:.4g} N m.")
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
