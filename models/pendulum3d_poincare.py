"""Poincare section and geometric phase of the 3D pendulum (paper 000 Sections 5.5, 5.6).

The pieces of the ``poincare_3d_pendulum`` problem that belong to the rigid body:

* :data:`LP_SECTION` -- the turning section P written on the Lagrange-Poincare model
  (``Gamma-dot = Gamma x omega``), and :func:`reduced_model_crossings`, the independent
  location of the crossings on that model;
* :func:`compare_orbit` -- the checks of one orbit's crossings (energy (5.16), event
  residual, refinement, missed crossings, count) and its regime by the FTLE;
* :func:`phase_check` and :func:`compare_phase` -- the geometric phase (5.15) against the
  reconstruction (Prop. 17) and against the full model on TSO(3);
* :func:`poincare_figure` -- Fig. 5.1: the crossings on the sphere, one panel per orbit.
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
    poincare_map,
    wrap_angle,
)
from workbench.simulation import simulate
from workbench.study import Result, sphere_axes

__all__ = ["LP_SECTION", "compare_orbit", "compare_phase", "phase_check", "poincare_figure",
           "reduced_model_crossings"]

E3 = np.array([0.0, 0.0, 1.0])


def _lp_event(ctx: Context) -> Any:
    return ca.dot(ca.DM(E3), ca.cross(ctx["Gamma"], ctx["omega"]))


def _lp_side(ctx: Context) -> Any:
    gam = ctx["Gamma"]
    return ca.dot(ca.DM(E3), ca.cross(gam, ca.cross(gam, ctx["omega"])))


LP_SECTION = Section("turning[Gamma x omega]", _lp_event, _lp_side,
                     description="P on S^2 x R^3 with Gamma-dot = Gamma x omega (4.4)")
"""The section P of paper 000 Sec. 5.6 on the Lagrange-Poincare model (4.3)-(4.4)."""


def reduced_model_crossings(body: dict[str, Any], c: float, n_crossings: int, *, rtol: float,
                            stabilization: float) -> PoincareOrbit:
    """The section P located on the Lagrange-Poincare model (independent check).

    Parameters
    ----------
    body : dict
        ``J``, ``rho``, ``m``, ``g`` of the pendulum.
    c : float
        The initial state: ``Gamma = e3``, ``omega = c (1, 1, 1)``.
    n_crossings : int
        Crossings to locate.
    rtol : float
        Integration tolerance (``atol`` equal).
    stabilization : float
        Gain of the constraint stabilisation.

    Returns
    -------
    PoincareOrbit
    """
    reduced = p3.reduced(**body)
    x0 = reduced.state(Gamma=E3, omega=c * np.ones(3))
    return poincare_map(reduced, x0, LP_SECTION, n_crossings=n_crossings, t_max=1e4,
                        rtol=rtol, atol=rtol, stabilization=stabilization)


def compare_orbit(res: Result, c: float, orb: PoincareOrbit, ftle: float, *, regular: bool,
                  n_crossings: int, rtol: float, ftle_tolerance: float) -> dict[str, Any]:
    """Check one orbit's crossings and its regime; summarise it.

    Parameters
    ----------
    res : Result
        Receives the comparisons, named ``c = <c>: ...``.
    c : float
        The orbit's ``omega0 = c (1, 1, 1)``.
    orb : PoincareOrbit
        Its crossings of P.
    ftle : float
        Its finite-time Lyapunov exponent [1/s].
    regular : bool
        Expected regular (FTLE near 0, within ``ftle_tolerance``) or chaotic (FTLE >= 0.1/s).
    n_crossings : int
        Crossings requested.
    rtol : float
        The integration tolerance (named in the energy comparison's source).
    ftle_tolerance : float
        Allowed FTLE of a regular orbit.

    Returns
    -------
    dict
        The orbit's energy, FTLE, crossings, end time and its diagnostics' maxima.
    """
    d = orb.diagnostics
    res.compare(f"c = {c}: relative energy error at crossings", 0.0,
                d["max_relative_invariant_error"], tolerance=2e-7,
                source=f"Prop. 19 (5.16); cvodes rtol = {rtol:g}, drift over "
                       f"{orb.t_end:.0f} s")
    res.compare(f"c = {c}: event residual |e3 . Gamma-dot|", 0.0,
                d["max_event_residual"], tolerance=1e-11, source="section P (Sec. 5.6)")
    res.compare(f"c = {c}: refinement error estimate", 0.0, d["max_refine_error"],
                tolerance=1e-8, source="RK4 refinement, 16 vs 32 substeps")
    res.compare(f"c = {c}: sample intervals with a possibly missed crossing pair", 0,
                d["suspect_intervals"], tolerance=0, source="Hermite test of g")
    res.compare(f"c = {c}: crossings found", n_crossings, orb.n, tolerance=0,
                source="requested")
    if regular:
        res.compare(f"c = {c}: FTLE [1/s] (regular: near 0)", 0.0, ftle,
                    tolerance=ftle_tolerance, source="Fig. 5.1 (a), (e) periodic")
    else:
        res.compare(f"c = {c}: FTLE >= 0.1 / s (chaotic; 1 = yes)", 1.0,
                    float(ftle >= 0.1), tolerance=0, source="Fig. 5.1 (b), (c) chaotic")
    return {"energy": d["invariant_initial"], "ftle": ftle,
            "regime": "regular" if regular else "chaotic", "crossings": orb.n,
            "t_end": orb.t_end, "max_event_residual": d["max_event_residual"],
            "max_relative_energy_error": d["max_relative_invariant_error"],
            "max_refine_error": d["max_refine_error"],
            "min_abs_event_rate": d["min_abs_event_rate"],
            "max_constraint_residual": d["max_constraint_residual"], "cost": orb.cost}


def _lift_over(gamma: np.ndarray) -> np.ndarray:
    """A rotation R with R^T e3 = gamma (the rotation taking gamma to e3 about gamma x e3)."""
    axis = np.cross(gamma, E3)
    s = np.linalg.norm(axis)
    return so3_exp(axis / s * np.arctan2(s, gamma @ E3))


def phase_check(body: dict[str, Any], start: tuple[np.ndarray, np.ndarray], *, mu: float,
                stabilization: float) -> dict[str, Any]:
    """(5.15) against the reconstruction (Prop. 17) and the full model, on one loop.

    Parameters
    ----------
    body : dict
        ``J``, ``rho``, ``m``, ``g`` of the pendulum.
    start : (numpy.ndarray, numpy.ndarray)
        ``Gamma`` and ``Gamma-dot`` at the start (normalised, resp. projected to the
        tangent plane here); the attitude starts at the rotation taking ``Gamma`` to e3.
    mu : float
        The momentum of the Routh reduction.
    stabilization : float
        Gain of the constraint stabilisation of the reconstruction.

    Returns
    -------
    dict
        ``check`` (the :func:`~workbench.global_dynamics.geometric_phase_check`), the
        holonomy angle ``theta_full`` and fibre residual ``fibre_full`` of the full model
        between the loop's times, and the two models used.
    """
    g0 = start[0] / np.linalg.norm(start[0])
    gd0 = start[1] - (start[1] @ g0) * g0
    R0 = _lift_over(g0)
    recon = p3.routh_reconstruction(**body, mu=mu)
    x0 = np.r_[g0, gd0, SO3.flat(R0), 0.0]
    pc = geometric_phase_check(recon, x0, density=p3.phase_density(recon.values["J"]),
                               t_max=10.0, rtol=1e-12, atol=1e-12, stabilization=stabilization)
    # the full model on TSO(3), from the reconstructed (R0, omega0) of (5.13)-(5.14)
    _, w0 = p3.reconstruct(recon, x0[None, :])
    full = p3.full(**body)
    tr = simulate(full, full.state(R=R0, omega=w0[0]), [0.0, pc.t1, pc.t2], rtol=1e-12,
                  atol=1e-12)
    theta_full, fibre_full = holonomy_angle(SO3.matrix(tr.x[1, :9]), SO3.matrix(tr.x[2, :9]))
    return {"check": pc, "theta_full": theta_full, "fibre_full": fibre_full,
            "full_model": full, "recon_model": recon}


def compare_phase(res: Result, label: str, ph: dict[str, Any]) -> dict[str, Any]:
    """Compare a :func:`phase_check` with (5.15), the two caps and the full model.

    Returns the check's fields with the full model's holonomy angle and fibre residual.
    """
    pc = ph["check"]
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
    return {**asdict(pc), "theta_full_model": ph["theta_full"],
            "fibre_residual_full": ph["fibre_full"]}


def poincare_figure(orbits: list[PoincareOrbit], cs: list[float], ftles: list[float]) -> Any:
    """Fig. 5.1: the crossings' attitudes Gamma on the sphere, one panel (a), (b), .. per orbit."""
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
    # laid out when drawn; room at the top for the two-line titles of 3D axes
    fig.set_layout_engine("tight", rect=(0, 0, 1, 0.92))
    return fig
