"""Poincare maps of the 3D pendulum (paper 000 Fig. 5.1) and its geometric phase (5.15).

The free 3D pendulum, reduced by its symmetry about the vertical, is cut by the paper's
Poincare section at five energies. The workbench reproduces the picture of Fig. 5.1:
regular motion at low energy, chaos in between, regular again at high energy, measured by
the finite-time Lyapunov exponent, with every crossing located to rounding and checked
against a second, independent model. The geometric phase formula (5.15) is confirmed
against the attitude rebuilt by the reconstruction equations and against the full model.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import casadi as ca
import numpy as np

from models import pendulum3d as p3
from workbench.core import Context
from workbench.core.manifolds import SO3, so3_exp
from workbench.global_dynamics import (
    PoincareOrbit,
    Section,
    geometric_phase_check,
    holonomy_angle,
    lyapunov_exponent,
    poincare_map,
    turning_section,
    wrap_angle,
)
from workbench.simulation import grid, simulate, sweep
from workbench.study import Result, sphere_axes

TITLE = "Poincare maps of the 3D pendulum from regular to chaotic and back; geometric phase"

BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
        "g": 9.81}
E3 = np.array([0.0, 0.0, 1.0])
C_VALUES = (1.0, 3.0, 4.5, 6.0, 10.0)
REGIME = {1.0: "regular", 3.0: "chaotic", 4.5: "chaotic", 6.0: "chaotic", 10.0: "regular"}
RTOL = 1e-11
STABILIZATION = 10.0


def initial_state(c: float) -> tuple[np.ndarray, float]:
    """Routh state (Gamma, Gamma-dot) and mu of R0 = I, omega0 = c (1, 1, 1)."""
    full = p3.full(**BODY)
    return p3.routh_state_from_full(full, full.state(R=np.eye(3), omega=c * np.ones(3)))


def orbit(*, c: float, n_crossings: int, lyapunov_time: float, rtol: float = RTOL,
          stabilization: float = STABILIZATION) -> dict[str, Any]:
    """One sweep item: the section crossings of the orbit for ``c`` and its FTLE."""
    x0, mu = initial_state(c)
    model = p3.routh(**BODY, mu=mu)
    orb = poincare_map(model, x0, turning_section(), n_crossings=n_crossings, t_max=1e4,
                       rtol=rtol, atol=rtol, stabilization=stabilization)
    ftle = lyapunov_exponent(model, x0, t_final=lyapunov_time, rtol=1e-10, atol=1e-10,
                             stabilization=stabilization)
    return {"c": c, "mu": mu, "orbit": orb, "ftle": ftle.value,
            "ftle_seconds": ftle.cost["wall_seconds"]}


def _lp_event(ctx: Context) -> Any:
    return ca.dot(ca.DM(E3), ca.cross(ctx["Gamma"], ctx["omega"]))


def _lp_side(ctx: Context) -> Any:
    gam = ctx["Gamma"]
    return ca.dot(ca.DM(E3), ca.cross(gam, ca.cross(gam, ctx["omega"])))


LP_SECTION = Section("turning[Gamma x omega]", _lp_event, _lp_side,
                     description="P on S^2 x R^3 with Gamma-dot = Gamma x omega (4.4)")


def reduced_model_crossings(c: float, n_crossings: int) -> PoincareOrbit:
    """The same section located on the Lagrange-Poincare model (independent check)."""
    reduced = p3.reduced(**BODY)
    x0 = reduced.state(Gamma=E3, omega=c * np.ones(3))
    return poincare_map(reduced, x0, LP_SECTION, n_crossings=n_crossings, t_max=1e4,
                        rtol=RTOL, atol=RTOL, stabilization=STABILIZATION)


def _lift_over(gamma: np.ndarray) -> np.ndarray:
    """A rotation R with R^T e3 = gamma (the rotation taking gamma to e3 about gamma x e3)."""
    axis = np.cross(gamma, E3)
    s = np.linalg.norm(axis)
    return so3_exp(axis / s * np.arctan2(s, gamma @ E3))


PHASE_START = (np.array([0.8, 0.2, 0.3]), np.array([0.0, 3.0, 1.0]))


def phase_check(*, mu: float) -> dict[str, Any]:
    """(5.15) against the reconstruction (Prop. 17) and the full model, on one loop."""
    g0 = PHASE_START[0] / np.linalg.norm(PHASE_START[0])
    gd0 = PHASE_START[1] - (PHASE_START[1] @ g0) * g0
    R0 = _lift_over(g0)
    recon = p3.routh_reconstruction(**BODY, mu=mu)
    x0 = np.r_[g0, gd0, SO3.flat(R0), 0.0]
    pc = geometric_phase_check(recon, x0, density=p3.phase_density(recon.values["J"]),
                               t_max=10.0, rtol=1e-12, atol=1e-12, stabilization=STABILIZATION)
    # the full model on TSO(3), from the reconstructed (R0, omega0) of (5.13)-(5.14)
    _, w0 = p3.reconstruct(recon, x0[None, :])
    full = p3.full(**BODY)
    tr = simulate(full, full.state(R=R0, omega=w0[0]), [0.0, pc.t1, pc.t2], rtol=1e-12,
                  atol=1e-12)
    theta_full, fibre_full = holonomy_angle(SO3.matrix(tr.x[1, :9]), SO3.matrix(tr.x[2, :9]))
    return {"check": pc, "theta_full": theta_full, "fibre_full": fibre_full,
            "full_model": full, "recon_model": recon}


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        200 crossings per orbit and a 100 s Lyapunov horizon instead of 1000 and 400 s.

    Returns
    -------
    Result

    Notes
    -----
    **Poincare maps.** The body of Section 5.6 (m = 1, J = diag(0.13, 0.28, 0.17),
    rho = (0, 0, 0.3), g = 9.81) starts at R0 = I, omega0 = c (1, 1, 1); its Lagrange-Routh
    orbit on TS^2 (momentum mu = 0.17 c) is cut by the section P = {e3 . Gamma-dot = 0,
    e3 . (Gamma x Gamma-dot) > 0} at the energy E(c) = 0.29 c^2 - 2.943 (5.16). The five
    values of c, one orbit each, run through :func:`workbench.simulation.sweep` in a process pool:

    =====  ========  ==========================================================================
    c      E [J]     what the map shows (measured by the finite-time Lyapunov exponent)
    =====  ========  ==========================================================================
    1      -2.653    regular (a): small oscillations about the hanging attitude, points on
                     closed curves; FTLE ~ 0.005/s, decaying like log(t)/t
    3      -0.333    chaotic (b): points scatter over an area; FTLE ~ 0.4/s
    4.5     2.930    chaotic (c): just below the inverted energy m g |rho| = 2.943; FTLE ~ 1/s
    6       7.497    chaotic (d): above the inverted energy, still mixing, with sticky
                     regions (FTLE 0.2-0.6/s depending on the horizon)
    10     26.057    regular (e): fast rotation, points on curves again; FTLE ~ 0.015/s
    =====  ========  ==========================================================================

    (The onset of chaos lies between c = 2 and 2.5, the return to regularity between 6 and 7.)
    Each orbit is integrated with CVODES (Adams) on the constraint-stabilised field (the
    Routh field's ambient extension drifts off TS^2 exponentially on chaotic orbits, see
    :mod:`workbench.global_dynamics`); every crossing is refined to an event residual below
    1e-11 and carries its energy error. Independent check: the first crossings of the regular
    orbit agree with those located on the Lagrange-Poincare model on S^2 x R^3 with the same
    section written in (Gamma, omega) (Gamma-dot = Gamma x omega).

    **Geometric phase.** For mu = 0 the reduced curve of an orbit is closed at its first
    self-intersection Gamma(t1) = Gamma(t2); the holonomy of the horizontal lift (Prop. 17,
    integrated from the graph) is compared with (5.15) over both caps of the loop, and with
    the attitude of the full model on TSO(3) integrated independently.
    """
    res = Result("poincare_3d_pendulum", TITLE, quick=quick)
    n_cross = 200 if quick else 1000
    t_ly = 100.0 if quick else 400.0
    with res.timed("sweep of the five orbits (process pool, 2 workers)"):
        out = sweep(orbit, grid(c=list(C_VALUES), n_crossings=[n_cross],
                                lyapunov_time=[t_ly]), workers=2, desc="Poincare orbits")
    items = out.values()
    per_c: dict[str, Any] = {}
    ftle_tol = 0.08 if quick else 0.05  # regular orbits: ~log(t)/t, 0.06 at 100 s
    for it in items:
        c, orb = it["c"], it["orbit"]
        d = orb.diagnostics
        res.compare(f"c = {c}: relative energy error at crossings", 0.0,
                    d["max_relative_invariant_error"], tolerance=2e-7,
                    source=f"Prop. 19 (5.16); cvodes rtol = {RTOL:g}, drift over "
                           f"{orb.t_end:.0f} s")
        res.compare(f"c = {c}: event residual |e3 . Gamma-dot|", 0.0,
                    d["max_event_residual"], tolerance=1e-11, source="section P (Sec. 5.6)")
        res.compare(f"c = {c}: refinement error estimate", 0.0, d["max_refine_error"],
                    tolerance=1e-8, source="RK4 refinement, 16 vs 32 substeps")
        res.compare(f"c = {c}: sample intervals with a possibly missed crossing pair", 0,
                    d["suspect_intervals"], tolerance=0, source="Hermite test of g")
        res.compare(f"c = {c}: crossings found", n_cross, orb.n, tolerance=0,
                    source="requested")
        if REGIME[c] == "regular":
            res.compare(f"c = {c}: FTLE [1/s] (regular: near 0)", 0.0, it["ftle"],
                        tolerance=ftle_tol, source="Fig. 5.1 (a), (e) periodic")
        else:
            res.compare(f"c = {c}: FTLE >= 0.1 / s (chaotic; 1 = yes)", 1.0,
                        float(it["ftle"] >= 0.1), tolerance=0,
                        source="Fig. 5.1 (b), (c) chaotic")
        per_c[f"c={c}"] = {
            "energy": d["invariant_initial"], "mu": it["mu"], "ftle": it["ftle"],
            "regime": REGIME[c], "crossings": orb.n, "t_end": orb.t_end,
            "max_event_residual": d["max_event_residual"],
            "max_relative_energy_error": d["max_relative_invariant_error"],
            "max_refine_error": d["max_refine_error"],
            "min_abs_event_rate": d["min_abs_event_rate"],
            "max_constraint_residual": d["max_constraint_residual"],
            "cost": orb.cost, "ftle_seconds": it["ftle_seconds"],
        }

    # independent check: the same section on the Lagrange-Poincare model
    n_chk = 30 if quick else 100
    with res.timed("Lagrange-Poincare cross-check"):
        lp = reduced_model_crossings(1.0, n_chk)
    routh_c1 = next(it["orbit"] for it in items if it["c"] == 1.0)
    gam_err = float(np.max(np.abs(lp.x[:, :3] - routh_c1.x[:n_chk, :3])))
    t_err = float(np.max(np.abs(lp.t - routh_c1.t[:n_chk])))
    res.compare(f"c = 1: max |Gamma_Routh - Gamma_LP| over {n_chk} crossings", 0.0, gam_err,
                tolerance=1e-7, source="Routh (5.7) vs Lagrange-Poincare (4.3)-(4.4)")
    res.compare(f"c = 1: max |t_Routh - t_LP| over {n_chk} crossings [s]", 0.0, t_err,
                tolerance=1e-7, source="Routh (5.7) vs Lagrange-Poincare (4.3)-(4.4)")

    # geometric phase
    phase: dict[str, Any] = {}
    for mu in (0.0, 0.3):
        with res.timed(f"geometric phase, mu = {mu}"):
            ph = phase_check(mu=mu)
        pc = ph["check"]
        res.use(ph["recon_model"], ph["full_model"])
        label = f"mu = {mu}"
        res.compare(f"{label}: wrap(theta_reconstruction - theta_(5.15)) [rad]", 0.0,
                    pc.difference, tolerance=1e-9,
                    source="Prop. 18 (5.15) vs Prop. 17 (R_hor holonomy)")
        # the two cones bound the two caps of the simple loop, both with the loop's sense
        # sigma = sign of its signed solid angle, so they differ by sigma int_S2 F dA
        sigma = float(np.sign(pc.signed_area))
        res.compare(f"{label}: (theta_cap - theta_other_cap) / 4 pi", -sigma,
                    pc.caps_differ_by, tolerance=1e-8,
                    source="int_S2 F dA = -4 pi (Euler number 2), loop sense sigma")
        total = wrap_angle(pc.theta_formula + pc.dynamic_phase)
        res.compare(f"{label}: wrap(theta_full - theta_(5.15) - theta_dyn) [rad]", 0.0,
                    wrap_angle(ph["theta_full"] - total), tolerance=1e-8,
                    source="full model (3.1)-(3.2) vs (5.12) + (5.15)")
        phase[label] = {**asdict(pc), "theta_full_model": ph["theta_full"],
                        "fibre_residual_full": ph["fibre_full"]}
    res.values = {
        "body": BODY,
        "c_values": list(C_VALUES), "crossings_per_orbit": n_cross,
        "rtol": RTOL, "stabilization": STABILIZATION, "orbits": per_c,
        "sweep": out.cost, "lagrange_poincare_check": {"max_gamma": gam_err, "max_t": t_err},
        "geometric_phase": phase,
    }
    res.notes.append(
        "The Routh field (5.7) in ambient coordinates amplifies constraint residuals "
        "(|Gamma|^2 - 1, Gamma . Gamma-dot) exponentially on chaotic orbits; the orbits are "
        f"integrated on the constraint-stabilised field (gain {STABILIZATION}/s), identical "
        "on TS^2, never projected.")
    res.notes.append(
        "(5.15) holds with B oriented by the curve (boundary orientation, outward normal "
        "Gamma), i.e. theta_geo = +int_B F dA for the cap to the left of the direction of "
        "travel; both caps agree modulo 4 pi because int_S2 F dA = -4 pi.")
    res.figure("poincare_maps", _figure([it["orbit"] for it in items], [it["c"] for it in items],
                                        [it["ftle"] for it in items]), caption=(
        "Paper 000 Fig. 5.1 recomputed: the Poincare section P of the reduced 3D pendulum "
        "(Gamma where e3 . Gamma-dot = 0, on the sphere) for five energies (c = 1, 3, 4.5, 6, "
        "10): points on closed curves when the motion is regular (a, e), scattered when it "
        "is chaotic (b-d); the finite-time Lyapunov exponent is in each title."))
    return res.finish()


def _figure(orbits: list[PoincareOrbit], cs: list[float], ftles: list[float]):  # noqa: ANN202
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(3.2 * len(orbits), 3.6))
    for k, (orb, c, ftle) in enumerate(zip(orbits, cs, ftles)):
        ax = sphere_axes(fig, (1, len(orbits), k + 1), elev=-60, azim=30)
        g = orb.part("Gamma")[:, :3]
        ax.scatter(g[:, 0], g[:, 1], g[:, 2], s=1.5, c="C3")
        ax.set_title(f"({'abcde'[k]}) c = {c:g}, E = {orb.diagnostics['invariant_initial']:.2f}"
                     f"\nFTLE {ftle:.3f}/s", fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.92))  # room for the two-line titles of 3D axes
    return fig


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
