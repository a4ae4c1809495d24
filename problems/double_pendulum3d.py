"""Two rigid bodies on spherical joints, defined only by their Lagrangian (SO(3) x SO(3)).

The first body hangs from a fixed pivot, the second from a point of the first. The mechanics
layer derives the equations from the two bodies' energies; Kane's method in Euler angles
(sympy) agrees with them. Energy and the angular momentum about the vertical are conserved;
the four equilibrium types — each body hanging or inverted — have the spectra of two planar
compound double pendulums (one per horizontal axis) with 0, 2, 2 and 4 unstable modes, the
four zero eigenvalues coming from the spins of the bodies about their own axes. Two long
runs at the same step stay on SO(3) x SO(3): the Lie-group integrator RKMK4 (order 4, not
symplectic) whose energy error drifts, and the variational integrator of the mechanics
layer (order 2, symplectic, discrete Noether) whose energy error stays bounded with no
secular growth and which keeps L_z to the Newton tolerance's scale.
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
STEP = 0.01


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
            lin = wb.linearize(model, x)
            es, sym = wb.eigenstructure(lin), wb.linear.symmetry_directions(lin)
            lam = es.eigenvalues
            res.values[f"{label}: class"] = f"{es.describe()}; {sym.describe()}"
            res.compare(f"{label}: zero eigenvalues from the rotation about e3", 2,
                        sym.orbit_rank + sym.conserved_rank, tolerance=0,
                        source="Noether: orbit and momentum L_z")
            ref = planar_spectrum(s1, s2)
            compare_spectrum(res, f"{label}: nonzero eigenvalues", lam[np.abs(lam) > 1e-8],
                             ref, tolerance=1e-9,
                             source="closed form, planar compound double pendulum")
            res.compare(f"{label}: unstable modes", int(np.sum(ref.real > 1e-8)),
                        int(np.sum(lam.real > 1e-8)), tolerance=0, source="closed form")
    long_runs(res, model, x0, 100.0 if quick else 1000.0)
    return res.finish()


def long_runs(res: Result, model: wb.Model, x0: np.ndarray, horizon: float) -> None:
    """RKMK4 and the variational integrator at h = 0.01 over ``horizon``: energy error."""
    t = np.linspace(0.0, horizon, 1001)
    tenth, late = len(t) // 10, t > horizon / 10
    curves, out = {}, {}
    for method, label in (("rkmk4", "RKMK4"), ("mechanics_variational", "variational")):
        with res.timed(f"long run, {label}"):
            run = wb.simulate(model, x0, t, method=method, step=STEP)
        E = run.invariant_series("energy")
        dE = np.abs(E - E[0])
        err = np.maximum.accumulate(dE)
        curves[label] = (t[1:], err[1:])
        out[method] = {"horizon": horizon, "step": STEP, "max_energy_error": float(err[-1]),
                       "max_relative_energy_error": float(err[-1] / abs(E[0])),
                       "first_tenth": float(dE[1 : tenth + 1].max()),
                       "last_tenth": float(dE[-tenth:].max()),
                       "rms_first_tenth": float(np.sqrt(np.mean(dE[1 : tenth + 1] ** 2))),
                       "rms_last_tenth": float(np.sqrt(np.mean(dE[-tenth:] ** 2))),
                       "growth_exponent": float(np.polyfit(np.log(t[late]), np.log(err[late]),
                                                           1)[0]),
                       "L_z_drift": run.diagnostics["invariant_drift"]["L_z"]["max_abs"],
                       "constraint_residual": run.diagnostics["constraint_residual"],
                       "seconds": run.cost["wall_seconds"]}
    rk, vi = out["rkmk4"], out["mechanics_variational"]
    res.values["rkmk4_long_run"], res.values["variational_long_run"] = rk, vi
    res.compare(f"RKMK4 (h = {STEP}), {horizon:g} s: max relative energy error", 0.0,
                rk["max_relative_energy_error"], tolerance=1e-5, source="fourth-order accuracy")
    res.compare(f"variational (h = {STEP}), {horizon:g} s: max relative energy error", 0.0,
                vi["max_relative_energy_error"], tolerance=2e-4, source="second-order accuracy")
    # The RMS over a window, not its maximum: on a chaotic orbit the window maximum is an
    # extreme-value statistic that rounding moves by a factor 2 (2.2 on one machine, 1.15
    # on another, same code); the RMS moves less (1.04-1.20 under perturbations of 1e-13 at
    # 1000 s, 0.64 at 100 s). The bound is one-sided, no secular growth: at most 2, which
    # RKMK4's drift (~t) exceeds, checked too so that the criterion is seen to discriminate.
    ratio = {k: v["rms_last_tenth"] / v["rms_first_tenth"] for k, v in out.items()}
    res.compare(f"variational, {horizon:g} s: growth of the RMS |dE|, max(0, last tenth / "
                f"first tenth - 1)", 0.0, max(0.0, ratio["mechanics_variational"] - 1.0),
                tolerance=1.0, source="symplectic: bounded energy error, no secular growth")
    res.compare(f"RKMK4, {horizon:g} s: RMS |dE| last tenth / first tenth above 2 (1 = yes)",
                1.0, float(ratio["rkmk4"] > 2.0), tolerance=0,
                source="not symplectic: the same criterion sees its drift")
    res.compare(f"variational, {horizon:g} s: drift of L_z", 0.0, vi["L_z_drift"],
                tolerance=1e-10, source="discrete Noether theorem")
    res.figure("energy", line_figure([Panel(
        f"Energy error over {horizon:g} s, h = {STEP}", curves, "t [s]",
        "max |E - E(0)| so far [J]", xscale="log", yscale="log")], ncols=1),
        caption=f"Energy error on the chaotic double 3D pendulum, both integrators on SO(3) x "
                f"SO(3): RKMK4's grows like t^{rk['growth_exponent']:.2f} (last tenth / first "
                f"tenth {rk['last_tenth'] / rk['first_tenth']:.1f}; not symplectic), the "
                f"variational integrator's stays bounded (t^{vi['growth_exponent']:.2f}, "
                f"ratio {vi['last_tenth'] / vi['first_tenth']:.2f}) and it keeps L_z to "
                f"{vi['L_z_drift']:.0e}. Ratios are of the window maxima; the checks use the "
                f"windows' RMS ({ratio['mechanics_variational']:.2f} and "
                f"{ratio['rkmk4']:.1f}), which rounding moves less on a chaotic orbit.")


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
