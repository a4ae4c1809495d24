"""Relative equilibria of the 3D pendulum: the elliptic cylinder of paper 000 Section 4.3.

Besides hanging and upside down, an asymmetric rigid pendulum can spin steadily about the
vertical in whole families of tilted attitudes (relative equilibria). For the elliptic
cylinder of paper 000 Section 4.3 the workbench finds them from the model alone, by
Newton's method and continuation, and recovers the paper's four families L1-L4, where they
begin and end, the two special equilibria (4.10), their momentum and where their stability
changes; it confirms the corrected closed form of Proposition 9 (an erratum) and treats
the degenerate bodies of cases 6 and 7.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from models import pendulum3d as p3
from models.relative_checks import RouthResidual, check_degenerate, check_families
from models.relative_equilibria import static_equilibria
from models.relative_equilibria_figure import relative_equilibria_figure
from models.relative_families import trace_relative_equilibria
from workbench.core.errors import ParameterError
from workbench.equilibria import PointKind, StepControl
from workbench.linear import eigenstructure, linearize, symmetry_directions
from workbench.study import Result, spectrum_figure

TITLE = ("Relative equilibria of the 3D pendulum: hanging, inverted, (4.10) and the families "
         "L1-L4 by continuation (paper 000 Sec. 4.3, Prop. 9, 20)")

J_DIAG = np.array([0.4486, 0.3943, 0.0772])
BODY = {"J": np.diag(J_DIAG), "rho": np.array([-0.0140, 0.1044, 0.4989]), "m": 1.0,
        "g": 9.81}
K_MAX = 100.0
"""Branches end at |k| = K_MAX (families that go to infinity); limits beyond by Richardson."""

DEGENERATE = {
    "case 6, rho_1 = 0": {"J": np.diag(J_DIAG), "rho": np.array([0.0, 0.1044, 0.4989])},
    "case 6, rho_3 = 0": {"J": np.diag(J_DIAG), "rho": np.array([-0.0140, 0.1044, 0.0])},
    "case 7(a), J1 = J2, rho_1 = rho_2 = 0": {"J": np.diag([0.4486, 0.4486, 0.0772]),
                                              "rho": np.array([0.0, 0.0, 0.4989])},
    "case 7(b), J1 = J2, rho_3 = 0": {"J": np.diag([0.4486, 0.4486, 0.0772]),
                                      "rho": np.array([-0.0140, 0.1044, 0.0])},
}

def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        Larger continuation steps (max_step 2.0 instead of 0.5).

    Returns
    -------
    Result

    Notes
    -----
    The Lagrange-Poincare reduced model (4.3)-(4.4) of the elliptic cylinder (J =
    diag(0.4486, 0.3943, 0.0772), rho = (-0.0140, 0.1044, 0.4989), m = 1, g = 9.81). Its
    equilibria are found from the model graph alone (models.relative_equilibria): the
    hanging and inverted equilibria by Newton on the sphere; the families of relative
    equilibria omega = k Gamma by pseudo-arclength continuation of the zeros of f((Gamma, k
    Gamma), 0) on S^2 x R, from the static equilibria in both directions of k and from the
    ends at infinity (the zeros on the slices |k| = k_max); the two equilibria (4.10) as the
    events k1 = 0 (alpha = +-infinity) on the branches through the inverted equilibrium.
    Along every branch: the residual of (4.3)-(4.4), the family parameter alpha = k^2/k1,
    the momentum mu (the model's invariant h, (5.22)) with the residual of the Routh model
    (5.7) at (Gamma, 0) with that mu (Prop. 20), and the spectral stability from the
    linearisation of the reduced model, with the changes located.

    References (closed forms, used only as the reference column): Prop. 9 with the erratum
    of docs/science.md (Gamma_e = -n_a/|n_a| for every alpha, n_a = (J - I/alpha)^-1 rho;
    omega_e = +-sqrt(mg/|n_a|) n_a), mu = omega_e.Gamma_e (Gamma_e^T J Gamma_e) (5.22), the
    limits alpha -> 0+ (hanging), 0- (inverted), +-infinity ((4.10)), 1/J_i (principal axes)
    of Section 4.3. The degenerate cases 6 (a zero component of rho) and 7 (J1 = J2) of
    Prop. 9 are traced too: their extra families are found as families (through branch
    points at alpha = 1/J_i, or as two-dimensional zero sets), and checked against (4.13)
    and case 7. A balanced body (rho = 0) is rejected with a clear error.
    """
    res = Result("relative_equilibria", TITLE, quick=quick)
    model = p3.reduced(**BODY)
    routh_model = p3.routh(**BODY, mu=0.0)
    res.use(model, routh_model)
    control = StepControl(max_step=2.0 if quick else 0.5)
    J, rho = BODY["J"], BODY["rho"]
    with res.timed("continuation with stability"):
        atlas = trace_relative_equilibria(model, k_max=K_MAX, control=control)
    rhat = rho / np.linalg.norm(rho)
    for name, ref in (("hanging", rhat), ("inverted", -rhat)):
        eq = atlas.static[name]
        res.compare(f"{name} attitude: max |Gamma - {'+' if name == 'hanging' else '-'}"
                    f"rho/|rho||", 0.0, float(np.max(np.abs(eq.x[:3] - ref))),
                    tolerance=1e-12, source="Prop. 9 cases 1, 2")
    routh = RouthResidual(routh_model)
    with res.timed("checks against the closed forms"):
        families, names = check_families(res, atlas, BODY, routh)
    found = sorted({n[:2] for n in names})
    res.compare("families found (L1..L4), each with both signs of omega", 8,
                sum(1 for n in names if n[:2] in ("L1", "L2", "L3", "L4") and "#" not in n),
                tolerance=0, source="Prop. 9 case 4/5: four families, two signs")
    case3 = [sp for b in atlas.branches for sp in b.specials(PointKind.EVENT, "k1")]
    res.compare("equilibria (4.10) located (k1 = 0 events, both signs)", 2,
                len({round(float(sp.y[3]), 8) for sp in case3}), tolerance=0,
                source="Prop. 9 case 3")
    degenerate: dict[str, Any] = {}
    with res.timed("degenerate cases 6 and 7"):
        for name, body in DEGENERATE.items():
            degenerate[name] = check_degenerate(res, name, model, {**body, "m": 1.0, "g": 9.81},
                                                k_max=K_MAX, control=StepControl(max_step=2.0))
    balanced = model.with_parameters(rho=[0.0, 0.0, 0.0])
    try:
        static_equilibria(balanced)
        balanced_msg = "no error (unexpected)"
    except ParameterError as exc:
        balanced_msg = str(exc)
    res.compare("rho = 0 rejected with a ParameterError", 1.0,
                float(balanced_msg.startswith("parameter 'rho'")), tolerance=0,
                source="balanced body: hanging/inverted undefined")
    res.values = {
        "body": {k: np.asarray(v).tolist() for k, v in BODY.items()},
        "k_max": K_MAX,
        "one_over_J": (1.0 / np.diag(J)).tolist(),
        "static": {k: v.summary() for k, v in atlas.static.items()},
        "families": families,
        "families_found": found,
        "case3": [{"Gamma": sp.y[:3].tolist(), "k": float(sp.y[3]), "mu": sp.data["mu"]}
                  for sp in case3],
        "continuation": {"step_control": control.__dict__, "branches": len(atlas.branches),
                         "points": int(sum(len(b) for b in atlas.branches)),
                         "evaluations": int(sum(b.evaluations for b in atlas.branches)),
                         "slice_failures": atlas.slice_failures,
                         "wall_time": atlas.wall_time},
        "degenerate": degenerate,
        "balanced_error": balanced_msg,
    }
    res.notes += [
        "Erratum applied (docs/science.md): Gamma_e = -n_a/|n_a| for every alpha; the "
        "hanging end is alpha -> 0+, the inverted end alpha -> 0-. The signs of alpha next "
        "to the static ends are measured above.",
        "(5.18) as printed pairs +-sgn(alpha) with the sign error of (4.11); the set "
        "{+-mu} is right, the signed value is (5.22) with the corrected Gamma_e.",
        "Branches stop at |k| = k_max; the limits alpha -> 1/J_i beyond it are Richardson "
        "extrapolations from slices at k_max, 2, 4, 8 k_max.",
        *atlas.notes,
    ]
    res.figure("relative_equilibria", relative_equilibria_figure(atlas, names, J), caption=(
        "Paper 000 Fig. 4.1 recomputed: the attitudes Gamma_e of the relative equilibria of "
        "the elliptic cylinder, coloured by the family parameter alpha, seen from two sides "
        "(the hanging and inverted equilibria and the equilibria (4.10) marked), and the "
        "momentum mu along each family L1-L4 with its stable and unstable stretches."))
    spectra, syms = {}, {}
    points = [(f"{name} (at rest)", eq.x) for name, eq in atlas.static.items()]
    points += [(f"(4.10), k = {float(sp.y[3]):+.3f}", np.r_[sp.y[:3], sp.y[3] * sp.y[:3]])
               for sp in sorted(case3, key=lambda sp: float(sp.y[3]))[:2]]
    for title, x in points:
        lin = linearize(model, x)
        spectra[title] = (eigenstructure(lin).eigenvalues, None)
        syms[title] = symmetry_directions(lin)
    spin = max((float(np.max(np.abs(lam.real))) for t, (lam, _) in spectra.items()
                if t.startswith("(4.10)")), default=float("nan"))
    res.figure("spectra", spectrum_figure(spectra, ncols=2, size=(3.4, 3.0), tol=1e-8,
                                          symmetry=syms), caption=(
        "Eigenvalues of the reduced model (S^2 x R^3, dimension 5) linearised at the hanging "
        "and inverted equilibria and at the two spinning equilibria (4.10) (omega = k Gamma, "
        "k1 = 0). One centre mode at each comes from the conserved momentum h (and energy); "
        "the hanging equilibrium's other four are oscillations, the inverted one is a "
        "saddle with two real unstable modes, and both spinning equilibria are unstable "
        f"with a complex quadruple (Re lambda = +-{spin:.2f})."))
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
