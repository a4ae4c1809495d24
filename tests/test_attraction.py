"""Domain-of-attraction tools against closed forms, and the Monte-Carlo checks.

Closed forms used as independent checks: the extrema of V (30) on S^2 x R^3; for the
cart (paper 003, A.6) V >= k_w k_q g l (1 + q . e3) on the boundary of D with equality at
rest with y = 0, so min V on the boundary is k_w k_q g l (1 - s); the step-1 value
V(q1-tilde, 0, 0, 0) = k_q l (k_y k_q l (1 - s^2) / 2 + k_w g (1 - s)); ray extents of
quadratic parts; Clopper-Pearson bounds with k = 0 or n.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import controllers as ctl
from models import pendulum3d as p3
from models.chain_cart import chain_cart
from tests.conftest import assert_close
from workbench.control._attraction import (
    check_convergence,
    clopper_pearson,
    estimate_basin,
)
from workbench.control._lyapunov import SublevelSet, ray_extent
from workbench.core.errors import ParameterError

J7 = np.array([[30.0, 20, 7], [20, 40, 0], [7, 0, 50]])
BODY = {"J": J7, "rho": np.array([0.0, 0.0, 0.2]), "m": 100.0, "g": 10.0}
GAINS = {"k_y": 4.0, "k_ydot": 2.8, "k_w": 1.0, "k_q": 14.0}
L1, G = 0.1, 9.81
E3 = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def pend():
    model = p3.reduced(**BODY)
    return (model, ctl.saturated_velocity_feedback(model, P=np.diag([5.0, 10.0, 15.0]), k=10.0),
            ctl.velocity_feedback_lyapunov(model))


@pytest.fixture(scope="module")
def cart():
    model = chain_cart(1, m=0.5, masses=L1, lengths=L1, g=G)
    return (model, ctl.cart_inverted_feedback(model, **GAINS), ctl.cart_lyapunov(model, **GAINS),
            ctl.cart_domain(model, k_w=1.0, k_q=14.0), ctl.CartGains(**GAINS).s)


def _sym(model):
    S = model.sym
    return S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)


def _distance(model):
    x, p = _sym(model)
    return ca.Function("d", [x, p], [ca.norm_2(x[0:3] - ca.DM(E3)) + ca.norm_2(x[3:6])])


def _cart_starts(rng, n, s):
    out = []
    while len(out) < n:
        q = rng.standard_normal(3)
        q /= np.linalg.norm(q)
        if q[2] < -s:
            w = rng.uniform(-3, 3, 3)
            out.append(np.r_[rng.uniform(-2, 2, 4), q, w - (w @ q) * q])
    return np.array(out)


# ----------------------------------------------------------------------------------------


def test_clopper_pearson_closed_forms_and_symmetry():
    lo, hi = clopper_pearson(0, 10, confidence=0.95)
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** (1 / 10), rel=1e-12)
    lo, hi = clopper_pearson(10, 10, confidence=0.95)
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / 10), rel=1e-12)
    a = clopper_pearson(7, 40, confidence=0.9)
    b = clopper_pearson(33, 40, confidence=0.9)
    assert_close(a, [1 - b[1], 1 - b[0]], atol=1e-12, what="symmetry")
    with pytest.raises(ParameterError):
        clopper_pearson(3, 2)
    with pytest.raises(ParameterError):
        clopper_pearson(1, 2, confidence=1.0)


def test_ray_extents_of_the_certified_cart_set(cart):
    model, _, V, b, s = cart
    c = GAINS["k_w"] * GAINS["k_q"] * G * L1 * (1 - s)
    cert = SublevelSet(V, c, strict=True, domain=b)
    xe = np.r_[0, 0, 0, 0, 0, 0, -1.0, 0, 0, 0]
    r = ray_extent(cert, xe, np.eye(8)[[0, 2, 3]], s_max=10.0)
    assert_close(r, [np.sqrt(2 * c / GAINS["k_y"]), np.sqrt(2 * c / (1 + GAINS["k_w"])),
                     np.sqrt(2 * c / (1 + GAINS["k_w"]))], atol=1e-8, what="V quadratic")


def test_ray_extent_along_omega_in_N(pend):
    model, _, V = pend
    level = ctl.hanging_set_level(model)
    r = ray_extent(SublevelSet(V, level), np.r_[E3, 0, 0, 0], np.eye(5)[2:], s_max=20.0)
    assert_close(r, np.sqrt(2 * level / np.diag(J7)), atol=1e-8, what="omega^T J omega / 2")


def test_convergence_report_and_the_inverted_equilibrium(pend, rng):
    model, k, _ = pend
    g = rng.standard_normal((8, 3))
    X = np.c_[g / np.linalg.norm(g, axis=1, keepdims=True), 0.5 * rng.standard_normal((8, 3))]
    X = np.r_[X, np.r_[-E3, 0, 0, 0][None, :]]
    rep = check_convergence(model, k, X, distance=_distance(model), horizon=150.0,
                            tolerance=1e-4)
    assert rep.statuses[:8] == ["converged"] * 8
    assert rep.statuses[8] == "not converged" and rep.worst_index == 8
    assert rep.worst_distance == pytest.approx(2.0, abs=1e-12)  # stays inverted
    assert rep.failure_rate_bound > 1 / 9  # one failure in nine


def test_convergence_bound_when_all_converge(pend):
    model, k, _ = pend
    X = np.array([np.r_[E3, 0.1, 0, 0], np.r_[E3, 0, -0.2, 0.1]])
    rep = check_convergence(model, k, X, distance=_distance(model), horizon=100.0,
                            tolerance=1e-4, confidence=0.9)
    assert rep.all_converged
    assert rep.failure_rate_bound == pytest.approx(1 - 0.1 ** (1 / 2), rel=1e-10)


def test_leaving_the_domain_and_a_singular_feedback_are_reported(pend, cart):
    model, k, _ = pend
    x, p = _sym(model)
    lower = ca.Function("b", [x, p], [x[2] - 0.5])  # D = {Gamma_3 < 0.5}; the target leaves D
    rep = check_convergence(model, k, np.r_[0.6, 0, -0.8, 0, 0, 0][None, :],
                            distance=_distance(model), horizon=100.0, tolerance=1e-4,
                            domain=lower)
    assert rep.statuses[0].startswith("left the domain") and rep.n_failed == 1
    cmodel, ck, _, _, s = cart
    q = np.r_[np.sqrt(1 - s**2), 0, -s]  # on the singular surface of (26)
    rep = check_convergence(cmodel, ck, np.r_[0, 0, 0, 0, q, 0, 0, 0][None, :],
                            distance=ca.Function("d", [*_sym(cmodel)], [0]), horizon=1.0,
                            tolerance=1e-4, max_steps=500, check_interval=0.1)
    assert rep.statuses[0].startswith("integrator failed")


def test_basin_estimate_contains_the_certified_set(pend, rng):
    model, k, V = pend
    N = SublevelSet(V, ctl.hanging_set_level(model))
    g = rng.standard_normal((12, 3))
    X = np.c_[g / np.linalg.norm(g, axis=1, keepdims=True), rng.uniform(-6, 6, (12, 3))]
    est = estimate_basin(N, k, X, distance=_distance(model), horizon=150.0, tolerance=1e-4)
    assert est.n_certified_not_converged == 0
    assert est.n_converged >= int(N.contains(X).sum())
    assert est.basin_fraction[1] <= est.basin_fraction[0] <= est.basin_fraction[2]


@pytest.mark.slow
def test_almost_global_convergence_few_hundred_samples(pend):
    """Paper 001 Thm. 2: 300 seeded states over S^2 x R^3 all reach the hanging state."""
    model, k, _ = pend
    r = np.random.default_rng(7)
    g = r.standard_normal((300, 3))
    X = np.c_[g / np.linalg.norm(g, axis=1, keepdims=True), r.standard_normal((300, 3))]
    rep = check_convergence(model, k, X, distance=_distance(model), horizon=150.0,
                            tolerance=1e-4)
    assert rep.all_converged, rep.as_dict()
    assert rep.failure_rate_bound < 0.01
