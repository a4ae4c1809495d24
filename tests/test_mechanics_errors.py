"""workbench.mechanics: bad input is refused with a message naming what is wrong."""

from __future__ import annotations

import casadi as ca
import mechanics_systems as ms
import numpy as np
import pytest

from workbench import mechanics
from workbench.core.errors import ModelError, ParameterError


def _cart_pendulum(**kw):
    s = mechanics.System("cp")
    cart = s.rn("x", 2, velocity="v")
    link = s.s2("link")
    m, l = s.parameter("m", 0.5), s.parameter("l", 0.3)  # noqa: E741
    s.point_mass(m, ca.vertcat(cart.x, 0))
    s.point_mass(m, ca.vertcat(cart.x, 0) + l * link.q)
    return s, cart, link, m, l


def test_errors_are_value_errors():
    assert issubclass(ModelError, ValueError) and issubclass(ParameterError, ValueError)


@pytest.mark.parametrize("value, fragment", [
    (np.nan, "finite"), (np.inf, "finite"), (1 + 2j, "complex"), (True, "bool"),
    ("heavy", "numeric"), (np.zeros((2, 2, 2)), "scalar, vector or matrix")])
def test_bad_parameter_values(value, fragment):
    s = mechanics.System("p")
    with pytest.raises(ParameterError, match=fragment) as err:
        s.parameter("m", value)
    assert "'m'" in str(err.value)


@pytest.mark.parametrize("J, fragment", [
    (np.diag([1.0, 1.0, 3.0]), "triangle inequality"),
    (np.diag([1.0, -1.0, 1.0]), "positive definite"),
    (np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "symmetric"),
    (np.eye(2), "3x3")])
def test_non_physical_inertias(J, fragment):
    s = mechanics.System("b")
    body = s.so3("R")
    with pytest.raises(ParameterError, match=fragment):
        s.inertia("J", J)
    with pytest.raises(ParameterError, match=fragment):
        s.rigid_body(1.0, J, body)


def test_inertia_parameter_checked_again_on_new_values():
    model = ms.pendulum_on_cart()
    with pytest.raises(ParameterError, match="triangle"):
        model.with_parameters(J=np.diag([0.1, 0.1, 0.5]))


def test_kinetic_energy_missing_a_velocity():
    s, cart, link, m, _ = _cart_pendulum()
    s.rn("y", 1)
    with pytest.raises(ModelError, match="does not depend on the velocity of factor 'y'"):
        s.model()


def test_kinetic_energy_singular_names_the_factor():
    s = mechanics.System("sing")
    body = s.so3("R", velocity="W")
    s.kinetic(0.5 * body.Omega[0] ** 2 + 0.5 * body.Omega[1] ** 2)  # no inertia about e3
    with pytest.raises(ModelError, match=r"singular .*factor 'R'"):
        s.model()


def test_kinetic_energy_not_positive_definite():
    s = mechanics.System("neg")
    x = s.rn("x", 1)
    s.kinetic(-0.5 * x.v[0] ** 2)
    with pytest.raises(ModelError, match="not positive definite"):
        s.model()


def test_kinetic_energy_singular_at_a_given_state():
    s = mechanics.System("where")
    x = s.rn("x", 1)
    s.kinetic(0.5 * (1 + x.x[0]) ** 2 * x.v[0] ** 2)
    model = s.model()  # positive definite at the check state
    with pytest.raises(ModelError, match=r"x = \[-1\.  0\.\].*factor 'x'"):
        mechanics.check_kinetic_energy(model.mechanics, s.factors, np.array([-1.0, 0.0]),
                                       model.p)


def test_positions_and_potentials_must_not_depend_on_velocities_or_inputs():
    s, cart, link, m, _ = _cart_pendulum()
    with pytest.raises(ModelError, match=r"position .*velocity .*'v'"):
        s.point_mass(m, ca.vertcat(cart.v, 0))
    u = s.input(2)
    with pytest.raises(ModelError, match="potential energy V .*input"):
        s.potential(u[0] * cart.x[0])
    with pytest.raises(ModelError, match=r"mass .*configuration"):
        s.point_mass(m * link.q[2], link.q)


