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
from models import pendulum3d_reference as paper
from models.relative_equilibria import (
    alpha,
    describe_stability,
    limit_at_infinity,
    slice_zeros,
    sphere_points,
    static_equilibria,
)
from models.relative_families import RelativeEquilibria, family_name, trace_relative_equilibria
from workbench.core import DenseEvaluator
from workbench.core.errors import ParameterError
from workbench.equilibria import Branch, EndReason, PointKind, StepControl
from workbench.study import Result

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

# ----------------------------------------------------------------------------------------
# checks of one branch


class _Routh:
    """Residual of the Routh model (5.7) at (Gamma, 0) for a given mu (graph shared)."""

    def __init__(self, model: Any) -> None:
        self.model = model
        self.ev = DenseEvaluator(model.function("f"))
        self.slot = model.parameter_slices["mu"].start
        self.p = model.p.copy()

    def residual(self, gam: np.ndarray, mu: float) -> float:
        self.p[self.slot] = mu
        return float(np.max(np.abs(self.ev(np.r_[gam, 0.0, 0.0, 0.0], np.zeros(0),
                                           self.p)[0])))


def _end_info(atlas: RelativeEquilibria, y: np.ndarray, y_next: np.ndarray,
              Jd: np.ndarray) -> dict[str, Any]:
    """Where a branch end lies: a static equilibrium (k = 0) or infinity (|k| = k_max)."""
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


def _check_branch(res: Result, name: str, b: Branch, atlas: RelativeEquilibria,
                  body: dict[str, Any], routh: _Routh) -> dict[str, Any]:
    J, rho, m, g = body["J"], body["rho"], body["m"], body["g"]
    Jd = np.diag(J)
    P = atlas.problem
    k, k1, mu = b.monitors["k"], b.monitors["k1"], b.monitors["mu"]
    a = alpha(k, k1)
    f_res, dG, dW, dmu, r_routh = [], [], [], [], []
    for y, ai, ki, mui in zip(b.points, a, k, mu):
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
    ends = [_end_info(atlas, b.points[0], b.points[1], Jd),
            _end_info(atlas, b.points[-1], b.points[-2], Jd)]
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
    for sp in b.specials(PointKind.EVENT, "k1"):
        Jr = np.linalg.solve(J, rho)
        res.compare(f"{name}: Gamma at alpha = +-inf vs (4.10) (max deviation)", 0.0,
                    float(np.max(np.abs(sp.y[:3] + Jr / np.linalg.norm(Jr)))),
                    tolerance=1e-10, source="Prop. 9 case 3 (4.10)")
        res.compare(f"{name}: |k| at alpha = +-inf vs sqrt(mg |J^-1 rho|)",
                    np.sqrt(m * g * np.linalg.norm(Jr)), abs(sp.y[3]), tolerance=1e-10,
                    relative=True, source="Prop. 9 case 3 (4.10)")
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


# ----------------------------------------------------------------------------------------
# degenerate cases


def _degenerate(res: Result, name: str, base: Any, body: dict[str, Any],
                control: StepControl) -> dict[str, Any]:
    model = base.with_parameters(J=body["J"], rho=body["rho"])  # graphs shared
    atlas = trace_relative_equilibria(model, k_max=K_MAX, control=control,
                                      with_stability=False)
    J, rho, mg = body["J"], body["rho"], 9.81
    Jd = np.diag(J)
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
        # two-dimensional family q = (gamma, delta, rho3/(J3 - J1)): k^2 Gamma_3 = const
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
        return out
    # the extra family: branches at constant alpha = 1/J_i through a branch point
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
    return out


# ----------------------------------------------------------------------------------------


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
    of papers/README.md (Gamma_e = -n_a/|n_a| for every alpha, n_a = (J - I/alpha)^-1 rho;
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
    routh = _Routh(routh_model)
    families: dict[str, Any] = {}
    names: list[str] = []
    with res.timed("checks against the closed forms"):
        for b in atlas.branches:
            a = alpha(b.monitors["k"], b.monitors["k1"])
            fam = family_name(a, np.diag(J))
            sign = "+" if np.nanmean(b.monitors["k"]) > 0 else "-"
            name = f"{fam}{sign}"
            if name in families:  # the same family traced twice would be a bug; keep both
                name += f"#{len(names)}"
            names.append(name)
            families[name] = _check_branch(res, name, b, atlas, BODY, routh)
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
            degenerate[name] = _degenerate(res, name, model, {**body, "m": 1.0, "g": 9.81},
                                           StepControl(max_step=2.0))
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
        "Erratum applied (papers/README.md): Gamma_e = -n_a/|n_a| for every alpha; the "
        "hanging end is alpha -> 0+, the inverted end alpha -> 0-. The signs of alpha next "
        "to the static ends are measured above.",
        "(5.18) as printed pairs +-sgn(alpha) with the sign error of (4.11); the set "
        "{+-mu} is right, the signed value is (5.22) with the corrected Gamma_e.",
        "Branches stop at |k| = k_max; the limits alpha -> 1/J_i beyond it are Richardson "
        "extrapolations from slices at k_max, 2, 4, 8 k_max.",
        *atlas.notes,
    ]
    res.figure("relative_equilibria", _figure(atlas, names, J), caption=(
        "Paper 000 Fig. 4.1 recomputed: the attitudes Gamma_e of the relative equilibria of "
        "the elliptic cylinder, coloured by the family parameter alpha, seen from two sides "
        "(the hanging and inverted equilibria and the equilibria (4.10) marked), and the "
        "momentum mu along each family L1-L4 with its stable and unstable stretches."))
    return res.finish()


