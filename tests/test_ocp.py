"""Optimal control on manifolds: transcriptions, manifold handlings, statuses, bad input.

The checks are mathematical: the NLP's defects and terminal chart vanish at a solution,
Gauss-Legendre collocation in ambient coordinates conserves the quadratic constraints
|q|^2 and q.w exactly while Radau does not, the Lie group transcription keeps every node
on the manifold, all transcriptions agree on the cost of the same local minimum, and the
open-loop re-simulation error falls with N.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models.chain_cart import chain_cart, link_state
from workbench.control.ocp import (
    OCP,
    Collocation,
    Direct,
    Guess,
    ManifoldHandling,
    MultipleShooting,
    OCPStatus,
    Scheme,
    TargetPoint,
    TargetSet,
    homotopy,
    local_for,
    multistart,
    solve,
    sx_function,
)
from workbench.control.ocp.local import dexpinv
from workbench.control.ocp.transcription import collocation_coefficients
from workbench.core import solve_spd
from workbench.core._model import Symbolic
from workbench.core.errors import ManifoldError, ParameterError, SolverError
from workbench.core.manifolds import S1, S2, SO3, TS2, ProductManifold, Rn, so3_exp

E3 = np.array([0.0, 0.0, 1.0])
X0 = np.r_[0.0, 0.0, 0.0, 0.0, link_state(E3)]
XF = np.r_[0.0, 0.0, 0.0, 0.0, link_state(-E3)]


def cart_ocp(*, u_max: float = 10.0, T=(0.5, 3.0)) -> OCP:
    model = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    return OCP(model, x0=X0, target=TargetPoint(model.manifold, XF), u_lower=-u_max,
               u_upper=u_max, T=T, running_cost=lambda x, u: ca.dot(u, u),
               terminal_cost=lambda x, T: T, name="test_cart")


@pytest.fixture(scope="module")
def ocp() -> OCP:
    return cart_ocp()


COARSE = {"defect_tol": None, "strategy": Direct()}
"""One Ipopt solve from the given guess (the strategy Direct), and: at N = 10 (and 20) the
transcription does not follow the dynamics closely enough for the
default defect_tol (local defect ~2.4 at N = 10, 1e-3 at N = 20);
the tests below compare NLPs and their solutions with each other, so they turn the refusal
off explicitly. test_defaults_refuse.py checks that the default refuses."""


@pytest.fixture(scope="module")
def base(ocp):
    """The N = 10 Legendre solution from the deterministic geodesic guess (ambient, direct).

    N = 10 is too coarse to follow the dynamics (local defect ~2.4, so the default
    ``defect_tol`` refuses it: tests/extremes/test_defaults_refuse.py); these tests read the
    NLP's own equations, so the refusal is turned off explicitly.
    """
    return solve(ocp, Collocation(N=10), handling=ManifoldHandling.AMBIENT, **COARSE)


@pytest.fixture(scope="module")
def trajectory(ocp):
    """The N = 20 Legendre solution from the same geodesic guess: a trajectory.

    At N = 10 (h ~ 0.25 s, 0.4 of the link's small-oscillation period 2 pi sqrt(l/g) =
    0.63 s) the base above is not one (local defect ~2.4; the N = 10, 20, 40 solutions
    from it lie on different local minima, costs 4.98, 4.91, 4.24), so comparing other
    transcriptions *of the dynamics* with it compared discretisation artefacts. At N = 20
    the geodesic guess reaches the two-swing minimum (cost 5.33, local defect 1e-3; 5.18
    at N = 40, 5.14 at N = 80); the comparisons below are made there.
    """
    # the default defect_tol (1e-2) accepts it
    s = solve(ocp, Collocation(N=20), handling=ManifoldHandling.AMBIENT, strategy=Direct())
    assert s.status.ok and s.error["local_defect"] < 1e-2
    return s


# --- building blocks ------------------------------------------------------------------


@pytest.mark.parametrize("spd", [False, True], ids=["qr", "ldl"])
@pytest.mark.parametrize("n", [1, 2])
def test_sx_function_equals_the_mx_graph(n, spd):
    model = chain_cart(n)
    assert model.spd_solves  # a mechanics model: its solves are with the mass matrix
    f, fs = model.function("f"), sx_function(model.function("f"), spd=spd)
    assert fs.is_a("SXFunction")
    rng = np.random.default_rng(n)
    for _ in range(5):
        x = model.manifold.random_point(rng, scale=2.0)
        u = rng.standard_normal(2)
        a, b = np.asarray(f(x, u, model.p)).ravel(), np.asarray(fs(x, u, model.p)).ravel()
        assert np.allclose(a, b, rtol=1e-12, atol=1e-10 * np.abs(a).max())


def test_ldl_replay_is_smaller_than_qr():
    # the reason for spd_solves: the double cart's field and its Hessian shrink
    model = chain_cart(2)
    qr, ldl = (sx_function(model.function("f"), spd=s) for s in (False, True))
    assert ldl.n_instructions() < 0.6 * qr.n_instructions()


def test_solve_spd_solves_an_spd_system_and_gives_non_finite_values_when_singular():
    rng = np.random.default_rng(3)
    G = rng.standard_normal((6, 6))
    A = G @ G.T + 6 * np.eye(6)
    b = rng.standard_normal((6, 2))
    As, bs = ca.SX.sym("A", 6, 6), ca.SX.sym("b", 6, 2)
    fn = ca.Function("s", [As, bs], [solve_spd(As, bs)])
    x = np.asarray(fn(A, b))
    assert np.allclose(A @ x, b, rtol=0, atol=1e-12 * np.abs(b).max() * np.linalg.cond(A))
    # a singular matrix gives non-finite values, not a silently wrong finite answer
    S = A.copy()
    S[:, 0] = S[0, :] = 0.0
    assert not np.all(np.isfinite(np.asarray(fn(S, b))))


@pytest.mark.parametrize("factor", [Rn(2), S1(), S2(), SO3(), TS2()], ids=repr)
def test_local_coordinates_land_on_the_factor_and_integrate_the_velocity(factor):
    rng = np.random.default_rng(7)
    loc = local_for(factor)
    for _ in range(5):
        xk = factor.random_point(rng)
        y = rng.standard_normal(loc.ydim)
        if isinstance(factor, TS2):
            y[3:] -= (y[3:] @ xk[:3]) * xk[:3]
        x = np.asarray(loc.act(xk, y), float).ravel()
        assert factor.residual_norm(x) < 1e-14
        # log inverts act
        assert np.allclose(np.asarray(loc.act(xk, loc.log(xk, x))).ravel(), x, atol=1e-12)
        # d/dt act(x_k, y + t ydot) = xdot for a random tangent velocity xdot
        xdot = factor.tangent_basis(x) @ rng.standard_normal(factor.dim)
        yd = np.asarray(loc.ydot(xk, y, x, xdot), float).ravel()
        eps = 1e-6
        fd = (np.asarray(loc.act(xk, y + eps * yd)).ravel()
              - np.asarray(loc.act(xk, y - eps * yd)).ravel()) / (2 * eps)
        assert np.allclose(fd, xdot, atol=1e-8)


def test_local_coordinates_symbolic_equal_numeric():
    loc = local_for(TS2())
    xs, ys = ca.SX.sym("x", 6), ca.SX.sym("y", 6)
    fn = ca.Function("a", [xs, ys], [loc.act(xs, ys)])
    rng = np.random.default_rng(3)
    xk, y = TS2().random_point(rng), rng.standard_normal(6)
    assert np.allclose(np.asarray(fn(xk, y)).ravel(), loc.act(xk, y), atol=1e-15)
    assert np.all(np.isfinite(np.asarray(fn(xk, np.zeros(6)))))  # safe at y = 0


@pytest.mark.parametrize("left", [True, False])
def test_dexpinv_inverts_the_derivative_of_exp(left):
    rng = np.random.default_rng(11)
    for scale in (1e-4, 0.5, 2.5):
        y, v = scale * rng.standard_normal(3), rng.standard_normal(3)
        w = dexpinv(y, v, left=left)
        eps = 1e-6
        dE = (so3_exp(y + eps * w) - so3_exp(y - eps * w)) / (2 * eps)
        E = so3_exp(y)
        W = dE @ E.T if left else E.T @ dE
        got = np.array([W[2, 1], W[0, 2], W[1, 0]])
        assert np.allclose(got, v, atol=1e-8)


@pytest.mark.parametrize("scheme", list(Scheme))
@pytest.mark.parametrize("d", [1, 2, 3, 4])
def test_collocation_coefficients_integrate_and_differentiate_polynomials(scheme, d):
    tau, C, D, B = collocation_coefficients(d, scheme)
    exact = 2 * d - 1 if scheme is Scheme.LEGENDRE else 2 * d - 2
    for k in range(exact + 1):
        assert B @ tau**k == pytest.approx(1.0 / (k + 1), abs=1e-13)
    for k in range(d + 1):
        assert D @ tau**k == pytest.approx(1.0, abs=1e-12)
        assert np.allclose((tau**k) @ C, k * tau ** max(k - 1, 0) if k else 0.0, atol=1e-11)
    if scheme is Scheme.RADAU:
        assert tau[-1] == pytest.approx(1.0)


@pytest.mark.parametrize("scale", [0.25, 0.5, 2.0])
def test_moment_on_a_link_keeps_its_authority_off_the_sphere(scale):
    """The ambient extension of a moment on an S^2 link: ``omega-dot`` gains ``P u / (m l^2)``
    with ``P = I - q q^T/|q|^2`` at every ``|q|`` (ambient iterates of a transcription leave
    the sphere; a gain fading like ``|q|^2`` let swing-ups collapse to ``q -> 0``, issue 17),
    and gravity's part is unchanged (``(g/l) q x e3``, as printed in paper 002)."""
    from models.spherical import spherical_pendulum
    m, l, g = 0.7, 1.3, 9.81  # noqa: E741
    model = spherical_pendulum(m=m, l=l, g=g)
    f = model.function("f")
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = rng.standard_normal(3)
        q *= scale / np.linalg.norm(q)
        w = np.cross(q, rng.standard_normal(3))  # normal to q
        u = rng.standard_normal(3)
        x = np.r_[q, w]
        f0 = np.asarray(f(x, np.zeros(3), model.p)).ravel()
        fu = np.asarray(f(x, u, model.p)).ravel()
        P = np.eye(3) - np.outer(q, q) / (q @ q)
        assert np.allclose(fu[3:] - f0[3:], P @ u / (m * l**2), rtol=1e-12, atol=1e-12)
        assert np.allclose(f0[3:], (g / l) * np.cross(q, E3), rtol=1e-12, atol=1e-12)
        assert np.allclose(f0[:3], np.cross(w, q), atol=1e-14)


