"""Checks of traced relative equilibria against paper 000 Section 4.3 (Prop. 9, 20).

The reference column of the ``relative_equilibria`` problem: :func:`check_branch` compares
one continuation branch of :func:`models.relative_families.trace_relative_equilibria` with
the corrected closed forms of Prop. 9 and with the Routh model (5.7) (through
:class:`RouthResidual`), and classifies the branch's two ends (:func:`branch_end`);
:func:`check_families` names every branch (L1+ .. L4-) and checks it;
:func:`check_degenerate` traces and checks a degenerate body (Prop. 9 cases 6 and 7).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from models import pendulum3d_reference as paper
from models.relative_equilibria import (
    alpha,
    describe_stability,
    limit_at_infinity,
    slice_zeros,
    sphere_points,
)
from models.relative_families import (
    RelativeEquilibria,
    family_name,
    trace_relative_equilibria,
)
from workbench.core import DenseEvaluator, Model
from workbench.equilibria import Branch, EndReason, PointKind, StepControl
from workbench.study import Result

__all__ = ["RouthResidual", "branch_end", "check_branch", "check_degenerate", "check_families"]


class RouthResidual:
    """Residual of the Routh model (5.7) at ``(Gamma, 0)`` for a given ``mu`` (graph shared).

    Parameters
    ----------
    model : Model
        The Routh model (``models.pendulum3d.routh``) with a parameter ``mu``.
    """

    def __init__(self, model: Model) -> None:
        self.model = model
        self.ev = DenseEvaluator(model.function("f"))
        self.slot = model.parameter_slices["mu"].start
        self.p = model.p.copy()

    def residual(self, gam: np.ndarray, mu: float) -> float:
        """Max-norm of the Routh field at the attitude ``gam``, zero velocity, momentum ``mu``."""
        self.p[self.slot] = mu
        return float(np.max(np.abs(self.ev(np.r_[gam, 0.0, 0.0, 0.0], np.zeros(0),
                                           self.p)[0])))


def branch_end(atlas: RelativeEquilibria, y: np.ndarray, y_next: np.ndarray,
               Jd: np.ndarray) -> dict[str, Any]:
    """Where a branch end lies: a static equilibrium (k = 0) or infinity (|k| = k_max).

    Parameters
    ----------
    atlas : RelativeEquilibria
        The traced families.
    y, y_next : numpy.ndarray
        The end point ``(Gamma, k)`` of a branch and its neighbour on the branch.
    Jd : numpy.ndarray
        The principal moments of inertia.

    Returns
    -------
    dict
        ``kind`` "static" with the nearest static equilibrium, its distance and the sign of
        alpha next to it; or ``kind`` "infinity" with the Richardson limit of alpha, the axis
        Gamma tends to and ``1/J_i`` of that axis.
    """
    P = atlas.problem
    if y[3] == 0.0 or abs(y[3]) < 1e-12:
        which = min(atlas.static, key=lambda k: np.linalg.norm(atlas.static[k].x[:3] - y[:3]))
        m = P.monitors(y_next)
        return {"kind": "static", "static": which,
                "distance": float(np.linalg.norm(atlas.static[which].x[:3] - y[:3])),
                "alpha_sign_next": float(np.sign(alpha(m["k"], m["k1"])))}
    lim = limit_at_infinity(P, y)
    axis = int(np.argmax(np.abs(lim["Gamma"])))
    return {"kind": "infinity", "alpha_limit": lim["alpha"], "richardson_change": lim["change"],
            "axis": axis, "axis_sign": float(np.sign(lim["Gamma"][axis])),
            "J_inverse": float(1.0 / Jd[axis]), "Gamma_limit": lim["Gamma"].tolist()}


def _compare_closed_forms(res: Result, name: str, b: Branch, atlas: RelativeEquilibria,
                          body: dict[str, Any], routh: RouthResidual) -> None:
    """Residuals and deviations from Prop. 9 / (5.22) / Prop. 20 along one branch."""
    J, rho, m, g = body["J"], body["rho"], body["m"], body["g"]
    P = atlas.problem
    k, k1, mu = b.monitors["k"], b.monitors["k1"], b.monitors["mu"]
    f_res, dG, dW, dmu, r_routh = [], [], [], [], []
    for y, ai, ki, mui in zip(b.points, alpha(k, k1), k, mu):
        f_res.append(float(np.max(np.abs(P.model.rhs(P.state(y))))))
        r_routh.append(routh.residual(y[:3], mui))
        if ai == 0.0 or not np.isfinite(ai):
            continue
        gam, om, mu_cf = paper.relative_equilibrium(J, rho, ai, m=m, g=g, omega_hint=ki * y[:3])
        dG.append(float(np.max(np.abs(gam - y[:3]))))
        dW.append(float(np.max(np.abs(om - ki * y[:3]))))
        dmu.append(abs(mu_cf - mui))
    src = "Prop. 9 with erratum (Gamma_e = -n_a/|n_a|)"
    res.compare(f"{name}: max |f(Gamma, k Gamma)| (4.3)-(4.4) over {len(b)} points", 0.0,
                max(f_res), tolerance=1e-10, source="residual of the model graph")
    res.compare(f"{name}: max |Gamma - Gamma_e(alpha)|", 0.0, max(dG), tolerance=1e-8,
                source=src)
    res.compare(f"{name}: max |omega - omega_e(alpha)|", 0.0, max(dW), tolerance=1e-8,
                source=src)
    res.compare(f"{name}: max |mu - mu(alpha)|", 0.0, max(dmu), tolerance=1e-8,
                source="(5.22) with the corrected Gamma_e")
    res.compare(f"{name}: max |Routh field (5.7)| at (Gamma, 0) with that mu", 0.0,
                max(r_routh), tolerance=1e-9, source="Prop. 20 (equilibria of (5.7))")


def _compare_ends(res: Result, name: str, ends: list[dict[str, Any]]) -> None:
    """The static ends' sign of alpha (erratum) and the limits alpha -> 1/J_i at infinity."""
    for which, e in zip(("start", "end"), ends):
        if e["kind"] == "static":
            ref = 1.0 if e["static"] == "hanging" else -1.0
            res.compare(f"{name}: sign of alpha next to the {e['static']} end", ref,
                        e["alpha_sign_next"], tolerance=0.0,
                        source="erratum: hanging as alpha -> 0+, inverted as alpha -> 0-")
        else:
            res.compare(f"{name}: alpha at the {which} (|k| -> infinity, Gamma -> "
                        f"{'+-'[e['axis_sign'] < 0]}e{e['axis'] + 1})", e["J_inverse"],
                        e["alpha_limit"], tolerance=1e-8,
                        source="Sec. 4.3: alpha -> 1/J_i (Richardson from k_max..8 k_max)")


