"""workbench.mechanics: energy and momenta along simulations; dE/dt = input power - 2 D."""

from __future__ import annotations

import casadi as ca
import mechanics_systems as ms
import numpy as np
import pytest
from conftest import assert_close

from workbench import mechanics
from workbench.core.manifolds import SO3
from workbench.simulation._simulate import simulate


def _drift(model, x0, T=2.0):
    tr = simulate(model, x0, np.linspace(0.0, T, 41), rtol=1e-11, atol=1e-11)
    inv0 = model.invariants(x0)
    out = {}
    for k, v0 in inv0.items():
        vals = np.array([model.invariants(x)[k] for x in tr.x])
        out[k] = float(np.max(np.abs(vals - v0)))
    # the motion is not trivial: the state moved
    assert float(np.max(np.abs(tr.x[-1] - x0))) > 1e-2
    return out


@pytest.mark.parametrize("make", [
    lambda: ms.chain(3, masses=[0.2, 0.1, 0.15], lengths=[0.3, 0.2, 0.25]),
    lambda: ms.pendulum_on_cart(),
    lambda: ms.double_pendulum3d(),
    lambda: ms.quadrotor_slung_load(),
], ids=["chain3", "pendulum3d_cart", "double_pendulum3d", "quadrotor_slung_load"])
def test_energy_and_momenta_are_conserved(make, rng):
    model = make()
    x0 = model.manifold.random_point(rng)
    drift = _drift(model, x0)
    assert set(drift) == set(model.invariant_names) and "energy" in drift
    for k, d in drift.items():
        assert d < 1e-8, f"{model.name}: invariant {k} drifted by {d:.2e}"


def _energy_rate(model, x, u):
    E = model.function("energy")
    S = model.sym
    xs = S.sym("x", x.size)
    grad = ca.Function("g", [xs], [ca.gradient(E(xs, ca.DM(model.p)), xs)])
    return float(np.asarray(grad(x)).ravel() @ model.rhs(x, u))


def test_energy_rate_is_input_power_minus_dissipation_cart_pendulum(rng):
    c = 0.7
    model = ms.pendulum_on_cart(damping=c)
    for _ in range(5):
        x, u = model.manifold.random_point(rng), rng.standard_normal(5)
        v, W = x[2:4], x[13:16]
        power = u[0:2] @ v + u[2:5] @ W - c * (v @ v)  # 2 D = c |v|^2
        assert_close(_energy_rate(model, x, u), power, atol=1e-11, rtol=1e-11,
                     what="dE/dt = F.v + M.Omega - 2D")


def test_energy_rate_is_input_power_quadrotor(rng):
    model = ms.quadrotor_slung_load()
    for _ in range(5):
        x, u = model.manifold.random_point(rng), rng.standard_normal(4)
        vQ, R, W = x[3:6], SO3.matrix(x[6:15]), x[15:18]
        thrust_world = R @ np.array([0.0, 0.0, -u[0]])
        power = thrust_world @ vQ + u[1:4] @ W
        assert_close(_energy_rate(model, x, u), power, atol=1e-11, rtol=1e-11,
                     what="dE/dt = thrust.vQ + M.Omega")


def test_energy_rate_is_input_power_chain(rng):
    model = ms.chain(2, masses=[0.2, 0.3], lengths=[0.4, 0.1])
    for _ in range(5):
        x, u = model.manifold.random_point(rng), rng.standard_normal(2)
        assert_close(_energy_rate(model, x, u), u @ x[2:4], atol=1e-11, rtol=1e-11,
                     what="dE/dt = u.v")


def test_pendulum3d_vertical_momentum_is_the_papers(rng):
    J = np.diag([0.13, 0.28, 0.17])
    model = ms.pendulum3d(J, [0.0, 0.0, 0.3])
    for _ in range(3):
        x = model.manifold.random_point(rng)
        R, W = SO3.matrix(x[:9]), x[9:]
        assert_close(model.invariants(x)["h"], W @ J @ R.T @ np.array([0, 0, 1.0]),
                     atol=1e-14, what="h = omega . J R^T e3")


def _bead_on_spinning_hoop(kind: str):
    """A bead on a hoop spun at a fixed rate (T with a term of degree 0 in the velocity),
    or a charge in a magnetic field (a term of degree 1): T + V is not conserved, the
    Jacobi integral Pi . nu - T + V is."""
    s = mechanics.System(kind)
    if kind == "hoop":
        th = s.rn("th", 1, velocity="w")
        W, r, g = 2.0, 1.0, 9.81  # spin rate [rad/s], radius [m]
        s.kinetic(0.5 * r**2 * (th.v[0] ** 2 + W**2 * ca.sin(th.x[0]) ** 2))
        s.potential(-g * r * ca.cos(th.x[0]))
        x0 = np.array([0.7, 0.3])
    else:
        q = s.rn("q", 2, velocity="v")
        B = 1.5  # field along e3: A = B/2 (-y, x)
        s.kinetic(0.5 * ca.dot(q.v, q.v) + 0.5 * B * (q.x[0] * q.v[1] - q.x[1] * q.v[0]))
        s.potential(0.5 * ca.dot(q.x, q.x))
        x0 = np.array([0.4, -0.2, 0.3, 0.5])
    return s.model(), x0


@pytest.mark.parametrize("kind", ["hoop", "magnetic"])
def test_energy_is_the_jacobi_integral_when_t_is_not_quadratic(kind):
    model, x0 = _bead_on_spinning_hoop(kind)
    drift = _drift(model, x0, T=3.0)
    assert drift["energy"] < 1e-8
    # the closed form of the Jacobi integral at x0 (T + V would be off by 2 T0 - T1)
    if kind == "hoop":
        th, w = x0
        E = 0.5 * w**2 - 0.5 * 4.0 * np.sin(th) ** 2 - 9.81 * np.cos(th)
    else:
        q, v = x0[:2], x0[2:]
        E = 0.5 * v @ v + 0.5 * q @ q  # the magnetic term does no work
    assert_close(model.invariants(x0)["energy"], E, rtol=1e-14, atol=1e-14)


def test_energy_is_t_plus_v_when_t_is_quadratic(rng):
    """The usual case keeps E = T + V (not 2T - T + V, which rounds differently), and
    equals the Jacobi integral there."""
    model = ms.pendulum_on_cart()
    der = model.mechanics
    assert der.homogeneous
    parts = ca.Function("TV", [der.x, der.ing.p],
                        [der.T, der.V, ca.dot(der.Pi, der.nu) - der.T + der.V])
    for _ in range(3):
        x = model.manifold.random_point(rng)
        T, V, jacobi = (float(v) for v in parts(x, model.p))
        assert T > 0
        assert model.invariants(x)["energy"] == T + V
        assert_close(jacobi, T + V, rtol=1e-13, atol=1e-13)
