"""Swing-up of the double pendulum on a cart (Bogdanov 2004), from the OCP's defaults + TVLQR.

Model: :func:`models.double_cartpole.double_cartpole` with Bogdanov's (2004) cart and rods
(cart 1.5 kg; uniform rods 0.5 kg, 0.5 m and 0.75 kg, 0.75 m; both link angles on S^1;
``e3`` down). From both rods hanging at rest with the cart at the origin to both upright
at rest with the cart back at the origin; one force on the cart, ``|u| <= 20`` N; ``T``
free in ``[1, 6]`` s; minimise ``integral u^2 dt + T``;
``Collocation(N=100, degree=3)``; solved by ``solve_ocp(ocp, METHOD)`` alone: no guess, no
handling.

The choices. 20 N accelerates the whole 2.75 kg at 7.3 m/s^2 (0.74 g), a bench-scale cart
drive; the rods must gain 15.3 J. The horizon's range leaves the optimum inside it (a
row checks it): the effort-time trade-off sets ``T``, not a bound of the range (with
``T <= 4`` s the defaults return a swing-up at ``T = 4``, at the bound). ``N = 100`` holds
the default ``defect_tol`` with a margin of about two orders of magnitude (a row shows
the defect against its limit; at ``N = 80`` the defaults can land on a slower swing-up whose
defect comes within a factor 1.5 of it).

The open-loop replay of the optimal force (``sol.resimulate()``) is recorded, not held
to a tolerance: it leaves the trajectory near upright, an unstable equilibrium (its
end error is in the values); the per-interval local defect measures the transcription,
and the TVLQR closed loop follows the trajectory.

Independent check: Bogdanov's closed form ``D(theta) theta-ddot + C theta-dot + G = H u``
(his angles from the upward vertical, integrated by SciPy) carries every node over its
interval to where the workbench's model (derived from the Lagrangian on ``S^1``,
integrated by CVODES) does; and the force's work along the intervals is the energy the
rods gain, ``g (m1 L1 + m2 (2 L1 + L2))`` in closed form.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from models.double_cartpole import BOGDANOV_2004, double_cartpole, hanging, upright
from problems import _swingup as sw
from workbench.control.ocp import OCP, Collocation, OCPSolution
from workbench.control.ocp.study import effort_time_ocp
from workbench.study import Result

TITLE = ("Swing-up of the double pendulum on a cart (Bogdanov 2004), from the OCP's "
         "defaults + TVLQR")

SUMMARY = (
    "Two rods jointed in series on a cart (Bogdanov's 2004 double inverted pendulum) are "
    "swung up from hanging to balance upright, both at once, by one force on the cart. The "
    "optimal control solver finds the swing-up from its own defaults, with no starting "
    "guess; the motion is checked against Bogdanov's own equations and the energy the rods "
    "gain, and a time-varying LQR holds it against perturbed starts.")

U_MAX = 20.0
T_RANGE = (1.0, 6.0)
METHOD = Collocation(N=100, degree=3)
Q_LQR = np.r_[10.0, 1.0, 100.0, 1.0, 100.0, 1.0]  # tangent: x, v, phi1, rate, phi2, rate
R_LQR = 0.1
PERTURBATION = np.r_[0.01, 0.01, 0.02, 0.05, 0.02, 0.05]


def problem() -> OCP:
    """The swing-up OCP (cost integral u^2 dt + T, |u| <= 20 N, T in [1, 6] s)."""
    model = double_cartpole()
    return effort_time_ocp(model, hanging(model), upright(model), u_max=U_MAX, T=T_RANGE,
                           name="double_cartpole",
                           description="cart at 0, both rods upright, rest")


def bogdanov_rhs(P: dict[str, float]) -> Any:
    """Bogdanov's (2004) eqs. (1)-(4), ``theta = (x, theta1, theta2)`` from the upward vertical.

    Returns ``f(t, y, u)`` with ``y = (theta, theta-dot)``: ``theta-ddot = D^-1 (H u - C
    theta-dot - G)``, ``H = (1, 0, 0)``.
    """
    m0, m1, m2, L1, L2, g = (P[n] for n in ("m0", "m1", "m2", "L1", "L2", "g"))
    l1, l2, I1, I2 = L1 / 2, L2 / 2, m1 * L1**2 / 12, m2 * L2**2 / 12
    d1, d2, d3 = m0 + m1 + m2, m1 * l1 + m2 * L1, m2 * l2
    d4, d5, d6 = m1 * l1**2 + m2 * L1**2 + I1, m2 * L1 * l2, m2 * l2**2 + I2
    f1, f2 = (m1 * l1 + m2 * L1) * g, m2 * l2 * g

    def f(t: float, y: np.ndarray, u: float) -> np.ndarray:
        _, t1, t2, _, w1, w2 = y
        c12, s12 = np.cos(t1 - t2), np.sin(t1 - t2)
        D = np.array([[d1, d2 * np.cos(t1), d3 * np.cos(t2)],
                      [d2 * np.cos(t1), d4, d5 * c12],
                      [d3 * np.cos(t2), d5 * c12, d6]])
        C = np.array([[0.0, -d2 * np.sin(t1) * w1, -d3 * np.sin(t2) * w2],
                      [0.0, 0.0, d5 * s12 * w2],
                      [0.0, -d5 * s12 * w1, 0.0]])
        G = np.array([0.0, -f1 * np.sin(t1), -f2 * np.sin(t2)])
        acc = np.linalg.solve(D, np.array([u, 0.0, 0.0]) - C @ y[3:] - G)
        return np.r_[y[3:], acc]

    return f


def bogdanov_flows(sol: OCPSolution, P: dict[str, float]) -> np.ndarray:
    """Each interval from its node by Bogdanov's equations (SciPy DOP853), as model states.

    ``theta_i = pi - phi_i`` and ``theta_i-dot = -phi_i-dot``, ``phi_i`` from hanging.
    """
    rhs, h, out = bogdanov_rhs(P), sol.T / len(sol.u), []
    for xk, uk in zip(sol.x[:-1], sol.u):
        x, v, p1, w1, p2, w2 = sw.coordinates(sol.ocp.model, xk, sol.ocp.model.manifold.names)[0]
        y = solve_ivp(rhs, (0.0, h), [x, np.pi - p1, np.pi - p2, v, -w1, -w2], rtol=1e-12,
                      method="DOP853", atol=1e-12, args=(float(uk[0]),)).y[:, -1]
        out.append(np.r_[y[0], y[3], -np.cos(y[1]), np.sin(y[1]), -y[4], -np.cos(y[2]),
                         np.sin(y[2]), -y[5]])
    return np.array(out)


def sketch(x: np.ndarray, P: dict[str, float] = BOGDANOV_2004) -> np.ndarray:
    """The cart and the rods' ends at state ``x``: points (e1, height), shape (3, 2)."""
    a, L = np.r_[0.0, np.arctan2(x[[3, 6]], x[[2, 5]])], np.r_[0.0, P["L1"], P["L2"]]
    return np.column_stack([x[0] + np.cumsum(L * np.sin(a)), -np.cumsum(L * np.cos(a))])


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        The same solve; 10 perturbed closed-loop starts held 1.5 s instead of 20 held 3 s.

    Returns
    -------
    Result
    """
    res = Result("swingup_double_cartpole", TITLE, quick=quick)
    ocp, P = problem(), BOGDANOV_2004
    res.label(x="cart position [m]", phi1="rod 1 from hanging", phi2="rod 2 from hanging")
    sol = sw.solve_and_check(
        res, ocp, METHOD, cost="integral u^2 dt + T", unit="N", target="chart at the end",
        manifold="cos^2 + sin^2 = 1", parameters=P, note=(
            "The problem has many local minima (swing patterns); the default strategy returns"
            " the first it reaches from its structured starts, not a certified global one."))
    if not sol.status.ok:
        return res.finish()
    sw.open_loop(res, sol, ocp.target.point, "the upright double pendulum")

    with res.timed("checks against Bogdanov's closed form"):
        flows = sw.interval_flows(ocp.model, sol.x, sol.u, sol.T)
        worst = float(np.max(np.abs(flows - bogdanov_flows(sol, P))))
    res.compare("interval flows: the model (S^1, CVODES) vs Bogdanov's D, C, G (SciPy)",
                0.0, worst, tolerance=1e-8, source="Bogdanov (2004) eqs. (1)-(4)")
    gain = P["g"] * (P["m1"] * P["L1"] + P["m2"] * (2 * P["L1"] + P["L2"]))
    balance = sw.work_energy(
        res, sol, coordinate="x", gain=gain, formula="g (m1 L1 + m2 (2 L1 + L2))", ends=flows,
        work="work of the force along the intervals = g (m1 L1 + m2 (2 L1 + L2))",
        tolerance=1e-3)
    res.values["independent_checks"] = {"max_end_state_difference": worst,
                                        "work": balance["work"], "energy_gain_closed_form": gain}

    _, mc = sw.closed_loop(res, sol, ocp.target.point, Q=Q_LQR, R=R_LQR, n=10 if quick else 20,
                           scale=PERTURBATION, hold=1.5 if quick else 3.0)
    res.figure("swingup", sw.angle_figure(
        sol, mc["runs"][:10], ("phi1", "phi2", "x"), res.labels, sketch=sketch,
        title="double pendulum on a cart", input_title="force on the cart", unit="N"), caption=(
        "The optimal swing-up from the defaults: left, the cart and both rods every few "
        "nodes (light to dark in time; up is -e3); middle, the link angles from hanging "
        "(pi: upright) and the cart's position, with closed-loop TVLQR runs from perturbed "
        "starts (thin); right, the force on the cart (|u| <= 20 N)."))
    res.notes.append(
        "Bogdanov (2004) poses stabilisation of the upright double pendulum, not this swing-up;"
        " his equations of motion serve here as the independent check of the dynamics.")
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