# --- solving ----------------------------------------------------------------------------


def test_collocation_solution_satisfies_dynamics_bounds_and_terminal_chart(ocp, base):
    assert base.status is OCPStatus.SUCCESS and base.ipopt_status == "Solve_Succeeded"
    assert base.error["constraint_violation"] < 1e-8
    assert base.error["target_residual"] < 1e-9
    # Gauss-Legendre conserves the quadratic invariants |q|^2 and q.w: the nodes are on
    # TS^2 up to the NLP's own constraint tolerance
    assert base.error["manifold_residual"] < 1e-8
    assert np.all(np.abs(base.u) <= 10 + 1e-8)
    assert 0.5 - 1e-8 <= base.T <= 3.0 + 1e-8
    assert base.t[-1] == pytest.approx(base.T)
    assert "Solve_Succeeded" in base.message and "iterations" in base.message


def test_radau_ambient_leaves_a_residual_projected_and_lie_group_do_not(ocp, trajectory):
    base = trajectory
    radau = Collocation(N=20, scheme=Scheme.RADAU)
    ambient = solve(ocp, radau, handling=ManifoldHandling.AMBIENT, guess=base,
                    manifold_tol=None, **COARSE)
    projected = solve(ocp, radau, handling=ManifoldHandling.PROJECTED, guess=base, **COARSE)
    lie = solve(ocp, Collocation(N=20), handling=ManifoldHandling.LIE_GROUP, guess=base,
                **COARSE)
    # Radau IIA does not conserve quadratic invariants: a drift of the order of its local
    # error (2e-3 at h = T/20), Gauss-Legendre's is the NLP's tolerance (3e-11)
    assert 100 * base.error["manifold_residual"] < ambient.error["manifold_residual"] < 0.1
    # the projected nodes and the Lie group's are on the manifold to the default 1e-10
    assert projected.error["manifold_residual"] <= 1e-10
    assert lie.error["manifold_residual"] <= 1e-10
    for s in (ambient, projected, lie):
        assert s.status.ok
        assert s.objective == pytest.approx(base.objective, rel=3e-2)
    # with the default manifold_tol the ambient nodes' drift is not a success
    again = solve(ocp, radau, handling=ManifoldHandling.AMBIENT, guess=base,
                  raise_on_failure=False, **COARSE)
    assert again.status is OCPStatus.OFF_MANIFOLD
    assert again.error["manifold_limit"] == 1e-10
    assert "manifold" in again.message and "Try next" in again.message


