"""The stable manifold M_i of the inverted equilibrium under velocity feedback (paper 001).

Under the saturated angular-velocity feedback of paper 001 the inverted 3D pendulum keeps
a three-dimensional set of states that creep back up to it (its stable manifold). A slice
of that set is computed by flowing backward from the equilibrium, and every computed point
of it lies outside the set N from which the paper proves convergence to hanging, as Lemma
4 and Remark 5 say; states just off the slice do end in N.
"""

from __future__ import annotations

import numpy as np

from models import controllers as ctl
from models import pendulum3d as p3
from workbench.control import SublevelSet
from workbench.global_dynamics import distances, invariant_manifold, validate
from workbench.linear import Subspace
from workbench.simulation import Method
from workbench.study import Panel, Result, compare_counts, line_figure, s2_manifold_figure

TITLE = "A slice of the stable manifold M_i of the inverted equilibrium avoids N (paper 001)"

BODY = {"J": np.array([[30.0, 20, 7], [20, 40, 0], [7, 0, 50]]), "rho": np.array([0, 0, 0.2]),
        "m": 100.0, "g": 10.0}
P = np.diag([5.0, 10.0, 15.0])
K_SAT = 10.0
DELTA = 1e-6


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        30 points over t <= 6 s without compilation, instead of 300 points over
        t <= 12 s with compiled steps; fewer validation samples.

    Returns
    -------
    Result

    Notes
    -----
    The reduced 3D pendulum on S^2 x R^3 (models.pendulum3d.reduced) with the body of paper
    001 Section 7 (J = [[30, 20, 7], [20, 40, 0], [7, 0, 50]], m = 100, rho = (0, 0, 0.2), g
    = 10) under the saturated angular-velocity feedback (34) (P = diag(5, 10, 15), k = 10).
    By Lemma 4 the inverted equilibrium (0, Gamma_i), Gamma_i = -rho/|rho|, has a
    3-dimensional stable manifold M_i; by Theorem 1 the set N of (33), V <= 2 m g |rho| with
    V of (30), lies in the domain of attraction of the hanging equilibrium except for (0,
    Gamma_i), so M_i meets N only there (Remark 5).

    Computed: a slice of M_i, the piece F^-t(B_delta), 0 <= t <= T, grown backward from a
    sphere of B_delta (delta = 1e-6) in the 3-dimensional stable eigenspace with the Lie-
    group RKMK4 method (all points per casadi call). Measured: the stable and unstable
    dimensions (Lemma 3-4); no computed state lies in N (membership by
    workbench.control._lyapunov's sublevel set of (30) at the level of
    models.controllers.hanging_set_level), with the margin V - 2 m g |rho| and the margin
    divided by the squared distance (12) to the equilibrium (bounded away from 0: the
    manifold touches the boundary of N only at the equilibrium, quadratically); V is non-
    decreasing backward along every trajectory (V-dot = -omega^T Psi(omega) <= 0 forward);
    points of the slice integrated forward with CVODES approach the inverted equilibrium,
    and the same points moved off it by 1e-2 enter N (so, by Theorem 1, go to the hanging
    equilibrium; Theorem 2).
    """
    res = Result("inverted_manifold_velocity_feedback", TITLE, quick=quick)
    model = p3.reduced(**BODY)
    res.use(model)
    k = ctl.saturated_velocity_feedback(model, P=P, k=K_SAT)
    gamma_h = BODY["rho"] / np.linalg.norm(BODY["rho"])
    x_i = model.state(Gamma=-gamma_h, omega=np.zeros(3))
    x_h = model.state(Gamma=gamma_h, omega=np.zeros(3))
    n_points, horizon = (30, 6.0) if quick else (300, 12.0)
    with res.timed("slice of M_i (RKMK4 backward)"):
        W = invariant_manifold(model, x_i, which=Subspace.STABLE, controller=k, delta=DELTA,
                               n_points=n_points, horizon=horizon, step=0.005,
                               output_step=0.05, method=Method.RKMK4, jit=not quick,
                               max_distance=50.0)
    es = W.eigen
    compare_counts(res, "inverted equilibrium", {
        "stable dimension (M_i is 3D)": (3, es.n_stable),
        "unstable dimension": (2, es.n_unstable)}, source="paper 001 Lemma 3-4")
    res.compare("max constraint residual |Gamma|^2 - 1", 0.0,
                W.diagnostics["constraint_residual"]["Gamma"], tolerance=1e-12,
                source="RKMK4 (S^2 kept by rotations)")

    V = ctl.velocity_feedback_lyapunov(model)
    level = ctl.hanging_set_level(model)
    N = SublevelSet(V, level)
    X = W.x.reshape(-1, W.x.shape[2])
    with res.timed("V on the slice"):
        inside = N.contains(X)
        vals = V.values(X).reshape(W.x.shape[:2])
    margin = vals - level
    d = W.distance()
    res.compare("computed states of M_i inside N (33)", 0, int(inside.sum()), tolerance=0,
                source="paper 001 Theorem 1, Remark 5")
    res.compare("the equilibrium itself lies in N (on its boundary)", 1,
                int(N.contains(x_i[None])[0]), tolerance=0, source="paper 001 (33)")
    scaled = float(np.min(margin / d**2))
    res.compare("min (V - 2 m g |rho|) / d^2 over the slice is positive", 1, int(scaled > 0),
                tolerance=0, source="paper 001 Remark 5")
    drop = float(np.max(np.maximum(vals[:-1] - vals[1:], 0) / vals[1:]))
    res.compare("V non-decreasing backward: max relative drop between output times", 0.0,
                drop, tolerance=1e-12, source="paper 001 Lemma 5 (V-dot <= 0)")

    with res.timed("validation (CVODES forward)"):
        val = validate(W, times=[3.0, horizon], n_per_time=2 if quick else 4,
                       min_distance=1e-2, extra_time=20.0, perturbation=1e-2, seed=3,
                       rtol=1e-12, atol=1e-12, output_step=0.05, target=x_h)
    res.compare("forward from the slice: max d_min / d_start", 0.0, val.worst_ratio,
                tolerance=1e-3, source="paper 001 Lemma 4 (M_i: solutions to Gamma_i)")
    v_off = V.values(val.final_states(off=True)) - level
    res.compare("off the slice (1e-2): points that end inside N (then converge to hanging)",
                len(val.off), int(np.sum(N.contains(val.final_states(off=True)))),
                tolerance=0, source="paper 001 Theorems 1-2")
    res.values = {
        "body": {k_: np.asarray(v).tolist() for k_, v in BODY.items()},
        "P": np.diag(P).tolist(), "k": K_SAT, "delta": DELTA, "n_points": n_points,
        "level_2mg|rho|": level, "manifold": W.summary(),
        "min_margin": float(margin.min()), "min_margin_t0": float(margin[0].min()),
        "min_margin_over_d2": scaled,
        "min_margin_at": {float(t): float(margin[W.index(t)].min())
                          for t in (1.0, 2.0, 3.0, horizon)},
        "validation": val.summary(), "off_final_V_minus_level": v_off.tolist(),
        "distance_hanging_from_inverted": float(distances(model, x_h[None], x_i)[0]),
    }
    res.notes.append(
        "The slice is the piece of M_i swept by the backward flow from a 2-sphere of radius "
        "1e-6 in the stable eigenspace up to t = T; every point of it has V > 2 m g |rho|. "
        "Near the equilibrium the margin is quadratic in the distance (V restricted to the "
        "stable subspace is positive definite there), which the scaled margin measures.")
    res.figure("slice_of_M_i", s2_manifold_figure(W, [W.t[-1]], factor="Gamma", ncols=1, marks={
        "Gamma_h": gamma_h, "Gamma_i": -gamma_h}), caption=(
        "A slice of the stable manifold M_i of the inverted equilibrium under the saturated "
        "feedback (34): the reduced attitude Gamma(t) of its points, from Gamma_i backward "
        "in time, coloured by |omega|; none of it enters N (33) around Gamma_h."))
    m = np.maximum(margin[:, ::max(1, W.n_points // 40)], 1e-16)  # at most ~40 trajectories
    res.figure("margin_to_N", line_figure([Panel("margin to N (33) along the slice", {
        "V - 2 m g |rho|": (W.t, m)}, xlabel="t (backward) [s]", yscale="log")], ncols=1),
        caption=(
        "The margin V - 2 m g |rho| by which points of the slice of M_i stay outside N (33), "
        "along up to 40 of its trajectories: positive everywhere, quadratic in the distance "
        "near the equilibrium and growing backward in time (paper 001 Remark 5)."))
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
