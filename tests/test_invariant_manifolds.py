"""Stable and unstable manifolds: seeds on B_delta, growth, stopping, validation, errors."""

from __future__ import annotations

import numpy as np
import pytest

from models import controllers as ctl
from models import pendulum3d as p3
from models.spherical import spherical_pendulum
from tests.conftest import assert_close
from workbench.core.errors import ManifoldError, ModelError, ParameterError, SolverError
from workbench.core.manifolds import SO3, so3_exp
from workbench.global_dynamics._invariant_manifolds import (
    invariant_manifold,
    stable_manifold,
    unstable_manifold,
)
from workbench.global_dynamics._manifold_validation import compare_per_point, validate
from workbench.global_dynamics._seeds import (
    ball_points,
    direction_spread,
    distances,
    equilibrium_distance,
    sphere_directions,
)
from workbench.linear._eigen import Subspace
from workbench.simulation._simulate import Method, simulate

E3 = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def sphere():
    model = spherical_pendulum(m=1.0, l=1.0, g=9.81)
    k = ctl.s2_pd(model, E3, k_q=1.0, k_w=1.0)
    return model, k, np.r_[-E3, np.zeros(3)], np.r_[E3, np.zeros(3)]


@pytest.fixture(scope="module")
def rigid():
    model = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.3])
    k = ctl.so3_pd(model, np.eye(3), k_R=1.0, k_Omega=1.0, G=[0.9, 1.0, 1.1])
    return model, k


def flip(i):
    e = np.eye(3)[i]
    return 2 * np.outer(e, e) - np.eye(3)


@pytest.fixture(scope="module")
def s2_manifold(sphere):
    model, k, x_e, _ = sphere
    return stable_manifold(model, x_e, controller=k, delta=1e-6, n_points=16, horizon=9.0,
                           step=0.002, output_step=0.02, method=Method.S2_VARIATIONAL)


# ----------------------------------------------------------------------------------------
# directions and seeds


@pytest.mark.parametrize("k, n", [(2, 7), (3, 50), (4, 40), (5, 60)])
def test_sphere_directions_are_unit_and_even(k, n):
    U = sphere_directions(k, n, seed=3)
    assert U.shape == (n, k)
    assert_close(np.linalg.norm(U, axis=1), np.ones(n), atol=1e-14, what="unit vectors")
    spread = direction_spread(U)
    assert spread["mesh_ratio"] < (1.0 + 1e-9 if k == 2 else 1.35)
    # random directions are far less even
    R = np.random.default_rng(0).standard_normal((n, k))
    R /= np.linalg.norm(R, axis=1, keepdims=True)
    assert direction_spread(R)["mesh_ratio"] > 2 * spread["mesh_ratio"]


def test_sphere_directions_deterministic_and_seeded():
    assert np.array_equal(sphere_directions(4, 30, seed=1), sphere_directions(4, 30, seed=1))
    assert not np.allclose(sphere_directions(4, 30, seed=1), sphere_directions(4, 30, seed=2))
    assert np.array_equal(sphere_directions(1, 2), [[1.0], [-1.0]])


@pytest.mark.parametrize("args, match", [((1, 3), "exactly 2"), ((0, 5), "k must be"),
                                         ((3, 0), "n must be"), ((3, 2.5), "n must be")])
def test_sphere_directions_bad_input(args, match):
    with pytest.raises(ParameterError, match=match):
        sphere_directions(*args)


def test_distance_is_paper_12_and_its_so3_analogue(sphere, rigid, rng):
    model, _, x_e, _ = sphere
    d = equilibrium_distance(model)
    for _ in range(5):
        x = model.manifold.random_point(rng, scale=2.0)
        q, w = x[:3], x[3:]
        ref = np.sqrt(1 - q @ x_e[:3]) + np.linalg.norm(w - x_e[3:])  # (12)
        assert_close(float(d(x, x_e)), ref, atol=1e-12, what="(12) on TS^2")
    rmodel, _ = rigid
    Re = flip(0)
    xe = np.r_[SO3.flat(Re), np.zeros(3)]
    for _ in range(5):
        x = rmodel.manifold.random_point(rng, scale=1.0)
        R = SO3.matrix(x[:9])
        ref = np.sqrt(np.trace(np.eye(3) - Re.T @ R) / 2) + np.linalg.norm(x[9:])
        assert_close(float(equilibrium_distance(rmodel)(x, xe)), ref, atol=1e-7,
                     what="TSO(3) analogue, G = I")


