"""PBH (first and second order), Kalman rank and the second-order form from the graph."""

from __future__ import annotations

import gc
import importlib
import itertools
import weakref

import numpy as np
import pytest
import scipy.linalg as sla
from conftest import assert_close

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from models.chain_cart_reference import paper_matrices as chain_paper_matrices
from models.spherical import spherical_pendulum
from workbench.core.errors import ModelError
from workbench.core.manifolds import hat, so3_exp
from workbench.linear._controllability import (
    kalman_rank,
    pbh,
    pbh_second_order,
    second_order_form,
)
from workbench.linear._linearize import linearize, mechanical_order

E3 = np.array([0.0, 0.0, 1.0])


def chain_equilibrium(n, s, x=(0.0, 0.0)):
    return np.concatenate([np.asarray(x, float), np.zeros(2)]
                          + [link_state(si * E3) for si in s])


@pytest.mark.parametrize("n", [1, 2, 3])
def test_second_order_form_of_the_chain_is_paper_003_16(n, rng):
    m, masses, lengths = 0.7, rng.uniform(0.05, 0.3, n), rng.uniform(0.05, 0.4, n)
    model = chain_cart(n, m=m, masses=masses, lengths=lengths, g=9.81)
    for s in itertools.product([1.0, -1.0], repeat=n):
        form = second_order_form(model, chain_equilibrium(n, s, rng.standard_normal(2)),
                                 pairs={"x": "v"})
        M, G, B = chain_paper_matrices(n, s, m=m, masses=masses, lengths=lengths, g=9.81)
        assert_close(form.M, M, atol=1e-13, what=f"M, s={s}")
        assert_close(form.G, G, atol=1e-12, what=f"G, s={s}")
        assert_close(form.B, B, atol=1e-13, what=f"B, s={s}")
        assert_close(form.D, np.zeros_like(M), atol=1e-12, what="no damping")
        assert max(form.checks.values()) < 1e-12
        # and the first-order linearisation in paper order is [[0, I], [-M^-1 G, 0]]
        lp = form.linear.permuted(form.positions + form.velocities)
        k = 2 * n + 2
        A_ref = np.block([[np.zeros((k, k)), np.eye(k)],
                          [-np.linalg.solve(M, G), np.zeros((k, k))]])
        assert_close(lp.A, A_ref, atol=1e-10, rtol=1e-12, what="A in paper order")


def test_second_order_form_of_the_3d_pendulum_is_paper_000_3_21(rng):
    L = rng.standard_normal((3, 3))
    J, rho, m, g = L @ L.T + np.eye(3), rng.standard_normal(3), 1.7, 9.81
    model = p3.full(J=J, rho=rho, m=m, g=g)
    # hanging: R^T e3 = rho/|rho|
    a = rho / np.linalg.norm(rho)
    axis = np.cross(a, E3)
    R = so3_exp(axis / np.linalg.norm(axis) * np.arccos(a @ E3))
    form = second_order_form(model, model.state(R=R, omega=np.zeros(3)),
                             pairs={"R": "omega"})
    K = -m * g / np.linalg.norm(rho) * hat(rho) @ hat(rho)
    assert_close(form.M, J, atol=1e-12, what="M = J")
    assert_close(form.G, K, atol=1e-11, what="G = -(mg/|rho|) hat(rho)^2")
    assert_close(form.B, np.eye(3), atol=1e-12, what="B = I")


