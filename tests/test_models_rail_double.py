"""The rail pendulum (S^2 under a spring-loaded slider) and the double pendulum on a cart.

Checked against independent physics: the rail pendulum's field equals Lagrange's equations
derived in sympy in the slider's position and two angles of the rod (``q = Rx(b) Ry(a)
e3``), at random states away from the chart's singularity ``cos a = 0``, random inputs
and parameters; the double pendulum's field equals Bogdanov's (2004) closed form ``D
theta-ddot + C theta-dot + G = H u`` in his angles from the upward vertical. Both conserve
their energy unforced (and the double pendulum its horizontal momentum); the
linearisations have the closed-form spectra at hanging and inverted (the rail pendulum's
swing along the rail coupled to the spring-loaded slider, ``M l w^4 - (k l + s (M + m) g)
w^2 + s k g = 0``; its swing across the rail ``w^2 = g / l`` exactly); PBH names the swing
across the rail as the rail pendulum's uncontrollable pair and finds the double pendulum
controllable upright.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import sympy as sp

import workbench as wb
from models import double_cartpole as dcp
from models import rail_pendulum as rp
from workbench import ModelError


def _random_parameters(rng, base):
    return {k: v * rng.uniform(0.5, 2.0) for k, v in base.items()}


# ---------------------------------------------------------------------------------------
# the rail pendulum against Lagrange's equations in angles (sympy)


@pytest.fixture(scope="module")
def rail():
    return rp.rail_pendulum()


@pytest.fixture(scope="module")
def rail_reference():
    """``(x, a, b, rates, u, P) -> (x-ddot, q, q-dot, q-ddot)`` by sympy.

    Independent of the model: the rod's direction in two angles, ``q = Rx(b) Ry(a) e3 =
    (sin a, -sin b cos a, cos a cos b)``, the bob at ``(x, 0, 0) + l q``, the slider at
    ``(x, 0, 0)``, ``V = k x^2 / 2 - m g l e3 . q``, and Lagrange's equations in ``(x, a,
    b)`` with the force on ``x``.
    """
    t = sp.symbols("t")
    x, a, b = (sp.Function(n)(t) for n in ("x", "a", "b"))
    M, m, ell, k, g, u = sp.symbols("M m l k g u", positive=True)
    q = sp.Matrix([sp.sin(a), -sp.sin(b) * sp.cos(a), sp.cos(a) * sp.cos(b)])
    slider = sp.Matrix([x, 0, 0])
    bob = slider + ell * q
    T = (M * slider.diff(t).dot(slider.diff(t)) + m * bob.diff(t).dot(bob.diff(t))) / 2
    V = k * x**2 / 2 - m * g * ell * q[2]
    L = T - V
    coords, forces = [x, a, b], [u, 0, 0]
    eqs = [sp.diff(L.diff(c.diff(t)), t) - L.diff(c) - F for c, F in zip(coords, forces)]
    dd = [c.diff(t, 2) for c in coords]
    A, rhs = sp.linear_eq_to_matrix([sp.expand(e) for e in eqs], dd)
    sym = sp.symbols("x_ a_ b_ xd ad bd xdd add bdd")
    subs = {c.diff(t, 2): s for c, s in zip(coords, sym[6:])}
    subs.update({c.diff(t): s for c, s in zip(coords, sym[3:6])})
    subs2 = dict(zip(coords, sym[:3]))

    def num(expr):
        return expr.subs(subs).subs(subs2)

    args = [*sym[:6], u, M, m, ell, k, g]
    fA, fb = sp.lambdify(args, num(A), "numpy"), sp.lambdify(args, num(rhs), "numpy")
    fq = sp.lambdify(sym[:6], [num(q), num(q.diff(t))], "numpy")
    fqdd = sp.lambdify(sym, num(q.diff(t, 2)), "numpy")

    def ref(state, u_, P):
        a_ = [*state, u_, P["M"], P["m"], P["l"], P["k"], P["g"]]
        acc = np.linalg.solve(np.asarray(fA(*a_), float), np.asarray(fb(*a_), float).ravel())
        qv, qd = (np.asarray(v, float).ravel() for v in fq(*state))
        qdd = np.asarray(fqdd(*state, *acc), float).ravel()
        return acc[0], qv, qd, qdd

    return ref


def test_rail_pendulum_field_is_the_sympy_derivation(rail, rail_reference):
    rng = np.random.default_rng(21)
    for trial in range(8):
        P = rp.DEFAULTS if trial == 0 else _random_parameters(rng, rp.DEFAULTS)
        model = rail.with_parameters(**P)
        state = np.r_[rng.normal(0, 0.3), rng.uniform(-1.2, 1.2), rng.uniform(-np.pi, np.pi),
                      rng.normal(0, 2, size=3)]
        u = rng.normal(0, 5)
        xdd, q, qd, qdd = rail_reference(state, u, P)
        omega = np.cross(q, qd)  # the angular velocity normal to q: q-dot = omega x q
        x = model.state(x=[state[0]], v=[state[3]], q=np.r_[q, omega])
        f = model.rhs(x, [u])
        # q-dot = omega x q; omega-dot = q x q-ddot (omega . q = 0 along the motion)
        expected = np.r_[state[3], xdd, np.cross(omega, q), np.cross(q, qdd)]
        assert np.max(np.abs(f - expected)) <= 1e-11 * np.max(np.abs(expected)), (f, expected)


def test_rail_pendulum_helpers_are_equilibria_and_refuse_another_model(rail):
    for x, q3 in ((rp.hanging(rail), 1.0), (rp.inverted(rail), -1.0)):
        assert np.array_equal(x, np.r_[0.0, 0.0, 0.0, 0.0, q3, 0.0, 0.0, 0.0])
        assert np.max(np.abs(rail.rhs(x, [0.0]))) <= 1e-15
    assert np.array_equal(rp.upright(rail), rp.inverted(rail))
    with pytest.raises(ModelError, match="rail pendulum"):
        rp.hanging(dcp.double_cartpole())


def _rail_along_roots(P, s):
    """``w^2`` of the swing along the rail: ``M l w^4 - (k l + s (M + m) g) w^2 + s k g``.

    ``s = +1`` hanging, ``-1`` inverted (the linearised Lagrangian in the slider's position
    and the rod's angle in the rail's plane).
    """
    M, m, ell, k, g = (P[n] for n in ("M", "m", "l", "k", "g"))
    return np.roots([M * ell, -(k * ell + s * (M + m) * g), s * k * g])


def test_rail_pendulum_spectra_hanging_and_inverted(rail):
    P = rp.DEFAULTS
    for x, s in ((rp.hanging(rail), 1.0), (rp.inverted(rail), -1.0)):
        lam = np.linalg.eigvals(wb.linearize(rail, x, [0.0]).A)
        # lambda^2 = -w^2: the swing along the rail (two roots), across it -s g / l
        lam2 = np.r_[-_rail_along_roots(P, s), -s * P["g"] / P["l"]]
        assert np.allclose(np.sort((lam**2).real), np.sort(np.repeat(lam2, 2)), rtol=1e-12)
        assert np.max(np.abs((lam**2).imag)) <= 1e-12 * np.max(np.abs(lam2))
        unstable = int(np.sum(lam.real > 1e-8))
        assert unstable == (0 if s > 0 else 2)
        if s > 0:
            assert np.max(np.abs(lam.real)) <= 1e-12 * np.max(np.abs(lam))


def test_rail_pendulum_pbh_names_the_swing_across_the_rail(rail):
    """The uncontrollable pair is the rotation about e1 (``q.v1``, ``q.eta1``), ``w^2 = g/l``.

    At ``q = +-e3`` the tangent coordinates ``q.v1``, ``q.eta1`` are the rotation of the rod
    about ``e1`` and its rate (``delta q = v1 e1 x q``): the swing across the rail.
    """
    P = rp.DEFAULTS
    w = np.sqrt(P["g"] / P["l"])
    for x, pair in ((rp.hanging(rail), [-1j * w, 1j * w]), (rp.inverted(rail), [-w, w])):
        res = wb.pbh(wb.linearize(rail, x, [0.0]))
        assert not res.controllable
        bad = res.uncontrollable
        assert np.allclose(np.sort_complex([m.eigenvalue for m in bad]), pair, rtol=1e-12)
        assert all(m.deficiency == 1 for m in bad)
        across = [res.labels.index("q.v1"), res.labels.index("q.eta1")]
        for m in bad:
            wl = m.left_vectors[:, 0]
            others = np.delete(wl, across)
            assert np.max(np.abs(others)) <= 1e-12 * np.max(np.abs(wl)), (res.labels, wl)
            text = res.describe_mode(m)
            assert "q.v1" in text and "q.eta1" in text and "x1" not in text, text
        assert all(m.ratio > 1e-4 for m in res.modes if m.controllable)


def test_rail_pendulum_plane_of_the_rail_is_invariant_under_feedback(rail):
    """Reflection ``e2 -> -e2`` is a symmetry with the input: a planar swing stays planar."""
    xs = ca.SX.sym("x", 8)
    k = ca.Function("k", [xs], [-3.0 * xs[0] - 2.0 * xs[1] + 4.0 * xs[2] * xs[4]])
    x0 = rail.state(x=[0.1], v=[-0.3], q=np.r_[np.sin(2.5), 0.0, np.cos(2.5), 0.0, 1.5, 0.0])
    tr = wb.simulate(rail, x0, np.linspace(0.0, 3.0, 31), controller=k, rtol=1e-12,
                     atol=1e-12)
    assert np.max(np.abs(tr.x[:, [3, 5, 7]])) <= 1e-12  # q2, omega1, omega3
    assert np.ptp(tr.x[:, 2]) > 0.5  # it did swing


# ---------------------------------------------------------------------------------------
# the double pendulum on a cart against Bogdanov's closed form


def bogdanov_acceleration(th, thd, u, P):
    """``theta-ddot`` of Bogdanov (2004) eqs. (1)-(4): angles from the upward vertical."""
    m0, m1, m2, L1, L2, g = (P[n] for n in ("m0", "m1", "m2", "L1", "L2", "g"))
    l1, l2, I1, I2 = L1 / 2, L2 / 2, m1 * L1**2 / 12, m2 * L2**2 / 12
    d1, d2, d3 = m0 + m1 + m2, m1 * l1 + m2 * L1, m2 * l2
    d4, d5, d6 = m1 * l1**2 + m2 * L1**2 + I1, m2 * L1 * l2, m2 * l2**2 + I2
    f1, f2 = (m1 * l1 + m2 * L1) * g, m2 * l2 * g
    _, t1, t2 = th
    _, w1, w2 = thd
    c12, s12 = np.cos(t1 - t2), np.sin(t1 - t2)
    D = np.array([[d1, d2 * np.cos(t1), d3 * np.cos(t2)],
                  [d2 * np.cos(t1), d4, d5 * c12],
                  [d3 * np.cos(t2), d5 * c12, d6]])
    C = np.array([[0.0, -d2 * np.sin(t1) * w1, -d3 * np.sin(t2) * w2],
                  [0.0, 0.0, d5 * s12 * w2],
                  [0.0, -d5 * s12 * w1, 0.0]])
    G = np.array([0.0, -f1 * np.sin(t1), -f2 * np.sin(t2)])
    return np.linalg.solve(D, np.array([u, 0.0, 0.0]) - C @ np.asarray(thd) - G), D


@pytest.fixture(scope="module")
def cartpole():
    return dcp.double_cartpole()


def _random_cartpole_state(model, rng):
    phi, rates = rng.uniform(-np.pi, np.pi, size=2), rng.normal(0, 3, size=2)
    x = model.state(x=[rng.normal(0, 0.5)], v=[rng.normal(0, 1)], phi1=phi[0],
                    phi1_dot=[rates[0]], phi2=phi[1], phi2_dot=[rates[1]])
    return x, phi, rates


def test_double_cartpole_field_is_bogdanovs_equations(cartpole):
    rng = np.random.default_rng(22)
    for trial in range(8):
        P = dcp.BOGDANOV_2004 if trial == 0 else _random_parameters(rng, dcp.BOGDANOV_2004)
        model = cartpole.with_parameters(**P)
        x, phi, rates = _random_cartpole_state(model, rng)
        u = rng.normal(0, 10)
        f = model.rhs(x, [u])
        # theta_i = pi - phi_i, theta_i-dot = -phi_i-dot; the cart's x is Bogdanov's theta0
        acc, _ = bogdanov_acceleration([x[0], *(np.pi - phi)], [x[1], *(-rates)], u, P)
        p1, p2 = x[2:4], x[5:7]
        expected = np.r_[x[1], acc[0], rates[0] * np.array([-p1[1], p1[0]]), -acc[1],
                         rates[1] * np.array([-p2[1], p2[0]]), -acc[2]]
        assert np.max(np.abs(f - expected)) <= 1e-11 * np.max(np.abs(expected)), (f, expected)


def test_double_cartpole_helpers_are_equilibria_and_refuse_another_model(cartpole, rail):
    for x, c in ((dcp.hanging(cartpole), 1.0), (dcp.upright(cartpole), -1.0)):
        assert np.allclose(x[[2, 5]], c, atol=0) and np.allclose(x[[3, 6]], 0.0, atol=1e-15)
        assert np.max(np.abs(cartpole.rhs(x, [0.0]))) <= 1e-14
    with pytest.raises(ModelError, match="double pendulum on a cart"):
        dcp.upright(rail)


def test_double_cartpole_spectra_and_controllability(cartpole):
    """``lambda^2`` are the eigenvalues of ``-D^-1 K`` with Bogdanov's ``D`` at rest and
    ``K = dG/dtheta = diag(0, -f1 cos theta1, -f2 cos theta2)``, plus the cart's zero pair."""
    P = dcp.BOGDANOV_2004
    m1, m2, L1, L2, g = (P[n] for n in ("m1", "m2", "L1", "L2", "g"))
    f1, f2 = (m1 * L1 / 2 + m2 * L1) * g, m2 * L2 / 2 * g
    for x, theta, unstable in ((dcp.hanging(cartpole), np.pi, 0),
                               (dcp.upright(cartpole), 0.0, 2)):
        _, D = bogdanov_acceleration([0.0, theta, theta], [0.0, 0.0, 0.0], 0.0, P)
        K = np.diag([0.0, -f1 * np.cos(theta), -f2 * np.cos(theta)])
        mu = np.sort(np.linalg.eigvals(-np.linalg.solve(D, K)).real)
        lin = wb.linearize(cartpole, x, [0.0])
        lam = np.linalg.eigvals(lin.A)
        zero = np.abs(lam) < 1e-6  # the cart's translation and its momentum (Jordan pair)
        assert zero.sum() == 2 and np.isclose(mu[np.argmin(np.abs(mu))], 0.0, atol=1e-12)
        lam2 = np.sort((lam[~zero] ** 2).real)
        mu_nz = np.sort(mu[np.abs(mu) > 1e-9])
        assert np.allclose(lam2, np.sort(np.repeat(mu_nz, 2)), rtol=1e-12)
        assert int(np.sum(lam.real > 1e-8)) == unstable
        assert wb.pbh(lin).controllable  # one force drives both links and the cart


