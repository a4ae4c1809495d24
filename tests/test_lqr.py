"""LQR: weights validated, refusal of uncontrollable pairs, Riccati solution, geometric law."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as sla
from conftest import assert_close

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from models.controllers import angular_velocity_feedback
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import so3_exp
from workbench.linear._linearize import linearize, mechanical_order
from workbench.linear._lqr import Requirement, geometric_feedback, lqr
from workbench.simulation._simulate import simulate

E3 = np.array([0.0, 0.0, 1.0])


def chain_lin(n, s):
    model = chain_cart(n)
    x_e = np.concatenate([np.zeros(4)] + [link_state(si * E3) for si in s])
    pos, vel = mechanical_order(model, {"x": "v"})
    return model, linearize(model, x_e).permuted(pos + vel)


def test_gain_solves_the_riccati_equation_independently_checked():
    model, lin = chain_lin(2, (-1.0, 1.0))
    Q = np.diag(np.r_[8, 8, np.ones(4), 8, 8, np.ones(4)])
    R = np.diag([1.0, 2.0])
    res = lqr(lin, Q, R)
    P = sla.solve_continuous_are(lin.A, lin.B, Q, R)  # the independent check
    assert_close(res.P, P, atol=1e-8 * np.max(np.abs(P)), what="P")
    assert_close(res.K, np.linalg.solve(R, lin.B.T @ P), atol=1e-7 * np.max(np.abs(res.K)),
                 what="K = R^-1 B' P")
    assert res.riccati_residual < 1e-10
    # the closed-loop spectrum is the stable half of the Hamiltonian matrix's spectrum
    # [[A, -B R^-1 B'], [-Q, -A']] (an independent route: no Riccati solution, no gain)
    H = np.block([[lin.A, -lin.B @ np.linalg.solve(R, lin.B.T)], [-Q, -lin.A.T]])
    hs = np.linalg.eigvals(H)
    stable = hs[hs.real < 0]
    assert stable.size == lin.dim
    pool = list(stable)  # matched as multisets: each value takes its nearest remaining one
    matched = np.array([pool.pop(int(np.argmin(np.abs(np.array(pool) - z))))
                        for z in res.closed_loop_eigenvalues])
    assert_close(res.closed_loop_eigenvalues, matched, atol=1e-7 * np.max(np.abs(hs)),
                 what="closed-loop spectrum vs stable Hamiltonian eigenvalues")
    assert res.method in ("scipy", "slycot") and res.controllability.controllable


def test_geometric_feedback_linearises_to_minus_k_and_stabilises_the_nonlinear_chain():
    model, lin = chain_lin(2, (-1.0, -1.0))  # the inverted double pendulum on a cart
    Q = np.eye(lin.dim)
    res = lqr(lin, Q, np.eye(2))
    k = res.feedback()
    pos, vel = mechanical_order(model, {"x": "v"})
    closed = linearize(model, lin.x_e, controller=k).permuted(pos + vel)
    assert_close(closed.A, lin.A - lin.B @ res.K, atol=1e-9 * np.max(np.abs(lin.A)),
                 what="closed-loop linearisation of the nonlinear law")
    # it is a smooth law on the full state: from a perturbed state the chain is caught
    x0 = lin.x_e.copy()
    x0[:2] = [0.05, -0.02]
    tilt = so3_exp([0.03, -0.02, 0.0])
    x0[4:7] = tilt @ x0[4:7]
    tr = simulate(model, x0, np.linspace(0.0, 15.0, 151), controller=k, rtol=1e-10,
                  atol=1e-10)
    e = np.linalg.norm(tr.final - lin.x_e)
    assert e < 1e-4, e


def test_law_for_a_closed_loop_linearisation_adds_to_the_controller():
    model = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.3])
    k0 = angular_velocity_feedback(model, D=np.eye(3))
    x_e = model.state(R=so3_exp([np.pi, 0.0, 0.0]), omega=np.zeros(3))
    lin = linearize(model, x_e, controller=k0)
    res = lqr(lin, np.eye(6), np.eye(3))
    law = geometric_feedback(lin, res.K)
    x = model.manifold.retract(x_e, 1e-3 * np.arange(1.0, 7.0))
    total = np.asarray(law(x, model.p)).ravel()
    expected = np.asarray(k0(x, model.p)).ravel() - res.K @ lin.chart(x)
    assert_close(total, expected, atol=1e-14, what="k0 + u_e - K z")
    closed = linearize(model, x_e, controller=law)
    assert np.max(np.linalg.eigvals(closed.A).real) < 0


@pytest.mark.parametrize(
    ("Q", "R", "pattern"),
    [
        (np.eye(5), np.eye(2), r"Q must have shape \(12, 12\)"),
        (np.eye(12), np.eye(3), r"R must have shape \(2, 2\)"),
        (np.diag(np.r_[-1.0, np.ones(11)]), np.eye(2), "positive semi-definite.*smallest -1"),
        (np.eye(12) + np.triu(np.ones((12, 12)), 1), np.eye(2), "Q must be symmetric"),
        (np.eye(12), np.diag([1.0, 0.0]), "R must be symmetric positive definite"),
        (np.eye(12), [[1.0, np.nan], [np.nan, 1.0]], "R must be finite"),
    ],
)
def test_bad_weights_are_refused(Q, R, pattern):
    _, lin = chain_lin(2, (1.0, 1.0))
    with pytest.raises(ParameterError, match=pattern):
        lqr(lin, Q, R)


def test_uncontrollable_pair_is_refused_naming_the_mode():
    J, rho, m, g = np.diag([3.0, 2.0, 1.0]), np.array([0.0, 0.0, 0.4]), 2.0, 9.81
    model = p3.full(J=J, rho=rho, m=m, g=g)
    lin = linearize(model, model.state(R=np.eye(3), omega=np.zeros(3)))
    one_axis = lin.with_input_map([[0.0], [0.0], [1.0]])
    w1 = np.sqrt(m * g * rho[2] / J[1, 1])  # the slower tilting mode, about body axis 2
    with pytest.raises(ParameterError, match=rf"uncontrollable mode.*lambda = .*{w1:.5f}i"):
        lqr(one_axis, np.eye(6), np.eye(1))
    # an unactuated but stable mode passes only when asked for stabilisability
    A = np.diag([-1.0, 2.0])
    B = np.array([[0.0], [1.0]])
    with pytest.raises(ParameterError, match=r"lambda = -1 .*Requirement.STABILIZABLE"):
        lqr(A, np.eye(2), np.eye(1), B=B)
    res = lqr(A, np.eye(2), np.eye(1), B=B, require=Requirement.STABILIZABLE)
    assert_close(np.sort(res.closed_loop_eigenvalues.real), [-np.sqrt(5.0), -1.0], atol=1e-12,
                 what="2 - k with k = 2 + sqrt(5); -1 untouched")
    with pytest.raises(ParameterError, match="stabilizable"):
        lqr(np.diag([1.0, 2.0]), np.eye(2), np.eye(1), B=B,
            require=Requirement.STABILIZABLE)


def test_bad_gain_shape_for_a_law():
    _, lin = chain_lin(1, (1.0,))
    with pytest.raises(ParameterError, match=r"K must be a finite \(2, 8\) matrix"):
        geometric_feedback(lin, np.zeros((2, 7)))


# ----------------------------------------------------------------------------------------
# moved from test_review_engine.py


@pytest.fixture(scope="module")
def planar():
    return p3.planar(Jt=0.2, rho_s=0.3)


def test_lqr_checks_its_system_like_pbh(planar):
    lin = linearize(planar, planar.state(p=[0.0, -1.0], omega_y=[0.0]))
    A = np.array([[0.0, 1.0], [2.0, 0.0]])
    for call, match in [
        (lambda: lqr(lin, np.eye(2), np.eye(0), B=np.ones((2, 1))), "pass B only"),
        (lambda: lqr(A, np.eye(2), np.eye(1)), "B is required when A is given as a matrix"),
        (lambda: lqr(A, np.eye(2), np.eye(1), B=np.ones((3, 1))), r"A \(2, 2\) and B \(3, 1\)"),
        (lambda: lqr(A, np.eye(2), np.eye(1), B=[[np.nan], [1.0]]), "must be finite"),
    ]:
        with pytest.raises(ModelError, match=match):
            call()
    res = lqr(A, np.eye(2), np.eye(1), B=[1.0, 1.0])  # a 1-D B is one input column
    assert np.all(res.closed_loop_eigenvalues.real < 0)
    assert res.riccati_residual < 1e-12


class _UncallableController:
    """Stands for a controller that no symbol class can call."""

    def n_in(self):
        return 1

    def name(self):
        return "stub"

    def __call__(self, x):
        raise RuntimeError(f"no {type(x).__name__} evaluation")


def test_geometric_feedback_keeps_the_original_error(planar):
    lin = linearize(planar, planar.state(p=[0.0, -1.0], omega_y=[0.0]))
    broken = replace(lin, controller=_UncallableController())
    with pytest.raises(ModelError, match="could not compose the controller 'stub'") as info:
        geometric_feedback(broken, np.zeros((0, 2)))
    msg = str(info.value)
    assert "on SX symbols with RuntimeError: no SX evaluation" in msg
    assert "on MX symbols with RuntimeError: no MX evaluation" in msg
    assert isinstance(info.value.__cause__, RuntimeError)
    law = geometric_feedback(lin, np.zeros((0, 2)))  # no controller: SX, nothing to retry
    assert law.is_a("SXFunction") and law.nnz_out(0) == 0