def check_branch(res: Result, name: str, b: Branch, atlas: RelativeEquilibria,
                 body: dict[str, Any], routh: RouthResidual) -> dict[str, Any]:
    """Compare one branch with the closed forms of Prop. 9 and summarise it.

    Parameters
    ----------
    res : Result
        Receives the comparisons (named after ``name``).
    name : str
        The family's name, e.g. ``"L1+"``.
    b : Branch
        The branch, from ``atlas.branches``.
    atlas : RelativeEquilibria
        The traced families.
    body : dict
        ``J``, ``rho``, ``m``, ``g`` of the body.
    routh : RouthResidual
        The Routh model's residual.

    Returns
    -------
    dict
        Ranges of alpha, k, mu; the two ends (:func:`branch_end`); the stability at the
        start and its changes; the (4.10) events; continuation statistics.
    """
    Jd = np.diag(body["J"])
    k, k1, mu = b.monitors["k"], b.monitors["k1"], b.monitors["mu"]
    a = alpha(k, k1)
    _compare_closed_forms(res, name, b, atlas, body, routh)
    ends = [branch_end(atlas, b.points[0], b.points[1], Jd),
            branch_end(atlas, b.points[-1], b.points[-2], Jd)]
    _compare_ends(res, name, ends)
    for sp in b.specials(PointKind.EVENT, "k1"):
        Jr = np.linalg.solve(body["J"], body["rho"])
        res.compare(f"{name}: Gamma at alpha = +-inf vs (4.10) (max deviation)", 0.0,
                    float(np.max(np.abs(sp.y[:3] + Jr / np.linalg.norm(Jr)))),
                    tolerance=1e-10, source="Prop. 9 case 3 (4.10)")
        res.compare(f"{name}: |k| at alpha = +-inf vs sqrt(mg |J^-1 rho|)",
                    np.sqrt(body["m"] * body["g"] * np.linalg.norm(Jr)), abs(sp.y[3]),
                    tolerance=1e-10, relative=True, source="Prop. 9 case 3 (4.10)")
    changes = [{"alpha": float(alpha(sp.data["k"], sp.data["k1"])), "k": sp.data["k"],
                "mu": sp.data["mu"], "before": describe_stability(sp.data["before"]),
                "after": describe_stability(sp.data["after"])}
               for sp in b.specials(PointKind.CLASS_CHANGE)]
    return {
        "n_points": len(b), "alpha_range": [float(np.min(a)), float(np.max(a))],
        "k_range": [float(np.min(k)), float(np.max(k))],
        "mu_range": [float(np.min(mu)), float(np.max(mu))],
        "ends": ends, "end_reason": b.end.code,
        "stability_at_start": describe_stability(b.labels[0]) if b.labels else None,
        "stability_changes": changes,
        "case3_events": len(b.specials(PointKind.EVENT, "k1")),
        "corrector_iterations_mean": float(np.mean(b.corrector_iterations[1:])),
        "rejected_steps": b.rejected_steps, "wall_time": b.wall_time,
    }


