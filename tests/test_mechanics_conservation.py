"""workbench.mechanics: energy and momenta along simulations; dE/dt = input power - 2 D."""

from __future__ import annotations

import casadi as ca
import mechanics_systems as ms
import numpy as np
import pytest
from conftest import assert_close

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