def test_second_order_form_errors():
    body = {"J": np.diag([1.0, 2.0, 3.0]), "rho": [0.0, 0.0, 0.5]}
    model = p3.full(**body)
    x_e = model.state(R=np.eye(3), omega=np.zeros(3))
    with pytest.raises(ModelError, match="energy invariant 'E'"):
        second_order_form(model, x_e, pairs={"R": "omega"}, energy="E")
    with pytest.raises(ModelError, match="neither a TS2 factor nor named in pairs"):
        second_order_form(model, x_e)
    # the reduced model's (Gamma, omega) is not (configuration, velocity)
    red = p3.reduced(**body)
    with pytest.raises(ModelError, match="same dimension"):
        second_order_form(red, red.state(Gamma=E3, omega=np.zeros(3)),
                          pairs={"Gamma": "omega"})
    # velocity and configuration swapped: the kinematic check fails
    with pytest.raises(ModelError, match="kinematics"):
        second_order_form(model, x_e, pairs={"omega": "R"})


def test_pbh_finds_the_uncontrollable_mode_and_its_left_eigenvector(rng):
    D = np.diag([-1.0, 2.0, 3.0])
    B = np.array([[1.0], [0.0], [1.0]])  # mode 2.0 is not actuated
    T = rng.standard_normal((3, 3)) + 2 * np.eye(3)
    A, Bt = T @ D @ np.linalg.inv(T), T @ B
    res = pbh(A, Bt)
    assert not res.controllable
    (mode,) = res.uncontrollable
    assert abs(mode.eigenvalue - 2.0) < 1e-10 and mode.deficiency == 1
    w = mode.left_vectors[:, 0]
    assert_close(np.abs(w.conj() @ (A - 2.0 * np.eye(3))), np.zeros(3), atol=1e-10,
                 what="left eigenvector")
    assert abs(w.conj() @ Bt[:, 0]) < 1e-10
    assert "lambda = 2" in res.describe_mode(mode)
    assert all(md.ratio > 1e-3 for md in res.modes if md is not mode)


def test_pbh_agrees_with_kalman_on_random_systems(rng):
    for trial in range(20):
        n, m = int(rng.integers(2, 6)), int(rng.integers(1, 3))
        A, B = rng.standard_normal((n, n)), rng.standard_normal((n, m))
        if trial % 2:  # make it uncontrollable: x_0' = A_00 x_0 is not reached by u
            A[0, 1:] = 0.0
            B[0] = 0.0
        r1, r2 = pbh(A, B), kalman_rank(A, B)
        assert r1.controllable == r2.controllable == (trial % 2 == 0)


def test_3d_pendulum_actuated_about_the_vertical_axis_only():
    """Only the rotation about the vertical is controllable: +-i sqrt(mgl_1,2) are not."""
    J, rho, m, g = np.diag([3.0, 2.0, 1.0]), np.array([0.0, 0.0, 0.4]), 2.0, 9.81
    model = p3.full(J=J, rho=rho, m=m, g=g)
    lin = linearize(model, model.state(R=np.eye(3), omega=np.zeros(3)))
    full = pbh(lin)
    assert full.controllable
    one = lin.with_input_map(np.array([[0.0], [0.0], [1.0]]))
    res = pbh(one)
    assert not res.controllable
    freqs = sorted(abs(md.eigenvalue.imag) for md in res.uncontrollable)
    mgl = np.sort(m * g * rho[2] / np.diag(J)[:2])
    assert_close(freqs, np.sort(np.repeat(np.sqrt(mgl), 2)), atol=1e-9,
                 what="uncontrollable modes +-i sqrt(m g rho / J_i), i = 1, 2")
    for md in res.uncontrollable:  # left eigenvectors live on the tilting coordinates
        w = np.abs(md.left_vectors[:, 0])
        assert w[[2, 5]].max() < 1e-10
    assert not kalman_rank(one).controllable


