"""workbench.mechanics: derived equations of motion against the papers' hand-written models.

The papers' printed vector fields (models/paper_forms.py: paper 000 (3.1)-(3.2), paper 002
Section II, paper 003 (12)-(13)) are the independent check: random states on the manifold,
random parameters, deviation <= 1e-11 -- for the systems written in these tests and for
the models of models/ (now defined by their Lagrangians).
"""

from __future__ import annotations

import casadi as ca
import mechanics_systems as ms
import numpy as np
import pytest
from conftest import assert_close

from models import chain_cart as chain_module
from models import pendulum3d as p3
from models import spherical as spherical_module
from models.paper_forms import (
    chain_cart_printed as chain_cart,
)
from models.paper_forms import (
    pendulum3d_full_printed,
)
from models.paper_forms import (
    spherical_pendulum_printed as spherical_pendulum,
)
from workbench import mechanics
from workbench.mechanics._equations import SPARSE_JACOBIAN_MAX

TOL = 1e-11


def _random_spd(rng):
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return Q @ np.diag(rng.uniform(0.1, 2.0, 3)) @ Q.T


def _compare(derived, printed, rng, n_states=6, n_inputs=None):
    worst = 0.0
    for _ in range(n_states):
        x = printed.manifold.random_point(rng)
        u = rng.standard_normal(printed.n_inputs)
        a, b = derived.rhs(x, u), printed.rhs(x, u)
        assert_close(a, b, atol=TOL, what=f"{printed.name} vector field")
        inv_a, inv_b = derived.invariants(x), printed.invariants(x)
        for k in inv_b:
            assert_close(inv_a[k], inv_b[k], atol=TOL, what=f"{printed.name} invariant {k}")
        worst = max(worst, float(np.max(np.abs(a - b))))
    return worst


def test_spherical_pendulum_matches_paper_002(rng):
    for _ in range(4):
        m, l, g = rng.uniform(0.2, 3.0, 3) * [1, 1, 5]  # noqa: E741
        printed = spherical_pendulum(m=m, l=l, g=g)
        _compare(ms.spherical(m, l, g), printed, rng)
        _compare(spherical_module.spherical_pendulum(m=m, l=l, g=g), printed, rng)


def test_pendulum3d_full_matches_paper_000(rng):
    for _ in range(4):
        J, rho = _random_spd(rng), rng.standard_normal(3) * 0.4
        m, g = rng.uniform(0.3, 3.0), rng.uniform(1.0, 12.0)
        printed = pendulum3d_full_printed(J=J, rho=rho, m=m, g=g)
        for derived in (ms.pendulum3d(J, rho, m, g), p3.full(J=J, rho=rho, m=m, g=g)):
            _compare(derived, printed, rng)
            assert derived.manifold.describe() == printed.manifold.describe()


def test_pendulum3d_full_off_so3_is_the_printed_field_with_the_documented_moment(rng):
    """Ambient R near SO(3) (a Gauss-Legendre stage): the printed (3.1)-(3.2), linear in R,
    with the body moment u entering as ``vee((R^T R hat(u) + hat(u) R^T R)/2)``, the
    extension :mod:`workbench.mechanics._forces` documents (equal to u on SO(3))."""
    from workbench.core.manifolds import hat, vee

    J, rho = _random_spd(rng), rng.standard_normal(3) * 0.4
    printed = pendulum3d_full_printed(J=J, rho=rho, m=1.3, g=9.81)
    derived = p3.full(J=J, rho=rho, m=1.3, g=9.81)
    for scale in (1e-6, 1e-2, 0.3):
        x = printed.manifold.random_point(rng)
        x[0:9] += scale * rng.standard_normal(9)  # R leaves SO(3)
        R = x[0:9].reshape(3, 3, order="F")
        u = rng.standard_normal(3)
        moment = vee((R.T @ R @ hat(u) + hat(u) @ R.T @ R) / 2)
        a, b = derived.rhs(x, u), printed.rhs(x, moment)
        assert_close(a, b, atol=1e-11 * (1 + np.max(np.abs(b))),
                     what=f"pendulum3d_full field, R off SO(3) by {scale}")
        if scale >= 1e-2:  # and the extension is not the printed field with u itself
            assert np.max(np.abs(a - printed.rhs(x, u))) > 1e-6 * scale


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_chain_matches_paper_003_unequal_links(n, rng):
    masses, lengths = rng.uniform(0.05, 0.5, n), rng.uniform(0.05, 0.6, n)
    m, g = rng.uniform(0.3, 2.0), rng.uniform(5.0, 12.0)
    derived = ms.chain(n, m=m, masses=masses, lengths=lengths, g=g)
    printed = chain_cart(n, m=m, masses=masses, lengths=lengths, g=g)
    assert derived.manifold.describe() == printed.manifold.describe()
    _compare(derived, printed, rng)
    _compare(chain_module.chain_cart(n, m=m, masses=masses, lengths=lengths, g=g), printed, rng)
    # first derivatives along the manifold (the ambient extensions differ off it)
    x = printed.manifold.random_point(rng)
    u = rng.standard_normal(2)
    N = printed.manifold.tangent_basis(x)
    fx_d = np.asarray(derived.function("f_x")(x, u, derived.p)) @ N
    fx_p = np.asarray(printed.function("f_x")(x, u, printed.p)) @ N
    assert_close(fx_d, fx_p, atol=1e-9, rtol=1e-9, what="tangent Jacobian")
    assert_close(np.asarray(derived.function("f_u")(x, u, derived.p)),
                 np.asarray(printed.function("f_u")(x, u, printed.p)), atol=1e-10,
                 what="input Jacobian")


