"""The swing-up problems: their OCPs, the symmetries and reductions they rely on.

Fast tests check the mathematics the problems use (the target sets, the equivalence of the
full and reduced 3D pendulum transcriptions, the rotation symmetry of the chain and its
gauge, the classification of swings); the problems themselves run in the slow tests.
"""

from __future__ import annotations

import numpy as np
import pytest

from problems import swingup_3d_pendulum as p3d
from problems import swingup_double_spherical_cart as dbl
from problems import swingup_drake_reference as drake_ref
from problems import swingup_spherical_cart as cart
from workbench.control.ocp import Collocation, Direct, Guess, ManifoldHandling, solve
from workbench.control.ocp.stepper import Stepper
from workbench.control.ocp.study import swings
from workbench.core.manifolds import SO3, so3_exp

AMBIENT_ONE = {"strategy": Direct(), "handling": ManifoldHandling.AMBIENT}
"""One ambient solve from the guess given: the transcriptions compared, not a strategy."""


def lift(sol, full):
    """A full-model guess from a reduced solution: R_{k+1} = R_k exp(h (w_k + w_{k+1})/2)."""
    R = np.eye(3)
    Xs = []
    h = sol.T / len(sol.u)
    for k, x in enumerate(sol.x):
        Xs.append(np.r_[SO3.flat(R), x[3:6]])
        if k < len(sol.u):
            R = R @ so3_exp(h * 0.5 * (x[3:6] + sol.x[k + 1, 3:6]))
    return Guess.from_samples(full, sol.t, np.array(Xs), sol.u)


def test_swing_classification():
    t = np.linspace(0, 1, 200)
    assert swings(t)["kind"] == "direct"
    pumped = -np.cos(3 * np.pi * t) * t  # rises while oscillating
    info = swings(pumped)
    assert info["kind"] == "pumping" and info["swings"] >= 1


def test_cart_problem_is_well_posed():
    ocp = cart.problem()
    assert ocp.model.manifold.dim == 8
    assert ocp.free_time and ocp.T_range == (0.5, 3.0)
    x = ocp.target.point
    assert ocp.target.distance(x) == 0.0
    assert ocp.target.distance(ocp.x0) == pytest.approx(0.0)  # the chart's antipode ...
    assert ocp.target.domain(x) and all(  # ... is excluded by the domain inequality
        float(e) < 0 for e in ocp.target.domain(ocp.x0))


def test_full_target_set_is_the_circle_of_inverted_rotations():
    red, full = p3d.problems("effort")
    for a in np.linspace(0.0, 2 * np.pi, 7):
        c, s = np.cos(a), np.sin(a)
        Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        x = np.r_[SO3.flat(Rz @ np.diag([1.0, -1.0, -1.0])), 0.0, 0.0, 0.0]
        assert full.target.distance(x) < 1e-15
    hanging = np.r_[SO3.flat(np.eye(3)), 0.0, 0.0, 0.0]
    assert all(float(e) < 0 for e in full.target.domain(hanging))


def test_lift_integrates_the_attitude_kinematics():
    red, full = p3d.problems("effort")
    st = Stepper(red.model, rtol=1e-12, atol=1e-12)
    x, X, U = red.x0, [red.x0], np.tile([0.3, -0.2, 0.1], (40, 1))
    for u in U:
        x = st.step(x, u, 0.01)
        X.append(x)
    X = np.array(X)
    g = Guess.from_samples(red, np.linspace(0, 0.4, 41), X, U)
    sol = type("S", (), {"x": X, "u": U, "t": np.linspace(0, 0.4, 41), "T": 0.4})()
    lifted = lift(sol, full)
    gam = np.array([SO3.matrix(r[:9]).T @ p3d.E3 for r in lifted.x])
    assert np.max(np.abs(gam - X[:, 0:3])) < 1e-4  # second order in h = 0.01
    assert g.T == pytest.approx(0.4)


