"""Extrema on the state manifold by Ipopt (workbench/control/_certify.py), against closed forms.

The extrema of V (30) on S^2 x R^3 (max 2 m g |rho| at the inverted state at rest, min on a
circle Gamma_3 = c0 of m g |rho| (1 - c0)) and the two-step certification of paper 003
(A.6): step 1 V(q1-tilde, 0, 0, 0) = k_q l (k_y k_q l (1 - s^2) / 2 + k_w g (1 - s)), step 2
min V on the boundary of D = k_w k_q g l (1 - s).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from test_attraction import BODY, E3, GAINS, L1, G, _cart_starts, _sym

from models import controllers as ctl
from models import pendulum3d as p3
from models.chain_cart import chain_cart
from tests.conftest import assert_close
from workbench.control._certify import Constraint, level_in_domain, optimize_lyapunov
from workbench.core.errors import SolverError


@pytest.fixture(scope="module")
def pend():
    model = p3.reduced(**BODY)
    return model, None, ctl.velocity_feedback_lyapunov(model)


@pytest.fixture(scope="module")
def cart():
    model = chain_cart(1, m=0.5, masses=L1, lengths=L1, g=G)
    return (model, None, ctl.cart_lyapunov(model, **GAINS),
            ctl.cart_domain(model, k_w=1.0, k_q=14.0), ctl.CartGains(**GAINS).s)


def test_extrema_of_v30_by_ipopt(pend, rng):
    model, _, V = pend
    mgr = BODY["m"] * BODY["g"] * 0.2
    x, p = _sym(model)
    rest = Constraint(ca.Function("w", [x, p], [x[3:6]]), 0.0, 0.0, "omega = 0")
    starts = np.array([model.manifold.random_point(rng) for _ in range(4)])
    top = optimize_lyapunov(V, starts, maximize=True, constraints=[rest])
    assert top.value == pytest.approx(2 * mgr, rel=1e-9)
    assert_close(top.x[:3], -E3, atol=1e-5, what="argmax = inverted")
    # min of V on the circle Gamma_3 = c0: m g |rho| (1 - c0), at omega = 0
    c0 = 0.3
    circle = ca.Function("b", [x, p], [x[2] - c0])
    low = level_in_domain(V, circle, starts)
    assert low.value == pytest.approx(mgr * (1 - c0), rel=1e-9)
    assert low.n_success == 4 and low.spread < 1e-9 * low.value and low.constraint_violation < 1e-9


def test_infeasible_program_raises_with_ipopt_status(pend, rng):
    model, _, V = pend
    x, p = _sym(model)
    impossible = Constraint(ca.Function("b", [x, p], [x[2]]), 2.0, 3.0, "Gamma_3 >= 2")
    with pytest.raises(SolverError, match=r"Ipopt failed from all 2 starts.*status:"):
        optimize_lyapunov(V, [model.manifold.random_point(rng) for _ in range(2)],
                          constraints=[impossible], max_iter=200)


def test_two_step_construction_of_paper_003_closed_forms(cart, rng):
    model, _, V, b, s = cart
    ky, _, kw, kq = GAINS.values()
    x, p = _sym(model)
    rest = Constraint(ca.Function("r", [x, p], [ca.vertcat(x[0:4], x[7:10])]), 0.0, 0.0)
    step1 = optimize_lyapunov(V, _cart_starts(rng, 4, s), maximize=True,
                              constraints=[rest, Constraint(b, -np.inf, 0.0)])
    ref1 = kq * L1 * (0.5 * ky * kq * L1 * (1 - s**2) + kw * G * (1 - s))
    assert step1.value == pytest.approx(ref1, rel=1e-7)
    assert step1.x[6] == pytest.approx(-s, abs=1e-7)
    step2 = level_in_domain(V, b, _cart_starts(rng, 6, s))
    assert step2.value == pytest.approx(kw * kq * G * L1 * (1 - s), rel=1e-9)
