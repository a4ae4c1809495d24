"""Manifold factors: the level-set structure, retraction/chart/basis consistency, SO(3)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from workbench.core.errors import ManifoldError
from workbench.core.manifolds import (
    S1,
    S2,
    SO3,
    TS2,
    ProductManifold,
    Rn,
    hat,
    so3_exp,
    so3_log,
    sphere_basis,
    vee,
)

FACTORS = [Rn(3), S1(), S2(), TS2(), SO3()]


def test_hat_vee(rng):
    for _ in range(20):
        a, b = rng.standard_normal(3), rng.standard_normal(3)
        assert_close(hat(a) @ b, np.cross(a, b), atol=1e-15, what="hat(a) b = a x b")
        assert_close(vee(hat(a)), a, atol=0, what="vee(hat(a))")
    s = ca.SX.sym("a", 3)
    assert_close(ca.evalf(ca.substitute(vee(hat(s)), s, ca.DM([1, 2, 3]))).full().ravel(),
                 [1, 2, 3], atol=0, what="symbolic vee(hat)")


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1e-4, 0.3, 1.0, 2.0, 3.0,
                                   np.pi - 1e-3, np.pi - 1e-6, np.pi - 1e-8, np.pi])
def test_so3_exp_log_round_trip(rng, angle):
    for _ in range(10):
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        v = angle * axis
        R = so3_exp(v)
        assert_close(R.T @ R, np.eye(3), atol=2e-15, what="exp lands on SO(3)")
        assert abs(np.linalg.det(R) - 1) < 1e-14
        w = so3_log(R)
        if angle < np.pi - 1e-9:
            assert_close(w, v, atol=1e-12, what=f"log(exp(v)) at angle {angle}")
        else:  # at pi, v and -v are the same rotation
            assert min(np.linalg.norm(w - v), np.linalg.norm(w + v)) < 1e-7
        assert_close(so3_exp(w), R, atol=1e-14, what="exp(log(R))")


def test_so3_exp_symbolic_matches_numeric_and_is_differentiable_at_zero(rng):
    v = ca.SX.sym("v", 3)
    E = ca.Function("E", [v], [ca.vec(so3_exp(v))])
    dE = ca.Function("dE", [v], [ca.jacobian(ca.vec(so3_exp(v)), v)])
    for vv in [np.zeros(3), 1e-5 * rng.standard_normal(3), rng.standard_normal(3)]:
        assert_close(np.asarray(E(vv)).ravel(), so3_exp(vv).ravel(order="F"), atol=1e-15,
                     what="symbolic exp")
    J0 = np.asarray(dE(np.zeros(3)))
    assert np.all(np.isfinite(J0))
    # d/dv exp(hat(v)) at 0 is hat(e_k)
    for k in range(3):
        assert_close(J0[:, k], hat(np.eye(3)[k]).ravel(order="F"), atol=1e-15, what="dexp(0)")


def test_sphere_basis(rng):
    assert_close(sphere_basis([0, 0, 1]), np.eye(3)[:, :2], atol=0, what="basis at e3")
    assert_close(sphere_basis([0, 0, -1]), np.eye(3)[:, :2], atol=0, what="basis at -e3")
    for _ in range(20):
        q = S2().random_point(rng)
        B = sphere_basis(q)
        assert_close(B.T @ B, np.eye(2), atol=1e-15, what="orthonormal")
        assert_close(B.T @ q, np.zeros(2), atol=1e-15, what="normal to q")


@pytest.mark.parametrize("factor", FACTORS, ids=lambda f: f.kind)
def test_retract_basis_chart_consistency(factor, rng):
    for _ in range(5):
        x = factor.random_point(rng, scale=0.7)
        assert factor.residual_norm(x) < 1e-14
        N = factor.tangent_basis(x)
        assert N.shape == (factor.ambient_dim, factor.dim)
        assert np.linalg.matrix_rank(N) == factor.dim
        Dh = factor.constraint_jacobian(x)
        assert_close(Dh @ N, np.zeros((Dh.shape[0], factor.dim)), atol=1e-13,
                     what="basis is tangent")
        v = rng.standard_normal(factor.dim)
        y = factor.retract(x, v)
        assert factor.residual_norm(y) < 1e-13, "retraction lands on the factor"
        # derivative of the retraction at 0 is the basis (central differences, error ~h^2)
        h = 1e-6
        D = np.column_stack([(factor.retract(x, h * e) - factor.retract(x, -h * e)) / (2 * h)
                             for e in np.eye(factor.dim)])
        assert_close(D, N, atol=1e-8, what="d retract = basis")
        # the chart vanishes at its centre and its derivative inverts the basis there
        xs = ca.SX.sym("x", factor.ambient_dim)
        chart = factor.chart(x, xs)
        dchart = ca.Function("dc", [xs], [ca.jacobian(chart, xs)])
        c0 = ca.Function("c", [xs], [chart])
        assert_close(np.asarray(c0(x)).ravel(), np.zeros(factor.dim), atol=1e-15,
                     what="chart(x, x) = 0")
        assert_close(np.asarray(dchart(x)) @ N, np.eye(factor.dim), atol=1e-12,
                     what="d chart . basis = I")
        # numeric and symbolic charts agree, and chart(retract(v)) = v + O(|v|^2)
        small = 1e-4 * v
        assert_close(np.ravel(factor.chart(x, factor.retract(x, small))), small,
                     atol=1e-7 * np.linalg.norm(v), what="chart inverts retract to 1st order")


@pytest.mark.parametrize("factor", [S1(), S2(), TS2(), SO3()], ids=lambda f: f.kind)
def test_project_lands_and_is_idempotent(factor, rng):
    for _ in range(10):
        x = factor.random_point(rng) + 0.05 * rng.standard_normal(factor.ambient_dim)
        p = factor.project(x)
        assert factor.residual_norm(p) < 1e-14
        assert_close(factor.project(p), p, atol=1e-15, what="projection idempotent")


def test_so3_project_is_nearest_rotation(rng):
    R = SO3.matrix(SO3().random_point(rng))
    noisy = R + 1e-3 * rng.standard_normal((3, 3))
    P = SO3.matrix(SO3().project(noisy))
    # no other rotation near P is closer to the noisy matrix (first-order optimality)
    for k in range(3):
        for s in (1e-4, -1e-4):
            Q = P @ so3_exp(s * np.eye(3)[k])
            assert np.linalg.norm(noisy - P) <= np.linalg.norm(noisy - Q)


def test_check_rejects_off_manifold_points_without_changing_them():
    q = np.array([0.0, 0.6, 0.8000001])
    with pytest.raises(ManifoldError, match=r"not on S2.*\|q\| = 1\.00000.*project"):
        S2().check(q, name="q0")
    assert q[2] == 0.8000001  # untouched
    with pytest.raises(ManifoldError, match="q.w"):
        TS2().check([0, 0, 1, 0, 0, 0.1])
    with pytest.raises(ManifoldError, match="must have 9 entries"):
        SO3().check(np.eye(2))
    with pytest.raises(ManifoldError, match="finite"):
        S2().check([np.nan, 0, 1])
    with pytest.raises(ManifoldError, match="reflection"):
        SO3().check(np.diag([1.0, 1.0, -1.0]))


def test_paper001_rounded_initial_attitude_is_rejected_and_projection_named():
    # paper 001 Section 7 prints R(0) rounded to four digits: not orthonormal (~1.7e-6)
    R0 = np.array([[0, -0.9999, -0.0141], [-1, 0, 0], [0, 0.0141, -0.9999]])
    with pytest.raises(ManifoldError) as err:
        SO3().check(R0, name="R0")
    msg = str(err.value)
    assert "R^T R - I" in msg and "SO3().project" in msg
    P = SO3.matrix(SO3().project(R0))
    assert np.linalg.norm(P - R0) < 1e-4
    SO3().check(P)


def test_product_manifold(rng):
    man = ProductManifold([("R", SO3()), ("omega", Rn(3)), ("q", TS2())])
    assert (man.ambient_dim, man.dim) == (18, 10)
    x = man.random_point(rng)
    man.check(x)
    N = man.tangent_basis(x)
    assert N.shape == (18, 10)
    v = rng.standard_normal(10)
    assert max(man.residual_norms(man.retract(x, v)).values()) < 1e-13
    assert_close(man.chart(x, x), np.zeros(10), atol=1e-15, what="product chart at centre")
    bad = x.copy()
    bad[12] += 0.1
    with pytest.raises(ManifoldError, match=r"x\['q'\]"):
        man.check(bad)
    with pytest.raises(ManifoldError, match="unique"):
        ProductManifold([("a", S2()), ("a", S2())])
    with pytest.raises(ManifoldError, match="n >= 1"):
        Rn(0)
