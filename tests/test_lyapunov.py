"""Lyapunov functions: V-dot from the graph against the papers' hand-derived derivatives.

Paper 001 Lemma 5: along u = -Psi(omega), V-dot = -omega^T Psi(omega) for V of (30);
V = E + m g |rho| (so V is conserved without control). Paper 003 A.6: along (21), (26),
V-dot = -k_ydot |y-dot|^2 for V of (25). Sublevel sets: membership and sampling.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import controllers as ctl
from models import pendulum3d as p3
from models.chain_cart import chain_cart
from tests.conftest import assert_close
from workbench.control._lyapunov import Lyapunov, SublevelSet, as_states
from workbench.core.errors import ModelError, SolverError
from workbench.simulation._simulate import simulate

J7 = np.array([[30.0, 20, 7], [20, 40, 0], [7, 0, 50]])
BODY = {"J": J7, "rho": np.array([0.1, -0.05, 0.2]), "m": 100.0, "g": 10.0}
P, K_SAT = np.diag([5.0, 10.0, 15.0]), 10.0
GAINS = {"k_y": 4.0, "k_ydot": 2.8, "k_w": 1.0, "k_q": 14.0}


def _states(model, rng, n, w_scale=1.0):
    return np.array([model.manifold.random_point(rng, scale=w_scale) for _ in range(n)])


@pytest.mark.parametrize("which", ["full", "reduced"])
def test_v30_derivative_is_minus_omega_psi(which, rng):
    model = getattr(p3, which)(**BODY)
    k = ctl.saturated_velocity_feedback(model, P=P, k=K_SAT)
    V = ctl.velocity_feedback_lyapunov(model)
    X = _states(model, rng, 20, w_scale=2.0)
    W = X[:, -3:]
    PW = W @ P.T
    psi = K_SAT * PW / (1 + np.linalg.norm(PW, axis=1, keepdims=True))
    ref = -np.einsum("ij,ij->i", W, psi)
    assert_close(V.derivative_values(X, k), ref, atol=1e-10, rtol=1e-12, what="Lemma 5")
    assert np.all(ref <= 0)


def test_v30_is_energy_plus_constant_and_conserved_open_loop(rng):
    model = p3.reduced(**BODY)
    V = ctl.velocity_feedback_lyapunov(model)
    X = _states(model, rng, 20, w_scale=3.0)
    E = np.array([model.invariants(x)["energy"] for x in X])
    mgr = BODY["m"] * BODY["g"] * np.linalg.norm(BODY["rho"])
    assert_close(V.values(X), E + mgr, atol=1e-10, rtol=1e-13, what="V = E + m g |rho|")
    assert_close(V.derivative_values(X), np.zeros(len(X)), atol=1e-10, what="open loop")
    gh = BODY["rho"] / np.linalg.norm(BODY["rho"])
    assert_close(V.values(np.r_[gh, 0, 0, 0]), [0.0], atol=1e-14, what="V(hanging)")
    assert_close(V.values(np.r_[-gh, 0, 0, 0]), [2 * mgr], atol=1e-10, what="V(inverted)")
    assert ctl.hanging_set_level(model) == pytest.approx(2 * mgr, rel=1e-15)


def test_v25_derivative_is_minus_k_ydot_ydot_squared(rng):
    cart = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    k = ctl.cart_inverted_feedback(cart, **GAINS)
    V = ctl.cart_lyapunov(cart, **GAINS)
    s = ctl.CartGains(**GAINS).s
    X = []
    while len(X) < 15:
        q = rng.standard_normal(3)
        q /= np.linalg.norm(q)
        if q[2] < -s - 0.05:
            w = rng.standard_normal(3)
            X.append(np.r_[rng.standard_normal(4), q, w - (w @ q) * q])
    X = np.array(X)
    yd = X[:, 2:4] - GAINS["k_q"] * 0.1 * np.cross(X[:, 4:7], X[:, 7:10])[:, :2]
    ref = -GAINS["k_ydot"] * np.sum(yd**2, axis=1)
    assert_close(V.derivative_values(X, k), ref, atol=1e-9, rtol=1e-10, what="A.6")


def test_monotonicity_detects_growth_and_decay(rng):
    model = p3.reduced(**BODY)
    V = ctl.velocity_feedback_lyapunov(model)
    x0 = np.r_[np.array([0.6, 0.0, 0.8]), 0.3, -0.2, 0.1]
    t = np.linspace(0.0, 5.0, 101)
    damped = simulate(model, x0, t, controller=ctl.angular_velocity_feedback(model, D=P))
    mono = V.monotonicity(damped, tolerance=1e-9)
    assert mono.ok and mono.max_increase == 0.0 and mono.Vf < mono.V0
    # negative damping u = +P omega: V grows (dV/dt = omega^T P omega > 0)
    xs, ps = ca.SX.sym("x", 6), ca.SX.sym("p", model.n_params)
    anti = ca.Function("anti", [xs, ps], [ca.DM(P) @ xs[3:6]])
    grown = simulate(model, x0, t, controller=anti)
    bad = V.monotonicity(grown, tolerance=1e-9)
    assert not bad.ok and bad.Vf > bad.V0 and bad.relative_increase > 1e-3


def test_lyapunov_rejects_nonscalar_and_wrong_states():
    model = p3.reduced(**BODY)
    V = Lyapunov(model, lambda ctx: ctx["omega"], name="not_scalar")
    with pytest.raises(ModelError, match="scalar"):
        V.function()
    with pytest.raises(ModelError, match=r"shape \(n, 6\)"):
        as_states(model, np.zeros((2, 5)))


def test_sublevel_set_membership_and_sampling(rng):
    model = p3.reduced(**BODY)
    V = ctl.velocity_feedback_lyapunov(model)
    level = ctl.hanging_set_level(model)
    gh = BODY["rho"] / np.linalg.norm(BODY["rho"])
    inverted = np.r_[-gh, 0, 0, 0]
    v_inv = float(V.values(inverted)[0])  # = level up to rounding: the boundary of N
    assert v_inv == pytest.approx(level, rel=1e-14)
    assert SublevelSet(V, v_inv).contains(inverted)[0]
    assert not SublevelSet(V, v_inv, strict=True).contains(inverted)[0]
    xs, ps = ca.SX.sym("x", 6), ca.SX.sym("p", model.n_params)
    upper = ca.Function("b", [xs, ps], [-xs[2]])  # D = {Gamma_3 > 0}
    cap = SublevelSet(V, level, domain=upper)

    def proposal(r: np.random.Generator, k: int) -> np.ndarray:
        g = r.standard_normal((k, 3))
        return np.c_[g / np.linalg.norm(g, axis=1, keepdims=True), r.uniform(-5, 5, (k, 3))]

    S, draws = cap.sample(proposal, 50, seed=3)
    assert S.shape == (50, 6) and draws >= 50
    assert np.all(V.values(S) <= level) and np.all(S[:, 2] > 0)
    with pytest.raises(SolverError, match="rejection sampling"):
        SublevelSet(V, 1e-9).sample(proposal, 5, max_draws=2000)


def test_derivatives_for_two_controllers_of_the_same_name_do_not_mix():
    model = p3.reduced(**BODY)
    V = ctl.velocity_feedback_lyapunov(model)
    X = np.array([[0.0, 0.0, 1.0, 1.0, 0.0, 0.0]] * 3)
    for kk in (1.0, 5.0, 1.0):
        k = ctl.saturated_velocity_feedback(model, P=np.eye(3), k=kk)
        assert_close(V.derivative_values(X, k), np.full(3, -kk / 2), atol=1e-14,
                     what=f"k = {kk}: V-dot = -k |w|^2 / (1 + |w|)")


# ----------------------------------------------------------------------------------------
# moved from test_review_engine.py


class _CountingDomain:
    """A domain b(x, p) that counts how often it is mapped over a batch."""

    def __init__(self, fn):
        self.fn, self.maps = fn, 0

    def map(self, n):
        self.maps += 1
        return self.fn.map(n)


def test_sublevel_set_maps_its_domain_once_per_batch_size(rng):
    model = p3.reduced(J=np.diag([3.0, 2.0, 1.0]), rho=[0.1, -0.05, 0.2])
    V = Lyapunov(model, lambda ctx: ca.dot(ctx["omega"], ctx["omega"]), name="kinetic")
    xs, ps = ca.SX.sym("x", 6), ca.SX.sym("p", model.n_params)
    domain = _CountingDomain(ca.Function("b", [xs, ps], [-xs[2]]))  # Gamma_3 > 0
    cap = SublevelSet(V, 1.0, domain=domain)
    X = np.array([model.manifold.random_point(rng) for _ in range(40)])
    first = cap.contains(X)
    assert_close(first, (np.sum(X[:, 3:] ** 2, axis=1) <= 1.0) & (X[:, 2] > 0), atol=0,
                 what="membership")
    for _ in range(3):
        assert_close(cap.contains(X), first, atol=0, what="same answer from the cache")
    cap.contains(X[:7])
    assert domain.maps == 2  # one map per batch size, not one per call