def test_shooting_agrees_with_collocation(ocp, trajectory):
    for handling in ManifoldHandling:  # RK4's ambient nodes drift by its local error
        s = solve(ocp, MultipleShooting(N=20, steps=1), handling=handling, guess=trajectory,
                  manifold_tol=None if handling is ManifoldHandling.AMBIENT else 1e-10,
                  **COARSE)
        assert s.status.ok
        assert s.objective == pytest.approx(trajectory.objective, rel=3e-2)


def test_mx_graph_gives_the_same_solution(ocp, base):
    s = solve(ocp, Collocation(N=10), graph=Symbolic.MX, guess=base,
              handling=ManifoldHandling.AMBIENT, **COARSE)
    assert s.objective == pytest.approx(base.objective, rel=1e-7)
    assert np.allclose(s.x, base.x, atol=1e-5)


@pytest.mark.slow  # builds N = 80 (~115 s): in `make test-all`, keeps `make test` < 10 min
def test_resimulation_error_falls_with_N(ocp, trajectory):
    mid = solve(ocp, Collocation(N=40), guess=trajectory, **COARSE)
    fine = solve(ocp, Collocation(N=80), guess=mid, **COARSE)
    e40 = mid.resimulate()["end_error"]
    e80 = fine.resimulate()["end_error"]
    assert fine.objective == pytest.approx(mid.objective, rel=3e-2)  # same local minimum
    assert e80 < e40 / 4  # order 2d = 6 in h, amplified by the unstable end phase