# ---------------------------------------------------------------------------------------
# invariants


@pytest.mark.parametrize("which", ["rail", "cartpole"])
def test_invariants_are_conserved_unforced(which, rail, cartpole):
    rng = np.random.default_rng(23)
    if which == "rail":
        model = rail
        q = rng.normal(size=3)
        q /= np.linalg.norm(q)
        w = np.cross(q, rng.normal(size=3))
        x0 = model.state(x=[0.2], v=[-0.5], q=np.r_[q, 3 * w])
        names = {"energy"}
    else:
        model = cartpole
        x0, _, _ = _random_cartpole_state(model, rng)
        names = {"energy", "linear_momentum_x"}
    tr = wb.simulate(model, x0, np.linspace(0.0, 5.0, 51), rtol=1e-12, atol=1e-12)
    drift = tr.diagnostics["invariant_drift"]
    assert set(drift) == names
    for name, d in drift.items():
        assert d["max_abs"] <= 1e-8 * max(1.0, abs(d["initial"])), (name, d)


def test_double_cartpole_momentum_is_the_translation(cartpole):
    s = dcp.double_cartpole_system()
    s.momenta.clear()  # found again from the Lagrangian alone
    assert list(s.detect_momenta()) == ["linear_momentum_x_1"]
    x0, _, _ = _random_cartpole_state(cartpole, np.random.default_rng(24))
    J_fn = cartpole.function("linear_momentum_x")
    xs = ca.SX.sym("x", x0.size)
    grad = np.asarray(ca.Function("g", [xs], [ca.gradient(J_fn(xs, cartpole.p), xs)])(x0))
    for u in (0.0, 2.5):  # the force is the momentum's rate
        assert grad.ravel() @ cartpole.rhs(x0, [u]) == pytest.approx(u, abs=1e-12)
