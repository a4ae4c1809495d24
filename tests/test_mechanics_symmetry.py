"""Symmetries found by the mechanics layer (System.detect_momenta).

Checks: the detected set of each system is the one its physics predicts (Noether: a
translation-invariant, rotation-invariant Lagrangian), no more, no fewer; each detected
momentum is conserved along an independent CVODES simulation; a broken symmetry (gravity
off the vertical, a spring to a fixed point, a torque) is not detected; bad options are
refused.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from workbench import ModelError, mechanics, simulate

E1, E3 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])


def cart_pendulum(gravity=E3):
    s = mechanics.System("cart_pendulum")
    cart = s.rn("x", 2, velocity="v")
    link = s.s2("link")
    M, m, ell, g = (s.parameter(k, v) for k, v in [("M", 0.5), ("m", 0.1), ("l", 0.3),
                                                   ("g", 9.81)])
    pivot = ca.vertcat(cart.x, 0)
    s.point_mass(M, pivot, name="cart")
    s.point_mass(m, pivot + ell * link.q, name="bob")
    s.gravity(g, direction=gravity)
    s.force(cart, s.input(2, "horizontal force on the cart [N]"))
    return s


def quadrotor():
    s = mechanics.System("quadrotor_slung_load")
    quad, att, cable = s.rn("xQ", 3, velocity="vQ"), s.so3("R", velocity="Omega"), s.s2("q")
    s.rigid_body(1.2, s.inertia("J", np.diag([0.02, 0.03, 0.04])), att, origin=quad.x,
                 name="quad")
    s.point_mass(0.3, quad.x + 0.8 * cable.q, name="load")
    s.gravity(9.81)
    f, M = s.input(1, "thrust [N]"), s.input(3, "body moment [N m]")
    s.force_at(quad.x, ca.vertcat(0, 0, -f), body="quad")
    s.moment(att, M)
    return s


def double_pendulum():
    s = mechanics.System("double_pendulum3d")
    b1, b2 = s.so3("R1", velocity="Omega1"), s.so3("R2", velocity="Omega2")
    joint = b1.R @ np.array([0.0, 0.0, 0.4])
    s.rigid_body(1.0, s.inertia("J1", np.diag([0.05, 0.06, 0.02])), b1,
                 com=np.array([0.0, 0.05, 0.2]))
    s.rigid_body(0.7, s.inertia("J2", np.diag([0.03, 0.02, 0.01])), b2, origin=joint,
                 com=np.array([0.03, 0.0, 0.15]))
    s.gravity(9.81)
    return s


def test_cart_pendulum_has_the_two_translations_and_the_vertical_rotation():
    found = cart_pendulum().detect_momenta()
    assert set(found) == {"linear_momentum_x_1", "linear_momentum_x_2", "angular_momentum_e3"}
    assert "turning x, link" in found["angular_momentum_e3"]  # the cart turns with the link


def test_gravity_along_e1_moves_the_rotation_to_e1():
    # the cart's plane is still (x1, x2, 0); gravity along e1 breaks the translation along
    # x1 and the rotation about e3; the rotation about e1 moves the cart off its plane (no
    # symmetry of the R^2 factor), so only the translation along x2 is left
    found = cart_pendulum(gravity=E1).detect_momenta()
    assert set(found) == {"linear_momentum_x_2"}


def test_quadrotor_with_load_keeps_horizontal_translations_and_yaw():
    found = quadrotor().detect_momenta()
    assert set(found) == {"linear_momentum_xQ_1", "linear_momentum_xQ_2",
                          "angular_momentum_e3"}
    assert "turning xQ, R, q" in found["angular_momentum_e3"]


def test_free_rigid_body_conserves_all_three_components():
    s = mechanics.System("free_body")
    R = s.so3("R")
    s.rigid_body(1.0, s.inertia("J", np.diag([1.0, 2.0, 3.0])), R)
    assert set(s.detect_momenta()) == {f"angular_momentum_e{i}" for i in (1, 2, 3)}


def test_only_total_momentum_of_two_coupled_particles():
    s = mechanics.System("two")
    a, b = s.rn("a", 1), s.rn("b", 1)
    s.point_mass(1.0, a.x)
    s.point_mass(2.0, b.x)
    s.potential(0.5 * (a.x - b.x) ** 2)
    assert set(s.detect_momenta()) == {"linear_momentum_1"}


def test_broken_symmetries_are_not_detected():
    s = mechanics.System("anchored")
    a = s.rn("a", 2)
    s.point_mass(1.0, a.x)
    s.potential(0.5 * ca.dot(a.x, a.x) + 0.1 * a.x[0])
    assert s.detect_momenta() == {}
    # a constant body moment is a load at u = 0: the rotation is no longer a symmetry
    s = mechanics.System("torqued")
    R = s.so3("R")
    s.rigid_body(1.0, s.inertia("J", np.diag([1.0, 2.0, 3.0])), R)
    s.moment(R, np.array([0.0, 0.0, 0.3]))
    assert s.detect_momenta() == {}


def test_declared_momenta_are_not_found_twice():
    s = cart_pendulum()
    s.momentum("px", translate={s.factor("x"): [1, 0]})
    found = s.detect_momenta()
    assert "linear_momentum_x_1" not in found
    assert set(found) == {"linear_momentum_x_2", "angular_momentum_e3"}


@pytest.mark.parametrize("make", [cart_pendulum, quadrotor, double_pendulum],
                         ids=["cart_pendulum", "quadrotor", "double_pendulum3d"])
def test_detected_momenta_are_conserved_along_cvodes(make):
    s = make()
    found = s.detect_momenta()
    assert "angular_momentum_e3" in found
    model = s.model()
    x0 = model.manifold.random_point(np.random.default_rng(3))
    traj = simulate(model, x0, np.linspace(0.0, 2.0, 41), rtol=1e-11, atol=1e-11)
    drift = traj.diagnostics["invariant_drift"]
    for name in found:
        scale = max(1.0, abs(drift[name]["initial"]))
        assert drift[name]["max_abs"] <= 1e-7 * scale, (name, drift[name])
    # energy is conserved too: the detection did not alter the equations
    assert drift["energy"]["max_abs"] <= 1e-7 * max(1.0, abs(drift["energy"]["initial"]))


@pytest.mark.parametrize("kw, match", [({"rtol": 0.0}, "rtol"), ({"rtol": "1e-9"}, "rtol"),
                                       ({"n_states": 0}, "n_states"),
                                       ({"n_states": 2.5}, "n_states")])
def test_bad_options_are_refused(kw, match):
    with pytest.raises(ModelError, match=match):
        cart_pendulum().detect_momenta(**kw)