def _hanging(model, n):
    return model.manifold.join({"x": np.zeros(2), "v": np.zeros(2),
                                **{f"link{i + 1}": np.r_[0, 0, (-1) ** i, 0, 0, 0]
                                   for i in range(n)}})


def test_mx_jacobian_equals_plain_ad_at_rest_and_in_motion(rng):
    """The supplied (implicit-function) Jacobian equals plain AD through a symbolic solve."""
    masses, lengths = rng.uniform(0.05, 0.5, 3), rng.uniform(0.05, 0.6, 3)
    mx = ms.chain(3, masses=masses, lengths=lengths)
    sx = ms.chain(3, masses=masses, lengths=lengths, symbolic="SX")
    assert (mx.symbolic, sx.symbolic) == ("MX", "SX")
    cases = [(_hanging(mx, 3), np.zeros(2)),  # at rest, zero acceleration: the short branch
             (_hanging(mx, 3), rng.standard_normal(2)), (mx.manifold.random_point(rng),
                                                         rng.standard_normal(2))]
    for x, u in cases:
        for name in ("f_x", "f_u"):
            a = np.asarray(mx.function(name)(x, u, mx.p))
            b = np.asarray(sx.function(name)(x, u, sx.p))
            assert_close(a, b, atol=1e-10, rtol=1e-10, what=name)


def test_mx_second_derivatives_are_exact(rng):
    mx = ms.chain(2, masses=[0.2, 0.1], lengths=[0.3, 0.2])
    sx = ms.chain(2, masses=[0.2, 0.1], lengths=[0.3, 0.2], symbolic="SX")
    w = rng.standard_normal(mx.manifold.ambient_dim)
    hess = []
    for model in (mx, sx):
        S = model.sym
        x, u = S.sym("x", model.manifold.ambient_dim), S.sym("u", 2)
        val = ca.dot(ca.DM(w), model.function("f")(x, u, ca.DM(model.p)))
        hess.append(ca.Function("h", [x, u], [ca.hessian(val, ca.vertcat(x, u))[0]]))
    x, u = mx.manifold.random_point(rng), rng.standard_normal(2)
    assert_close(np.asarray(hess[0](x, u)), np.asarray(hess[1](x, u)), atol=1e-8, rtol=1e-8,
                 what="Hessian through the linear solve")


