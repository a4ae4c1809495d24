"""Seeds on B_delta and stable manifolds for saddles in any orientation (issue 19).

The saddles: the inverted equilibrium ``(-q_d, 0)`` of the spherical pendulum under the
PD law of paper 002 Sec. II-A with a random desired direction ``q_d``, and the saddles
``R_d exp(pi hat(e_i))`` of the PD law on SO(3) (Sec. III-A) with a random ``R_d`` (all
seeded). Neither has exact coordinates, which is what made the old seed placement fail.

Tolerances, from rounding (``EPS`` = 2.2e-16):

* the seeds' distance in the chart they are placed in: ``SEED_TOL`` = 16 EPS (the chart
  distance is a composition of fewer than 16 rounded operations);
* the distance measured again from the stored coordinates: :func:`rounding_bound`,
  ``EPS (sum_f c_f |x_e,f| + 16 delta)``, twice the worst storage rounding (each stored
  coordinate is within EPS / 2 of ``x_e + increment``) plus the relative rounding; about
  ``0.7 EPS / delta`` relative, i.e. 1.6e-8 at delta = 1e-8 -- no placement can do better,
  since a stored coordinate near 1 cannot move by less than EPS / 2;
* agreement with the factor's own retraction: 4 EPS (measured: 1 EPS; both round a
  rotation of unit vectors);
* the constraint residual of the seeds: that of ``x_e`` plus 4 EPS (``x_e + increment``
  with an exact increment lies on the manifold; measured: equal to that of ``x_e``);
* tangency to the stable eigenspace: the manifold's chart (``B^T (q_e x q)``, ``vee(R_e^T
  R - R^T R_e) / 2``) differs from the retraction's by ``O(delta)`` (curvature) and its
  evaluation from stored coordinates by ``O(EPS / delta)``: bounded by ``delta + EPS /
  delta`` (measured: at most 0.3 of it).

Forward-flow checks (:func:`validate`, CVODES at 1e-12): the manifold is grown until its
fastest stable mode has multiplied the seeds' distance by ``2 max(1e-2 / delta, 1e3)``;
points of it at distance >= 10 p are integrated forward, and the same points moved off the
manifold by ``p = max(1e-3, 100 delta)`` (a seeded tangent direction). On it, the closest
approach to the saddle must be below 1e-3 of the start distance (measured: <= 3e-7 on
S^2, <= 2e-4 on SO(3), where a stable rate is 0.05); off it, no closer than p / 10 (their
component along the unstable directions does not shrink forward; measured >= 0.7 p), ten
times farther than the manifold's points, and the end is far from the saddle (distance > 1;
they go to the desired equilibrium ``(q_d, 0)`` or ``(R_d, 0)``; measured >= 1.41).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from models import controllers as ctl
from models import pendulum3d as p3
from models.spherical import spherical_pendulum
from workbench.core.errors import ModelError, SolverError
from workbench.core.manifolds import S1, S2, SO3, TS2, ProductManifold, Rn
from workbench.global_dynamics._invariant_manifolds import stable_manifold
from workbench.global_dynamics._manifold_validation import validate
from workbench.global_dynamics._seeds import (
    EPS,
    SEED_TOL,
    ball_points,
    chart_increments,
    distances,
    rounding_bound,
    seed_report,
    sphere_directions,
)
from workbench.linear import Subspace, eigenstructure, linearize
from workbench.simulation import Method

N_ORIENTATIONS = 20
DELTAS = [1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3]
S2_MODEL = spherical_pendulum(m=1.0, l=1.0, g=9.81)
SO3_MODEL = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.3])


def flip(i: int) -> np.ndarray:
    """``exp(pi hat(e_i)) = 2 e_i e_i^T - I``."""
    e = np.eye(3)[i]
    return 2 * np.outer(e, e) - np.eye(3)


def s2_saddle(k: int):
    """The k-th seeded random orientation on S^2: (model, controller, saddle, goal)."""
    q_d = np.random.default_rng([19, 2, k]).standard_normal(3)
    q_d /= np.linalg.norm(q_d)
    ctrl = ctl.s2_pd(S2_MODEL, q_d, k_q=1.0, k_w=1.0)
    return S2_MODEL, ctrl, np.r_[-q_d, np.zeros(3)], np.r_[q_d, np.zeros(3)]


def so3_saddle(k: int):
    """The k-th seeded random saddle ``R_d exp(pi hat(e_i))`` of PD on SO(3)."""
    rng = np.random.default_rng([19, 3, k])
    R_d = SO3.matrix(SO3().random_point(rng))
    i = int(rng.integers(3))
    ctrl = ctl.so3_pd(SO3_MODEL, R_d, k_R=1.0, k_Omega=1.0, G=[0.9, 1.0, 1.1])
    x_e = np.r_[SO3.flat(R_d @ flip(i)), np.zeros(3)]
    return SO3_MODEL, ctrl, x_e, np.r_[SO3.flat(R_d), np.zeros(3)]


SADDLES = {"S2": s2_saddle, "SO3": so3_saddle}


def stable_basis(model, ctrl, x_e):
    """Linearised equilibrium and an orthonormal basis of its stable eigenspace."""
    lin = linearize(model, x_e, controller=ctrl)
    return lin.x_e, eigenstructure(lin).subspace(Subspace.STABLE)


def residual(model, x) -> float:
    """Largest constraint residual of a state (all factors)."""
    return float(np.max(np.abs(model.manifold.residual(x))))


# ----------------------------------------------------------------------------------------
# seeds


@pytest.mark.parametrize("space", ["S2", "SO3"])
def test_seeds_at_distance_delta_for_random_saddles(space):
    for k in range(N_ORIENTATIONS):
        model, ctrl, x_e, _ = SADDLES[space](k)
        xe, W = stable_basis(model, ctrl, x_e)
        assert W.shape[1] >= 2  # a saddle (S^2: 2; SO(3): 3, 4 or 5 stable modes)
        U = sphere_directions(W.shape[1], 12)
        for delta in DELTAS:
            P, r = ball_points(model, xe, W, U, delta=delta)
            V = r[:, None] * (U @ W.T)
            rep = seed_report(model, xe, P, V, delta)
            assert rep["seed_distance_error"] <= SEED_TOL
            # measured again from the stored coordinates: only their rounding
            d = distances(model, P, xe)
            bound = rounding_bound(model, xe, delta)
            assert np.max(np.abs(d - delta)) <= bound
            # the factor's own retraction of the same tangent vectors
            ref = np.array([model.manifold.retract(xe, v) for v in V])
            assert np.max(np.abs(P - ref)) <= 4 * EPS
            # on the manifold
            assert max(residual(model, p) for p in P) <= residual(model, xe) + 4 * EPS
            # in the stable eigenspace, to the curvature of the chart and the rounding
            C = np.array([model.manifold.chart(xe, p) for p in P])
            out = np.linalg.norm(C - (C @ W) @ W.T, axis=1) / np.linalg.norm(C, axis=1)
            assert np.max(out) <= delta + EPS / delta


@pytest.mark.parametrize("scale", [1e-8, 1e-5, 1e-2, 0.5])
def test_chart_increments_are_the_retraction_for_every_factor(scale):
    """x_e + increment is the factors' own retraction, and its distance the distance (12)."""
    man = ProductManifold([("x", Rn(2)), ("p", S1()), ("q", S2()), ("v", TS2()),
                           ("R", SO3()), ("w", Rn(3))])
    model = SimpleNamespace(manifold=man)  # chart_increments reads the manifold only
    rng = np.random.default_rng([19, 7])
    for _ in range(10):
        x_e = man.random_point(rng, scale=2.0)  # TS2 with w != 0: a chart, not a saddle
        V = scale * rng.standard_normal((5, man.dim))
        D, d, angle = chart_increments(model, x_e, V)
        ref = np.array([man.retract(x_e, v) for v in V])
        assert np.max(np.abs(x_e + D - ref)) <= 8 * EPS * (1 + np.max(np.abs(x_e)))
        amb = distances(model, x_e + D, x_e)
        assert np.max(np.abs(amb - d)) <= rounding_bound(model, x_e, float(d.max()))
        assert np.all(angle <= np.linalg.norm(V, axis=1))