def check_families(res: Result, atlas: RelativeEquilibria, body: dict[str, Any],
                   routh: RouthResidual) -> tuple[dict[str, Any], list[str]]:
    """Name every branch by its family and the sign of omega, and check it (:func:`check_branch`).

    Parameters
    ----------
    res : Result
        Receives the comparisons.
    atlas : RelativeEquilibria
        The traced families.
    body : dict
        ``J``, ``rho``, ``m``, ``g`` of the body.
    routh : RouthResidual
        The Routh model's residual.

    Returns
    -------
    families : dict
        :func:`check_branch`'s summary per name.
    names : list of str
        A name per branch of ``atlas.branches``, e.g. ``"L1+"``; a family traced twice (a
        bug) keeps both, the second with ``#i`` appended.
    """
    families: dict[str, Any] = {}
    names: list[str] = []
    for b in atlas.branches:
        a = alpha(b.monitors["k"], b.monitors["k1"])
        fam = family_name(a, np.diag(body["J"]))
        sign = "+" if np.nanmean(b.monitors["k"]) > 0 else "-"
        name = f"{fam}{sign}"
        if name in families:  # the same family traced twice would be a bug; keep both
            name += f"#{len(names)}"
        names.append(name)
        families[name] = check_branch(res, name, b, atlas, body, routh)
    return families, names


def _check_surface(res: Result, name: str, atlas: RelativeEquilibria, body: dict[str, Any],
                   out: dict[str, Any]) -> None:
    """Case 7(a): the two-dimensional family q = (gamma, delta, rho3/(J3 - J1))."""
    Jd, rho, mg = np.diag(body["J"]), body["rho"], body["m"] * body["g"]
    pts = [z.y for z in atlas.surfaces]
    for kk in (3.0, 6.0, 20.0):
        zs, _ = slice_zeros(atlas.problem, kk, sphere_points(64))
        pts += [z.y for z in zs if z.local_dimension > 0]
    const = mg * rho[2] / (Jd[0] - Jd[2])
    dev = max(abs(y[3] ** 2 * y[2] - const) for y in pts)
    res.compare(f"{name}: max |k^2 Gamma_3 - mg rho_3/(J1 - J3)| on the 2-D family "
                f"({len(pts)} points)", 0.0, dev, tolerance=1e-8 * const,
                source="Prop. 9 case 7(a)")
    dims = {int(z.local_dimension) + 1 for z in atlas.surfaces}
    out["surface_dimension"] = sorted(dims)
    res.compare(f"{name}: dimension of the extra family (from the rank)", 2,
                min(dims), tolerance=0, source="Prop. 9 case 7(a)")


