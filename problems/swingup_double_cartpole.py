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
from workbench.control import solve_ocp, tvlqr_along
from workbench.control.ocp import OCP, Collocation, OCPSolution, Stepper
from workbench.control.ocp.solve import DEFECT_TOL, MANIFOLD_TOL
from workbench.control.ocp.study import effort_time_ocp, monte_carlo, solution_row
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
CLOSED_LOOP_TOL = 1e-2


def problem() -> OCP:
    """The swing-up OCP (cost integral u^2 dt + T, |u| <= 20 N, T in [1, 6] s)."""
    model = double_cartpole()
    return effort_time_ocp(model, hanging(model), upright(model), u_max=U_MAX, T=T_RANGE,
                           name="double_cartpole",
                           description="cart at 0, both rods upright, rest")


def angles(X: np.ndarray) -> np.ndarray:
    """``(x, v, phi1, phi1-dot, phi2, phi2-dot)`` per row, the angles unwrapped from the nodes."""
    X = np.atleast_2d(X)
    phi1 = np.unwrap(np.arctan2(X[:, 3], X[:, 2]))
    phi2 = np.unwrap(np.arctan2(X[:, 6], X[:, 5]))
    return np.column_stack([X[:, 0], X[:, 1], phi1, X[:, 4], phi2, X[:, 7]])


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


def flows_compared(sol: OCPSolution, P: dict[str, float]) -> dict[str, Any]:
    """Each interval from its node: the model (CVODES) against Bogdanov (SciPy DOP853).

    Returns the largest difference of the end states, in ``(x, v, cos, sin, rate)`` per
    link, and the force's work along the model's intervals.
    """
    model = sol.ocp.model
    stepper = Stepper(model, rtol=1e-11, atol=1e-11)
    rhs = bogdanov_rhs(P)
    h = sol.T / len(sol.u)
    worst, work = 0.0, 0.0
    for xk, uk in zip(sol.x[:-1], sol.u):
        ours = np.asarray(stepper.step(xk, uk, h), float)
        work += float(uk[0]) * (ours[0] - xk[0])
        a = angles(xk)[0]  # theta_i = pi - phi_i, theta_i-dot = -phi_i-dot
        y0 = np.r_[a[0], np.pi - a[2], np.pi - a[4], a[1], -a[3], -a[5]]
        y = solve_ivp(rhs, (0.0, h), y0, method="DOP853", rtol=1e-12, atol=1e-12,
                      args=(float(uk[0]),)).y[:, -1]
        phi1, phi2 = np.pi - y[1], np.pi - y[2]
        theirs = np.r_[y[0], y[3], np.cos(phi1), np.sin(phi1), -y[4],
                       np.cos(phi2), np.sin(phi2), -y[5]]
        worst = max(worst, float(np.max(np.abs(ours - theirs))))
    return {"max_end_state_difference": worst, "work": work}


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
    ocp = problem()
    model = ocp.model
    res.use(model)
    P = BOGDANOV_2004

    with res.timed("solve from the defaults"):
        sol = solve_ocp(ocp, METHOD, raise_on_failure=False)
    row = solution_row(sol, resimulate=sol.status.ok)
    res.values["problem"] = (f"integral u^2 dt + T, |u| <= {U_MAX:g} N, T in {list(T_RANGE)} s,"
                             f" {METHOD.describe()}; solve_ocp(ocp, method): no guess, no "
                             f"handling")
    res.values["solution"] = row
    res.values["attempts"] = [dict(a) for a in sol.attempts]
    res.values["strategy"] = {"attempts": len(sol.attempts),
                              "cpu_seconds": sol.cost.get("strategy_cpu_seconds")}
    if sol.diagnosis is not None:
        res.values["diagnosis"] = str(sol.message)
    res.compare(f"converged from the defaults ({sol.status.name} after {len(sol.attempts)} "
                "attempts)", 1.0, float(sol.status.ok), tolerance=0.0,
                source="Ipopt status, on the manifold, within defect_tol")
    res.compare("target residual (chart at the end)", 0.0, sol.error["target_residual"],
                tolerance=1e-8, source="terminal chart = 0")
    res.compare("node manifold residual", 0.0, sol.error["manifold_residual"],
                tolerance=MANIFOLD_TOL, source="cos^2 + sin^2 = 1 (default manifold_tol)")
    limit = DEFECT_TOL * max(1.0, float(np.max(np.abs(sol.x))))
    res.compare("local defect against CVODES (limit: default defect_tol x max(1, max|x|))",
                0.0, sol.error.get("local_defect", np.inf), tolerance=limit,
                source=f"Legendre d = 3, h = T/{METHOD.N}")
    res.compare("bound respected: max(0, max |u| - 20 N)", 0.0,
                max(0.0, float(np.max(np.abs(sol.u))) - U_MAX), tolerance=1e-6,
                source="input bound (Ipopt relaxes bounds by 1e-8)")
    lo, hi = T_RANGE
    res.compare(f"T = {sol.T:.3f} s strictly inside [{lo:g}, {hi:g}] s (1 = at a bound)", 0.0,
                float(not lo + 1e-3 < sol.T < hi - 1e-3), tolerance=0.0,
                source="the range leaves the effort-time trade-off free")
    res.values["open_loop"] = {
        "end_error": row["resim_end_error"], "target_residual": row["resim_target_residual"],
        "why": "the optimal force replayed open loop from x0 (CVODES, rtol 1e-10) leaves "
               "the trajectory near upright, an unstable equilibrium: the per-interval "
               "local defect measures the transcription, the TVLQR closed loop follows it"}

    with res.timed("checks against Bogdanov's closed form"):
        check = flows_compared(sol, P)
    gain = P["g"] * (P["m1"] * P["L1"] + P["m2"] * (2 * P["L1"] + P["L2"]))
    res.values["independent_checks"] = check | {"energy_gain_closed_form": gain}
    res.compare("interval flows: the model (S^1, CVODES) vs Bogdanov's D, C, G (SciPy)",
                0.0, check["max_end_state_difference"], tolerance=1e-8,
                source="Bogdanov (2004) eqs. (1)-(4)")
    res.compare("work of the force along the intervals = g (m1 L1 + m2 (2 L1 + L2))",
                gain, check["work"], tolerance=1e-3, relative=True,
                source="closed form: energy theorem (hanging -> upright, rest); the "
                       "nodes' energy jumps are the local defects")

    with res.timed("TVLQR + closed loop"):
        ctrl = tvlqr_along(sol, x_eq=ocp.target.point, Q=Q_LQR, R=R_LQR)
        mc = monte_carlo(ctrl, ocp.x0, n=10 if quick else 20, scale=PERTURBATION, seed=0,
                         hold=1.5 if quick else 3.0, tol=CLOSED_LOOP_TOL,
                         u_bounds=(ocp.u_lower, ocp.u_upper))
    res.values["tvlqr"] = {k: v for k, v in mc.items() if k != "runs"}
    res.values["tvlqr"].update(dict(ctrl.info), design=ctrl.cost, sample_period=ctrl.dt,
                               Q=Q_LQR.tolist(), R=R_LQR)
    res.compare(f"TVLQR success rate from {mc['n']} perturbed starts", 1.0,
                mc["success_rate"], tolerance=0.1,
                source="closed loop reaches upright within 1e-2 (chart max-norm)")

    res.figure("swingup", swingup_figure(sol, mc["runs"][:10], P), caption=(
        "The optimal swing-up from the defaults: left, the cart and both rods every few "
        "nodes (light to dark in time; up is -e3); middle, the link angles from hanging "
        "(pi: upright) and the cart's position, with closed-loop TVLQR runs from perturbed "
        "starts (thin); right, the force on the cart (|u| <= 20 N)."))
    res.notes.append(
        "Solved by solve_ocp(ocp, Collocation(N=100, degree=3)) with no guess and no handling:"
        " the default strategy's attempts are listed under 'attempts'. The problem has many "
        "local minima (swing patterns); the default strategy returns the first it reaches "
        "from its structured starts, not a certified global one.")
    res.notes.append(
        "Bogdanov (2004) poses stabilisation of the upright double pendulum, not this swing-up;"
        " his equations of motion serve here as the independent check of the dynamics.")
    return res.finish()