@pytest.mark.parametrize("q_d", [[0.0, 0.6, 0.8], [0.0, 0.0, 1.0]])
@pytest.mark.parametrize("delta", [1e-8, 1e-6, 1e-5])
def test_issue_19_tilted_desired_direction(q_d, delta):
    """The issue's case: the old placement raised for every delta <= 1e-5 with (0, .6, .8)."""
    model = S2_MODEL
    ctrl = ctl.s2_pd(model, q_d, k_q=1.0, k_w=1.0)
    x_e = np.r_[-np.asarray(q_d), np.zeros(3)]
    W = stable_manifold(model, x_e, controller=ctrl, delta=delta, n_points=8, horizon=0.5,
                        step=0.05, output_step=0.5)
    assert W.diagnostics["seed_distance_error"] <= SEED_TOL
    assert W.diagnostics["seed_ambient_distance_error"] <= W.diagnostics["seed_rounding_bound"]
    assert W.diagnostics["seed_rounding_bound"] < EPS / delta  # 0.7 EPS / delta + 16 EPS


def test_too_large_delta_names_the_chart_and_the_knob():
    model, ctrl, x_e, _ = s2_saddle(0)
    xe, W = stable_basis(model, ctrl, x_e)
    with pytest.raises(SolverError, match=r"turn a configuration by .* >= pi.*use a smaller "
                                          r"delta") as err:
        ball_points(model, xe, W, sphere_directions(2, 4), delta=50.0)
    assert err.value.status == "outside_chart"
    with pytest.raises(SolverError, match=r"relative error .* > tol = 1e-17 .* raise max_iter, "
                                          r"or raise tol") as err:
        # one iteration: the first radius r = delta misses delta by 22% here; the
        # saddle's stable directions now come out with exact zeros, along which the chart
        # distance is linear in r and a second iteration lands exactly (error 0 <= 1e-17)
        ball_points(model, xe, W, sphere_directions(2, 4), delta=1e-6, tol=1e-17, max_iter=1)
    assert err.value.status == "no_radius"


