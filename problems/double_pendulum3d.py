"""Two rigid bodies on spherical joints, defined only by their Lagrangian (SO(3) x SO(3)).

The first body hangs from a fixed pivot, the second from a point of the first. The mechanics
layer derives the equations from the two bodies' energies; Kane's method in Euler angles
(sympy) agrees with them. Energy and the angular momentum about the vertical are conserved;
the four equilibrium types — each body hanging or inverted — have the spectra of two planar
compound double pendulums (one per horizontal axis) with 0, 2, 2 and 4 unstable modes, the
four zero eigenvalues coming from the spins of the bodies about their own axes. A long run
with the Lie-group integrator RKMK4 stays on SO(3) x SO(3) and measures how its energy
error grows (it is not symplectic, so it drifts; no variational integrator for products of
rotation groups exists in the workbench yet).
"""

from __future__ import annotations

import numpy as np

import workbench as wb
from models import kane_references
from models.double_pendulum3d import double_pendulum3d
from workbench.study import Panel, Result, compare_spectrum, line_figure

TITLE = "Double 3D pendulum from its Lagrangian: invariants, the four equilibria and their " \
        "spectra, long-run energy error"

BODIES = {"m1": 1.0, "J1": np.diag([0.20, 0.22, 0.05]), "rho1": [0.0, 0.0, 0.25],
          "d1": [0.0, 0.0, 0.5], "m2": 0.8, "J2": np.diag([0.10, 0.12, 0.03]),
          "rho2": [0.0, 0.0, 0.2], "g": 9.81}
INVERTED = np.diag([1.0, -1.0, -1.0])


def planar_spectrum(s1: int, s2: int) -> np.ndarray:
    """Closed form: linearised compound double pendulum in each vertical plane.

    ``s_i = +1`` hanging, ``-1`` inverted; mass matrix ``[[J1 + m2 l1^2, s1 s2 m2 l1 r2],
    [., J2]]`` and stiffness ``diag(s1 g (m1 r1 + m2 l1), s2 g m2 r2)`` per plane (the
    bodies' inertias about their pivots about that axis).

    Returns
    -------
    ndarray of complex, shape=(8,)
    """
    b = BODIES
    r1, l1, r2, m1, m2, g = b["rho1"][2], b["d1"][2], b["rho2"][2], b["m1"], b["m2"], b["g"]
    out = []
    for axis in (0, 1):
        c = s1 * s2 * m2 * l1 * r2
        M = np.array([[b["J1"][axis, axis] + m2 * l1**2, c], [c, b["J2"][axis, axis]]])
        K = np.diag([s1 * g * (m1 * r1 + m2 * l1), s2 * g * m2 * r2])
        lam2 = np.linalg.eigvals(-np.linalg.solve(M, K)).astype(complex)
        out += [*np.sqrt(lam2), *-np.sqrt(lam2)]
    return np.array(out)


def solve(*, quick: bool = False) -> Result:
    """Run the problem (quick: a 100 s long run instead of 1000 s)."""
    res = Result("double_pendulum3d", TITLE, quick=quick)
    model = double_pendulum3d(**BODIES)
    res.use(model)
    dev = kane_references.deviation(model, np.random.default_rng(3), n=3 if quick else 20)
    res.compare("accelerations vs Kane's method (sympy, Euler angles), max rel.", 0.0, dev,
                tolerance=1e-10, source="independent derivation")
    x0 = model.state(R1=wb.so3_exp([0.5, 0.2, 0.0]), Omega1=[0.3, 0.1, 0.5],
                     R2=wb.so3_exp([-0.4, 0.3, 0.1]), Omega2=[0.0, 0.4, -0.2])
    tr = wb.simulate(model, x0, np.linspace(0, 20, 201), rtol=1e-12, atol=1e-12)
    for name, d in tr.diagnostics["invariant_drift"].items():
        res.compare(f"CVODES, 20 s: drift of {name}", 0.0, d["max_abs"], tolerance=1e-8,
                    source="conservation law")
    for (n1, s1, R1) in (("hanging", 1, np.eye(3)), ("inverted", -1, INVERTED)):
        for (n2, s2, R2) in (("hanging", 1, np.eye(3)), ("inverted", -1, INVERTED)):
            label = f"body 1 {n1}, body 2 {n2}"
            x = model.state(R1=R1, Omega1=[0, 0, 0], R2=R2, Omega2=[0, 0, 0])
            res.compare(f"{label}: |f|", 0.0, np.linalg.norm(model.rhs(x)), tolerance=1e-13,
                        source="equilibrium")
            lam = wb.eigenstructure(wb.linearize(model, x)).eigenvalues
            ref = planar_spectrum(s1, s2)
            compare_spectrum(res, f"{label}: nonzero eigenvalues", lam[np.abs(lam) > 1e-8],
                             ref, tolerance=1e-9,
                             source="closed form, planar compound double pendulum")
            res.compare(f"{label}: unstable modes", int(np.sum(ref.real > 1e-8)),
                        int(np.sum(lam.real > 1e-8)), tolerance=0, source="closed form")
    horizon = 100.0 if quick else 1000.0
    t = np.linspace(0.0, horizon, 1001)
    with res.timed("long run, RKMK4"):
        run = wb.simulate(model, x0, t, method="rkmk4", step=0.01)
    E = np.array([model.invariants(x)["energy"] for x in run.x])
    err = np.maximum.accumulate(np.abs(E - E[0]))
    late = t > horizon / 10
    growth = float(np.polyfit(np.log(t[late]), np.log(err[late]), 1)[0])
    res.values["rkmk4_long_run"] = {"horizon": horizon, "step": 0.01,
                                    "max_energy_error": float(err[-1]),
                                    "growth_exponent": growth,
                                    "constraint_residual": run.diagnostics.get(
                                        "constraint_residual")}
    res.compare(f"RKMK4 (h = 0.01), {horizon:g} s: max relative energy error", 0.0,
                err[-1] / abs(E[0]), tolerance=1e-5, source="fourth-order accuracy")
    res.figure("energy", line_figure([Panel(
        f"Energy error of RKMK4 over {horizon:g} s", {"h = 0.01": (t[1:], err[1:])}, "t [s]",
        "max |E - E(0)| so far [J]", xscale="log", yscale="log")], ncols=1),
        caption=f"Energy error of the Lie-group integrator RKMK4 on the chaotic double 3D "
                f"pendulum: it stays on SO(3) x SO(3) but its energy error grows like "
                f"t^{growth:.2f} (RKMK4 is not symplectic).")
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
