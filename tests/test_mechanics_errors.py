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
    (lambda s, c, k: s.rn("z", 0), r"integer in \[1, 100000\]; got 0"),
        (lambda s, c, k: s.rn("z", 10**9), r"integer in \[1, 100000\]; got 1000000000"),
        (lambda s, c, k: s.rn("z", 1, velocity="z"), "need different names"),
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
    (lambda s, c, k, m: s.momentum("px", translate={c: [1.0]}), r"shape \(2, 1\)"),
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


def test_new_parameter_values_get_the_build_checks():
    """with_parameters (and find_equilibrium(params=...)) re-run the physics checks."""
    s, *_ = _cart_pendulum()
    model = s.model()
    with pytest.raises(ModelError, match="kinetic energy is not positive definite"):
        model.with_parameters(m=-1.0)
    with pytest.raises(ModelError, match="kinetic energy is singular"):
        model.with_parameters(l=0.0)
    assert model.with_parameters(m=2.0).values["m"] == 2.0  # a physical value passes
    from workbench import find_equilibrium

    with pytest.raises(ModelError, match="not positive definite"):
        find_equilibrium(model, model.manifold.random_point(np.random.default_rng(0)),
                         params={"m": -0.5})


def test_inertia_made_of_parameters_is_checked_with_their_values():
    s = mechanics.System("b")
    body = s.so3("R")
    J = s.parameter("J", np.diag([1.0, 2.0, 2.5]))  # declared with the default check only
    s.rigid_body(1.0, J, body)
    model = s.model()
    bad = np.diag([1.0, 2.0, 2.5])
    bad[0, 1] = 0.3  # Omega^T J Omega would use (J + J^T)/2 without a word
    with pytest.raises(ModelError, match="'body1'.*must be symmetric"):
        model.with_parameters(J=bad)
    with pytest.raises(ModelError, match="'body1'.*positive definite"):
        model.with_parameters(J=np.diag([1.0, -2.0, 2.5]))


def test_attitude_expression_must_be_a_rotation():
    def hoop(A):
        s = mechanics.System("hoop")
        th = s.rn("th", 1)
        c, sn = ca.cos(th.x[0]), ca.sin(th.x[0])
        Rz = ca.vertcat(ca.horzcat(c, -sn, 0), ca.horzcat(sn, c, 0), ca.horzcat(0, 0, 1))
        s.rigid_body(1.0, np.diag([1.0, 1.0, 1.5]), ca.DM(A) @ Rz, name="disc")
        return s.model()

    assert hoop(np.eye(3)).n_params == 0
    with pytest.raises(ModelError, match="'disc'.*must be a rotation.*det R = 8"):
        hoop(2.0 * np.eye(3))
    with pytest.raises(ModelError, match="'disc'.*must be a rotation.*det R = -1"):
        hoop(np.diag([1.0, 1.0, -1.0]))


def test_gravity_once_and_unit_with_parameter_values():
    s, cart, link, m, _ = _cart_pendulum()
    s.gravity(9.81)
    with pytest.raises(ModelError, match="gravity is declared once"):
        s.gravity(9.81)
    s, cart, link, m, _ = _cart_pendulum()
    d = s.parameter("d", [0.0, 0.0, 1.0])
    s.gravity(9.81, d)
    model = s.model()
    with pytest.raises(ModelError, match="direction must be a unit vector.*norm 2"):
        model.with_parameters(d=[0.0, 0.0, 2.0])
    s, cart, link, m, _ = _cart_pendulum()
    with pytest.raises(ModelError, match="direction"):
        s.gravity(9.81, ca.vertcat(cart.x, 1.0))  # not a function of parameters


def test_dissipation_must_take_energy_out():
    s, cart, link, m, _ = _cart_pendulum()
    c = s.parameter("c", 0.3)
    s.dissipation(0.5 * c * ca.dot(cart.v, cart.v))
    model = s.model()
    with pytest.raises(ModelError, match="dissipation function must be >= 0"):
        model.with_parameters(c=-0.3)
    s, cart, link, m, _ = _cart_pendulum()
    s.dissipation(-0.5 * ca.dot(cart.v, cart.v))
    with pytest.raises(ModelError, match="dissipation function must be >= 0"):
        s.model()