def test_s2_manifolds_in_any_orientation_are_rotated_copies():
    """PD on S^2 is rotation-equivariant: W^s of (-q_d, 0) is R W^s of (-e3, 0), R e3 = q_d.

    The stable eigenvalue is double (-1.618), so every seed's distance profile d(t) is the
    same for every orientation, and each trajectory stays on a great circle through q_e
    (paper 002 Sec. II-D 3). Both are measured on tilted saddles against q_d = e3.

    Tolerance: each step rounds the O(1) coordinates of a tilted state by ~EPS, i.e. by
    EPS / d relative to its distance d to the saddle, and a relative error along the
    manifold persists backward; summed over the steps while d = delta exp(lam t) grows,
    that is EPS / (delta lam h) (1.4e-8 here; measured 7e-9, growing as 1 / h). At e3 the
    small coordinates are exact to their own size, hence ~1e-15 there.
    """
    opts = {"delta": 1e-6, "n_points": 6, "horizon": 8.0, "step": 0.01, "output_step": 0.5,
            "method": Method.RKMK4}
    ref = stable_manifold(S2_MODEL, np.r_[0.0, 0.0, -1.0, np.zeros(3)],
                          controller=ctl.s2_pd(S2_MODEL, [0, 0, 1], k_q=1.0, k_w=1.0),
                          **opts).distance()[:, 0]
    assert ref[-1] > 1e-1  # grown by five orders of magnitude
    for k in range(5):
        model, ctrl, x_e, _ = s2_saddle(k)
        W = stable_manifold(model, x_e, controller=ctrl, **opts)
        d = W.distance()
        lam, h = (1 + np.sqrt(5)) / 2, opts["step"]  # stable rate: s^2 + s - 1 = 0
        assert np.max(np.abs(d - ref[:, None]) / ref[:, None]) < 4 * EPS / (1e-6 * lam * h)
        q = W.x[:, :, :3]
        for j in range(W.n_points):
            n = np.linalg.svd(q[:, j])[2][-1]
            assert np.max(np.abs(q[:, j] @ n)) < 1e-10  # a great circle
            assert abs(n @ x_e[:3]) < 1e-10  # through the saddle


def test_so3_half_turn_about_a_random_axis_is_no_equilibrium_of_pd():
    """With R_d = I, exp(pi hat(n)) = 2 n n^T - I has e_R = vee(G F - F G) / 2, zero only
    when n is an eigenvector of G = diag(0.9, 1, 1.1): the saddles off the body axes are
    R_d exp(pi hat(e_i)) with R_d random, as tested here."""
    n = np.random.default_rng([19, 5]).standard_normal(3)
    n /= np.linalg.norm(n)
    x_e = np.r_[SO3.flat(2 * np.outer(n, n) - np.eye(3)), np.zeros(3)]
    ctrl = ctl.so3_pd(SO3_MODEL, np.eye(3), k_R=1.0, k_Omega=1.0, G=[0.9, 1.0, 1.1])
    with pytest.raises(ModelError, match="not an equilibrium"):
        stable_manifold(SO3_MODEL, x_e, controller=ctrl, horizon=1.0, step=0.1,
                        output_step=0.5)


