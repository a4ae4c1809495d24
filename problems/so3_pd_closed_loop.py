"""Geometric PD control on SO(3): the desired attitude and the three saddles (paper 002).

The 3D pendulum under the paper's geometric PD law is simulated on the rotation group
itself. Started from random attitudes it always comes to rest at the desired attitude;
started a hair away from each of the three saddles (half turns about the principal axes)
it leaves along the unstable directions the linearisation predicts, then converges too.
The saddles' eigenvalues agree with the values printed in paper 002.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import scipy.linalg as sla

from models import controllers as ctl
from models import pendulum3d as p3
from models.so3_pd_reference import PRINTED
from workbench.control import check_convergence
from workbench.core.manifolds import SO3
from workbench.linear import eigenstructure, linearize
from workbench.simulation import simulate
from workbench.study import Panel, Result, compare_spectrum, line_figure

TITLE = "Geometric PD on SO(3): convergence to (I, 0), escape from the three saddles (paper 002)"

BODY = {"J": np.diag([3.0, 2.0, 1.0]), "rho": np.array([0.05, -0.1, 0.3]), "m": 1.0,
        "g": 9.81}
G = np.array([0.9, 1.0, 1.1])
K_R = K_OMEGA = 1.0
def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        5 instead of 40 generic initial attitudes and a shorter convergence horizon.

    Returns
    -------
    Result

    Notes
    -----
    The 3D pendulum under u = -k_R e_R - k_Omega Omega - m g rho x R^T e3 (paper 002 Section
    III-A, e_R = vee(G R_d^T R - R^T R_d G) / 2), with the paper's J = diag(3, 2, 1), G =
    diag(0.9, 1, 1.1), k_R = k_Omega = 1, R_d = I. Gravity is cancelled, so m and rho do not
    enter the closed loop (rho = (0.05, -0.1, 0.3) is taken to exercise the cancellation).

    Measured: the closed-loop field vanishes at (I, 0) and at (exp(pi e_i^), 0); the spectra
    of the closed-loop linearisations (from the graph, workbench.linear._linearize) against
    the paper's values (Sec. III-C and (17)-(19)) and their unstable dimensions 0, 3, 2, 1;
    generic initial attitudes (seeded) converge to (I, 0); from a small random perturbation
    of each saddle the trajectory leaves along the unstable subspace of the linearisation
    (its angle to that subspace, measured when the perturbation has grown by 10^5), and then
    converges to (I, 0).
    """
    res = Result("so3_pd_closed_loop", TITLE, quick=quick)
    model = p3.full(**BODY)
    res.use(model)
    k = ctl.so3_pd(model, np.eye(3), k_R=K_R, k_Omega=K_OMEGA, G=G)
    tol = 1e-11
    spectra, escapes, norms, angles = {}, {}, {}, {}
    rng = np.random.default_rng(2011)
    x_goal = model.state(R=np.eye(3), omega=np.zeros(3))
    for (name, (Re, table, _, n_unst, _)) in zip(("I", "e1", "e2", "e3"), PRINTED.values()):
        xe = model.state(R=Re, omega=np.zeros(3))
        with res.timed("linearisations"):
            lin = linearize(model, xe, controller=k, tol=1e-12)
            es = eigenstructure(lin)
        compare_spectrum(res, f"{name} (4 printed digits)", es.eigenvalues,
                         [lp for lp, _ in table], tolerance=1e-4,
                         source="paper 002 Sec. III-C, (17)-(19)")
        res.compare(f"unstable dimension at {name}", n_unst, es.n_unstable,
                    tolerance=0, source="paper 002 Sec. III-C")
        spectra[name] = {**es.summary(), "field_residual": float(np.max(np.abs(lin.residual)))}
        if name == "I":
            continue
        if name == "e3":  # one unstable mode: compare its direction with (19) + erratum
            u = es.unstable_basis[:, 0]
            v = np.r_[0.0, 0.0, 1.0, 0.0, 0.0, float(np.max(es.eigenvalues.real))]
            res.compare("sin(angle) of E^u at e3 to v6 = e3 + lambda6 e6", 0.0,
                        float(np.sin(sla.subspace_angles(u[:, None], v[:, None])[0])),
                        tolerance=1e-9, source="paper 002 (19) with the erratum (not e2)")
            spectra[name]["unstable_direction"] = u.tolist()
        # escape from the saddle: random small perturbation, measured in tangent coordinates
        delta, grow = 1e-9, 1e5
        z0 = rng.standard_normal(6)
        x0 = model.manifold.retract(xe, delta * z0 / np.linalg.norm(z0))
        U = es.unstable_basis
        L = np.linalg.pinv(lin.basis)
        t = np.linspace(0.0, 200.0, 4001)
        with res.timed("saddle escapes"):
            tr = simulate(model, x0, t, controller=k, rtol=tol, atol=1e-14)
        z = (tr.x - xe) @ L.T
        zn = np.linalg.norm(z, axis=1)
        off = np.linalg.norm(z - (z @ U) @ U.T, axis=1) / np.maximum(zn, 1e-300)
        i_grow = int(np.argmax(zn >= grow * delta))
        if zn[i_grow] < grow * delta:
            raise RuntimeError(f"no escape from saddle {name} within {t[-1]} s")
        d_final = float(np.linalg.norm(tr.final - x_goal))
        res.compare(f"sin(angle to E^u) at |z| = 1e5 |z0|, saddle {name}", 0.0, off[i_grow],
                    tolerance=1e-3, source="paper 002 Sec. III-C (saddle, unstable modes)")
        res.compare(f"|x(200 s) - (I, 0)| from near saddle {name}", 0.0, d_final,
                    tolerance=1e-6, source="paper 002 Sec. III (almost-global)")
        escapes[name] = {"delta": delta, "t_escape": float(t[i_grow]),
                         "sin_angle_initial": float(off[0]), "sin_angle_at_escape":
                         float(off[i_grow]), "final_distance_to_goal": d_final,
                         "trajectory": tr.summary()}
        norms[f"saddle {name}"] = (t, zn)
        angles[f"saddle {name}"] = (t, np.maximum(off, 1e-16))

    # generic initial attitudes
    n_gen = 5 if quick else 40
    X0 = np.array([np.r_[SO3().random_point(rng), rng.standard_normal(3)]
                   for _ in range(n_gen)])
    x, p = ca.SX.sym("x", 12), ca.SX.sym("p", model.n_params)
    dist = ca.Function("dist_goal", [x, p], [ca.norm_2(x - ca.DM(x_goal))])
    with res.timed("generic initial attitudes"):
        rep = check_convergence(model, k, X0, distance=dist, horizon=150.0,
                                tolerance=1e-6, rtol=1e-10, atol=1e-12)
    res.compare("generic initial states not converging to (I, 0)", 0,
                rep.n_samples - rep.n_converged, tolerance=0, source="paper 002 Sec. III")
    res.values = {
        "body": BODY, "G": G, "k_R": K_R, "k_Omega": K_OMEGA,
        "spectra": spectra, "escapes": escapes, "generic": rep.as_dict(),
        "initial_distribution": "R uniform on SO(3) (Haar), omega ~ N(0, I), seed 2011",
    }
    res.figure("saddle_escapes", line_figure([
        Panel("|z(t)|, tangent coordinates at the saddle", norms, xlabel="t [s]",
              yscale="log"),
        Panel("sin(angle between z(t) and E^u)", angles, xlabel="t [s]", yscale="log")]),
        caption="Escape from the three saddles of PD control on SO(3), each started 1e-9 "
                "away in a random direction: the distance from the saddle grows "
                "exponentially until the trajectory leaves (left), while its direction "
                "turns into the unstable subspace of the linearisation (right).")
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
