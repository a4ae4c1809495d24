"""Reduced and Routh models computed from the Lagrangian: paper 000's 3D pendulum and beyond.

``workbench.mechanics.reduce`` derives, from the full model on TSO(3) and its symmetry
about gravity (the momentum ``h``), the Lagrange-Poincare model on S^2 x R^3 and the
Routh model on TS^2 at a momentum value, with the reconstruction of the full motion.
Here they are checked against the models transcribed from paper 000 (models/pendulum3d.py:
(4.3)-(4.4), (5.7)-(5.9), Prop. 17) at random states and random bodies (inertia with random
principal axes and condition up to 1e3), against the full model's trajectories, and at the
relative equilibria traced by continuation (models/relative_families.py).

State map of the Routh models: the derived one stores ``(Gamma, w)`` with ``Gamma-dot =
w x Gamma`` (the S^2 factor of the mechanics layer), paper 000 stores ``(Gamma,
Gamma-dot)``; so ``Gamma-dot = w x Gamma`` and ``Gamma-ddot = w-dot x Gamma + w x
Gamma-dot``. The Lagrange-Poincare models share ``(Gamma, omega)``.

Beyond the papers (problems/_mechanics_reduction_beyond.py): the systems the workbench
added, reduced by their symmetries, their relative equilibria found as equilibria of the
reduced models from structured starts and checked in the full model and against closed
forms: the Furuta pendulum by the shift of its arm angle (the motor refused by name, then
held at zero), the 3D pendulum on a cart by each translation, the quadrotor with a slung
load by a translation and by yaw, the double 3D pendulum by yaw of the pair (quotient
coordinates ``Gamma1 = R1^T e3`` and ``R1^T R2``).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from models import pendulum3d as p3
from problems._mechanics_reduction_beyond import beyond_the_papers
from problems._mechanics_reduction_beyond import figure as beyond_figure
from problems._mechanics_reduction_checks import (
    BODY,
    fields,
    geometric_phase,
    reconstruction,
    relative_equilibria,
)
from workbench.study import Result

TITLE = ("Reduced and Routh models computed from the Lagrangian: the 3D pendulum vs paper 000, "
         "and the systems beyond the papers")
FIELD_TOL, RECON_TOL, RE_TOL = 1e-11, 1e-8, 1e-9


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        3 random bodies with 10 states each (instead of 8 with 40), and a coarser
        continuation of the relative equilibria (max_step 2.0 instead of 0.5), and 5
        random states (instead of 20) for the quadrotor's free fall.

    Returns
    -------
    Result

    Notes
    -----
    Measured: (1) the largest relative deviation ``max|f_derived - f_paper| / max|f_paper|``
    of the Lagrange-Poincare field (with a random body moment) and of the Routh field
    (through the state map above, random ``mu``), and of the invariants (energy, ``h``,
    relative to the size of their terms: ``omega.J omega / 2 + m g |rho|``, ``|J Gamma|
    |omega|``),
    at random states and bodies (J with random axes, condition up to 1e3; rho, m, g, mu
    random); at most 1e-11; and the reduced field's independence from the lift (the
    section against a lift turned about e3 by a random angle). (2) The full state
    reconstructed from the derived Routh and Lagrange-Poincare models against the full
    model's own trajectory over 10 s at rtol 1e-12 (at most 1e-8), on the elliptic cylinder
    released near hanging (``SCENE_SEED``; the full model's own error there, rtol 1e-12
    against 1e-13, must be at most 1e-9), and the derived reconstruction's dynamic phase
    and horizontal lift against paper 000's (5.10)-(5.12); the holonomy of the derived
    horizontal lift over a loop of Gamma(t) against the geometric phase (5.15) (at mu = 0
    and 0.3, at most 1e-9). (3) At every point of the
    relative equilibria of paper 000's elliptic cylinder traced by continuation (Section
    4.3), the derived
    Routh field at ``(Gamma, 0)`` with that point's momentum, and the gradient of the
    amended potential on the sphere (at most 1e-9, the corrector's tolerance level).
    (4) Beyond the papers, for each system: the equilibria of its Routh (or, where the
    thrust must stay on, Lagrange-Poincare) model found from structured starts, their
    number and position against a closed form (Furuta ``cos(alpha) = 3 g / (2 Omega^2
    Lp)``; the cart's uniform motion at ``mu / (M + m)``; the quadrotor's level flight and
    its spinning hover with the load swung out, ``cos(beta) = (mQ + mL) g / (mQ L
    Omega^2)``; the double pendulum's pair tilted in a principal plane against the
    critical points of its hand-written amended potential), the amended potential's
    gradient, and in the full model the steady motion ``|f(x) - xi g'(x)| / |xi g'(x)|``
    (at most 1e-10) and the momentum ``|J - mu| / |mu|`` (at most 1e-12).
    """
    res = Result("mechanics_reduction", TITLE, quick=quick)
    rng = np.random.default_rng(31)
    n_bodies, n_states = (3, 10) if quick else (8, 40)
    with res.timed("fields at random states and bodies"):
        dev = fields(rng, n_bodies, n_states)
    src = "models/pendulum3d.py (paper 000 (4.3)-(4.4), (5.7)-(5.9), (4.6), (5.16))"
    for k, v in dev.items():
        res.compare(f"max relative deviation, {k}", 0.0, max(v), tolerance=FIELD_TOL,
                    source=src if k != "lift independence" else
                    "the reduced field from the section and from a lift turned about e3")
    t = np.linspace(0.0, 10.0, 501)
    with res.timed("reconstruction over 10 s"):
        rec = reconstruction(t)
    for k, v in rec.items():
        own = k.startswith("full")
        res.compare(k if own else f"max |reconstructed - reference| over 10 s, {k}", 0.0,
                    float(v.max()), tolerance=RECON_TOL / 10 if own else RECON_TOL,
                    source="the reference must be 10x more accurate than the check" if own
                    else "paper 000 Prop. 17, models.pendulum3d" if "vs" in k
                    else "the full model's trajectory (rtol 1e-12)")
    with res.timed("geometric phase"):
        phases = {mu: geometric_phase(mu) for mu in (0.0, 0.3)}
    for mu, d in phases.items():
        res.compare(f"geometric phase, mu = {mu:g}: wrap(theta_reconstruction - theta_(5.15))"
                    " [rad]", 0.0, abs(d), tolerance=RE_TOL,
                    source="paper 000 Prop. 18 (5.15), workbench.global_dynamics")
    with res.timed("relative equilibria"):
        n, worst_f, worst_v = relative_equilibria(quick)
    res.compare("max |Routh field| at the relative equilibria", 0.0, worst_f, tolerance=RE_TOL,
                source="models.relative_families (continuation, paper 000 Prop. 9)")
    res.compare("max |grad V_mu| on S^2 at the relative equilibria", 0.0, worst_v,
                tolerance=RE_TOL, source="amended potential V + mu^2 / (2 Gamma.J Gamma)")
    res.values = {"max_deviation": {k: max(v) for k, v in dev.items()},
                  "median_deviation": {k: float(np.median(v)) for k, v in dev.items()},
                  "reconstruction": {k: float(v.max()) for k, v in rec.items()},
                  "geometric_phase_difference": {str(k): v for k, v in phases.items()},
                  "relative_equilibria": {"points": n, "max_routh_field": worst_f,
                                          "max_amended_gradient": worst_v}}
    fig = Figure(figsize=(7.0, 3.2))
    ax1, ax2 = fig.subplots(1, 2)
    bins = np.linspace(-18, -10, 33)
    for k in ("Lagrange-Poincare", "Routh"):
        ax1.hist(np.log10(np.maximum(dev[k], 1e-18)), bins=bins, histtype="step", label=k)
    ax1.axvline(np.log10(FIELD_TOL), color="k", ls="--", lw=1)
    ax1.set(xlabel="log10 relative field deviation", ylabel="states")
    ax1.legend(fontsize=7)
    for k, v in rec.items():
        ax2.semilogy(t, np.maximum(v, 1e-17), lw=1, label=k)
    ax2.axhline(RECON_TOL, color="k", ls="--", lw=1)
    ax2.set(xlabel="t [s]", ylabel="max abs deviation")
    ax2.legend(fontsize=6)
    fig.set_layout_engine("tight")
    res.figure("reduction", fig, caption=(
        "Left: relative deviation of the derived reduced fields from paper 000's at each "
        "random state (tolerance 1e-11 dashed). Right: the full motion reconstructed from "
        "the derived Routh and Lagrange-Poincare models against the full model's, and the "
        "derived dynamic phase and horizontal lift against Prop. 17's (tolerance 1e-8)."))
    with res.timed("beyond the papers"):
        rows, beyond, reduced = beyond_the_papers(rng, quick)
    for row in rows:
        res.compare(row.quantity, row.reference, row.value, tolerance=row.tolerance,
                    source=row.source)
    res.values["beyond_the_papers"] = beyond
    res.figure("furuta_relative_equilibria", beyond_figure(beyond), caption=(
        "The Furuta pendulum reduced by its arm angle's shift: equilibria of the Routh model "
        "(motor held at zero) at 11 momentum values, plotted at the arm rate of the full "
        "model's steady motion, against the closed form (hanging, upright and the tilted "
        "pair past the pitchfork)."))
    res.use(p3.full(**BODY), *reduced)
    res.notes.append(f"Relative equilibria checked: {n} continuation points of the elliptic "
                     "cylinder (all families L1-L4 and their ends).")
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