def test_so3_stable_eigenspace_in_body_coordinates_does_not_depend_on_R_d():
    """PD on SO(3) is left-invariant: at R_d exp(pi hat(e_i)) the stable eigenspace in the
    body tangent coordinates is that of R_d = I (the projectors agree to rounding)."""
    for k in range(N_ORIENTATIONS):
        model, ctrl, x_e, goal = so3_saddle(k)
        R_d = SO3.matrix(goal[:9])
        i = int(np.argmax(np.diag(R_d.T @ SO3.matrix(x_e[:9]))))  # the flipped axis
        _, W = stable_basis(model, ctrl, x_e)
        ctrl0 = ctl.so3_pd(model, np.eye(3), k_R=1.0, k_Omega=1.0, G=[0.9, 1.0, 1.1])
        _, W0 = stable_basis(model, ctrl0, np.r_[SO3.flat(flip(i)), np.zeros(3)])
        assert W.shape == W0.shape
        assert np.max(np.abs(W @ W.T - W0 @ W0.T)) < 1e-10


# ----------------------------------------------------------------------------------------
# stable manifolds at delta = 1e-6, validated by forward flow

# space -> (n_points, step, slowest "fastest stable rate" over the saddles, extra time)
GROW = {"S2": (4, 0.01, (1 + np.sqrt(5)) / 2, 15.0), "SO3": (8, 0.02, 1.0, 30.0)}


def grow_and_validate(space: str, k: int, delta: float, *, n_factor: int = 1,
                      step_factor: float = 1.0, n_per_time: int = 2):
    """Grow W^s of saddle k from B_delta and integrate some of its points forward.

    The horizon lets the fastest stable mode grow the seeds by ``G = max(1e-2 / delta,
    1e3)`` (twice that, for margin), the points validated are at distance >= 10 p, and they
    are moved off the manifold by ``p = max(1e-3, 100 delta)``.
    """
    n_points, step, rate, extra = GROW[space]
    p = max(1e-3, 100 * delta)
    horizon = float(np.ceil(2 * np.log(2 * max(1e-2 / delta, 1e3)) / rate) / 2)
    model, ctrl, x_e, goal = SADDLES[space](k)
    W = stable_manifold(model, x_e, controller=ctrl, delta=delta, n_points=n_factor * n_points,
                        horizon=horizon, step=step * step_factor, output_step=0.5,
                        method=Method.RKMK4)
    val = validate(W, times=[horizon], n_per_time=n_per_time, min_distance=10 * p,
                   extra_time=extra, perturbation=p, seed=k, target=goal)
    return W, val, p


def check_manifold(W, val, p: float) -> None:
    """The seeds, the constraint, and forward flow: on it to the saddle, off it away."""
    assert W.diagnostics["seed_distance_error"] <= SEED_TOL
    assert W.diagnostics["seed_ambient_distance_error"] <= W.diagnostics["seed_rounding_bound"]
    assert max(W.diagnostics["constraint_residual"].values()) < 1e-13  # RKMK4 stays on it
    on_closest = max(r["d_min"] for r in val.on)
    off_closest = min(r["d_min"] for r in val.off)
    assert val.worst_ratio < 1e-3  # on the manifold: forward to the saddle
    assert off_closest > p / 10  # off it by p: never closer than a tenth of that ...
    assert on_closest < off_closest / 10  # ... so ten times farther than the manifold's
    assert val.least_escape > 1.0  # ... and gone (to the desired equilibrium)


@pytest.mark.parametrize("k", range(N_ORIENTATIONS))
@pytest.mark.parametrize("space", ["S2", "SO3"])
def test_stable_manifold_random_saddle_forward_flow(space, k):
    """The issue's must-show: delta = 1e-6, 20 random saddles each, forward-flow validated."""
    W, val, p = grow_and_validate(space, k, 1e-6)
    assert len(val.on) == len(val.off) == 2
    check_manifold(W, val, p)


@pytest.mark.parametrize("j", range(len(DELTAS)))
@pytest.mark.parametrize("space", ["S2", "SO3"])
def test_stable_manifold_forward_flow_at_every_delta(space, j):
    """delta = 1e-8 ... 1e-3, each on another random saddle."""
    W, val, p = grow_and_validate(space, N_ORIENTATIONS + j, DELTAS[j])
    check_manifold(W, val, p)


@pytest.mark.slow
@pytest.mark.parametrize("space", ["S2", "SO3"])
def test_stable_manifolds_random_saddles_sweep(space):
    """Every delta on every one of the 20 saddles, twice the seeds, four points validated."""
    for k in range(N_ORIENTATIONS):
        for delta in DELTAS:
            W, val, p = grow_and_validate(space, k, delta, n_factor=2, n_per_time=4)
            check_manifold(W, val, p)