def test_momentum_check_is_relative_at_small_scales():
    """A spring of 1e-15 N/m breaks the cart's momentum just as much, relatively."""
    s = mechanics.System("tiny")
    cart = s.rn("x", 1)
    M, k = s.parameter("M", 1e-15), s.parameter("k", 1e-15)
    s.point_mass(M, cart.x)
    s.potential(0.5 * k * cart.x[0] ** 2)
    s.momentum("px", translate={cart: [1.0]})
    with pytest.raises(ModelError, match="'px' is not conserved"):
        s.model()


@pytest.mark.parametrize("name", ["p", "x", "u", "f"])
def test_momentum_names_must_not_shadow_function_inputs(name):
    s, cart, link, m, _ = _cart_pendulum()
    with pytest.raises(ModelError, match="momentum name must not be one of"):
        s.momentum(name, translate={cart: [1.0, 0.0]})


@pytest.mark.parametrize("call, error, fragment", [
    (lambda s, c: s.momentum("L", rotate=[0.0, 0.0, 0.0]), ModelError, "generator is zero"),
    (lambda s, c: s.parameter("k", 1.0, check=3), ModelError, "must be callable"),
    (lambda s, c: s.parameter("k", 1.0, shape="x"), ModelError, "tuple of integers"),
    (lambda s, c: s.parameter("k", []), ParameterError, "at least one entry"),
    (lambda s, c: s.model(check="no"), ModelError, "True or False"),
    (lambda s, c: s.model(name="a\nb"), ModelError, "model name must be an identifier"),
])
def test_bad_declarations_named(call, error, fragment):
    s, cart, *_ = _cart_pendulum()
    with pytest.raises(error, match=fragment):
        call(s, cart)


def test_input_count_is_bounded():
    s, *_ = _cart_pendulum()
    with pytest.raises(ModelError, match=r"integer in \[1, 100000\]; got 100000000"):
        s.input(10**8)


def test_a_symbol_of_another_system_is_foreign_even_with_the_same_name():
    other = mechanics.System("other")
    k_other = other.parameter("k", 2.0)
    x_other = other.rn("x", 2)
    s, cart, link, m, _ = _cart_pendulum()
    s.parameter("k", 1.0)
    with pytest.raises(ModelError, match="did not create.*another System"):
        s.potential(0.5 * k_other * ca.dot(cart.x, cart.x))
    with pytest.raises(ModelError, match="did not create"):
        s.point_mass(1.0, ca.vertcat(x_other.x, 0))


@pytest.mark.parametrize("M, m, length", [(1.0, 1.0, 1e-12), (1e11, 1.0, 0.3),
                                           (1.0, 1e-9, 0.3)])
def test_positive_definite_test_does_not_depend_on_units(M, m, length):
    """Valid systems of very different scales build: the test scales the mass matrix to a
    unit diagonal (singular ones are still refused, tests above)."""
    s = mechanics.System("cart_pendulum")
    cart, link = s.rn("x", 1), s.s2("q")
    pivot = ca.vertcat(cart.x, 0, 0)
    s.point_mass(M, pivot)
    s.point_mass(m, pivot + length * link.q)
    model = s.model()
    assert model.manifold.dim == 6
    s = mechanics.System("rotor")
    body = s.so3("R")
    s.rigid_body(1.0, np.diag([1.0, 1e14, 1e14]), body)
    s.model()



