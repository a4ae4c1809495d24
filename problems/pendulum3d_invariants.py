"""Invariants of the 3D pendulum and the agreement of its three models (paper 000).

The uncontrolled 3D pendulum is simulated in its three forms: the full attitude model, the
reduced model of the direction of gravity in the body, and the Routh model, from which the
full motion is rebuilt. Energy and the vertical angular momentum are conserved to
integration accuracy, and all three forms trace the same motion; the planar special case
swings with the period of the elliptic-integral formula, and the spherical special case
moves as the axisymmetric 3D pendulum does.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ellipk

from models import pendulum3d as p3
from workbench.core.errors import SolverError
from workbench.core.manifolds import SO3
from workbench.global_dynamics import Section, poincare_map
from workbench.simulation import simulate
from workbench.study import Panel, Result, compare_rows, line_figure

TITLE = "3D pendulum invariants; full, Lagrange-Poincare and Routh models agree (paper 000)"

BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
        "g": 9.81}
E3 = np.array([0.0, 0.0, 1.0])


def planar_period(*, Jt: float, rho_s: float, theta0: float, m: float = 1.0, g: float = 9.81,
                  rtol: float = 1e-13) -> dict[str, float]:
    """Period of the planar special case, measured by simulation, and its closed form.

    The pendulum starts at rest at angle ``theta0`` (``p = (-sin theta0, cos theta0)``).
    The period is measured without the closed form: the time between the first and the
    third crossing of the bottom (``p_x = 0``), located by the Poincare map's event
    detection within a horizon of several linearised periods.

    Returns
    -------
    dict
        ``measured``, ``closed_form`` (4 sqrt(Jt/(m g rho_s)) K(sin^2(theta0/2))) and the
        ``crossing_times``.
    """
    model = p3.planar(Jt=Jt, rho_s=rho_s, m=m, g=g)
    x0 = model.state(p=[-np.sin(theta0), np.cos(theta0)], omega_y=[0.0])
    w0 = np.sqrt(m * g * rho_s / Jt)
    o = poincare_map(model, x0, Section("bottom", lambda ctx: ctx["p"][0]), n_crossings=3,
                     t_max=2 * 2 * np.pi / w0 * (1 + theta0**2), rtol=rtol, atol=rtol)
    if o.n < 3:
        raise SolverError(f"no full period within the horizon for theta0 = {theta0} "
                          f"({o.n} crossings of the bottom)", status="crossings")
    return {"measured": float(o.t[2] - o.t[0]), "crossing_times": o.t[:3].tolist(),
            "closed_form": 4.0 / w0 * float(ellipk(np.sin(theta0 / 2) ** 2))}


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        Shorter horizon (20 s instead of 100 s).

    Returns
    -------
    Result

    Notes
    -----
    The body of paper 000 Section 5.6 (m = 1, J = diag(0.13, 0.28, 0.17), rho = (0, 0, 0.3),
    R0 = I, omega0 = c (1, 1, 1)) is simulated on TSO(3), on S^2 x R^3 and on TS^2 (Routh,
    with the reconstruction of Prop. 17), uncontrolled. Measured: conservation of the energy
    E and of the vertical angular momentum h (Prop. 1); Gamma = R^T e3 of the full model
    against the reduced model; (R, omega) reconstructed from the Routh model against the
    full model; and, for the special cases of Section 4.1, the period of the planar pendulum
    against the complete elliptic integral, and the spherical case against the reduced 3D
    pendulum with an axisymmetric body.
    """
    res = Result("pendulum3d_invariants", TITLE, quick=quick)
    c = 1.0
    horizon = 20.0 if quick else 100.0
    tol = 1e-12
    t = np.linspace(0.0, horizon, int(20 * horizon) + 1)
    full = p3.full(**BODY)
    reduced = p3.reduced(**BODY)
    res.use(full, reduced)
    x0 = full.state(R=np.eye(3), omega=c * np.ones(3))

    with res.timed("full model"):
        tr_full = simulate(full, x0, t, rtol=tol, atol=tol)
    with res.timed("reduced model"):
        tr_red = simulate(reduced, reduced.state(Gamma=E3, omega=x0[9:]), t, rtol=tol, atol=tol)
    ts, mu = p3.routh_state_from_full(full, x0)
    routh = p3.routh_reconstruction(**BODY, mu=mu)
    res.use(routh)
    with res.timed("Routh model + reconstruction"):
        tr_routh = simulate(routh, np.r_[ts, SO3.flat(np.eye(3)), 0.0], t, rtol=tol, atol=tol)
    R_rec, w_rec = p3.reconstruct(routh, tr_routh.x)

    drift = tr_full.diagnostics["invariant_drift"]
    gamma_full = np.einsum("nji,j->ni", tr_full.part("R"), E3)

    compare_rows(res, [
        ("relative drift of E, full model", 0.0, drift["energy"]["max_rel"], 1e-9,
         "Prop. 1 (E conserved)"),
        ("relative drift of h, full model", 0.0, drift["h"]["max_rel"], 1e-9,
         "Prop. 1 (h conserved)"),
        ("max |Gamma_full - Gamma_reduced|", 0.0, np.max(np.abs(gamma_full - tr_red.x[:, :3])),
         1e-9, "Prop. 4 (Gamma = R^T e3)"),
        ("max |R_full - R_reconstructed|", 0.0, np.max(np.abs(R_rec - tr_full.part("R"))), 1e-7,
         "Prop. 17 (5.10)-(5.14)"),
        ("max |omega_full - omega_reconstructed|", 0.0, np.max(np.abs(w_rec - tr_full.x[:, 9:])),
         1e-7, "Prop. 17 (5.14)"),
        ("relative drift of Routh energy (5.16)", 0.0,
         tr_routh.diagnostics["invariant_drift"]["energy"]["max_rel"], 1e-9, "Prop. 19")])

    # special cases of Section 4.1
    with res.timed("planar period"):
        per = planar_period(Jt=0.2, rho_s=0.3, theta0=2.5)
    res.compare("planar period, theta0 = 2.5 rad [s]", per["closed_form"], per["measured"],
                tolerance=1e-8, relative=True, source="closed form 4 sqrt(Jt/mg rho_s) K(k)")
    sph = p3.spherical(Jt=0.2, Ja=0.05, rho_s=0.3)
    axi = p3.reduced(J=np.diag([0.2, 0.2, 0.05]), rho=[0, 0, 0.3])
    res.use(sph, axi)
    g0 = np.array([np.sin(1.0), 0.0, np.cos(1.0)])
    ts_ = np.linspace(0.0, 5.0 if quick else 20.0, 201)
    with res.timed("spherical special case"):
        tr_s = simulate(sph, sph.state(Gamma=g0, omega_xy=[0.3, -0.4]), ts_, rtol=tol, atol=tol)
        tr_a = simulate(axi, axi.state(Gamma=g0, omega=[0.3, -0.4, 0.0]), ts_, rtol=tol,
                        atol=tol)
    res.compare("max |Gamma_spherical - Gamma_3D|, J = diag(Jt, Jt, Ja)", 0.0,
                float(np.max(np.abs(tr_s.x[:, :3] - tr_a.x[:, :3]))), tolerance=1e-9,
                source="Prop. 6")

    res.values = {
        "body": BODY, "c": c, "horizon_s": horizon, "tolerance": tol, "mu": mu,
        "E0": drift["energy"]["initial"], "h0": drift["h"]["initial"], "planar_period": per,
        "full": tr_full.summary(), "reduced": tr_red.summary(), "routh": tr_routh.summary()}
    tt = tr_full.t[1:]
    E, h = tr_full.invariant_series("energy"), tr_full.invariant_series("h")
    words = res.label(**{f"Gamma_{k}": f"gravity direction, body axis {k}"
                         for k in (1, 2, 3)},
                      **{"|E - E0|/|E0|": "energy drift",
                         "|h - h0|/|h0|": "vertical momentum drift"})
    res.figure("invariant_drift", line_figure([
        Panel("invariant drift, cvodes rtol = 1e-12", {
            "|E - E0|/|E0|": (tt, np.abs(E[1:] - E[0]) / abs(E[0]) + 1e-18),
            "|h - h0|/|h0|": (tt, np.abs(h[1:] - h[0]) / abs(h[0]) + 1e-18)},
            xlabel="t [s]", yscale="log"),
        Panel("reduced attitude Gamma = R^T e3", {f"Gamma_{k + 1}": (tr_full.t, gamma_full[:, k])
                                                  for k in range(3)}, xlabel="t [s]")],
        labels=words),
        caption="The free 3D pendulum of paper 000 Section 5.6 (c = 1): relative drift of "
                "the energy E and of the vertical angular momentum h, both conserved "
                "(Prop. 1), at the integration tolerance (left); the direction of gravity "
                "in the body frame along the motion (right).")
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
