"""Manifold factors: the level-set structure, retraction/chart/basis consistency, SO(3)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close, ulps

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


def test_hat_vee(rng):
    for _ in range(20):
        a, b = rng.standard_normal(3), rng.standard_normal(3)
        # each entry is a difference of two products, rounded (or fused) once each: 4 ulps of
        # the products (worst of 20000 seeded draws: 2, numpy 2.4 and 2.5)
        assert_close(hat(a) @ b, np.cross(a, b), atol=ulps(4, np.outer(a, b)),
                     what="hat(a) b = a x b")
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
        # Rodrigues' three terms, then R^T R's sums of three: 32 ulps of |R| (worst of 20000
        # seeded draws: 14)
        assert_close(R.T @ R, np.eye(3), atol=ulps(32, R), what="exp lands on SO(3)")
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
        # the same formula evaluated by casadi and by numpy in another order: 32 ulps of |R|
        # (worst of 5000 seeded draws: 16)
        R = so3_exp(vv)
        assert_close(np.asarray(E(vv)).ravel(), R.ravel(order="F"), atol=ulps(32, R),
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
        # 8 ulps of the unit vectors (worst of 20000 seeded draws: 4 and 2.9)
        assert_close(B.T @ B, np.eye(2), atol=ulps(8, B), what="orthonormal")
        assert_close(B.T @ q, np.zeros(2), atol=ulps(8, q), what="normal to q")


# ----------------------------------------------------------------------------------------
# the contract every manifold factor passes (geomstats style), and the product of factors


def _product() -> ProductManifold:
    return ProductManifold([("R", SO3()), ("omega", Rn(3)), ("q", TS2())])


SPACES = [Rn(3), S1(), S2(), TS2(), SO3(), _product()]


def _name(space) -> str:
    return getattr(space, "kind", "product")


def _residual(space, x) -> np.ndarray:
    return np.ravel(np.asarray(space.residual(np.asarray(x, dtype=float)), dtype=float))


def _jacobian(space, x) -> np.ndarray:
    """dh/dx at ``x`` by automatic differentiation of the factor's residual."""
    xs = ca.SX.sym("x", space.ambient_dim)
    h = space.residual(xs)
    return np.asarray(ca.Function("Dh", [xs], [ca.jacobian(h, xs)])(x)).reshape(
        h.numel(), space.ambient_dim)


def _gram_metric(space) -> np.ndarray | None:
    """The Gram matrix an orthonormal basis has, in the ambient inner product.

    Identity for R^n, S1, S2; ``2 I`` for SO3 (``R hat(e_i)`` is orthonormal in the
    bi-invariant metric ``<A, B> = tr(A^T B) / 2``); ``None`` where the basis is the
    derivative of the retraction but not orthonormal (TS2: moving ``q`` also turns ``w``).
    """
    kind = getattr(space, "kind", "")
    if kind == "SO3":
        return 2.0 * np.eye(3)
    if kind in ("TS2", "") or space.dim == 0:
        return None
    return np.eye(space.dim)


@pytest.fixture(params=SPACES, ids=_name)
def space(request):
    return request.param