@pytest.mark.parametrize("call, fragment", [
    (lambda s, c, k: s.force("nope", [1.0, 0.0]), "unknown factor 'nope'"),
    (lambda s, c, k: s.moment("nope", [0.0, 0.0, 1.0]), "unknown factor 'nope'"),
    (lambda s, c, k: s.force_at(c.x[0] * ca.DM.ones(3), [1.0, 0, 0], body="arm"),
     "unknown rigid body 'arm'"),
    (lambda s, c, k: s.force(k, [1.0, 0.0, 0.0]), r"acts on R\^k factors; 'link' is S\^2"),
    (lambda s, c, k: s.moment(c, [1.0, 0.0, 0.0]), r"acts on S\^2 or SO\(3\) factors"),
    (lambda s, c, k: s.momentum("px", translate={k: [1.0, 0.0, 0.0]}), "R\\^k factors"),
    (lambda s, c, k: s.momentum("energy", translate={c: [1.0, 0.0]}), "already used"),
    (lambda s, c, k: s.rn("x", 2), "already used"),
    (lambda s, c, k: s.rn("z", 0), "integer >= 1"),
])
def test_unknown_names_and_misused_factors(call, fragment):
    s, cart, link, m, _ = _cart_pendulum()
    with pytest.raises(ModelError, match=fragment):
        call(s, cart, link)


@pytest.mark.parametrize("call, fragment", [
    (lambda s, c, k, m: s.point_mass(m, ca.vertcat(c.x, 0, 0)), "1 to 3 coordinates"),
    (lambda s, c, k, m: s.force(c, [1.0, 2.0, 3.0]), r"force must have shape \(2, 1\)"),
    (lambda s, c, k, m: s.moment(k, [1.0, 2.0]), r"moment must have shape \(3, 1\)"),
    (lambda s, c, k, m: s.kinetic(c.v), r"kinetic energy T must have shape \(1, 1\)"),
    (lambda s, c, k, m: s.momentum("p", translate={c: [1.0]}), r"shape \(2, 1\)"),
    (lambda s, c, k, m: s.rigid_body(m, np.eye(3), k.q), r"attitude must have shape"),
])
def test_wrong_shapes(call, fragment):
    s, cart, link, m, _ = _cart_pendulum()
    with pytest.raises(ModelError, match=fragment):
        call(s, cart, link, m)


def test_foreign_and_mx_symbols_and_bad_numbers():
    s, cart, link, m, _ = _cart_pendulum()
    with pytest.raises(ModelError, match="did not create"):
        s.potential(ca.SX.sym("z") * cart.x[0])
    with pytest.raises(ModelError, match="MX"):
        s.potential(ca.MX.sym("z"))
    with pytest.raises(ParameterError, match="positive"):
        s.point_mass(-1.0, ca.vertcat(cart.x, 0))
    with pytest.raises(ParameterError, match="finite"):
        s.force(cart, [np.nan, 0.0])
    with pytest.raises(ParameterError, match="unit vector"):
        s.gravity(9.81, direction=[0.0, 0.0, 2.0])


def test_wrong_momentum_declaration_is_caught():
    s, cart, link, m, _ = _cart_pendulum()
    s.potential(0.5 * ca.dot(cart.x, cart.x))  # a spring ties the cart to the origin
    s.momentum("px", translate={cart: [1.0, 0.0]})
    with pytest.raises(ModelError, match="'px' is not conserved"):
        s.model()


def test_bad_model_options():
    s, *_ = _cart_pendulum()
    with pytest.raises(ModelError, match="symbolic"):
        s.model(symbolic="dense")
    with pytest.raises(ModelError, match="linsol"):
        s.model(linear_solver="gauss")
    with pytest.raises(ModelError, match="no factors"):
        mechanics.System("empty").model()
