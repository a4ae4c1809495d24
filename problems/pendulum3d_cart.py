"""A 3D pendulum on a planar cart, defined only by its Lagrangian, through the whole pipeline.

A rigid body on a spherical joint whose pivot rides a cart in the horizontal plane (R^2 x
SO(3)): nobody derived its equations — the mechanics layer did, from the cart's and the
body's kinetic energies and gravity. The problem checks them against an independent
derivation (Kane's method in sympy, Euler angles), shows that energy, horizontal momentum and
vertical angular momentum are conserved, finds the hanging and inverted equilibria with the
spectra the planar cart-pendulum predicts in each vertical plane, names the yaw rate as the
one mode the cart force cannot reach (PBH), stabilises the inverted body with LQR (cart force
plus a body moment) from a 20 degree tilt, swings the body up with Ipopt using the cart
alone, and exports the LQR law as C that agrees with the graph bit for bit.
"""

from __future__ import annotations

import tempfile

import casadi as ca
import numpy as np

import workbench as wb
from models import kane_references
from models.pendulum3d_cart import at_rest, inverted_at_origin, pendulum3d_cart
from workbench import SO3, codegen
from workbench.study import Panel, Result, compare_spectrum, line_figure

TITLE = "3D pendulum on a planar cart from its Lagrangian: invariants, equilibria, PBH, LQR, " \
        "swing-up, C export"

BODY = {"M": 1.0, "m": 1.0, "J": np.diag([0.13, 0.28, 0.17]), "rho": [0.0, 0.0, 0.3],
        "g": 9.81}
E3, INVERTED = np.array([0.0, 0.0, 1.0]), np.diag([1.0, -1.0, -1.0])


def planar_frequencies() -> np.ndarray:
    """Closed form, a cart-pendulum in each vertical plane: w^2 = m g r (M+m)/(J (M+m) - m^2 r^2).

    Returns
    -------
    ndarray, shape=(2,)
    """
    M, m, g, r = BODY["M"], BODY["m"], BODY["g"], BODY["rho"][2]
    J = np.diag(BODY["J"])[:2]
    return np.sqrt(m * g * r * (M + m) / (J * (M + m) - m**2 * r**2))


