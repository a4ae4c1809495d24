"""Time-varying LQR in tangent coordinates: linearisation, Riccati recursion, closed loop."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import scipy.linalg as sla

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from workbench.control._tvlqr import closed_loop, perturbed_starts, tvlqr
from workbench.control.ocp import Stepper
from workbench.core.errors import ParameterError
from workbench.linear._linearize import linearize
from workbench.simulation._simulate import simulate

E3 = np.array([0.0, 0.0, 1.0])
BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
        "g": 9.81}


@pytest.fixture(scope="module")
def pendulum():
    return p3.reduced(**BODY)


def _reference(model, x0, u, dt, K):
    """An exact trajectory of the model under a constant input (CVODES)."""
    st = Stepper(model, rtol=1e-12, atol=1e-12)
    xs = [x0]
    for _ in range(K):
        xs.append(st.step(xs[-1], u, dt))
    return np.arange(K + 1) * dt, np.array(xs), np.tile(u, (K, 1))


def test_stepper_agrees_with_simulate(pendulum):
    x0 = pendulum.state(Gamma=[np.sin(0.4), 0.0, np.cos(0.4)], omega=[0.1, -0.2, 0.3])
    u = np.array([0.2, -0.1, 0.05])
    ctrl = ca.Function("u", [ca.SX.sym("x", 6)], [ca.DM(u)])
    ref = simulate(pendulum, x0, [0.0, 0.7], controller=ctrl, rtol=1e-12, atol=1e-12).final
    got = Stepper(pendulum, rtol=1e-12, atol=1e-12).step(x0, u, 0.7)
    assert np.allclose(got, ref, atol=1e-9)


def test_tangent_linearisation_matches_finite_differences_in_charts(pendulum):
    """A_k v = d/de chart(x_{k+1}, Phi(retract(x_k, e v), u_k)) at e = 0."""
    man = pendulum.manifold
    x0 = pendulum.state(Gamma=[np.sin(1.0), 0.3, np.cos(1.0)] / np.linalg.norm(
        [np.sin(1.0), 0.3, np.cos(1.0)]), omega=[0.5, -0.2, 0.1])
    t, X, U = _reference(pendulum, x0, np.array([0.1, 0.0, -0.2]), 0.05, 4)
    c = tvlqr(pendulum, t, X, U, x_eq=np.r_[-E3, 0, 0, 0], Q=1.0, R=1.0, rtol=1e-12)
    st = Stepper(pendulum, rtol=1e-12, atol=1e-12)
    k = 2
    # rebuild A_k from the gains' ingredients: compare with finite differences
    from workbench.control._tvlqr import _Flow

    flow = _Flow(pendulum, 1e-12)
    _, Fx, Fu = flow(X[k], U[k], c.dt)
    A = np.linalg.pinv(man.tangent_basis(X[k + 1])) @ Fx @ man.tangent_basis(X[k])
    rng = np.random.default_rng(0)
    v = rng.standard_normal(man.dim)
    eps = 1e-6
    plus = st.step(man.retract(X[k], eps * v), U[k], c.dt)
    minus = st.step(man.retract(X[k], -eps * v), U[k], c.dt)
    fd = (np.asarray(man.chart(X[k + 1], plus)) - np.asarray(man.chart(X[k + 1], minus))) / (
        2 * eps)
    assert np.allclose(A @ v, fd, atol=1e-6)
    assert Fu.shape == (6, 3)


def test_riccati_along_an_equilibrium_converges_to_the_dare(pendulum):
    """Backward from S_inf along the constant reference x_eq, S_k stays at S_inf."""
    xe = np.r_[-E3, 0.0, 0.0, 0.0]
    t, X, U = _reference(pendulum, xe, np.zeros(3), 0.05, 20)
    c = tvlqr(pendulum, t, X, U, x_eq=xe, Q=np.r_[10, 10, 1, 1, 1], R=1.0)
    for k in range(len(U)):
        assert np.allclose(c.S[k], c.S_eq, rtol=1e-7, atol=1e-9)
        assert np.allclose(c.gains[k], c.gain_eq, rtol=1e-7, atol=1e-9)
    assert c.info["closed_loop_spectral_radius_eq"] < 1
    for S in c.S:
        assert np.allclose(S, S.T) and np.linalg.eigvalsh(S).min() > 0


def test_discrete_equilibrium_linearisation_is_the_exponential_of_the_continuous_one(
        pendulum):
    """Independent check against workbench.linear._linearize: A_d = expm(A_c dt) in one basis."""
    xe = np.r_[-E3, 0.0, 0.0, 0.0]
    dt = 0.02
    t, X, U = _reference(pendulum, xe, np.zeros(3), dt, 2)
    from workbench.control._tvlqr import _Flow

    _, Fx, Fu = _Flow(pendulum, 1e-12)(xe, np.zeros(3), dt)
    N = pendulum.manifold.tangent_basis(xe)
    Ad = np.linalg.pinv(N) @ Fx @ N
    lin = linearize(pendulum, xe, basis=N)
    assert np.allclose(Ad, sla.expm(np.asarray(lin.A) * dt), atol=1e-9)


def test_lqr_closed_loop_stabilises_the_inverted_cart():
    model = chain_cart(1)
    xe = np.r_[0.0, 0.0, 0.0, 0.0, link_state(-E3)]
    dt = 0.02
    t, X, U = _reference(model, xe, np.zeros(2), dt, 5)
    c = tvlqr(model, t, X, U, x_eq=xe, Q=np.r_[100, 100, 10, 10, 100, 100, 1, 1], R=0.1)
    starts = perturbed_starts(model, xe, n=3, scale=0.05, seed=4)
    for x0 in starts:
        assert max(model.manifold.residual_norms(x0).values()) < 1e-12
        e0 = np.max(np.abs(np.asarray(model.manifold.chart(xe, x0))))
        run = closed_loop(c, x0, hold=3.0, tol=1e-2 * e0)
        assert run.success, (run.final_error, e0)


def test_bad_weights_and_non_equilibria_are_rejected(pendulum):
    xe = np.r_[-E3, 0.0, 0.0, 0.0]
    t, X, U = _reference(pendulum, xe, np.zeros(3), 0.05, 2)
    with pytest.raises(ParameterError, match="R must be positive definite"):
        tvlqr(pendulum, t, X, U, x_eq=xe, R=0.0)
    with pytest.raises(ParameterError, match="Q must be"):
        tvlqr(pendulum, t, X, U, x_eq=xe, Q=np.ones((2, 2)))
    with pytest.raises(ParameterError, match="not an equilibrium"):
        tvlqr(pendulum, t, X, U, x_eq=np.r_[np.sin(0.3), 0, np.cos(0.3), 0, 0, 0])
    with pytest.raises(ParameterError, match="x_ref must have shape"):
        tvlqr(pendulum, t, X[:-1], U, x_eq=xe)
