"""Property tests over random bodies (hypothesis, derandomised, few examples).

Random symmetric positive-definite inertias (condition numbers up to 1e4, arbitrary
principal axes) and centre-of-mass offsets (|rho| from 1e-6 to 1) are drawn from a seed
that hypothesis chooses deterministically. For each: the invariants are conserved along
simulations; the linearisation from the graph equals finite differences and its spectrum
equals the closed form (3.22)-(3.28); the relative equilibria of Prop. 9 (with the erratum)
are zeros of the graph to 1e-10 and are found by the workbench's Newton solve. On SO(3):
exp/log round trips at any angle, including angles within 1e-8 of pi; projections land on
their factor, are idempotent and nearest.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import eigh

from models import pendulum3d as p3
from models.relative_equilibria import alpha, rotation_problem, slice_zeros
from tests.conftest import assert_close, ulps
from workbench import S1, S2, SO3, TS2, linearize, simulate, so3_exp, so3_log
from workbench.core.manifolds import hat

E3 = np.array([0.0, 0.0, 1.0])
FEW = settings(max_examples=10, deadline=None, derandomize=True)
seeds = st.integers(0, 2**31 - 1)


def random_body(seed: int, *, log_cond: float, log_rho: float, even: bool = False) -> dict:
    """J = Q diag(d) Q^T with cond(J) = 10^log_cond, |rho| = 10^log_rho, random directions.

    The middle moment is random, or with ``even`` the geometric mean of the others.
    """
    rng = np.random.default_rng(seed)
    mid = -log_cond / 2 if even else rng.uniform(-log_cond, 0.0)
    d = np.sort(10.0 ** np.r_[0.0, mid, -log_cond])[::-1]
    Q = so3_exp(rng.uniform(-np.pi, np.pi, 3))
    J = Q @ np.diag(0.5 * d) @ Q.T
    r = rng.standard_normal(3)
    rho = 10.0**log_rho * r / np.linalg.norm(r)
    return {"J": 0.5 * (J + J.T), "rho": rho, "m": float(rng.uniform(0.5, 2.0)), "g": 9.81}


def rotation_taking(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A rotation R with R a = b (unit vectors), a = -b handled."""
    v, c = np.cross(a, b), float(a @ b)
    s = np.linalg.norm(v)
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        axis = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        return so3_exp(np.pi * axis / np.linalg.norm(axis))
    return so3_exp(v / s * np.arctan2(s, c))


def closed_form_frequencies(body: dict) -> np.ndarray:
    """sqrt(m g l_i) of (3.22)-(3.23): J x'' = (m g / |rho|) hat(rho)^2 x, two nonzero modes."""
    rho = body["rho"]
    K = -body["m"] * body["g"] * hat(rho) @ hat(rho) / np.linalg.norm(rho)
    w = np.sort(eigh(K, body["J"], eigvals_only=True))[1:]
    return np.sqrt(w)


# ----------------------------------------------------------------------------------------
# invariants


@FEW
@given(seed=seeds, log_cond=st.floats(0.0, 3.0), log_rho=st.floats(-6.0, 0.0),
       speed=st.floats(0.0, 3.0))
def test_energy_and_vertical_momentum_are_conserved_for_random_bodies(seed, log_cond,
                                                                      log_rho, speed):
    body = random_body(seed, log_cond=log_cond, log_rho=log_rho)
    model = p3.full(**body)
    rng = np.random.default_rng(seed + 1)
    x0 = model.state(R=SO3.matrix(SO3().random_point(rng)), omega=speed * rng.standard_normal(3))
    tr = simulate(model, x0, np.linspace(0.0, 2.0, 5), rtol=1e-12, atol=1e-12)
    J, w = body["J"], x0[9:]
    # largest kinetic energy and momentum on the energy level: the scales of E and h
    kinetic = 0.5 * w @ J @ w + 2 * body["m"] * body["g"] * np.linalg.norm(body["rho"])
    scale = {"energy": kinetic, "h": np.sqrt(2 * kinetic * np.linalg.eigvalsh(J)[-1])}
    for name in ("energy", "h"):
        drift = tr.diagnostics["invariant_drift"][name]["max_abs"]
        assert drift <= 1e-9 * scale[name], (name, drift, scale[name])
    assert tr.diagnostics["constraint_residual"]["R"] < 1e-9