def swingup_figure(sol: OCPSolution, runs: Any, P: dict[str, float]) -> Any:
    """Snapshots of cart and rods, the angles and cart over time, and the force."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 3, figsize=(13.0, 4.0))
    A = angles(sol.x)
    ax = axs[0]
    picks = np.linspace(0, len(A) - 1, 11).round().astype(int)
    for j, k in enumerate(picks):
        x, p1, p2 = A[k, 0], A[k, 2], A[k, 4]
        c = plt.cm.viridis(0.15 + 0.8 * j / (len(picks) - 1))
        e1 = (x + P["L1"] * np.sin(p1), -P["L1"] * np.cos(p1))
        e2 = (e1[0] + P["L2"] * np.sin(p2), e1[1] - P["L2"] * np.cos(p2))
        ax.plot([x, e1[0], e2[0]], [0.0, e1[1], e2[1]], "-o", color=c, ms=2.5, lw=1.2)
        ax.plot([x - 0.1, x + 0.1], [0.0, 0.0], color=c, lw=4)
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.set_aspect("equal")
    ax.set_xlabel("e1 [m]")
    ax.set_ylabel("height (-e3) [m]")
    ax.set_title("cart and rods", fontsize=9)
    ax = axs[1]
    for r in runs:
        B = angles(r.x)
        t = np.asarray(r.t)
        ax.plot(t, B[:, 2], color="tab:blue", lw=0.4, alpha=0.5)
        ax.plot(t, B[:, 4], color="tab:orange", lw=0.4, alpha=0.5)
    ax.plot(sol.t, A[:, 2], color="tab:blue", lw=1.5, label="phi1")
    ax.plot(sol.t, A[:, 4], color="tab:orange", lw=1.5, label="phi2")
    ax.plot(sol.t, A[:, 0], color="k", lw=1.2, label="cart x [m]")
    for level in (-np.pi, np.pi):
        ax.axhline(level, color="0.6", ls=":", lw=0.8)
    ax.set_xlabel("t [s]")
    ax.set_title("angles from hanging [rad], cart", fontsize=9)
    ax.legend(fontsize=8)
    ax = axs[2]
    ax.plot(np.repeat(sol.t, 2)[1:-1], np.repeat(sol.u[:, 0], 2), color="tab:blue")
    for b in (sol.ocp.u_lower[0], sol.ocp.u_upper[0]):
        ax.axhline(b, color="0.6", ls=":", lw=0.8)
    ax.set_xlabel("t [s]")
    ax.set_title("force on the cart [N]", fontsize=9)
    fig.suptitle(f"double pendulum on a cart from the defaults: cost {sol.objective:.4f}, "
                 f"T = {sol.T:.3f} s, {len(sol.attempts)} attempts", fontsize=9)
    fig.set_layout_engine("tight")
    return fig


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
