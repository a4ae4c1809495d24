"""Equilibria by Newton on the manifold: zeros, local dimension, convergence, failures."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from workbench.core.errors import ManifoldError, ModelError, ParameterError, SolverError
from workbench.core.manifolds import SO3, so3_exp
from workbench.equilibria._equilibria import enumerate_equilibria, find_equilibrium
from workbench.equilibria._roots import DenseEvaluator, RootStatus, ZeroProblem

J = np.diag([0.4486, 0.3943, 0.0772])
RHO = np.array([-0.0140, 0.1044, 0.4989])
E3 = np.array([0.0, 0.0, 1.0])
MG = 9.81


@pytest.fixture(scope="module")
def reduced():
    return p3.reduced(J=J, rho=RHO)


@pytest.fixture(scope="module")
def chain2():
    return chain_cart(2)


def test_reduced_newton_lands_on_a_relative_equilibrium(reduced, rng):
    """From a perturbed static guess Newton lands on the 1-D zero set (Prop. 9 case 4/5)."""
    rhat = RHO / np.linalg.norm(RHO)
    for _ in range(5):
        g = so3_exp(0.3 * rng.standard_normal(3)) @ rhat
        eq = find_equilibrium(reduced, np.r_[g, 0.3 * rng.standard_normal(3)])
        gam, w = eq.parts["Gamma"], eq.parts["omega"]
        assert eq.residual <= 1e-12
        assert eq.constraint_residual <= 1e-14
        assert eq.local_dimension == 1  # on a family of relative equilibria
        assert_close(np.cross(gam, w), np.zeros(3), atol=1e-12, what="omega parallel Gamma")
        # independent check: closed form at its own alpha (erratum: -n/|n| for all alpha)
        k = w @ gam
        k1 = gam @ (k * k * J @ gam + MG * RHO)
        a = k * k / k1
        n = np.linalg.solve(J - np.eye(3) / a, RHO)
        assert_close(gam, -n / np.linalg.norm(n), atol=1e-9, what="Gamma_e(alpha)")
        assert_close(abs(k), np.sqrt(MG * np.linalg.norm(n)), atol=1e-9, rtol=1e-9,
                     what="|k| = sqrt(mg|n|)")


def test_full_model_hanging_manifold(rng):
    """On TSO(3) the hanging equilibria form a circle (rotations about the vertical)."""
    full = p3.full(J=J, rho=RHO)
    rhat = RHO / np.linalg.norm(RHO)
    # a rotation with R^T e3 = rho/|rho|, then perturbed
    axis = np.cross(E3, rhat)
    Re = so3_exp(axis / np.linalg.norm(axis) * np.arccos(E3 @ rhat)).T
    assert_close(Re.T @ E3, rhat, atol=1e-14, what="construction")
    R0 = Re @ so3_exp(0.05 * rng.standard_normal(3))
    eq = find_equilibrium(full, np.r_[SO3.flat(R0), 0.01 * rng.standard_normal(3)])
    R = SO3.matrix(eq.x[:9])
    assert_close(R.T @ E3, rhat, atol=1e-12, what="Gamma of the found equilibrium")
    assert_close(eq.x[9:], np.zeros(3), atol=1e-12, what="omega")
    assert_close(R.T @ R, np.eye(3), atol=1e-14, what="R stays a rotation")
    assert eq.local_dimension == 1


def test_newton_converges_quadratically(chain2, rng):
    s = (1, -1)
    parts = [np.zeros(2), 0.05 * rng.standard_normal(2)]
    for si in s:
        q = so3_exp(0.1 * rng.standard_normal(3)) @ (si * E3)
        parts.append(link_state(q, np.cross(0.1 * rng.standard_normal(3), q)))
    eq = find_equilibrium(chain2, np.concatenate(parts), tol=1e-13)
    h = np.array(eq.history)
    assert eq.ok and eq.iterations <= 8
    # once in the quadratic regime, r_{k+1} <= C r_k^2 with a moderate C
    late = [(a, b) for a, b in zip(h[:-1], h[1:]) if a < 1.0]
    assert late, h
    assert all(b <= 1e3 * a * a for a, b in late), h
    assert eq.local_dimension == 2  # the free cart position
    # minimum-norm steps have no component along the free directions: x stays put
    assert_close(eq.parts["x"], parts[0], atol=1e-14, what="cart position")


def test_enumerate_merges_duplicates_and_keeps_failures(chain2, rng):
    guesses = []
    for s in [(1, 1), (1, 1), (-1, 1)]:
        guesses.append(np.concatenate(
            [np.zeros(4)] + [link_state(so3_exp(0.02 * rng.standard_normal(3)) @ (si * E3))
                             for si in s]))
    # a guess from which no equilibrium is reachable in one iteration
    far = np.concatenate([np.zeros(2), [2.0, 1.0], link_state([1, 0, 0], [0, 3, 0]),
                          link_state([0, 1, 0], [0, 0, 3])])
    guesses.append(far)
    found = enumerate_equilibria(chain2, guesses, distinct_tol=1e-8, max_iterations=1)
    assert len(found.failures) >= 1 and 3 in found.failures
    assert found.failures[3].status in (RootStatus.MAX_ITERATIONS, RootStatus.STAGNATED)
    found = enumerate_equilibria(chain2, guesses[:3], distinct_tol=1e-8)
    assert len(found) == 2 and found.sources == [[0, 1], [2]]


def test_no_equilibrium_is_a_status_not_an_answer(chain2):
    hanging = np.concatenate([np.zeros(4), link_state(E3), link_state(E3)])
    eq = find_equilibrium(chain2, hanging, u=[1.0, 0.0], raise_on_failure=False)
    assert eq.status is RootStatus.STAGNATED and not eq.ok
    assert "no zero near the guess" in eq.message
    assert eq.residual > 0.1  # the cart acceleration cannot vanish
    with pytest.raises(SolverError) as err:
        find_equilibrium(chain2, hanging, u=[1.0, 0.0])
    assert err.value.status == "stagnated"


def test_far_start_with_small_budget_fails_with_status(reduced):
    guess = np.r_[np.array([1.0, 0.0, 0.0]), 30.0, -20.0, 50.0]
    eq = find_equilibrium(reduced, guess, max_iterations=2, raise_on_failure=False)
    assert eq.status is RootStatus.MAX_ITERATIONS
    assert "no convergence in 2 iterations" in eq.message
    with pytest.raises(SolverError, match="raise_on_failure=False"):
        find_equilibrium(reduced, guess, max_iterations=2)


def test_bad_input(reduced):
    ok = np.r_[RHO / np.linalg.norm(RHO), 0.0, 0.0, 0.0]
    with pytest.raises(ManifoldError, match="guess"):
        find_equilibrium(reduced, np.r_[1.1 * ok[:3], ok[3:]])
    with pytest.raises(ManifoldError, match="6 entries"):
        find_equilibrium(reduced, ok[:5])
    with pytest.raises(ModelError, match="u must have 3 entries"):
        find_equilibrium(reduced, ok, u=[1.0])
    with pytest.raises(ParameterError, match="tol"):
        find_equilibrium(reduced, ok, tol=-1.0)
    with pytest.raises(ParameterError, match="max_iterations"):
        find_equilibrium(reduced, ok, max_iterations=0)
    with pytest.raises(ParameterError, match="unknown parameter"):
        find_equilibrium(reduced, ok, params={"mass": 2.0})
    with pytest.raises(ModelError, match="workbench Model"):
        find_equilibrium("pendulum", ok)


def test_params_override_shares_graphs(reduced):
    n_built = len(reduced.build_log)
    rho2 = np.array([0.0, 0.2, 0.3])
    g0 = so3_exp([0.01, -0.02, 0.0]) @ (rho2 / np.linalg.norm(rho2))
    eq = find_equilibrium(reduced, np.r_[g0, 0.0, 0.0, 0.0], params={"rho": rho2})
    assert eq.residual <= 1e-12 and eq.local_dimension == 1
    # a point of the family through the hanging equilibrium of the new body: the model's
    # field with the new rho vanishes there, and omega is parallel to Gamma
    assert_close(np.cross(eq.parts["Gamma"], eq.parts["omega"]), np.zeros(3), atol=1e-12,
                 what="omega parallel Gamma")
    assert len(reduced.build_log) == n_built


def test_tangent_jacobian_is_the_derivative_along_the_retraction(chain2, rng):
    """A = dF/dy N equals the central difference of F(retract(y, e v))."""
    prob = ZeroProblem.equilibria(chain2)
    y = chain2.manifold.random_point(rng, scale=0.3)
    F, A, _ = prob.linearization(y)
    v = rng.standard_normal(chain2.manifold.dim)
    eps = 1e-6
    fd = (prob.residual(chain2.manifold.retract(y, eps * v))
          - prob.residual(chain2.manifold.retract(y, -eps * v))) / (2 * eps)
    assert_close(A @ v, fd, atol=1e-6 * max(1.0, np.max(np.abs(fd))), what="A v")


def test_dense_evaluator_matches_casadi_for_sparse_outputs():
    x = ca.SX.sym("x", 3)
    fn = ca.Function("f", [x], [ca.vertcat(x[0] * x[1], ca.sin(x[2])),
                                ca.jacobian(ca.vertcat(x[0] * x[1], ca.sin(x[2])), x)])
    ev = DenseEvaluator(fn)
    xv = np.array([0.3, -1.2, 0.7])
    F, D = ev(xv)
    assert_close(F, np.asarray(fn(xv)[0]).ravel(), atol=0.0, what="F")
    assert_close(D, np.asarray(fn(xv)[1]), atol=0.0, what="sparse Jacobian densified")
