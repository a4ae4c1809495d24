"""Multistart on all cores (issue 17): the pumping guess and the forked starts.

The guess is checked geometrically (unit directions, end points, the model's velocity
convention by finite differences, the number of reversals); the starts in processes
against the same starts solved here, and the early stop against its own report. The
spherical cart at N = 10 keeps the builds short (coarse: ``defect_tol=None``, these tests
compare two ways of running the same NLP).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models.chain_cart import chain_cart, link_state
from workbench.control.ocp import OCP, Collocation, Guess, TargetPoint
from workbench.control.ocp.study import parallel_starts, pumping_guess
from workbench.core.errors import ParameterError
from workbench.core.manifolds import sphere_basis

E3 = np.array([0.0, 0.0, 1.0])
COARSE = {"defect_tol": None, "max_iter": 200}


@pytest.fixture(scope="module")
def cart() -> OCP:
    model = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    x0 = np.r_[0.0, 0.0, 0.0, 0.0, link_state(E3)]
    xf = np.r_[0.0, 0.0, 0.0, 0.0, link_state(-E3)]
    return OCP(model, x0=x0, target=TargetPoint(model.manifold, xf), u_lower=-10.0,
               u_upper=10.0, T=(0.5, 3.0), running_cost=lambda x, u: ca.dot(u, u),
               terminal_cost=lambda x, T: T, name="test_study_cart")


@pytest.mark.parametrize("k", [0, 3, 4])
def test_pumping_guess_swings_k_times_on_the_sphere(cart, k):
    g = pumping_guess(cart, half_swings=k, T=2.0, samples=801)
    q, w = g.x[:, 4:7], g.x[:, 7:10]
    assert np.max(np.abs(np.linalg.norm(q, axis=1) - 1)) < 1e-14
    assert np.allclose(q[0], E3, atol=1e-14) and np.allclose(q[-1], -E3, atol=1e-14)
    assert np.allclose(g.x[:, :4], 0.0) and np.all(g.u == 0.0) and g.T == 2.0
    # the chain stores omega with q-dot = omega x q: compare with finite differences
    dt = np.diff(g.s) * g.T
    qdot = np.diff(q, axis=0) / dt[:, None]
    mid = 0.5 * (w[1:] + w[:-1])
    qm = 0.5 * (q[1:] + q[:-1])
    assert np.max(np.abs(np.cross(mid, qm) - qdot)) < 2e-3 * np.max(np.abs(qdot))
    assert np.max(np.abs(np.sum(q * w, axis=1))) < 1e-12  # tangent
    # k reversals of the swing angle (the angle from hanging, signed in the plane)
    a = np.cross(E3, q) @ sphere_basis(E3)[:, 0]  # sin(th) along the default axis
    th = np.unwrap(np.arctan2(a, q @ E3))
    assert int(np.sum(np.diff(np.sign(np.diff(th))) != 0)) == k


def test_pumping_guess_refuses_bad_input(cart):
    with pytest.raises(ParameterError, match="half_swings must be an integer >= 0"):
        pumping_guess(cart, half_swings=-1)
    with pytest.raises(ParameterError, match="half_swings must be an integer >= 0"):
        pumping_guess(cart, half_swings=2.5)
    with pytest.raises(ParameterError, match=r"axes\['link1'\] must not be parallel"):
        pumping_guess(cart, half_swings=2, axes={"link1": [0.0, 0.0, 2.0]})
    with pytest.raises(ParameterError, match=r"axes must name .*\['link1'\]; got \['q1'\]"):
        pumping_guess(cart, half_swings=2, axes={"q1": [1.0, 0.0, 0.0]})
    rest = OCP(cart.model, x0=cart.x0, target=TargetPoint(cart.model.manifold, cart.x0),
               u_lower=-1.0, u_upper=1.0, T=1.0, running_cost=lambda x, u: ca.dot(u, u),
               name="no_swing")
    with pytest.raises(ParameterError, match="no S\\^2 factor goes to its antipode"):
        pumping_guess(rest, half_swings=1)


def test_starts_in_processes_equal_the_starts_here_and_stop_when_told(cart):
    guesses = [pumping_guess(cart, half_swings=k, T=2.0) for k in (3, 4)]
    guesses.append(Guess.geodesic(cart, T=1.5, rng=np.random.default_rng(0), noise=0.1))
    ladder = [Collocation(N=10)]
    a, ra, sa = parallel_starts(cart, guesses, ladder, workers=1, **COARSE)
    b, rb, sb = parallel_starts(cart, guesses, ladder, workers=2, **COARSE)
    assert [r["status"] for r in ra] == [r["status"] for r in rb]
    assert [r["objective"] for r in ra] == pytest.approx([r["objective"] for r in rb],
                                                         rel=1e-9)
    assert b.objective == pytest.approx(a.objective, rel=1e-9)
    converged = [r["objective"] for r in rb if r["status"] in ("SUCCESS", "ACCEPTABLE")]
    assert b.objective == pytest.approx(min(converged), rel=1e-6)  # the re-solve = best
    assert sb["finished"] == 3 and sb["stopped_early"] == ""
    assert sb["reached_best"] == sum(r["reached_best"] for r in rb) >= 1
    # stop at the cost of the first start: the run ends early and says so
    target = ra[0]["objective"]
    c, rc, sc = parallel_starts(cart, guesses, ladder, workers=1, stop_below=target,
                                **COARSE)
    assert sc["finished"] == 1 and "stopped after start 0" in sc["stopped_early"]
    assert [r["status"] for r in rc[1:]] == ["STOPPED", "STOPPED"]
    assert c.objective == pytest.approx(target, rel=1e-6)


def test_parallel_starts_refuses_bad_input(cart):
    g = [pumping_guess(cart, half_swings=1)]
    ladder = [Collocation(N=10)]
    with pytest.raises(ParameterError, match="workers must be an integer >= 1"):
        parallel_starts(cart, g, ladder, workers=0)
    with pytest.raises(ParameterError, match="guesses must be a non-empty sequence"):
        parallel_starts(cart, [], ladder, workers=1)
    with pytest.raises(ParameterError, match="ladder must hold"):
        parallel_starts(cart, g, [], workers=1)
    with pytest.raises(ParameterError, match="guess is set by parallel_starts"):
        parallel_starts(cart, g, ladder, workers=1, guess=g[0])
    with pytest.raises(ParameterError, match="stop_below must be a finite cost"):
        parallel_starts(cart, g, ladder, workers=1, stop_below=float("nan"))
