"""Which inputs a Routh model may keep: decided at rounding level, whatever ``rtol`` is.

An input may stay in a Routh model only when it does not change the momentum, ``dJ/du =
0``. That is structural (a motor on the symmetry's own coordinate changes ``J`` one for
one), so a loose invariance tolerance ``rtol`` must not let such a motor through, and an
input that keeps the momentum must be carried over at any ``rtol``.

Checks: ``dJ/du`` from the loads' virtual power along the group (no solve) equals
``grad J . df/du`` of the full model's own field; the Furuta motor is refused at every
accepted ``rtol``; a torque on the link joint and a cart force normal to the translation
are kept, and the Routh model's input effect is the full model's, projected; a radial
force on a particle whose rotation momentum is declared (its rate cancels only to
rounding) is kept, a tangential one refused.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from workbench import ModelError, mechanics
from workbench.mechanics._symmetry import input_momentum_rates

RTOLS = (1e-8, 1e-3, 0.05, 0.1, 0.2, 0.3, 0.9)


def furuta(link_torque: bool = False) -> mechanics.System:
    """The Furuta pendulum of docs/own-model.md: motor on the arm, optionally a link torque."""
    s = mechanics.System("furuta")
    arm, link = s.s1("theta", velocity="theta_dot"), s.s1("alpha", velocity="alpha_dot")
    Jr, Lr, lp, mp, g = 4.0e-4, 0.085, 0.0645, 0.024, 9.81
    s.kinetic(0.5 * Jr * arm.rate**2)
    s.point_mass(mp, Lr * ca.vertcat(arm.cos, arm.sin, 0)
                 + lp * (link.cos * ca.DM([0, 0, 1])
                         + link.sin * ca.vertcat(arm.sin, -arm.cos, 0)))
    s.gravity(g)
    s.moment(arm, s.input(1, "motor torque [N m]"))
    if link_torque:
        s.moment(link, s.input(1, "link torque [N m]"))
    s.momentum("L", shift=[arm])
    return s


def cart_pendulum() -> mechanics.System:
    s = mechanics.System("cart")
    cart, link = s.rn("x", 2, velocity="v"), s.s2("q")
    s.point_mass(1.0, ca.vertcat(cart.x, 0))
    s.point_mass(0.2, ca.vertcat(cart.x, 0) + 0.4 * link.q)
    s.gravity(9.81)
    s.force(cart, ca.vertcat(0, s.input(1, "force along x2 [N]")))
    s.force(cart, ca.vertcat(s.input(1, "force along x1 [N]"), 0))
    s.momentum("p1", translate={cart: [1.0, 0.0]})
    return s


def test_dj_du_without_the_solve_is_grad_j_times_the_field_input_jacobian():
    s = furuta(link_torque=True)
    model = s.model()
    der = model.mechanics
    rates, structural = input_momentum_rates(der, der.ing.momenta["L"])
    assert structural == [False, True]  # the link torque does not load the arm's joint
    grad = ca.Function("g", [der.x, der.ing.p],
                       [ca.gradient(der.momentum(der.ing.momenta["L"])(der.x, der.ing.p),
                                    der.x)])
    rng = np.random.default_rng(11)
    for _ in range(5):
        x = model.manifold.random_point(rng)
        u = rng.standard_normal(2)
        dj = np.asarray(rates(x, u, model.p)[0], dtype=float).ravel()
        fu = np.asarray(model.function("f_u")(x, u, model.p), dtype=float).reshape(-1, 2)
        ref = np.asarray(grad(x, model.p), dtype=float).ravel() @ fu
        assert dj == pytest.approx([1.0, 0.0], abs=1e-15)  # the motor: one for one
        assert ref == pytest.approx(dj, abs=1e-12)


@pytest.mark.parametrize("rtol", RTOLS)
def test_the_furuta_motor_is_refused_at_every_accepted_rtol(rtol):
    with pytest.raises(ModelError, match=r"u\[0\]: it changes the momentum 'L' \(dJ/du = 1\)"):
        mechanics.reduce(furuta(), "L", momentum=0.01, rtol=rtol)


@pytest.mark.parametrize("rtol", RTOLS)
def test_a_link_torque_is_kept_and_acts_as_in_the_full_model(rtol):
    red = mechanics.reduce(furuta(link_torque=True), "L", momentum=0.01, rtol=rtol,
                           breaking_inputs="hold_zero")
    assert red.held_inputs == (0,)
    assert red.model.n_inputs == 1
    rng = np.random.default_rng(5)
    r = red.model.manifold.random_point(rng)
    f = red.model.function("f")
    du = (np.asarray(f(r, [1.0], red.model.p), dtype=float)
          - np.asarray(f(r, [0.0], red.model.p), dtype=float)).ravel()
    ref = red.field_at_lift(r, [0.0, 1.0]) - red.field_at_lift(r, [0.0, 0.0])
    assert np.linalg.norm(du) > 1.0  # the torque moves the link
    assert du == pytest.approx(ref, abs=1e-12 * np.linalg.norm(ref))


@pytest.mark.parametrize("rtol", (1e-8, 0.3))
def test_a_cart_force_normal_to_the_translation_is_kept_the_other_refused(rtol):
    with pytest.raises(ModelError, match=r"u\[1\]: it changes the momentum 'p1'"):
        mechanics.reduce(cart_pendulum(), "p1", momentum=0.5, rtol=rtol)
    red = mechanics.reduce(cart_pendulum(), "p1", momentum=0.5, rtol=rtol,
                           breaking_inputs="hold_zero")
    assert red.held_inputs == (1,) and red.model.n_inputs == 1


def particle(direction: str) -> mechanics.System:
    """A particle on R^2 with a central spring, a force ``u`` along ``x`` or across it."""
    s = mechanics.System(f"particle_{direction}")
    x = s.rn("x", 2, velocity="v")
    s.point_mass(1.0, x.x)
    s.potential(0.5 * ca.dot(x.x, x.x))
    unit = x.x / ca.norm_2(x.x)
    push = unit if direction == "radial" else ca.vertcat(-unit[1], unit[0])
    s.force(x, s.input(1, f"{direction} force [N]") * push)
    s.momentum("h", generators={x: ca.vertcat(-x.x[1], x.x[0])})
    return s


@pytest.mark.parametrize("direction", ["radial", "tangential"])
def test_a_radial_force_keeps_the_angular_momentum_to_rounding_a_tangential_one_not(direction):
    """``dJ/du = (e3 x x) . push``: 0 radially (the graph cancels in value only), ``|x|``
    across (the torque of a unit force at ``x``), against the scale ``|e3 x x| . |push|``."""
    der = particle(direction).model().mechanics
    rates, structural = input_momentum_rates(der, der.ing.momenta["h"])
    assert structural == [False]
    x = np.array([0.7, -1.3, 0.2, 0.4])
    rate, scale = (float(v) for v in rates(x, [1.0], np.zeros(0)))
    r = np.hypot(0.7, 1.3)
    push = np.array([0.7, -1.3]) / r if direction == "radial" else np.array([1.3, 0.7]) / r
    assert scale == pytest.approx(np.abs([1.3, 0.7]) @ np.abs(push), rel=1e-14)
    if direction == "radial":
        assert abs(rate) <= 4 * np.finfo(float).eps * scale
    else:
        assert rate == pytest.approx(r, rel=1e-14)
        assert abs(rate) > 1e6 * 1e-10 * scale  # far above INPUT_MOMENTUM_TOL