def test_ball_points_at_distance_delta_in_the_eigenspace(rigid):
    model, k = rigid
    x_e = np.r_[SO3.flat(flip(2)), np.zeros(3)]
    W = stable_manifold(model, x_e, controller=k, delta=1e-5, n_points=30, horizon=0.1,
                        step=0.01, output_step=0.1)
    assert W.basis.shape == (6, 5)
    d = distances(model, W.seeds, x_e)
    assert_close(d, np.full(30, 1e-5), atol=0, rtol=1e-12, what="d(seed, x_e) = delta")
    assert W.diagnostics["seed_tangency"] < 1e-4  # O(delta): chart vs retraction
    assert W.diagnostics["constraint_residual"]["R"] < 1e-14


def test_ball_points_reports_unreachable_radius(sphere):
    model, _, x_e, _ = sphere
    W = np.eye(4)[:, :2]  # configuration only: the distance is sqrt(2) sin(r / 2) <= sqrt(2)
    with pytest.raises(SolverError, match="could not place seed 0.*raise max_iter") as err:
        ball_points(model, x_e, W, sphere_directions(2, 4), delta=0.3, max_iter=1)
    assert err.value.status == "no_radius"
    with pytest.raises(SolverError, match=r"too large .* >= pi .*use a smaller delta") as err:
        ball_points(model, x_e, W, sphere_directions(2, 4), delta=1.5)
    assert err.value.status == "outside_chart"
    P, r = ball_points(model, x_e, W, sphere_directions(2, 4), delta=1.0)
    assert_close(r, np.full(4, np.pi / 2), atol=0, rtol=1e-15, what="sqrt(2) sin(r/2) = 1")


# ----------------------------------------------------------------------------------------
# the S^2 saddle (paper 002 Sec. II-D)


def test_s2_manifold_great_circles_and_circular_boundary(s2_manifold):
    W = s2_manifold
    assert W.which is Subspace.STABLE and W.sign == -1.0
    assert W.x.shape == (451, 16, 6) and W.t[-1] == pytest.approx(9.0)
    assert np.all(np.isinf(W.stop_time))
    assert W.diagnostics["constraint_residual"]["q"] < 1e-12
    q = W.part("q")[:, :, :3]
    for j in range(W.n_points):
        n = np.linalg.svd(q[:, j])[2][-1]
        assert np.max(np.abs(q[:, j] @ n)) < 1e-10  # a great circle
    for t in (2.0, 6.0, 9.0):
        z = W.at(t)[:, 2]
        assert np.ptp(z) < 1e-12  # the boundary is a circle about the e3 axis
    d = W.distance()
    assert np.all(np.diff(d.max(axis=1)) > 0)  # grows backward


def test_forward_validation_returns_to_the_saddle(s2_manifold, sphere):
    model, _, _, x_h = sphere
    val = validate(s2_manifold, times=[7.0, 9.0], n_per_time=2, min_distance=1e-2,
                   extra_time=25.0, perturbation=1e-2, seed=1, target=x_h)
    assert len(val.on) == len(val.off) == 4
    assert val.worst_ratio < 1e-3
    assert all(r["d_return"] < 1e-3 for r in val.on)
    assert val.worst_target_distance < 1e-3  # off the manifold: to the hanging equilibrium
    assert val.least_escape > 1.0
    assert val.summary()["n_samples"] == 4
    with pytest.raises(ParameterError, match="min_distance"):
        validate(s2_manifold, times=[1.0], n_per_time=1, min_distance=1.0, extra_time=1.0,
                 perturbation=1e-3)