def _colour(a: np.ndarray, Jd: np.ndarray) -> np.ndarray:
    """Monotone map of alpha in [-inf, inf] to [0, 1] with the breakpoints 0, 1/J_i."""
    inv = np.sort(1.0 / Jd)
    knots = np.array([0.0, *inv])
    vals = np.array([0.12, 0.35, 0.55, 0.82])
    out = np.interp(a, knots, vals)
    out = np.where(a < 0, 0.12 * (1 + 2 / np.pi * np.arctan(a)), out)
    out = np.where(a > inv[2], 0.82 + 0.18 * 2 / np.pi * np.arctan(a - inv[2]), out)
    return np.clip(out, 0, 1)


def _figure(atlas: RelativeEquilibria, names: list[str], J: np.ndarray):  # noqa: ANN202
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    Jd = np.diag(J)
    cmap = plt.get_cmap("jet")
    fig = plt.figure(figsize=(14, 5))
    u, v = np.mgrid[0:2 * np.pi:36j, 0:np.pi:18j]
    for panel, (elev, azim) in enumerate(((25, 35), (-25, 125))):
        ax = fig.add_subplot(1, 3, panel + 1, projection="3d")
        ax.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v),
                          color="0.88", lw=0.3)
        for b in atlas.branches:
            a = alpha(b.monitors["k"], b.monitors["k1"])
            c = _colour(a, Jd)
            P = b.points[:, :3]
            segs = np.stack([P[:-1], P[1:]], axis=1)
            ax.add_collection(Line3DCollection(segs, colors=cmap(0.5 * (c[:-1] + c[1:])),
                                               linewidths=2.2))
        for name, col in (("hanging", "blue"), ("inverted", "red")):
            ax.scatter(*atlas.static[name].x[:3], color=col, s=45, label=name,
                       edgecolor="k")
        for b in atlas.branches:
            for sp in b.specials(PointKind.EVENT, "k1"):
                ax.scatter(*sp.y[:3], color="magenta", s=35, marker="D", edgecolor="k",
                           label="(4.10)")
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.invert_zaxis()
        ax.set_xlabel("Gamma_1", fontsize=7)
        ax.set_ylabel("Gamma_2", fontsize=7)
        ax.set_zlabel("Gamma_3 (down)", fontsize=7)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_ticks([-1.0, 0.0, 1.0])
        ax.tick_params(labelsize=6)
        handles, labels = ax.get_legend_handles_labels()
        keep = dict(zip(labels, handles))
        ax.legend(keep.values(), keep.keys(), fontsize=7, loc="upper left")
        ax.set_title("Gamma_e of the families, colour = alpha: -inf blue .. 0 .. 1/J1 "
                     "cyan\n.. 1/J2 green .. 1/J3 orange .. +inf red (Fig. 4.1)", fontsize=8)
    ax2 = fig.add_subplot(1, 3, 3)
    for b, name in zip(atlas.branches, names):
        x = _colour(alpha(b.monitors["k"], b.monitors["k1"]), Jd)
        jump = np.r_[False, np.abs(np.diff(x)) > 0.3]
        x = np.where(jump, np.nan, x)
        stable = np.array([lab == (0, 0) for lab in b.labels])
        mu = b.monitors["mu"]
        ax2.plot(np.where(stable, x, np.nan), mu, "-", lw=1.6, label=name)
        ax2.plot(np.where(~stable, x, np.nan), mu, ":", lw=1.0, color="k")
    ax2.set_yscale("symlog", linthresh=1.0)
    ax2.set_xticks(_colour(np.array([-10.0, 0.0, *np.sort(1 / Jd)]), Jd))
    ax2.set_xticklabels(["-10", "0", "1/J1", "1/J2", "1/J3"])
    ax2.set_xlabel("alpha (compressed scale)")
    ax2.set_ylabel("mu (5.22)")
    ax2.set_title("momentum along the families\nsolid: spectrally stable, dotted: unstable",
                  fontsize=8)
    ax2.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