@FEW
@given(seed=seeds, log_cond=st.floats(0.0, 3.0), log_rho=st.floats(-3.0, 0.0))
def test_lgvi_keeps_the_vertical_momentum_exactly_and_the_energy_bounded(seed, log_cond,
                                                                          log_rho):
    body = random_body(seed, log_cond=log_cond, log_rho=log_rho)
    model = p3.full(**body)
    rng = np.random.default_rng(seed + 2)
    x0 = model.state(R=SO3.matrix(SO3().random_point(rng)), omega=rng.standard_normal(3))
    omega_max = np.sqrt(2 * (0.5 * x0[9:] @ body["J"] @ x0[9:] + 2 * body["m"] * body["g"]
                             * np.linalg.norm(body["rho"])) / np.linalg.eigvalsh(body["J"])[0])
    step = 0.05 / omega_max  # h |omega| <= 0.05 over the whole energy level
    tr = simulate(model, x0, np.linspace(0.0, 200 * step, 5), method="lgvi", step=step)
    h0 = tr.diagnostics["invariant_drift"]["h"]
    # exact up to the implicit solve (newton_tol 1e-13 relative) accumulated over 200 steps
    h_scale = omega_max * np.linalg.eigvalsh(body["J"])[-1]
    assert h0["max_abs"] <= 200 * 1e-13 * h_scale
    assert tr.diagnostics["constraint_residual"]["R"] < 1e-13
    E = tr.diagnostics["invariant_drift"]["energy"]
    E_scale = 0.5 * x0[9:] @ body["J"] @ x0[9:] + body["m"] * body["g"] * np.linalg.norm(
        body["rho"])
    assert E["max_abs"] <= 1e-2 * E_scale  # second order, h |omega| <= 0.05


# ----------------------------------------------------------------------------------------
# linearisation


def _fd_A(model, x_e, h=1e-6):
    N = model.manifold.tangent_basis(x_e)
    L = np.linalg.pinv(N)
    cols = []
    for j in range(N.shape[1]):
        e = np.zeros(N.shape[1])
        e[j] = h
        cols.append(L @ (model.rhs(model.manifold.retract(x_e, e))
                         - model.rhs(model.manifold.retract(x_e, -e))) / (2 * h))
    return np.column_stack(cols)


@FEW
@given(seed=seeds, log_cond=st.floats(0.0, 4.0), log_rho=st.floats(-6.0, 0.0),
       inverted=st.booleans())
def test_linearisation_equals_finite_differences_and_the_closed_form_spectrum(seed, log_cond,
                                                                               log_rho,
                                                                               inverted):
    body = random_body(seed, log_cond=log_cond, log_rho=log_rho)
    rho_hat = body["rho"] / np.linalg.norm(body["rho"])
    R = rotation_taking(rho_hat, -E3 if inverted else E3)
    for model in (p3.full(**body), p3.reduced(**body)):
        parts = {"R": R} if "R" in model.manifold.names else {"Gamma": R.T @ E3}
        x_e = model.state(**parts, omega=np.zeros(3))
        lin = linearize(model, x_e)
        A_fd = _fd_A(model, x_e)
        scale = max(1.0, float(np.max(np.abs(lin.A))))
        assert_close(lin.A, A_fd, atol=1e-6 * scale, what=f"A vs FD ({model.name})")
        # (3.22)-(3.28): +-i sqrt(m g l_i) hanging, +-sqrt(m g l_i) inverted, the rest zero
        w = closed_form_frequencies(body)
        ev = np.linalg.eigvals(lin.A)
        ev = ev[np.argsort(-np.abs(ev))]
        expect = np.sort(np.r_[w, w])[::-1]
        assert_close(np.abs(ev[:4]), expect, atol=0, rtol=1e-9 * 10**log_cond,
                     what="|eigenvalues| vs sqrt(m g l_i)")
        on_axis = np.abs(ev[:4].real) if not inverted else np.abs(ev[:4].imag)
        assert np.all(on_axis <= 1e-9 * expect)
        assert np.all(np.abs(ev[4:]) <= 1e-7 * max(1.0, np.abs(lin.A).max()))


# ----------------------------------------------------------------------------------------
# relative equilibria (Prop. 9 with the erratum: Gamma_e = -n_a/|n_a| for every alpha)


def closed_form_relative_equilibrium(body: dict, a: float) -> tuple[np.ndarray, float]:
    n = np.linalg.solve(body["J"] - np.eye(3) / a, body["rho"])
    gamma = -n / np.linalg.norm(n)
    omega = np.sqrt(body["m"] * body["g"] / np.linalg.norm(n)) * n
    return gamma, float(omega @ gamma)