def test_vectorised_agrees_with_per_point_and_other_methods(s2_manifold, sphere):
    same = compare_per_point(s2_manifold, indices=[0, 5])
    assert same["worst"] < 1e-10
    ref = compare_per_point(s2_manifold, indices=[3], method=Method.CVODES)
    assert ref["worst_relative"] < 1e-4  # order 2 at h = 0.002
    model, k, x_e, _ = sphere
    opts = {"controller": k, "delta": 1e-6, "n_points": 16, "horizon": 9.0, "step": 0.002,
            "output_step": 0.02}
    W4 = stable_manifold(model, x_e, method=Method.RKMK4, **opts)
    WR = stable_manifold(model, x_e, method=Method.RK, **opts)
    assert np.max(np.abs(W4.x - s2_manifold.x) / (1 + np.abs(W4.x))) < 1e-4
    assert np.max(np.abs(WR.x - W4.x)) < 1e-8  # both order 4
    assert W4.diagnostics["constraint_residual"]["q"] < 1e-13
    assert WR.diagnostics["constraint_residual"]["q"] > 0  # ambient RK4 drifts, reported


def test_threads_give_the_same_points(sphere):
    model, k, x_e, _ = sphere
    opts = {"controller": k, "delta": 1e-6, "n_points": 9, "horizon": 2.0, "step": 0.01,
            "output_step": 0.1}
    a = stable_manifold(model, x_e, threads=1, **opts)
    b = stable_manifold(model, x_e, threads=2, **opts)
    assert np.array_equal(a.x, b.x)


def test_unstable_manifold_ends_at_the_hanging_equilibrium(sphere):
    model, k, x_e, x_h = sphere
    U = unstable_manifold(model, x_e, controller=k, delta=1e-6, n_points=6, horizon=45.0,
                          step=0.01, output_step=0.5, method=Method.RKMK4)
    assert U.sign == 1.0 and U.basis.shape[1] == 2
    assert np.max(distances(model, U.x[-1], x_h)) < 1e-3


def test_stopping_radius_freezes_and_records(sphere):
    model, k, x_e, _ = sphere
    W = stable_manifold(model, x_e, controller=k, delta=1e-6, n_points=8, horizon=10.0,
                        step=0.002, output_step=0.02, method=Method.RKMK4, max_distance=0.5)
    assert W.diagnostics["n_stopped"] == 8
    d = W.distance()
    for j in range(8):
        ts = W.stop_time[j]
        assert 8.0 < ts < 10.0
        i = int(np.searchsorted(W.t, ts))  # first output at or after the stop
        assert d[i, j] > 0.5 and np.all(W.x[i:, j] == W.x[i, j])  # frozen
        assert d[i - 1, j] <= 0.5 + 1e-12 or W.t[i - 1] >= ts
        assert not W.running(ts)[j] and W.running(ts - 0.01)[j]
    # the running part agrees with an unstopped run
    free = stable_manifold(model, x_e, controller=k, delta=1e-6, n_points=8, horizon=8.0,
                           step=0.002, output_step=0.02, method=Method.RKMK4)
    assert np.array_equal(free.x, W.x[: len(free.t)])


def test_step_failure_is_reported(sphere):
    model, k, x_e, _ = sphere
    with pytest.raises(SolverError, match=r"failed for point \d+ of 6 between t") as err:
        stable_manifold(model, x_e, controller=k, delta=1e-6, n_points=6, horizon=14.0,
                        step=0.5, output_step=0.5, method=Method.S2_VARIATIONAL)
    assert err.value.status in ("newton_not_converged", "non-finite")


# ----------------------------------------------------------------------------------------
# SO(3) saddles (paper 002 Sec. III)


def test_so3_saddle_manifolds_lgvi_matches_rkmk4_and_per_point(rigid):
    model, k = rigid
    x_e = np.r_[SO3.flat(flip(1)), np.zeros(3)]
    opts = {"controller": k, "delta": 1e-6, "n_points": 10, "horizon": 8.0, "step": 0.004,
            "output_step": 0.2}
    WL = stable_manifold(model, x_e, method=Method.LGVI, **opts)
    W4 = stable_manifold(model, x_e, method=Method.RKMK4, **opts)
    assert WL.basis.shape[1] == 4  # (18): four stable modes
    assert WL.diagnostics["newton"]["max_residual"] <= 1e-13
    assert np.max(np.abs(WL.x - W4.x)) < 1e-4 * np.max(np.abs(W4.x[:, :, 9:])) + 1e-9
    same = compare_per_point(WL, indices=[2])
    assert same["worst"] < 1e-10
    R = WL.part("R")
    assert R.shape == (41, 10, 3, 3)
    assert np.array_equal(R[7, 3], SO3.matrix(WL.x[7, 3, :9]))  # column-major storage
    assert np.max(np.abs(np.einsum("tnji,tnjk->tnik", R, R) - np.eye(3))) < 1e-13