@pytest.mark.parametrize("n", [1, 2, 3])
def test_chain_controllable_at_every_equilibrium_first_and_second_order(n):
    model = chain_cart(n)
    for s in itertools.product([1.0, -1.0], repeat=n):
        form = second_order_form(model, chain_equilibrium(n, s), pairs={"x": "v"})
        r1, r2 = pbh(form.linear), pbh_second_order(form)
        assert r1.controllable and r2.controllable, s
        # the paper's reduced test (18): rank[lambda^2 M_qq + G_qq, M_qx] = 2n
        q = slice(2, None)
        r18 = pbh_second_order(form.M[q, q], form.G[q, q], form.M[q, :2])
        assert r18.controllable
        # second-order eigenvalues lambda^2 are the squares of the first-order ones
        lam2 = np.sort_complex(np.array([md.eigenvalue for md in r2.modes]))
        first = np.linalg.eigvals(form.linear.A) ** 2
        for mu in lam2:
            assert np.min(np.abs(first - mu)) < 1e-6 * max(1.0, abs(mu))


def test_second_order_pbh_detects_unactuated_and_repeated_modes():
    M = np.diag([1.0, 2.0, 3.0])
    G = np.diag([4.0, 8.0, 3.0])
    B = np.array([[1.0], [1.0], [0.0]])
    # third oscillator (lambda^2 = -1) is unactuated; the first two share lambda^2 = -4 and
    # one input, so one combination of them is uncontrollable too (geometric multiplicity 2)
    res = pbh_second_order(M, G, B)
    assert not res.controllable
    found = {round(md.eigenvalue.real, 9): (md.multiplicity, md.deficiency)
             for md in res.uncontrollable}
    assert found == {-4.0: (2, 1), -1.0: (1, 1)}
    # the first-order test on the equivalent state space agrees: +-2i and +-i
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.linalg.solve(M, G), np.zeros((3, 3))]])
    Bf = np.vstack([np.zeros((3, 1)), np.linalg.solve(M, B)])
    assert {round(abs(md.eigenvalue.imag), 9) for md in pbh(A, Bf).uncontrollable} == {1.0,
                                                                                      2.0}
    assert sla.eigvals(G, -M).size == 3
    # with a second input on the second oscillator everything is controllable
    assert pbh_second_order(M, G, np.column_stack([B, [0.0, 1.0, 1.0]])).controllable


def test_bad_input():
    with pytest.raises(ModelError, match="B is required"):
        pbh(np.eye(2))
    with pytest.raises(ModelError, match=r"A must be square \(n, n\) and B \(n, m\)"):
        pbh(np.eye(2), np.ones((3, 1)))
    with pytest.raises(ModelError, match="tol must be in"):
        pbh(np.eye(2), np.ones((2, 1)), tol=2.0)
    with pytest.raises(ModelError, match="M must be invertible"):
        pbh_second_order(np.zeros((2, 2)), np.eye(2), np.ones((2, 1)))
    model = spherical_pendulum()
    lin = linearize(model, model.state(q=np.r_[E3, np.zeros(3)]))
    with pytest.raises(ModelError, match="pass B only"):
        pbh(lin, np.ones((4, 1)))
    pos, vel = mechanical_order(model)
    assert pos == [0, 1] and vel == [2, 3]


# ----------------------------------------------------------------------------------------
# moved from test_review_engine.py


def test_energy_hessian_is_cached_with_the_model_and_released_with_it(monkeypatch):
    amb = importlib.import_module("workbench.linear._ambient")
    monkeypatch.setattr(amb, "_JAC_CACHE", {})  # linearize's bounded cache, emptied below
    model = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.5])
    x_e = model.state(R=np.diag([1.0, -1.0, -1.0]), omega=np.zeros(3))  # hanging
    forms = [second_order_form(model, x_e, pairs={"R": "omega"}),
             second_order_form(model.with_parameters(m=2.0), x_e, pairs={"R": "omega"})]
    assert_close(forms[1].G, 2.0 * forms[0].G, atol=1e-12, what="G scales with m")
    assert model.build_log.names().count(f"{model.name}.energy_hessian") == 1
    graphs = weakref.ref(model._graphs)
    amb._JAC_CACHE.clear()
    del model, forms
    gc.collect()
    assert graphs() is None, "a module-level cache keeps the model's graphs alive"