def _check_extra_branches(res: Result, name: str, atlas: RelativeEquilibria,
                          body: dict[str, Any], out: dict[str, Any]) -> None:
    """Cases 6 and 7(b): the extra family at constant alpha = 1/J_i through a branch point."""
    Jd, rho, mg = np.diag(body["J"]), body["rho"], body["m"] * body["g"]
    i = 0 if rho[0] == 0.0 and Jd[0] != Jd[1] else 2
    extra = [b for b in atlas.branches
             if np.ptp(alpha(b.monitors["k"], b.monitors["k1"])) < 1e-6]
    a_extra = [alpha(b.monitors["k"], b.monitors["k1"]) for b in extra]
    res.compare(f"{name}: branch points found at alpha = 1/J{i + 1}", 1.0 / Jd[i],
                out["branch_points_alpha"][0] if out["branch_points_alpha"] else np.nan,
                tolerance=1e-8, source="Prop. 9 proof: (4.15) singular at alpha = 1/J_i")
    res.compare(f"{name}: max |alpha - 1/J{i + 1}| on the extra family "
                f"({len(extra)} branches)", 0.0,
                max(float(np.max(np.abs(a - 1.0 / Jd[i]))) for a in a_extra) if extra
                else np.nan, tolerance=1e-8, source="Prop. 9 cases 6, 7(b)")
    # closed form: Gamma = -p/|p|, p = (known components, gamma); k^2 = mg |p|
    known = [j for j in range(3) if j != i]
    c = np.array([rho[j] / (Jd[j] - Jd[i]) for j in known])
    dev = 0.0
    for b in extra:
        for y in b.points:
            gam = y[:3]
            scale = -(c @ gam[known]) / (gam[known] @ gam[known])  # |p|
            dev = max(dev, float(np.max(np.abs(-scale * gam[known] - c))),
                      abs(y[3] ** 2 - mg * scale) / (mg * scale))
    res.compare(f"{name}: deviation of the extra family from p_{i + 1} (4.13) / r (7b)",
                0.0, dev, tolerance=1e-8,
                source="Prop. 9 (4.13), 7(b): Gamma = -p/|p|, k^2 = mg|p|")
    out["extra_family_branches"] = len(extra)


def check_degenerate(res: Result, name: str, base: Model, body: dict[str, Any], *,
                     k_max: float, control: StepControl) -> dict[str, Any]:
    """Trace the families of a degenerate body (Prop. 9 cases 6, 7) and check its extra family.

    Parameters
    ----------
    res : Result
        Receives the comparisons (named after ``name``; "7(a)" in it selects the
        two-dimensional family of case 7(a)).
    name : str
        The case's name.
    base : Model
        The reduced model (``models.pendulum3d.reduced``); its graphs are shared.
    body : dict
        ``J``, ``rho``, ``m``, ``g`` of the degenerate body.
    k_max : float
        Where the branches end.
    control : StepControl
        The continuation's step control.

    Returns
    -------
    dict
        Branches and their ends, surface points, notes, the branch points' alpha and the
        extra family's size or dimension.
    """
    model = base.with_parameters(J=body["J"], rho=body["rho"])  # graphs shared
    atlas = trace_relative_equilibria(model, k_max=k_max, control=control,
                                      with_stability=False)
    out: dict[str, Any] = {"n_branches": len(atlas.branches),
                           "branch_ends": [b.end.code for b in atlas.branches],
                           "n_surface_points": len(atlas.surfaces), "notes": atlas.notes}
    bps = [sp for b in atlas.branches for sp in b.specials(PointKind.BRANCH_POINT)]
    out["branch_points_alpha"] = sorted({round(float(alpha(sp.data["k"], sp.data["k1"])), 9)
                                         for sp in bps})
    failures = [b for b in atlas.branches if b.end not in (EndReason.BOUND,
                                                           EndReason.STOP_EVENT)]
    res.compare(f"{name}: branches that ended in a solver failure", 0, len(failures),
                tolerance=0, source="families, not failures")
    res.compare(f"{name}: max |f| over all branches", 0.0,
                max(float(np.max(b.residuals)) for b in atlas.branches), tolerance=1e-10,
                source="residual of the model graph")
    if "7(a)" in name:
        _check_surface(res, name, atlas, body, out)
    else:
        _check_extra_branches(res, name, atlas, body, out)
    return out