def test_one_dimensional_unstable_manifold_of_the_e3_saddle(rigid):
    model, k = rigid
    x_e = np.r_[SO3.flat(flip(2)), np.zeros(3)]
    with pytest.raises(ParameterError, match="exactly 2"):
        unstable_manifold(model, x_e, controller=k, n_points=4, horizon=1.0, step=0.01,
                          output_step=0.1)
    U = unstable_manifold(model, x_e, controller=k, delta=1e-6, n_points=2, horizon=40.0,
                          step=0.01, output_step=0.5, method=Method.RKMK4)
    assert U.basis.shape[1] == 1
    assert_close(U.directions, [[1.0], [-1.0]], atol=0, what="the two branches")
    goal = np.r_[SO3.flat(np.eye(3)), np.zeros(3)]
    for branch in U.x[-1]:  # both branches go on to the desired equilibrium
        tr = simulate(model, branch, [0.0, 80.0], controller=k)
        assert distances(model, tr.final[None], goal)[0] < 1e-3


# ----------------------------------------------------------------------------------------
# errors


def test_bad_input_is_named(sphere):
    model, k, x_e, x_h = sphere
    base = {"controller": k, "horizon": 1.0, "step": 0.01, "output_step": 0.1}
    with pytest.raises(ModelError, match="not an equilibrium"):
        stable_manifold(model, np.r_[0.6, 0.0, -0.8, 0.0, 0.0, 0.0], **base)
    with pytest.raises(ModelError, match="no unstable eigenvalues"):
        unstable_manifold(model, x_h, **base)
    with pytest.raises(ModelError, match="hyperbolic"):
        stable_manifold(model, x_h, horizon=1.0, step=0.01, output_step=0.1)  # open loop
    with pytest.raises(ManifoldError):
        stable_manifold(model, np.r_[0.0, 0.0, -2.0, 0.0, 0.0, 0.0], **base)
    with pytest.raises(ParameterError, match="method must be one of"):
        stable_manifold(model, x_e, method=Method.CVODES, **base)
    with pytest.raises(ParameterError, match="output_step must divide horizon"):
        stable_manifold(model, x_e, **{**base, "output_step": 0.3})
    with pytest.raises(ParameterError, match="step must not exceed output_step"):
        stable_manifold(model, x_e, **{**base, "step": 0.2})
    with pytest.raises(ParameterError, match="max_distance must exceed delta"):
        stable_manifold(model, x_e, max_distance=1e-7, **base)
    with pytest.raises(ParameterError, match="delta must be a positive"):
        stable_manifold(model, x_e, delta=-1.0, **base)
    with pytest.raises(ParameterError, match="STABLE or Subspace.UNSTABLE"):
        invariant_manifold(model, x_e, which=Subspace.CENTRE, **base)
    W = stable_manifold(model, x_e, n_points=4, **base)
    with pytest.raises(ParameterError, match="not an output time"):
        W.at(0.05)
    with pytest.raises(ModelError, match="unknown factor"):
        W.part("R")


def test_progress_bar(sphere, capsys):
    model, k, x_e, _ = sphere
    stable_manifold(model, x_e, controller=k, n_points=4, horizon=0.2, step=0.01,
                    output_step=0.1, progress=True)
    assert "stable manifold" in capsys.readouterr().err


@pytest.mark.slow
def test_compiled_steps_agree_with_the_virtual_machine(rigid):
    model, k = rigid
    x_e = np.r_[SO3.flat(so3_exp([np.pi, 0.0, 0.0])), np.zeros(3)]
    opts = {"controller": k, "delta": 1e-6, "n_points": 12, "horizon": 6.0, "step": 0.002,
            "output_step": 0.1, "method": Method.LGVI}
    a = stable_manifold(model, x_e, **opts)
    b = stable_manifold(model, x_e, jit=True, **opts)
    assert np.max(np.abs(a.x - b.x)) < 1e-12