def solve(*, quick: bool = False) -> Result:
    """Run the problem (quick: shorter runs, a coarser swing-up)."""
    res = Result("pendulum3d_cart", TITLE, quick=quick)
    free, act = pendulum3d_cart(**BODY), pendulum3d_cart(**BODY, body_moment=True)
    res.use(free, act)
    dev = kane_references.deviation(act, np.random.default_rng(1), n=3 if quick else 20)
    res.compare("accelerations vs Kane's method (sympy, Euler angles), max rel.", 0.0, dev,
                tolerance=1e-10, source="independent derivation")
    x0 = free.state(x=[0, 0], v=[0.2, -0.1], R=wb.so3_exp([0.8, 0.3, 0.2]), Omega=[0.5, -0.3, 1.0])
    t = np.linspace(0.0, 5.0 if quick else 50.0, 501)
    with res.timed("simulate"):
        tr = wb.simulate(free, x0, t, rtol=1e-12, atol=1e-12)
    for name, d in tr.diagnostics["invariant_drift"].items():
        res.compare(f"drift of {name} over {t[-1]:g} s", 0.0, d["max_abs"], tolerance=1e-8,
                    source="conservation law")
    w = planar_frequencies()
    for name, R, ref in [("hanging", np.eye(3), np.r_[1j * w, -1j * w]),
                         ("inverted", INVERTED, np.r_[w, -w])]:
        start = free.state(x=[0.01, 0], v=[0, 0], R=R @ wb.so3_exp([0.02, 0.01, 0.03]),
                           Omega=[0, 0, 0])
        eq = wb.find_equilibrium(free, start, u=np.zeros(2))
        res.compare(f"{name}: Newton from a 2 degree offset, |f|", 0.0,
                    np.linalg.norm(free.rhs(eq.x, np.zeros(2))), tolerance=1e-12,
                    source="equilibrium")
        lin = wb.linearize(free, at_rest(free, R), np.zeros(2))
        es = wb.eigenstructure(lin)
        nonzero = es.eigenvalues[np.abs(es.eigenvalues) > 1e-8]
        compare_spectrum(res, f"{name}: nonzero eigenvalues", nonzero, ref, tolerance=1e-10,
                         source="closed form, planar cart-pendulum")
        sym = wb.linear.symmetry_directions(lin)
        res.values[f"{name}_class"] = f"{es.describe()}; {sym.describe()}"
        res.compare(f"{name}: zero eigenvalues not from a symmetry (cart, yaw)", 0,
                    np.nan if sym.unexplained is None else sym.unexplained, tolerance=0,
                    source="Noether: p_x, p_y, L_z")
        test = wb.pbh(lin)
        res.values[f"{name}_uncontrollable_by_cart_force"] = [
            test.describe_mode(mode) for mode in test.uncontrollable]
        yaw = [mode for mode in test.uncontrollable
               if np.argmax(np.abs(mode.left_vectors[:, 0])) == lin.labels.index("Omega3")]
        res.compare(f"{name}: uncontrollable modes with the cart force alone (yaw rate)", 1,
                    len(yaw), tolerance=0, source="symmetry about the vertical")
        res.compare(f"{name}: PBH with cart force and body moment (1 = controllable)", 1,
                    float(wb.pbh(wb.linearize(act, at_rest(act, R), np.zeros(5))).controllable),
                    tolerance=0, source="PBH")
    x_up = at_rest(act, INVERTED)
    design = wb.lqr(wb.linearize(act, x_up, np.zeros(5)), Q=np.eye(10), R=np.eye(5))
    k = design.feedback(name="pendulum3d_cart_lqr")
    tilt = act.state(x=[0, 0], v=[0, 0], R=INVERTED @ wb.so3_exp([np.deg2rad(20), 0, 0]),
                     Omega=[0, 0, 0])
    with res.timed("closed loop"):
        cl = wb.simulate(act, tilt, np.linspace(0, 30, 301), controller=k, rtol=1e-10, atol=1e-10)
    err = np.linalg.norm(cl.x - x_up, axis=1)
    res.compare("LQR closed loop from a 20 degree tilt: |x - x_up| at 30 s", 0.0, err[-1],
                tolerance=1e-4, source="asymptotic stability")
    ocp = wb.OCP(free, x0=at_rest(free), target=inverted_at_origin(free), u_lower=-20, u_upper=20,
              T=2.5, running_cost=lambda x, u: ca.dot(u, u), name="pendulum3d_cart_swingup")
    with res.timed("swing-up"):
        sol = wb.solve_ocp(ocp, wb.Collocation(N=40), raise_on_failure=False)
    res.compare("swing-up with the cart force alone: Ipopt solved (1 = yes)", 1,
                float(sol.status.name == "SUCCESS"), tolerance=0,
                source=f"Ipopt: {sol.status.value}")
    res.compare("swing-up: yaw rate Omega_3 at the end (not in the target; see the model)",
                0.0, abs(sol.x[-1, 15]) if sol.status.ok else np.inf, tolerance=1e-8,
                source="uncontrollable yaw rate, zero from rest")
    res.values["swingup"] = {"cost": sol.objective, "iterations": sol.cost["iterations"],
                             "local_defect": sol.error.get("local_defect")}
    with tempfile.TemporaryDirectory() as out:
        exported = codegen.export_feedback(act, k, out, name="pendulum3d_cart_lqr",
                                           title="LQR of the 3D pendulum on a cart, inverted",
                                           example_state=x_up)
        c = exported.controller
        gap = codegen.agreement(c, exported.compiled, c.sample_states(500, seed=2),
                                binding=codegen.Binding.FROZEN).max()
    res.compare("exported C LQR law vs casadi, 500 states, max rel.", 0.0, gap,
                tolerance=1e-12, source="compiled C")
    height = -np.array([(SO3.matrix(x[4:13]) @ BODY["rho"]) @ E3 for x in sol.x])
    res.figure("swing-up", line_figure([
        Panel("Swing-up: height of the centre of mass", {"": (sol.t, height)}, "t [s]",
              "height above the pivot [m]"),
        Panel("Swing-up: cart force", {"u_x": (sol.t[:-1], sol.u[:, 0]),
                                       "u_y": (sol.t[:-1], sol.u[:, 1])}, "t [s]", "[N]"),
        Panel("LQR from a 20 degree tilt", {"": (cl.t, err)}, "t [s]", "|x - x_up|",
              yscale="log")]), caption="Left: the optimal swing-up with the cart force alone "
               "(|u| <= 20 N, 2.5 s) raises the centre of mass from 0.3 m below the pivot to "
               "0.3 m above it. Middle: the cart force. Right: the LQR law (cart force and "
               "body moment) brings the body back from a 20 degree tilt.")
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