def test_warm_start_of_the_same_transcription_is_immediate_and_cached(ocp, base):
    again = solve(ocp, Collocation(N=10), guess=base, handling=ManifoldHandling.AMBIENT,
                  **COARSE)
    assert again.cost["iterations"] <= 3
    assert again.cost["transcription_cached"]
    assert again.objective == pytest.approx(base.objective, rel=1e-9)


def test_homotopy_in_the_bound_reuses_the_build(ocp, base):
    last, path = homotopy(ocp, Collocation(N=10),
                              steps=[{"u_lower": -b, "u_upper": b} for b in (8.0, 6.0)],
                              guess=base, handling=ManifoldHandling.AMBIENT, **COARSE)
    assert all(p.cost["transcription_cached"] for p in path)
    assert np.all(np.abs(last.u) <= 6.0 + 1e-8)
    assert last.objective >= base.objective - 1e-6  # tighter bound, no cheaper optimum nearby


def test_multistart_keeps_the_cheapest_converged_start(ocp):
    best, records = multistart(ocp, Collocation(N=10), seeds=[0, 1], T_guesses=[1.2, 1.9],
                               max_iter=150, **COARSE)
    ok = [r["objective"] for r in records if r["status"] in ("SUCCESS", "ACCEPTABLE")]
    assert ok and best.objective == pytest.approx(min(ok))