def _relative_equilibrium_case(seed, log_cond, u, interval):
    body = random_body(seed, log_cond=log_cond, log_rho=-0.5, even=True)
    inv = np.sort(1.0 / np.linalg.eigvalsh(body["J"]))  # 1/J_1 < 1/J_2 < 1/J_3
    edges = [(-50.0, -0.02), (0.0, inv[0]), (inv[0], inv[1]), (inv[1], inv[2]),
             (inv[2], inv[2] + 50.0)]
    lo, hi = edges[interval]
    a = lo + u * (hi - lo)
    gamma, k = closed_form_relative_equilibrium(body, a)
    model = p3.reduced(**body)
    problem = rotation_problem(model)
    y = np.append(gamma, k)
    F_scale = max(1.0, k * k * np.abs(body["J"]).max())
    assert np.max(np.abs(problem.residual(y))) <= 1e-10 * F_scale
    # the workbench's own Newton solve on the slice, from a guess 1e-3 away
    guess = S2().retract(gamma, np.array([1e-3, -1e-3]))
    zeros, _ = slice_zeros(problem, k, guess[None, :], tol=1e-11 * F_scale)
    assert len(zeros) == 1
    z = zeros[0]
    assert z.root.residual <= 1e-10 * F_scale
    assert_close(z.y[:3], gamma, atol=1e-8, what="Gamma vs Prop. 9")
    mon = problem.monitors(z.y)
    assert abs(float(alpha(mon["k"], mon["k1"])) - a) <= 1e-8 * max(1.0, abs(a))


RELATIVE = {"seed": seeds, "log_cond": st.floats(0.5, 2.0), "u": st.floats(0.02, 0.98),
            "interval": st.integers(0, 4)}
test_relative_equilibria_of_prop_9_are_zeros_found_by_newton = FEW(
    given(**RELATIVE)(_relative_equilibrium_case))
test_relative_equilibria_many = pytest.mark.slow(settings(
    max_examples=300, deadline=None, derandomize=True)(given(**RELATIVE)(
        _relative_equilibrium_case)))


# ----------------------------------------------------------------------------------------
# SO(3): exp/log, also within 1e-8 of pi


def _exp_log_case(axis, where, t):
    k = np.asarray(axis) / np.linalg.norm(axis)
    angle = {"any": t * np.pi, "near_pi": np.pi - 10.0 ** (-8 - 8 * t), "pi": np.pi,
             "near_zero": 10.0 ** (-16 * t)}[where]
    v = angle * k
    R = so3_exp(v)
    # a few ulps: Rodrigues' formula sums three O(1) terms (5000 examples reach 1.2e-15)
    assert_close(R.T @ R, np.eye(3), atol=4e-15, what="exp lands on SO(3)")
    assert abs(np.linalg.det(R) - 1.0) < 4e-15
    w = so3_log(R)
    assert np.linalg.norm(w) <= np.pi + 1e-15
    assert_close(so3_exp(w), R, atol=2e-15, what="exp(log(R)) == R")
    if np.pi - angle > 1e-8:
        assert_close(w, v, atol=1e-12, what=f"log(exp(v)), angle {angle!r}")
    else:  # within 1e-8 of pi the axis sign is decided by roundoff; the angle is not
        assert min(np.linalg.norm(w - v), np.linalg.norm(w + v)) <= 1e-12
        assert abs(np.linalg.norm(w) - angle) <= 1e-12


EXP_LOG = {"axis": st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(
               lambda a: np.linalg.norm(a) > 0.1),
           "where": st.sampled_from(["any", "near_pi", "pi", "near_zero"]),
           "t": st.floats(0.0, 1.0)}
test_exp_log_round_trip_at_every_angle_including_near_pi = settings(
    max_examples=60, deadline=None, derandomize=True)(given(**EXP_LOG)(_exp_log_case))
test_exp_log_round_trip_many = pytest.mark.slow(settings(
    max_examples=5000, deadline=None, derandomize=True)(given(**EXP_LOG)(_exp_log_case)))


# ----------------------------------------------------------------------------------------
# projections


@settings(max_examples=40, deadline=None, derandomize=True)
@given(seed=seeds, log_scale=st.floats(-150.0, 150.0),
       which=st.sampled_from(["S1", "S2", "TS2", "SO3"]))
def test_projection_lands_is_idempotent_and_nearest(seed, log_scale, which):
    rng = np.random.default_rng(seed)
    factor = {"S1": S1(), "S2": S2(), "TS2": TS2(), "SO3": SO3()}[which]
    x = 10.0**log_scale * rng.standard_normal(factor.ambient_dim)
    if which == "TS2":  # a point near the bundle: its q part is what gets scaled
        x[3:] = rng.standard_normal(3)
    p = factor.project(x)
    assert factor.belongs(p, tol=1e-14)
    # rounding only: 32 ulps of the point (SO3's SVD: worst of 20000 seeded draws 15)
    assert_close(factor.project(p), p, atol=ulps(32, p), what="projection is idempotent")
    if which == "SO3":
        M = SO3.matrix(x)
        for _ in range(5):  # no other rotation is closer
            Rr = SO3.matrix(SO3().random_point(rng))
            assert np.linalg.norm(SO3.matrix(p) - M) <= np.linalg.norm(Rr - M) + 1e-12
    elif which in ("S1", "S2"):
        assert_close(p, x / np.linalg.norm(x), atol=1e-15, what="q / |q|")
