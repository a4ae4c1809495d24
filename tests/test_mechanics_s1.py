"""The S^1 factor of the mechanics layer: an angle stored as (cos, sin) with its rate.

Checked: the pendulum written with ``s.s1`` has the closed-form field
``theta-ddot = -(g/l) sin theta + tau/(m l^2)`` and agrees with the transcribed planar
pendulum of paper 000 (``models.pendulum3d.planar``) to round-off; its linearisation has
the spectra ``+-i sqrt(g/l)`` hanging and ``+-sqrt(g/l)`` upright; ``model.state`` takes an
angle or a unit 2-vector (never normalised); a torque's authority does not fade off the
circle; an angle's momentum is detected as angular (named after the angle) and a declared
``shift=`` momentum is conserved; the variational integrator is of order 2 on S^1 and keeps
the energy error bounded; bad input is refused with the argument named.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import workbench as wb
from models import pendulum3d
from workbench import ManifoldError, ModelError, mechanics

G, L, M = 9.81, 0.5, 1.3


def pendulum(*, torque: bool = True):
    """A point mass on a massless rod, angle 0 hanging (gravity along the plane's e2)."""
    s = mechanics.System("pendulum_s1")
    th = s.s1("theta", velocity="theta_dot")
    m, ell, g = s.parameter("m", M), s.parameter("l", L), s.parameter("g", G)
    s.point_mass(m, ell * ca.vertcat(th.sin, th.cos))  # (horizontal, down)
    s.gravity(g, direction=[0.0, 1.0])
    if torque:
        s.moment(th, s.input(1, "torque at the pivot [N m]"))
    return s


def double_pendulum():
    """Two point masses; the second angle relative to the first (an acrobot's geometry)."""
    s = mechanics.System("double_s1")
    a, b = s.s1("a"), s.s1("b")
    c_ab, s_ab = a.cos * b.cos - a.sin * b.sin, a.sin * b.cos + a.cos * b.sin
    d1, d2 = ca.vertcat(a.sin, a.cos), ca.vertcat(s_ab, c_ab)
    s.point_mass(1.0, 0.9 * d1)
    s.point_mass(0.7, 0.9 * d1 + 0.8 * d2)
    s.kinetic(0.5 * 0.05 * a.rate**2 + 0.5 * 0.02 * (a.rate + b.rate) ** 2)
    s.gravity(9.81, direction=[0.0, 1.0])
    return s


@pytest.fixture(scope="module")
def model():
    return pendulum().model()


def test_field_is_the_closed_form_pendulum(model):
    rng = np.random.default_rng(1)
    for _ in range(5):
        th, w, tau = rng.uniform(-np.pi, np.pi), rng.normal(), rng.normal()
        f = model.rhs(model.state(theta=th, theta_dot=[w]), [tau])
        expected = [-w * np.sin(th), w * np.cos(th),
                    -G / L * np.sin(th) + tau / (M * L**2)]
        assert np.allclose(f, expected, rtol=1e-13, atol=1e-13)


def test_agrees_with_the_transcribed_planar_pendulum():
    """models.pendulum3d.planar: p = (Gamma_x, Gamma_z), Jt omega_y-dot = m g rho p_x."""
    Jt, rho, m, g = 0.37, 0.21, 1.7, 9.81
    s = mechanics.System("planar")
    p = s.s1("p", velocity="omega_y")
    # Jt is the whole inertia about the pivot: gravity enters as a potential, not as a body
    s.kinetic(0.5 * s.parameter("Jt", Jt) * p.rate**2)
    mgr = s.parameter("m", m) * s.parameter("g", g) * s.parameter("rho_s", rho)
    s.potential(-mgr * p.sin)  # the centre of mass at rho_s (Gamma_x, 0, Gamma_z), e3 down
    derived = s.model()
    transcribed = pendulum3d.planar(Jt=Jt, rho_s=rho, m=m, g=g)
    rng = np.random.default_rng(2)
    for _ in range(5):
        x = transcribed.state(p=rng.uniform(-np.pi, np.pi), omega_y=[rng.normal()])
        assert np.allclose(derived.rhs(x), transcribed.rhs(x), rtol=1e-14, atol=1e-14)
        e_d, e_t = derived.invariants(x)["energy"], transcribed.invariants(x)["energy"]
        assert abs(e_d - e_t) <= 1e-14 * max(1.0, abs(e_t))


@pytest.mark.parametrize("theta, kind", [(0.0, "hanging"), (np.pi, "upright")])
def test_linearisation_spectra_are_sqrt_g_over_l(model, theta, kind):
    lin = wb.linearize(model, model.state(theta=theta, theta_dot=[0.0]), [0.0])
    lam = np.sort_complex(np.linalg.eigvals(lin.A))
    w = np.sqrt(G / L)
    expected = np.array([-1j * w, 1j * w]) if kind == "hanging" else np.array([-w, w])
    assert np.allclose(lam, expected, rtol=1e-12, atol=1e-12)
    assert lin.A.shape == (2, 2)  # one angle, one rate: the minimal dimension
    assert wb.pbh(lin).controllable


def test_state_takes_an_angle_or_a_unit_vector(model):
    a = model.state(theta=0.3, theta_dot=[0.1])
    b = model.state(theta=[np.cos(0.3), np.sin(0.3)], theta_dot=[0.1])
    assert np.array_equal(a, b)
    assert np.array_equal(model.state(theta=np.float64(-7.0), theta_dot=[0.0])[:2],
                          [np.cos(-7.0), np.sin(-7.0)])


@pytest.mark.parametrize("bad, match", [
    ([0.9, 0.1], "is not on S1"),              # a non-unit 2-vector: refused, not normalised
    ([1.0, 0.0, 0.0], "must have 2 entries"),
    (True, "angle"),
    (np.nan, "angle"),
    ("0.3", "angle"),
])
def test_bad_angles_are_refused(model, bad, match):
    with pytest.raises(ManifoldError, match=match):
        model.state(theta=bad, theta_dot=[0.0])


def test_torque_authority_does_not_fade_off_the_circle():
    """Off S^1 (|p| != 1, an optimiser's iterate) a torque still acts as itself."""
    s = pendulum()
    mdl = s.model()
    rhs = mdl.function("f")
    for scale in (0.5, 1.0, 2.0):
        x = np.array([scale * np.cos(0.4), scale * np.sin(0.4), 0.0])
        du = np.asarray(rhs(x, [1.0], mdl.p) - rhs(x, [0.0], mdl.p)).ravel()
        # inertia m l^2 |p|^2 off the circle, generalised force tau whatever |p|
        assert du[2] == pytest.approx(1.0 / (M * L**2 * scale**2), rel=1e-13)


def test_angle_momenta_are_detected_and_named_angular():
    s = mechanics.System("rotors")
    a, b = s.s1("a"), s.s1("b")
    s.kinetic(0.5 * a.rate**2 + 0.5 * 2.0 * b.rate**2 + 0.3 * a.rate * b.rate)
    s.potential(1.5 * (a.cos * b.cos + a.sin * b.sin))  # depends on a - b only
    found = s.detect_momenta()
    assert list(found) == ["angular_momentum_a_b"], found
    model = s.model()
    x0 = model.state(a=0.2, a_dot=[1.0], b=-1.0, b_dot=[0.4])
    tr = wb.simulate(model, x0, np.linspace(0.0, 5.0, 11), rtol=1e-12, atol=1e-12)
    J = np.array([model.invariants(x)["angular_momentum_a_b"] for x in tr.x])
    assert np.ptp(J) <= 1e-10 * np.max(np.abs(J))
    assert J[0] == pytest.approx(1.0 + 0.3 * 0.4 + 2.0 * 0.4 + 0.3 * 1.0, rel=1e-14)


def test_gravity_breaks_the_shift_of_the_hanging_angle_only():
    """The double pendulum with gravity: no momentum; without gravity the total one."""
    assert double_pendulum().detect_momenta() == {}
    s = mechanics.System("free_double")
    a, b = s.s1("a"), s.s1("b")
    c_ab, s_ab = a.cos * b.cos - a.sin * b.sin, a.sin * b.cos + a.cos * b.sin
    d1, d2 = ca.vertcat(a.sin, a.cos), ca.vertcat(s_ab, c_ab)
    s.point_mass(1.0, 0.9 * d1)
    s.point_mass(0.7, 0.9 * d1 + 0.8 * d2)
    found = s.detect_momenta()
    # b is relative to a: shifting a alone turns the whole pendulum
    assert list(found) == ["angular_momentum_a"], found


def test_declared_shift_momentum_is_checked_and_conserved():
    s = mechanics.System("rotor")
    a = s.s1("a")
    s.kinetic(0.5 * 0.2 * a.rate**2)
    s.momentum("spin", shift=[a])
    model = s.model()
    x = model.state(a=1.0, a_dot=[3.0])
    assert model.invariants(x)["spin"] == pytest.approx(0.6, rel=1e-15)
    s2 = pendulum(torque=False)
    s2.momentum("spin", shift={"theta": 1.0})
    with pytest.raises(ModelError, match="'spin' is not conserved"):
        s2.model()


@pytest.mark.parametrize("call, match", [
    (lambda s, th, x: s.momentum("j", shift=[x]), "shift acts on S\\^1 factors"),
    (lambda s, th, x: s.momentum("j", shift={th: 0.0}), "generator is zero"),
    (lambda s, th, x: s.momentum("j", shift=th), "shift must be a sequence"),
    (lambda s, th, x: s.moment(th, [1.0, 0.0, 0.0]), "moment must have shape \\(1, 1\\)"),
    (lambda s, th, x: s.force(th, [1.0]), "force\\(...\\) acts on R\\^k factors"),
    (lambda s, th, x: s.s1("theta"), "already used"),
    (lambda s, th, x: s.s1("phi", velocity="phi"), "different names"),
    (lambda s, th, x: th.rotation_generator(ca.SX([0.0, 0.0, 1.0])), "shift=\\{angle"),
])
def test_misuse_is_refused_with_the_argument_named(call, match):
    s = mechanics.System("misuse")
    th, x = s.s1("theta"), s.rn("x", 1)
    with pytest.raises(ModelError, match=match):
        call(s, th, x)


def test_describes_the_angle_as_s1():
    model = double_pendulum().model()
    assert "S^1 a (cos, sin) x S^1 b (cos, sin)" in model.description
    assert [k for k, _ in model.manifold.factors] == ["a", "a_dot", "b", "b_dot"]


def _variational_errors(model, x0, t, steps):
    ref = wb.simulate(model, x0, t, rtol=1e-13, atol=1e-13)
    return np.array([np.max(np.abs(
        wb.simulate(model, x0, t, method="mechanics_variational", step=h).x - ref.x))
        for h in steps])


def test_variational_integrator_is_of_order_two_on_s1():
    model = double_pendulum().model()
    x0 = model.state(a=2.0, a_dot=[0.3], b=-0.5, b_dot=[1.0])
    steps = np.array([0.02, 0.01, 0.005, 0.0025])
    err = _variational_errors(model, x0, np.linspace(0.0, 2.0, 5), steps)
    order = np.polyfit(np.log(steps), np.log(err), 1)[0]
    assert 1.9 < order < 2.1, (err, order)


def _energy_error_by_quarter(model, x0, method, step):
    t = np.linspace(0.0, 200.0, 4001)
    tr = wb.simulate(model, x0, t, method=method, step=step)
    E = np.array([model.invariants(x)["energy"] for x in tr.x])
    return np.abs(E - E[0]).reshape(-1)[1:].reshape(4, 1000).max(axis=1), tr


def test_variational_energy_error_is_bounded_and_the_circle_kept():
    """Over 200 s (2e4 steps): no secular drift, an O(h^2) band; RK4 drifts meanwhile."""
    model = double_pendulum().model()
    x0 = model.state(a=2.0, a_dot=[0.3], b=-0.5, b_dot=[1.0])
    coarse, tr = _energy_error_by_quarter(model, x0, "mechanics_variational", 0.01)
    fine, _ = _energy_error_by_quarter(model, x0, "mechanics_variational", 0.005)
    for band in (coarse, fine):
        assert band[-1] <= 1.5 * band[0], band  # bounded: the last quarter as the first
    assert 3.0 < coarse.max() / fine.max() < 5.0  # the band shrinks like h^2
    p_norms = np.hypot(tr.x[:, [0, 3]], tr.x[:, [1, 4]])
    assert np.max(np.abs(p_norms - 1.0)) <= 1e-13  # rotated by Cayley, never projected
    rk, _ = _energy_error_by_quarter(model, x0, "rk", 0.01)
    assert rk[-1] >= 2.5 * rk[0], rk  # the non-symplectic method's error grows


@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_a_world_rotation_shifts_an_angle_in_its_own_sense(sense):
    """A spherical pendulum on a turning arm: the rotation about e3 turns the link and
    shifts the arm's angle, at +1 or -1 as the angle was written."""
    s = mechanics.System("arm_spherical")
    arm, link = s.s1("theta"), s.s2("q")
    s.kinetic(0.5 * 0.01 * arm.rate**2)
    s.point_mass(0.1, 0.2 * ca.vertcat(arm.cos, sense * arm.sin, 0) + 0.3 * link.q)
    s.gravity(9.81)
    assert s.detect_momenta() == {"angular_momentum_e3": "rotation about e3 turning theta, q"}
    gens = s.momenta["angular_momentum_e3"]
    assert float(ca.DM(gens[id(arm)])) == sense
    model = s.model()
    x0 = model.state(theta=0.3, theta_dot=[1.0], q=np.r_[0.6, 0.0, 0.8, 0.0, 1.0, 0.0])
    tr = wb.simulate(model, x0, np.linspace(0.0, 3.0, 7), rtol=1e-12, atol=1e-12)
    drift = tr.diagnostics["invariant_drift"]["angular_momentum_e3"]
    assert drift["max_abs"] <= 1e-10 * abs(drift["initial"])


@pytest.mark.parametrize("method, step, tol", [
    # measured 1.0e-9, 5.4e-11, 6.4e-10, 4.7e-4 (order 4, 6, 4, 2; link 2 spins at 6 rad/s)
    ("rk", 1e-3, 2e-9), ("collocation", 1e-2, 1e-10), ("rkmk4", 1e-3, 1.3e-9),
    ("mechanics_variational", 1e-3, 1e-3),
])
def test_every_simulation_method_steps_s1(method, step, tol):
    """Each method against CVODES at 1e-13 on the double pendulum on S^1 x S^1."""
    model = double_pendulum().model()
    x0 = model.state(a=2.0, a_dot=[0.3], b=-0.5, b_dot=[1.0])
    t = np.linspace(0.0, 1.0, 11)
    ref = wb.simulate(model, x0, t, rtol=1e-13, atol=1e-13)
    tr = wb.simulate(model, x0, t, method=method, step=step)
    assert np.max(np.abs(tr.x - ref.x)) <= tol