def test_quiet_by_default(ocp, base, capfd):
    solve(ocp, Collocation(N=10), guess=base, **COARSE)
    out, err = capfd.readouterr()
    assert out == "" and "Ipopt" not in err


def test_geodesic_guess_lies_on_the_manifold(ocp):
    g = Guess.geodesic(ocp, rng=np.random.default_rng(2), noise=0.2)
    man = ocp.model.manifold
    for s in np.linspace(0, 1, 17):
        assert max(man.residual_norms(g.state(s)).values()) < 1e-12
    assert np.allclose(g.state(0.0), X0) and np.allclose(g.state(1.0), XF, atol=1e-12)
    assert np.all(np.abs(g.u) <= 10.0)


# --- failures and bad input -------------------------------------------------------------


def test_infeasible_problem_reports_ipopt_and_raises_by_default():
    ocp = cart_ocp(u_max=0.1, T=0.5)
    with pytest.raises(SolverError) as info:
        solve(ocp, Collocation(N=10), max_iter=500)
    err = info.value
    # Ipopt's verdict on this infeasible problem (|u| <= 0.1 N cannot swing up in 0.5 s) is
    # a local minimum of the infeasibility, reached directly or after a failed restoration
    assert err.status in ("Infeasible_Problem_Detected", "Restoration_Failed")
    assert err.status in str(err)
    assert err.solution.status in (OCPStatus.INFEASIBLE, OCPStatus.FAILED)
    assert not err.solution.status.ok


def test_terminal_state_off_the_manifold_is_rejected_before_solving():
    model = chain_cart(1)
    bad = XF.copy()
    bad[4:7] *= 1.1
    with pytest.raises(ManifoldError, match="terminal state"):
        TargetPoint(model.manifold, bad)


def test_ambient_equality_terminal_condition_is_rejected_as_dependent():
    model = chain_cart(1)
    ambient = TargetSet(map=lambda x: x, manifold=ProductManifold([("all", Rn(10))]),
                        value=XF, witness=XF, description="x_N = x_f (ambient)")
    with pytest.raises(ManifoldError, match="not independent"):
        OCP(model, x0=X0, target=ambient, u_lower=-1, u_upper=1, T=1.0)


def test_target_set_witness_must_be_in_the_set():
    model = chain_cart(1)
    up = TargetSet(map=lambda x: x[4:7], manifold=ProductManifold([("q", S2())]),
                   value=-E3, witness=X0, description="q1 = -e3")
    with pytest.raises(ManifoldError, match="not in the target set"):
        OCP(model, x0=X0, target=up, u_lower=-1, u_upper=1, T=1.0)


def test_initial_state_off_the_manifold_is_rejected():
    model = chain_cart(1)
    bad = X0.copy()
    bad[7:10] = [1.0, 0.0, 1.0]  # q . w != 0
    with pytest.raises(ManifoldError, match="x0"):
        OCP(model, x0=bad, target=TargetPoint(model.manifold, XF), u_lower=-1, u_upper=1,
            T=1.0)


