"""Optimal swing-up of the spherical pendulum on a cart (paper 003, n = 1), stabilised by TVLQR.

Model: :func:`models.chain_cart.chain_cart` with n = 1, m = 0.5 kg, m1 = 0.1 kg,
l1 = 0.1 m, g = 9.81 (paper 003 Section 5). From hanging at rest with the cart at the
origin (q1 = +e3; e3 points down) to inverted at rest with the cart back at the origin
(q1 = -e3), imposed through the chart of (R^2)^2 x TS^2 (8 independent equations).

Reference case (solved by peers too): minimise integral u^T u dt + T, |u_i| <= 10 N,
T free in [0.5, 3] s, N = 40 intervals. The problem has several local minima; the OCP's
defaults (no guess, no handling: the default strategy) find one, seeded coarse starts
(N = 10) refined to N = 40 find the best known. Harder case |u_i| <= 2 N: geodesic
guesses fail or land in worse minima; the defaults solve it directly (their energy-pumping
start). Measured: the
speed-accuracy table over N and both manifold handlings (solve time, iterations, cost,
end-state error of an open-loop CVODES re-simulation), and the TVLQR closed loop from
seeded perturbed starts.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from models.chain_cart import chain_cart, link_state
from workbench.control import tvlqr_along
from workbench.control.ocp import (
    OCP,
    Collocation,
    ManifoldHandling,
    MultipleShooting,
    Scheme,
    TargetPoint,
    multistart,
)
from workbench.control.ocp import solve as solve_ocp
from workbench.control.ocp.study import (
    monte_carlo,
    plot_swingup,
    solution_row,
    speed_accuracy,
    swings,
    transcription_builds,
)
from workbench.study import Result, cores

TITLE = "Optimal swing-up of the spherical pendulum on a cart (paper 003, n = 1) + TVLQR"

E3 = np.array([0.0, 0.0, 1.0])
PARAMS = {"m": 0.5, "masses": 0.1, "lengths": 0.1, "g": 9.81}
U_MAX = 10.0
U_MAX_HARD = 2.0
T_RANGE = (0.5, 3.0)
T_GUESSES = (1.0, 1.5, 2.0, 2.5)
Q_LQR = np.r_[10.0, 10.0, 1.0, 1.0, 100.0, 100.0, 1.0, 1.0]  # x, v, link (angle, rate)
R_LQR = 0.1
PERTURBATION = np.r_[0.01, 0.01, 0.02, 0.02, 0.05, 0.05, 0.1, 0.1]
CLOSED_LOOP_TOL = 1e-2


def problem(*, u_max: float = U_MAX, T: Any = T_RANGE) -> OCP:
    """The reference swing-up OCP (cost integral u^T u dt + T)."""
    model = chain_cart(1, **PARAMS)
    x0 = np.r_[0.0, 0.0, 0.0, 0.0, link_state(E3)]
    xf = np.r_[0.0, 0.0, 0.0, 0.0, link_state(-E3)]
    return OCP(
        model, x0=x0, target=TargetPoint(model.manifold, xf, "cart at 0, link inverted, rest"),
        u_lower=-u_max, u_upper=u_max, T=T,
        running_cost=lambda x, u: ca.dot(u, u), terminal_cost=lambda x, T: T,
        name="spherical_cart",
    )


def height(X: np.ndarray) -> np.ndarray:
    """Height of the bob above the pivot (up = -e3), per node."""
    return -PARAMS["lengths"] * X[:, 6]


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        4 seeded coarse starts instead of 12; the table over N = 20, 40 (ambient) and
        N = 40 (Lie group) only, without shooting; 1.5 s of hold in the closed loop
        instead of 3 s.

    Returns
    -------
    Result
    """
    res = Result("swingup_spherical_cart", TITLE, quick=quick)
    ocp = problem()
    res.use(ocp.model)
    ladder = [Collocation(N=n, degree=3) for n in (10, 20, 40)]
    coll = ladder[-1]

    with res.timed("the defaults (no guess, no handling), N = 40"):
        cold = solve_ocp(ocp, coll, raise_on_failure=False)
    with res.timed("seeded coarse starts refined to N = 40"):
        best, starts = multistart(
            ocp, ladder[0], seeds=range(4 if quick else 12), T_guesses=T_GUESSES,
            refine_with=ladder[1:], max_iter=150, describe=lambda s: swings(height(s.x)),
            workers=cores())
        best = min(best, cold, key=lambda s: s.objective)  # the cheapest of every solve
    res.values["reference"] = {
        "problem": "integral u^T u dt + T, |u_i| <= 10 N, T in [0.5, 3] s, N = 40, "
                   "Legendre d = 3, ambient coordinates",
        "defaults": solution_row(cold, height=height),
        "defaults_attempts": cold.attempts,
        "seeded_starts": starts,
        "starts_reaching_best": sum(r["reached_best"] for r in starts),
        "gauge": best.gauge,
        "local_minima": _minima(starts),
        "best": solution_row(best, height=height),
        "strategy": "seeded geodesic guesses (random great circles, control noise 0.1, T "
                    f"guesses {T_GUESSES}) solved at N = 10, each refined 20 -> 40",
    }
    res.compare("target residual of the best solution (chart)", 0.0,
                best.error["target_residual"], tolerance=1e-8, source="terminal chart = 0")
    res.compare("re-simulated end-state error, best, N = 40", 0.0,
                best.error["resim_end_error"], tolerance=5e-2,
                source="CVODES rtol 1e-10 vs transcription (amplified by the instability)")
    res.compare("the defaults converged, on the manifold (node residual)", 0.0,
                cold.error["manifold_residual"] if cold.status.ok else np.inf,
                tolerance=1e-10, source="default strategy, projected nodes")
    res.compare("best cost <= the defaults' cost", 0.0,
                max(0.0, best.objective - cold.objective), tolerance=1e-6,
                source="multistart strategy")

    with res.timed("speed-accuracy table"):
        if quick:
            cases = [(Collocation(N=20), ManifoldHandling.AMBIENT),
                     (coll, ManifoldHandling.AMBIENT), (coll, ManifoldHandling.LIE_GROUP)]
        else:
            cases = [(Collocation(N=n), h) for n in (20, 40, 80, 160) for h in ManifoldHandling]
            cases += [(Collocation(N=40, scheme=Scheme.RADAU), h) for h in ManifoldHandling]
            cases += [(MultipleShooting(N=40, steps=1), h) for h in ManifoldHandling]
        rows = []
        for method, handling in cases:
            rows += speed_accuracy(ocp, [method], [handling], guess=best, height=height)
    res.values["speed_accuracy"] = rows
    for r in rows:  # coarser transcriptions are listed, not held to the N = 40 cost
        if r["N"] >= 40 and r["status"] in ("SUCCESS", "ACCEPTABLE"):
            res.compare(f"{r['transcription']}: cost vs best N=40", best.objective,
                        r["objective"], tolerance=5e-2, relative=True,
                        source="same local minimum")

    with res.timed("harder case |u| <= 2: the defaults"):
        hard_ocp = ocp.with_bounds(u_lower=-U_MAX_HARD, u_upper=U_MAX_HARD)
        hard = solve_ocp(hard_ocp, coll, raise_on_failure=False)
        if hard.status.ok:
            hard.resimulate()
    res.values["harder_case"] = {
        "problem": "as the reference with |u_i| <= 2 N, from the defaults",
        "attempts": hard.attempts,
        "solution": solution_row(hard, resimulate=False, height=height),
    }
    res.compare("harder case: solved from the defaults", 1.0, float(hard.status.ok),
                tolerance=0.0, source="default strategy")
    if hard.status.ok and hard.objective < best.objective:  # local minima, said so
        res.notes.append(
            f"The harder case's optimum (cost {hard.objective:.4f}) is feasible for the "
            f"reference problem and cheaper than the reference's best found here "
            f"({best.objective:.4f}): the starts reach local minima, not the global one.")
    res.compare("harder case: bound violation max(0, max |u_i| - 2)", 0.0,
                max(0.0, float(np.max(np.abs(hard.u))) - U_MAX_HARD), tolerance=1e-6,
                source="control bound")
    res.values["transcription_builds"] = transcription_builds(ocp)

    with res.timed("TVLQR design + closed loop"):
        ctrl = tvlqr_along(best, x_eq=ocp.target.point, substeps=1, Q=Q_LQR, R=R_LQR)
        mc = monte_carlo(ctrl, ocp.x0, n=20, scale=PERTURBATION, seed=0,
                         hold=1.5 if quick else 3.0, tol=CLOSED_LOOP_TOL,
                         u_bounds=(ocp.u_lower, ocp.u_upper))
    res.values["tvlqr"] = {k: v for k, v in mc.items() if k != "runs"}
    res.values["tvlqr"].update(dict(ctrl.info), design=ctrl.cost, sample_period=ctrl.dt,
                               Q=Q_LQR.tolist(), R=R_LQR)
    res.compare("TVLQR success rate from 20 perturbed starts", 1.0, mc["success_rate"],
                tolerance=0.1, source="closed loop reaches the inverted equilibrium")
    res.figures["swingup"] = plot_swingup(
        best, [("link direction q1", lambda X: X[:, 4:7])], runs=mc["runs"][:10],
        title=f"spherical cart swing-up, cost {best.objective:.4f}, T = {best.T:.3f} s")
    res.figures["harder_case"] = plot_swingup(
        hard, [("link direction q1", lambda X: X[:, 4:7])],
        title=f"|u_i| <= 2 N: cost {hard.objective:.4f}, T = {hard.T:.3f} s")
    res.notes.append(
        "Local minima (cost = integral u^T u + T) differ in the number of swings: more "
        "swings, less force, longer T. The defaults' solve and the seeded starts are listed with "
        "their swing count; the strategy keeps the cheapest after refinement to N = 40.")
    return res.finish()


def _minima(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Distinct converged costs among the starts (rounded to 1e-4)."""
    seen: dict[float, dict[str, Any]] = {}
    for r in records:
        if r["status"] in ("SUCCESS", "ACCEPTABLE"):
            key = round(r["objective"], 4)
            seen.setdefault(key, {"objective": r["objective"], "T": r["T"], "seeds": [],
                                  "kind": r.get("kind"), "swings": r.get("swings")})
            seen[key]["seeds"].append(r["seed"])
    return sorted(seen.values(), key=lambda d: d["objective"])


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