def test_mass_matrix_singular_at_one_state_is_reported_not_a_numpy_error():
    """A massless cart with the link hanging straight down: M is singular there only."""
    from workbench import find_equilibrium, linearize
    from workbench.core.errors import SolverError

    s = mechanics.System("massless_cart")
    cart, link = s.rn("x", 1, velocity="v"), s.s2("q")
    pivot = ca.vertcat(cart.x, 0, 0)
    s.point_mass(s.parameter("M", 0.0), pivot, name="cart")
    s.point_mass(0.5, pivot + 0.8 * link.q, name="bob")
    s.gravity(9.81)
    model = s.model()  # positive definite at the (random) check state
    x = model.state(x=[0.0], v=[0.0], q=[0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    with pytest.raises(ModelError, match="not finite.*singular solve"):
        model.rhs(x)
    # linearize checks the kinetic energy at x_e first and names its null direction
    with pytest.raises(ModelError, match="at x_e: the kinetic energy is singular at the state"):
        linearize(model, x)
    with pytest.raises(SolverError, match="not finite at the start.*status: diverged"):
        find_equilibrium(model, x)


def test_detect_momenta_seed_and_body_force_point_are_checked():
    s, cart, link, m, _ = _cart_pendulum()
    with pytest.raises(ModelError, match="seed must be an integer >= 0; got 'a'"):
        s.detect_momenta(seed="a")
    s = mechanics.System("b")
    body = s.so3("R")
    rb = s.rigid_body(1.0, np.eye(3), body)
    with pytest.raises(ModelError, match="needs a 3-vector point"):
        s.force_at(ca.DM([0.0, 1.0]), [1.0, 0.0], body=rb)


def test_the_state_check_screens_many_states_as_the_single_state_check_decides():
    """Two independent computations of the tangent mass matrix's spectrum: the batch
    (all states in one casadi call, its own orthonormal basis of each T_q S^2) and
    :func:`check_kinetic_energy` (``velocity_basis``, one state at a time) give the same
    eigenvalues (an orthonormal change of basis keeps them), and the check passes or fails
    on the same states."""
    from scipy.linalg import block_diag

    from workbench.mechanics._factors import S2Factor
    from workbench.mechanics._state_check import StateCheck, _sphere_bases

    rng = np.random.default_rng(7)
    for model in (ms.spherical(), ms.quadrotor_slung_load(), ms.chain(2)):
        check, der = model.state_check, model.mechanics
        X = np.array([model.manifold.random_point(rng) for _ in range(50)])
        M = np.asarray(check.mass_matrix(X.T, model.p)).reshape(
            der.n_nu, 50, der.n_nu).transpose(1, 0, 2)
        for x, Mx in zip(X, M):
            blocks, blocks_ref, kx = [], [], 0
            for f in der.ing.factors:
                B = f.velocity_basis(x[kx:kx + f.config_sym.shape[0]])
                blocks_ref.append(B)
                sphere = isinstance(f, S2Factor)
                blocks.append(_sphere_bases(x[None, kx:kx + 3])[0] if sphere else B)
                kx += sum(s.shape[0] for s in f.state_symbols())
            N, N_ref = block_diag(*blocks), block_diag(*blocks_ref)
            assert np.allclose(N.T @ N, np.eye(N.shape[1]), atol=1e-14)
            a = np.linalg.eigvalsh(N.T @ Mx @ N)
            b = np.linalg.eigvalsh(N_ref.T @ Mx @ N_ref)
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * np.max(np.abs(b)))
        check(model, X, t=np.arange(50.0), what="random states")  # all positive definite
    # a link on a cart whose inertia turns negative for q3 < 0.3: the batch screen flags
    # every state the single-state check refuses (and only states near or past the limit)
    s = mechanics.System("half_bad")
    cart, link = s.rn("x", 2), s.s2("q")
    s.point_mass(1.0, ca.vertcat(cart.x, 0))
    w = ca.cross(link.omega, link.q)
    s.kinetic(0.5 * (link.q[2] - 0.3) * ca.dot(w, w) + 0.1 * ca.dot(cart.v, w[0:2]))
    s.kinetic(0.5 * 1e-3 * ca.dot(w, w))
    model = s.model(check=False)
    X = np.array([model.manifold.random_point(rng) for _ in range(400)])
    check = StateCheck(model.mechanics, s.factors)  # check=False: none on the model
    screened = set(check._screen(X, model.p).tolist())  # noqa: SLF001
    refused = set()
    for k, x in enumerate(X):
        try:
            mechanics.check_kinetic_energy(model.mechanics, s.factors, x, model.p)
        except ModelError:
            refused.add(k)
    assert 50 < len(refused) < 350 and refused <= screened
    assert len(screened - refused) <= 2  # within SCREEN of the limit: decided one by one
    s = mechanics.System("where_many")
    x = s.rn("x", 1)
    s.kinetic(0.5 * (1 + x.x[0]) ** 2 * x.v[0] ** 2)
    model = s.model()
    X = np.column_stack([np.linspace(1.0, -3.0, 9), np.zeros(9)])  # x = -1 at state 4
    with pytest.raises(ModelError, match=r"along the path, at t = 0.4 \(state 4 of 9\): the "
                                         r"kinetic energy is singular at the state x = \[-1"):
        model.state_check(model, X, t=np.linspace(0.0, 0.8, 9), what="the path")