@pytest.mark.parametrize(
    "kwargs, match",
    [({"u_lower": 1.0, "u_upper": -1.0}, "u_lower must not exceed"),
     ({"u_lower": [-1, -1, -1], "u_upper": 1.0}, "u_lower must be"),
     ({"T": (3.0, 1.0)}, "T must satisfy"),
     ({"T": -1.0}, "T must satisfy"),
     ({"T": "long"}, "T must")],
)
def test_bad_problem_data_is_rejected(kwargs, match):
    model = chain_cart(1)
    args = {"u_lower": -1.0, "u_upper": 1.0, "T": 1.0} | kwargs
    with pytest.raises(ParameterError, match=match):
        OCP(model, x0=X0, target=TargetPoint(model.manifold, XF), **args)


def test_bad_method_and_options_are_rejected(ocp):
    with pytest.raises(ParameterError, match="N must be"):
        Collocation(N=0)
    with pytest.raises(ParameterError, match="degree must be"):
        Collocation(degree=0)
    with pytest.raises(ParameterError, match="scheme"):
        Collocation(scheme="radau")
    with pytest.raises(ParameterError, match="tol"):
        solve(ocp, Collocation(N=10), tol=-1.0)
    with pytest.raises(ParameterError, match="rng"):
        Guess.geodesic(ocp, noise=0.1)


@pytest.mark.parametrize("kw, fragment", [
    ({"max_iter": 2**32 + 3}, r"max_iter must be .*2147483647"),
    ({"ipopt_options": {"max_iter": 3.5}}, r"ipopt_options\['max_iter'\] must be an integer"),
    ({"ipopt_options": {"max_iter": True}}, r"ipopt_options\['max_iter'\] must be a number"),
    ({"ipopt_options": {"tol": None}}, r"ipopt_options\['tol'\] must be a number"),
])
def test_ipopt_numbers_are_never_truncated_or_dropped(ocp, kw, fragment):
    """casadi passes integer options as C ints: 2**32 + 3 became 3 iterations, 3.5 became 3,
    True became 1, and a None was dropped."""
    with pytest.raises(ParameterError, match=fragment):
        solve(ocp, Collocation(N=10), **kw)


def test_solution_inputs_are_checked_not_clamped(base):
    with pytest.raises(ParameterError, match=r"t must be in \[0, T\]"):
        base.control(base.T * 1.5)
    with pytest.raises(ParameterError, match="finite"):
        base.control(float("nan"))
    assert np.array_equal(base.control(base.T), base.u[-1])
    with pytest.raises(ParameterError, match="substeps"):
        base.resimulate(substeps=0)


def test_multistart_refuses_a_guess_it_would_ignore(ocp, base):
    with pytest.raises(ParameterError, match="multistart makes its own guesses"):
        multistart(ocp, Collocation(N=10), seeds=[0], guess=base)


@pytest.mark.parametrize("make, fragment", [
    (lambda: Collocation(N=10, degree=10), r"degree must be an integer in \[1, 9\]"),
    (lambda: Collocation(N=10**8), r"N must be an integer in \[1, 100000\]"),
])
def test_transcription_sizes_are_bounded(make, fragment):
    with pytest.raises(ParameterError, match=fragment):
        make()


@pytest.mark.parametrize("kw, fragment", [
    ({"T": -1.0}, "T must be"), ({"T": float("nan")}, "T must be"),
    ({"noise": -5.0}, "noise must be >= 0"), ({"noise": float("nan")}, "noise must be"),
    ({"samples": 1}, "samples must be"), ({"samples": 2.7}, "samples must be"),
    ({"axes": {"nope": [1.0, 0.0, 0.0]}}, r"axes names factors.*\['nope'\]"),
])
def test_geodesic_guess_arguments_are_checked(ocp, kw, fragment):
    with pytest.raises(ParameterError, match=fragment):
        Guess.geodesic(ocp, rng=np.random.default_rng(0), **kw)


def test_bounds_that_leave_no_admissible_control_are_refused():
    model = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    with pytest.raises(ParameterError, match="u_lower must not be inf"):
        OCP(model, x0=X0, target=TargetPoint(model.manifold, XF), u_lower=np.inf,
            u_upper=np.inf, T=2.0, running_cost=lambda x, u: ca.dot(u, u))