def test_large_chain_jacobian_by_forward_sweeps_matches_finite_differences(rng):
    n = (SPARSE_JACOBIAN_MAX - 2) // 3 + 1  # just above the sparse-AD size
    model = ms.chain(n, masses=rng.uniform(0.05, 0.3, n), lengths=rng.uniform(0.1, 0.3, n))
    f, fx = model.function("f"), model.function("f_x")
    x, u = model.manifold.random_point(rng), rng.standard_normal(2)
    J = np.asarray(fx(x, u, model.p))
    h = 1e-6
    cols = rng.choice(x.size, 8, replace=False)
    for k in cols:
        e = np.zeros(x.size)
        e[k] = h
        fd = (np.asarray(f(x + e, u, model.p)) - np.asarray(f(x - e, u, model.p))).ravel() / (2 * h)
        assert_close(J[:, k], fd, atol=1e-5, rtol=1e-5, what=f"column {k}")
    xe = _hanging(model, n)
    Je = np.asarray(fx(xe, np.zeros(2), model.p))
    for k in cols:
        e = np.zeros(x.size)
        e[k] = h
        fd = (np.asarray(f(xe + e, 0, model.p)) - np.asarray(f(xe - e, 0, model.p))).ravel()
        fd = fd / (2 * h)
        assert_close(Je[:, k], fd, atol=1e-5, rtol=1e-5, what=f"column {k} at rest")


def test_so3_equation_convention_rows(rng):
    """d/dt dL/dOmega + Omega x dL/dOmega = sum_i dL/dr_i x r_i, r_i the rows of R.

    For V(R) = tr(K R) (L = T - V): J Omega-dot = J Omega x Omega + sum_i r_i x K[:, i].
    """
    K, J = rng.standard_normal((3, 3)), _random_spd(rng)
    s = mechanics.System("so3_potential")
    body = s.so3("R", velocity="W")
    s.kinetic(0.5 * ca.dot(body.Omega, ca.DM(J) @ body.Omega))
    s.potential(ca.trace(ca.DM(K) @ body.R))
    model = s.model()
    for _ in range(5):
        x = model.manifold.random_point(rng)
        R, W = x[:9].reshape(3, 3, order="F"), x[9:]
        rows = sum(np.cross(R[i, :], K[:, i]) for i in range(3))
        expected = np.linalg.solve(J, np.cross(J @ W, W) + rows)
        assert_close(model.rhs(x)[9:], expected, atol=1e-12, what="SO(3) Euler-Poincare")
        assert_close(model.rhs(x)[:9], (R @ np.array([[0, -W[2], W[1]], [W[2], 0, -W[0]],
                                                       [-W[1], W[0], 0]])).ravel(order="F"),
                     atol=1e-14, what="R-dot = R hat(Omega)")


def test_s2_kinetic_energy_written_directly_matches_bodies(rng):
    """T = m l^2 |omega|^2 / 2 written directly (it sees omega's normal part, which the
    layer removes) gives the same field as the point mass at l q."""
    s = mechanics.System("direct")
    q = s.s2("q")
    m, l, g = s.parameter("m", 1.3), s.parameter("l", 0.7), s.parameter("g", 9.81)  # noqa: E741
    s.kinetic(0.5 * m * l**2 * ca.dot(q.omega, q.omega) + 0.1 * ca.dot(q.q, q.omega) ** 2)
    s.potential(-m * g * l * q.q[2])
    s.moment(q, s.input(3))
    direct, bodies = s.model(), ms.spherical(1.3, 0.7, 9.81)
    for _ in range(5):
        x, u = bodies.manifold.random_point(rng), rng.standard_normal(3)
        assert_close(direct.rhs(x, u), bodies.rhs(x, u), atol=1e-12, what="S^2 field")


def test_s2_angular_velocity_stays_tangent_off_the_manifold(rng):
    model = ms.chain(3, masses=[0.2, 0.1, 0.3], lengths=[0.3, 0.2, 0.1])
    for _ in range(5):
        x = rng.standard_normal(model.manifold.ambient_dim)  # not on the manifold at all
        xdot = model.rhs(x, rng.standard_normal(2))
        for i in range(3):
            q, wdot = x[4 + 6 * i : 7 + 6 * i], xdot[7 + 6 * i : 10 + 6 * i]
            assert abs(q @ wdot) <= 1e-11 * np.linalg.norm(q) * np.linalg.norm(wdot) + 1e-13


def test_derived_model_has_the_printed_layout_and_parameters():
    derived, printed = ms.chain(2), chain_cart(2)
    assert derived.manifold.names == printed.manifold.names
    assert [p.name for p in derived.parameters] == [p.name for p in printed.parameters]
    assert [p.shape for p in derived.parameters] == [p.shape for p in printed.parameters]
    assert derived.invariant_names == ["energy", "px", "py", "Lz"]
    assert derived.n_inputs == printed.n_inputs == 2