def test_full_and_reduced_transcriptions_are_equivalent():
    """Gamma = R^T e3 is linear in R: ambient Legendre collocation commutes with it."""
    red, full = p3d.problems("time")
    red = red.with_bounds(u_lower=-3.0, u_upper=3.0, T=(0.5, 5.0))
    full = full.with_bounds(u_lower=-3.0, u_upper=3.0, T=(0.5, 5.0))
    s_red = solve(red, Collocation(N=20), guess=Guess.geodesic(red, T=1.5), **AMBIENT_ONE)
    s_full = solve(full, Collocation(N=20), guess=lift(s_red, full), **AMBIENT_ONE)
    # the full solution, reduced, is a KKT point of the reduced transcription
    back = solve(red, Collocation(N=20), guess=p3d.reduce(s_full, red), **AMBIENT_ONE)
    assert back.objective == pytest.approx(s_full.objective, rel=1e-8)
    gam = np.array([SO3.matrix(r[:9]).T @ p3d.E3 for r in s_full.x])
    assert np.allclose(gam, back.x[:, 0:3], atol=1e-6)
    assert np.allclose(s_full.x[:, 9:12], back.x[:, 3:6], atol=1e-5)
    lie = solve(full, Collocation(N=20), handling=ManifoldHandling.LIE_GROUP, guess=s_full,
                strategy=Direct())
    assert lie.objective == pytest.approx(s_full.objective, rel=2e-2)


def test_chain_is_equivariant_under_rotations_about_the_vertical():
    """The symmetry behind the gauge: f(Q x, Q u) = Q f(x, u) for Q about e3."""
    ocp = dbl.problem()
    model = ocp.model
    rng = np.random.default_rng(5)
    x = model.manifold.random_point(rng, scale=1.0)
    u = rng.standard_normal(2)
    a = 0.7
    xr, ur = dbl.rotate_about_vertical(x[None, :], u[None, :], a)
    fr, _ = dbl.rotate_about_vertical(model.rhs(x, u)[None, :], u[None, :], a)
    assert np.allclose(model.rhs(xr[0], ur[0]), fr[0], atol=1e-10)


def test_lifted_double_guess_is_on_the_manifold_and_gauged():
    ocp = dbl.problem()
    sur = dbl.surrogate()
    g = Guess.geodesic(sur, T=1.5, rng=np.random.default_rng(0), noise=0.2)
    fake = type("S", (), {"x": g.x, "u": g.u, "t": g.s * 1.5, "T": 1.5})()
    lifted = dbl.lift(fake, ocp)
    for s in np.linspace(0, 1, 9):
        assert max(ocp.model.manifold.residual_norms(lifted.state(s)).values()) < 1e-12
    assert abs(lifted.u[0, 1]) < 1e-12


def test_drake_reference_poses_drakes_problem():
    for free in (False, True):
        ocp = drake_ref.problem(cart_free=free)
        assert drake_ref.METHOD.N + 1 == 41 and ocp.T_range == (0.5, 3.0)
        assert np.all(ocp.u_upper == 10.0) and np.all(ocp.u_lower == -10.0)
        assert ocp.symmetry is not None and ocp.symmetry.axis == "e3"
        g = drake_ref.drake_guess(ocp)
        assert g.T == 1.5 and not np.any(g.u)
        for s in np.linspace(0, 1, 7):  # the straight swing: a great circle in the y-z plane
            x = g.state(s)
            assert abs(x[4]) < 1e-15 and abs(np.linalg.norm(x[4:7]) - 1) < 1e-12
    free = drake_ref.problem(cart_free=True)
    moved = np.r_[0.3, -0.2, 0.0, 0.0, free.target.witness[4:]]
    assert free.target.distance(moved) == 0.0  # the cart may end anywhere
    assert drake_ref.problem().target.distance(moved) > 0.1


@pytest.mark.slow
def test_drake_peer_maps_to_the_workbench_state():
    peer = pytest.importorskip("problems._drake_peer")
    if not peer.drake_available():
        pytest.skip("drake not installed")
    d = peer.drake_solve(peer.drake_plant(), cart_free=False)
    t, X, U = peer.to_workbench(d["t"], d["x"], d["u"])
    ocp = drake_ref.problem()
    for x in X:
        ocp.model.manifold.check(x, tol=1e-12)
    assert ocp.target.distance(X[-1]) < 1e-8 and np.allclose(X[0], ocp.x0)
    # Drake's optimum is (to its tolerance) a KKT point of the Lie-group Hermite-Simpson NLP
    s = solve(ocp, drake_ref.METHOD, handling=ManifoldHandling.LIE_GROUP,
              guess=Guess.from_samples(ocp, t, X, U), strategy=Direct())
    assert s.objective == pytest.approx(d["cost"], rel=1e-7)
    assert np.allclose(s.x, X, atol=1e-5)


@pytest.mark.slow
@pytest.mark.parametrize("module", [cart, p3d, dbl, drake_ref], ids=lambda m: m.__name__)
def test_problem_runs_in_quick_mode(module):
    res = module.solve(quick=True)
    assert res.ok, [c.as_dict() for c in res.comparisons if not c.ok]
