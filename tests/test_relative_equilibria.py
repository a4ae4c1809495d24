"""Relative equilibria of the 3D pendulum from the graph, checked against paper 000 Prop. 9.

The closed forms below (Prop. 9 and (5.22) with the erratum of docs/science.md:
Gamma_e = -n_a/|n_a| for every alpha) exist only here, as independent checks.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from models import relative_families
from models.chain_cart import chain_cart
from models.relative_equilibria import (
    alpha,
    limit_at_infinity,
    rotation_problem,
    slice_zeros,
    sphere_points,
    stability_label,
    static_equilibria,
)
from models.relative_families import at_alpha, trace_relative_equilibria
from workbench.core._model import Model
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import so3_exp
from workbench.equilibria._branch import EndReason, PointKind, StepControl
from workbench.equilibria._continuation import correct_point

J_CYL = np.diag([0.4486, 0.3943, 0.0772])
RHO_CYL = np.array([-0.0140, 0.1044, 0.4989])
MG = 9.81
COARSE = StepControl(max_step=2.0)


def closed_form(J, rho, a):
    """Prop. 9 case 4/5 with the erratum: Gamma_e(alpha) and |omega_e| = sqrt(mg |n_a|)."""
    n = np.linalg.solve(J - np.eye(3) / a, rho)
    return -n / np.linalg.norm(n), np.sqrt(MG * np.linalg.norm(n))


def random_body(rng):
    """A body with a non-diagonal inertia (principal axes rotated) and a generic rho."""
    Q = so3_exp(rng.standard_normal(3))
    Jd = np.sort(rng.uniform(0.1, 0.6, 3))[::-1]
    return Q @ np.diag(Jd) @ Q.T, rng.uniform(-0.3, 0.3, 3) + np.array([0, 0, 0.2]), Jd, Q


@pytest.fixture(scope="module")
def cylinder():
    return p3.reduced(J=J_CYL, rho=RHO_CYL)


@pytest.fixture(scope="module")
def cylinder_atlas(cylinder):
    return trace_relative_equilibria(cylinder, control=COARSE)


def test_problem_graph_is_the_model_field_and_invariants(cylinder, rng):
    prob = rotation_problem(cylinder)
    for _ in range(4):
        g = rng.standard_normal(3)
        y = np.append(g / np.linalg.norm(g), rng.normal(scale=3.0))
        x = prob.state(y)
        assert_close(prob.residual(y), cylinder.rhs(x), atol=1e-14, what="F = f(Gamma, kG)")
        m = prob.monitors(y)
        gam, k = y[:3], y[3]
        assert_close(m["mu"], cylinder.invariants(x)["h"], atol=1e-14, what="mu = h")
        # k1 of (4.14): Gamma . (k^2 J Gamma + m g rho), written out here independently
        assert_close(m["k1"], gam @ (k * k * J_CYL @ gam + MG * RHO_CYL), atol=1e-12,
                     what="k1")


def test_problem_rejects_other_models():
    with pytest.raises(ModelError, match="S2 x R"):
        rotation_problem(chain_cart(1))
    with pytest.raises(ModelError, match="S2 x R"):
        rotation_problem(p3.full(J=J_CYL, rho=RHO_CYL))
    with pytest.raises(ModelError, match="no invariant"):
        rotation_problem(p3.reduced(J=J_CYL, rho=RHO_CYL), momentum="Lz")


def test_static_equilibria_and_balanced_body(rng):
    for _ in range(3):
        J, rho, _, _ = random_body(rng)
        st = static_equilibria(p3.reduced(J=J, rho=rho))
        rhat = rho / np.linalg.norm(rho)
        assert_close(st["hanging"].parts["Gamma"], rhat, atol=1e-12, what="hanging")
        assert_close(st["inverted"].parts["Gamma"], -rhat, atol=1e-12, what="inverted")
    with pytest.raises(ParameterError, match="rho") as err:
        static_equilibria(p3.reduced(J=J_CYL, rho=[0.0, 0.0, 0.0]))
    assert "balanced" in str(err.value) and "dimension 2" in str(err.value)


def test_alpha_conventions():
    assert alpha(0.0, 2.0) == 0.0
    assert alpha(2.0, 0.0) == np.inf
    assert_close(alpha([1.0, 2.0], [2.0, -8.0]), [0.5, -0.5], atol=0.0, what="k^2/k1")


def test_stability_at_hanging_and_inverted(cylinder):
    st = static_equilibria(cylinder)
    assert stability_label(cylinder, st["hanging"].x) == (0, 0)  # (4.21)-(4.23): centre
    assert stability_label(cylinder, st["inverted"].x) == (2, 0)  # (4.25)-(4.27): saddle


def test_families_of_a_rotated_body_match_the_closed_form(rng):
    """A non-diagonal J: the families, their ends and (4.10), all from the graph."""
    J, rho, Jd, Q = random_body(rng)
    model = p3.reduced(J=J, rho=rho)
    atlas = trace_relative_equilibria(model, control=COARSE, with_stability=False)
    assert len(atlas.branches) == 8  # four families, both signs of omega
    assert all(b.end in (EndReason.BOUND, EndReason.STOP_EVENT) for b in atlas.branches)
    case3 = []
    for b in atlas.branches:
        k, k1 = b.monitors["k"], b.monitors["k1"]
        a = alpha(k, k1)
        assert np.max(b.residuals) <= 1e-10
        for y, ai in zip(b.points, a):
            if ai == 0 or not np.isfinite(ai):
                continue
            gam, w = closed_form(J, rho, ai)
            assert_close(y[:3], gam, atol=1e-8, what="Gamma_e(alpha)")
            # |n| = |(J - I/alpha)^-1 rho| amplifies the point's own error by the condition of
            # J - I/alpha, which grows without bound towards the ends at alpha = 1/J_i: the
            # relative error of |k| is held to 1e-12 cond (worst measured: 4.5e-13 cond, with
            # numpy 2.4.6 and 2.5.5; cond up to 1.5e5 on these branches)
            cond = np.linalg.cond(J - np.eye(3) / ai)
            assert_close(abs(y[3]), w, atol=0.0, rtol=1e-12 * cond, what="|k| = sqrt(mg|n|)")
        if b.points[0][3] == 0.0:  # started at a static equilibrium
            hanging = b.points[0][:3] @ rho > 0
            assert np.sign(a[1]) == (1.0 if hanging else -1.0)  # erratum: 0+ hanging
        case3 += b.specials(PointKind.EVENT, "k1")
    Jr = np.linalg.solve(J, rho)
    assert len(case3) == 2
    for sp in case3:  # (4.10)
        assert_close(sp.y[:3], -Jr / np.linalg.norm(Jr), atol=1e-10, what="(4.10) Gamma")
        assert_close(abs(sp.y[3]), np.sqrt(MG * np.linalg.norm(Jr)), atol=1e-9, what="k")
    # the ends at infinity: alpha -> 1/J_i, Gamma -> +-principal axis
    lim = limit_at_infinity(atlas.problem, atlas.ends[0].y)
    i = int(np.argmax(np.abs(Q.T @ lim["Gamma"])))
    assert_close(lim["alpha"], 1.0 / Jd[i], atol=1e-8, what="alpha -> 1/J_i")
    assert_close(np.abs(Q[:, i] @ lim["Gamma"]), 1.0, atol=1e-9, what="principal axis")


def test_saddle_centre_changes_sit_at_folds_of_mu(cylinder_atlas):
    """Along a family, (0,0) <-> (1,0) happens where mu has an extremum (energy-momentum)."""
    P = cylinder_atlas.problem
    found = 0
    for b in cylinder_atlas.branches:
        dmu = np.abs(np.diff(b.monitors["mu"]) / np.diff(b.s))
        for sp in b.specials(PointKind.CLASS_CHANGE):
            if {sp.data["before"], sp.data["after"]} != {(0, 0), (1, 0)}:
                continue
            found += 1
            ys = [correct_point(P, sp.y, sp.tangent, h, control=StepControl()).x
                  for h in (-1e-4, 1e-4)]
            slope = (P.monitor("mu", ys[1]) - P.monitor("mu", ys[0])) / 2e-4
            assert abs(slope) <= 1e-5 * np.median(dmu)
    assert found == 4  # on L3 and L4, both signs


def test_stability_along_l2_and_known_changes(cylinder_atlas):
    """L2 (from hanging) stays spectrally stable; L1 turns stable beyond alpha = 13.58."""
    names = cylinder_atlas.origins
    for b, o in zip(cylinder_atlas.branches, names):
        if o.startswith("hanging"):
            assert set(b.labels) == {(0, 0)}
        if o.startswith("inverted"):
            ch = b.specials(PointKind.CLASS_CHANGE)
            assert [(c.data["before"], c.data["after"]) for c in ch] == \
                [((2, 0), (2, 2)), ((2, 2), (0, 0))]
            assert all(c.data["located"] for c in ch)


def test_at_alpha_generic_and_at_one_over_j(cylinder_atlas):
    out = at_alpha(cylinder_atlas, 1.0)
    assert len(out["points"]) == 2 and not out["whole_branches"]
    gam, w = closed_form(J_CYL, RHO_CYL, 1.0)
    for p in out["points"]:
        assert_close(p.y[:3], gam, atol=1e-9, what="Gamma at alpha = 1")
        assert_close(abs(p.y[3]), w, atol=1e-9, what="|k| at alpha = 1")
        assert p.residual <= 1e-10
    assert len(at_alpha(cylinder_atlas, np.inf)["points"]) == 2  # (4.10)
    # exactly 1/J_1: the closed form is singular; no finite relative equilibrium has it
    out = at_alpha(cylinder_atlas, 1.0 / J_CYL[0, 0])
    assert not out["points"] and not out["whole_branches"]
    assert "limit_at_infinity" in out["message"]
    with pytest.raises(ParameterError, match="static limit"):
        at_alpha(cylinder_atlas, 0.0)


def test_zero_rho_component_gives_a_family_at_one_over_j(cylinder):
    """Prop. 9 case 6: rho_1 = 0 adds the family p_1 at alpha = 1/J1 through a branch point."""
    model = cylinder.with_parameters(rho=[0.0, RHO_CYL[1], RHO_CYL[2]])
    atlas = trace_relative_equilibria(model, control=COARSE, with_stability=False)
    bps = [sp for b in atlas.branches for sp in b.specials(PointKind.BRANCH_POINT)]
    assert bps
    for sp in bps:
        assert_close(float(alpha(sp.data["k"], sp.data["k1"])), 1.0 / J_CYL[0, 0],
                     atol=1e-8, what="branch point at alpha = 1/J1")
    out = at_alpha(atlas, 1.0 / J_CYL[0, 0])
    assert len(out["whole_branches"]) == 4  # two halves, two signs
    a_, b_ = RHO_CYL[1] / (J_CYL[1, 1] - J_CYL[0, 0]), RHO_CYL[2] / (J_CYL[2, 2] - J_CYL[0, 0])
    for i in out["whole_branches"]:
        for y in atlas.branches[i].points:
            norm_p = -a_ / y[1]  # Gamma = -p/|p| with p = (gamma, a, b)
            assert_close(-norm_p * y[2], b_, atol=1e-9, what="p_1 third component")
            assert_close(y[3] ** 2, MG * norm_p, atol=1e-9, rtol=1e-9, what="k^2 = mg|p|")


def test_axisymmetric_body_gives_a_two_dimensional_family(cylinder):
    """Prop. 9 case 7(a): J1 = J2, rho on the axis: a 2-D family, reported as such."""
    J = np.diag([0.4486, 0.4486, 0.0772])
    model = cylinder.with_parameters(J=J, rho=[0.0, 0.0, 0.4989])
    prob = rotation_problem(model)
    zs, failures = slice_zeros(prob, 10.0, sphere_points(40))
    surface = [z for z in zs if z.local_dimension > 0]
    assert surface and failures == 0
    for z in surface:
        assert z.local_dimension == 1  # a curve in the slice: a surface in (Gamma, k)
        assert_close(z.y[3] ** 2 * z.y[2], MG * 0.4989 / (0.4486 - 0.0772), atol=1e-9,
                     what="k^2 Gamma_3 = mg rho3/(J1 - J3)")


# ----------------------------------------------------------------------------------------
# moved from test_review_engine.py


def test_trace_notes_a_branch_point_whose_other_branch_was_not_picked_up(monkeypatch):
    """A corrector that cannot converge (tol below rounding) leaves a note per branch point."""
    model = p3.reduced(J=np.diag([0.4486, 0.3943, 0.0772]), rho=[0.0, 0.1044, 0.4989])
    real = relative_families.switch_branch

    def failing(problem, sp, *, step, control, raise_on_failure):
        hopeless = replace(control, tol=1e-300, max_corrector_iterations=1)
        return real(problem, sp, step=step, control=hopeless,
                    raise_on_failure=raise_on_failure)

    monkeypatch.setattr(relative_families, "switch_branch", failing)
    atlas = trace_relative_equilibria(model, control=StepControl(max_step=2.0),
                                      with_stability=False)
    bps = [sp for b in atlas.branches for sp in b.specials(PointKind.BRANCH_POINT)]
    notes = [n for n in atlas.notes if "was not picked up" in n]
    assert bps and len(notes) == len(bps)
    assert all("2 of 2 sides" in n and "max_iterations" in n for n in notes)
    assert not any(o.startswith("branch point") for o in atlas.origins)
    assert atlas.summary()["notes"] == atlas.notes


class _RenamedOffset:
    """A builder context that reads the offset 'rho' from a parameter called 'c'."""

    def __init__(self, ctx):
        self._ctx, self.x, self.u, self.p, self.model = ctx, ctx.x, ctx.u, ctx.p, ctx.model

    def __getitem__(self, name):
        return self._ctx["c" if name == "rho" else name]


def _balanced_body_with_offset_called_c():
    red = p3.reduced(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.0])
    params = [replace(p, name="c") if p.name == "rho" else p for p in red.parameters]
    values = {("c" if k == "rho" else k): v for k, v in red.values.items()}
    return Model(
        name="renamed", manifold=red.manifold, n_inputs=red.n_inputs, parameters=params,
        values=values, vector_field=lambda ctx: red._vector_field(_RenamedOffset(ctx)),
        invariants={k: (lambda ctx, b=b: b(_RenamedOffset(ctx)))
                    for k, b in red._invariants.items()})


def test_static_equilibria_quotes_the_offset_parameter_the_model_has():
    model = _balanced_body_with_offset_called_c()
    with pytest.raises(ParameterError, match="the body is balanced") as info:
        static_equilibria(model)
    assert "'rho'" not in str(info.value)  # the model has no parameter 'rho'
    with pytest.raises(ParameterError, match=r"parameter 'c' = \[0.0, 0.0, 0.0\] makes the "
                                             r"body balanced"):
        static_equilibria(model, offset="c")
    with pytest.raises(ModelError, match=r"offset must name .* \['J', 'c', 'm', 'g'\].*'rho'"):
        static_equilibria(model, offset="rho")
    with pytest.raises(ParameterError, match=r"parameter 'rho' = \[0.0, 0.0, 0.0\] makes"):
        static_equilibria(p3.reduced(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.0]))