class TestFactorContract:
    """Invariants every factor (and a product of factors) satisfies, on seeded points."""

    def test_random_points_belong_and_pass_check(self, space, rng):
        for _ in range(5):
            x = space.random_point(rng, scale=0.7)
            assert x.shape == (space.ambient_dim,)
            assert np.max(np.abs(_residual(space, x)), initial=0.0) < 1e-14
            assert_close(space.check(x), x, atol=0.0, what="check returns the point unchanged")

    def test_residual_is_zero_on_points_and_nonzero_off(self, space, rng):
        x = space.random_point(rng)
        Dh = _jacobian(space, x)
        if Dh.shape[0] == 0:  # R^n: no constraint, no point is off
            assert space.dim == space.ambient_dim
            return
        # a step along the normal space (rows of dh/dx) leaves the level set at first order
        n = Dh.T @ rng.standard_normal(Dh.shape[0])
        for eps in (1e-3, 1e-6):
            off = x + eps * n / np.linalg.norm(n)
            r = np.linalg.norm(_residual(space, off))
            assert_close(r, eps * np.linalg.norm(Dh @ n) / np.linalg.norm(n), atol=0.0,
                         rtol=1e-2, what=f"|h(x + eps n)| = eps |Dh n| at eps = {eps}")

    def test_tangent_basis_spans_the_tangent_space(self, space, rng):
        x = space.random_point(rng, scale=0.7)
        N = space.tangent_basis(x)
        Dh = _jacobian(space, x)
        assert N.shape == (space.ambient_dim, space.dim)
        assert np.linalg.matrix_rank(N) == space.dim
        assert space.dim == space.ambient_dim - (np.linalg.matrix_rank(Dh) if Dh.size else 0)
        assert_close(Dh @ N, np.zeros((Dh.shape[0], space.dim)), atol=1e-13,
                     what="every column is tangent (dh/dx N = 0)")

    def test_tangent_basis_is_orthonormal_in_the_factor_metric(self, space, rng):
        x = space.random_point(rng, scale=0.7)
        N = space.tangent_basis(x)
        gram = _gram_metric(space)
        if gram is not None:
            assert_close(N.T @ N, gram, atol=1e-14, what="orthonormal basis")
        elif getattr(space, "kind", "") == "TS2":
            # q-directions: the base S2 block is orthonormal; w-directions: orthonormal, w only
            assert_close(N[:3, :2].T @ N[:3, :2], np.eye(2), atol=1e-14, what="T_q S2 part")
            assert_close(N[:, 2:].T @ N[:, 2:], np.eye(2), atol=1e-14, what="fibre part")
            assert_close(N[:3, 2:], np.zeros((3, 2)), atol=0.0, what="fibre moves w only")
        else:  # the product: block diagonal, each factor's block as above
            for name, f in space.factors:
                sl = space.slices[name]
                blk = N[sl][:, np.any(N[sl] != 0, axis=0)]
                assert blk.shape[1] == f.dim
                assert_close(blk, f.tangent_basis(x[sl]), atol=0.0, what=f"block {name}")

    def test_project_is_idempotent_and_lands(self, space, rng):
        for _ in range(5):
            y = space.random_point(rng) + 0.05 * rng.standard_normal(space.ambient_dim)
            p = space.project(y)
            assert np.max(np.abs(_residual(space, p)), initial=0.0) < 1e-14
            # rounding only: SO3's projection is the polar factor U V^T of an SVD, 32 ulps of
            # the point (worst of 20000 seeded draws: 15, numpy 2.4 and 2.5)
            assert_close(space.project(p), p, atol=ulps(32, p), what="project(project(y))")
        x = space.random_point(rng)
        assert_close(space.project(x), x, atol=ulps(32, x), what="points are fixed by project")

    def test_retraction_lands_on_the_manifold_with_the_basis_as_derivative(self, space, rng):
        x = space.random_point(rng, scale=0.7)
        for size in (1e-8, 1.0, 10.0):
            y = space.retract(x, size * rng.standard_normal(space.dim))
            assert np.max(np.abs(_residual(space, y)), initial=0.0) < 1e-13 * max(1.0, size)
        assert_close(space.retract(x, np.zeros(space.dim)), x, atol=0.0, what="retract(x, 0)")
        h = 1e-6  # central differences: error ~h^2
        D = np.column_stack([(space.retract(x, h * e) - space.retract(x, -h * e)) / (2 * h)
                             for e in np.eye(space.dim)])
        assert_close(D, space.tangent_basis(x), atol=1e-8, what="d retract(x, .)(0) = basis")

    def test_chart_of_the_retraction_inverts_it_to_first_order(self, space, rng):
        x = space.random_point(rng, scale=0.7)
        v = rng.standard_normal(space.dim)
        v /= np.linalg.norm(v)
        assert_close(np.ravel(space.chart(x, x)), np.zeros(space.dim), atol=1e-15,
                     what="chart(x, x) = 0")
        err = [np.linalg.norm(np.ravel(space.chart(x, space.retract(x, t * v))) - t * v)
               for t in (1e-3, 5e-4)]
        # chart(retract(t v)) = t v + O(t^2): halving t divides the error by >= ~4
        assert err[0] <= 1e-5 and (err[1] <= err[0] / 3.5 or err[0] < 1e-15), err
        xs = ca.SX.sym("x", space.ambient_dim)
        dchart = ca.Function("dc", [xs], [ca.jacobian(space.chart(x, xs), xs)])
        assert_close(np.asarray(dchart(x)) @ space.tangent_basis(x), np.eye(space.dim),
                     atol=1e-12, what="d chart . basis = I (symbolic chart)")


@pytest.mark.parametrize("angle", [1e-12, 1e-8, 1e-5, np.pi - 1e-4, np.pi - 1e-7])
def test_so3_retraction_is_exp_and_chart_inverts_it_near_zero_and_pi(rng, angle):
    """On SO3, retract(x, v) = x exp(hat v) and log inverts exp up to |v| < pi."""
    so3 = SO3()
    x = so3.random_point(rng)
    axis = rng.standard_normal(3)
    v = angle * axis / np.linalg.norm(axis)
    y = so3.retract(x, v)
    assert_close(SO3.matrix(y), SO3.matrix(x) @ so3_exp(v), atol=1e-15, what="x exp(v)")
    assert_close(so3_log(SO3.matrix(x).T @ SO3.matrix(y)), v, atol=1e-9 if angle > 3 else 1e-15,
                 what=f"log(x^T retract(x, v)) = v at |v| = {angle:g}")


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


def test_the_charts_cross_product_is_numpys_bit_for_bit():
    from workbench.core.manifolds.factors import _cross

    rng = np.random.default_rng(11)
    for _ in range(2000):
        a = rng.standard_normal(3) * 10.0 ** rng.uniform(-150, 150, 3)
        b = rng.standard_normal(3) * 10.0 ** rng.uniform(-150, 150, 3)
        assert np.array_equal(_cross(a, b), np.cross(a, b))
    with pytest.raises(ValueError):  # anything but two 3-vectors: numpy's own error
        _cross(np.ones(4), np.ones(3))
