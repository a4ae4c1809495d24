"""The default strategy's bookkeeping: what it returns, from which attempt, and why.

Checked on the rail pendulum's swing-up (and a spherical pendulum for the gauge): the
relaxation is polished to the same optimum on the manifold; a means (a relaxation, a
continuation step) is never returned as a success; a failure returns the solve of the
problem itself that came closest, and its message names it; the continuations reach the
optimum a direct solve reaches; the bookkeeping behind them (the gauge's re-solve, the
structured starts' cache, the residual of ``x0``, the polish) keeps the problem as posed.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import rail_pendulum
from models.spherical import spherical_pendulum
from workbench.control.ocp import (
    OCP,
    Auto,
    Collocation,
    Direct,
    Guess,
    ManifoldHandling,
    OCPStatus,
    TargetPoint,
    solve,
)
from workbench.control.ocp.diagnose import diagnose
from workbench.control.ocp.initial import structure, structured_guesses
from workbench.core.errors import SolverError


def _rail(u_max: float = 10.0, T: float | tuple[float, float] = 3.0) -> OCP:
    model = rail_pendulum.rail_pendulum()
    return OCP(model, x0=rail_pendulum.hanging(model),
               target=TargetPoint(model.manifold, rail_pendulum.inverted(model)),
               u_lower=-u_max, u_upper=u_max, T=T, running_cost=lambda x, u: ca.dot(u, u),
               name="rail")


def rail_builder() -> OCP:
    """Module level (picklable): the problem an executor's workers build."""
    return _rail(10.0, (1.0, 3.0))


@pytest.fixture(scope="module")
def rail() -> OCP:
    return _rail()


@pytest.fixture(scope="module")
def default_solve(rail):
    return solve(rail, Collocation(N=30))


def test_the_relaxation_is_polished_to_its_optimum_on_the_manifold(rail, default_solve):
    sol = default_solve
    relax, polish = sol.attempts[0], sol.attempts[1]
    assert (relax["what"], relax["handling"], relax["problem_itself"]) == \
        ("ambient relaxation", "ambient", False)
    assert polish["handling"] == "projected" and polish["problem_itself"]
    assert sol.cost["strategy_attempt"] == 2 and len(sol.attempts) == 2
    assert polish["iterations"] <= 5  # a warm start at the relaxation's optimum
    # the same optimum (Gauss-Legendre nodes of the ambient NLP are on TS^2 up to rounding:
    # the two NLPs share their solution), now with every node on the manifold
    assert sol.objective == pytest.approx(relax["objective"], rel=1e-9)
    assert sol.error["manifold_residual"] <= 1e-10
    assert sol.cost["strategy_cpu_seconds"] >= sol.cost["strategy_solve_cpu_seconds"] > 0


def test_the_same_problem_gives_the_same_trajectory(rail, default_solve):
    again = solve(rail, Collocation(N=30))
    assert np.array_equal(again.x, default_solve.x)
    assert np.array_equal(again.u, default_solve.u)
    assert again.T == default_solve.T
    assert [a["iterations"] for a in again.attempts] == \
        [a["iterations"] for a in default_solve.attempts]


def test_a_relaxation_is_never_returned_as_a_success(rail):
    # one attempt allowed: the relaxation converges, the problem itself is never solved
    sol = solve(rail, Collocation(N=30), strategy=Auto(max_attempts=1),
                raise_on_failure=False)
    assert sol.attempts[0]["status"] == "SUCCESS" and not sol.attempts[0]["problem_itself"]
    assert sol.status is OCPStatus.NOT_SOLVED and not sol.status.ok
    assert sol.handling is ManifoldHandling.AMBIENT  # what it is, said as it is
    assert "max_attempts" in sol.message
    with pytest.raises(SolverError, match="NOT_SOLVED"):
        solve(rail, Collocation(N=30), strategy=Auto(max_attempts=1))


def test_a_failure_returns_the_closest_solve_of_the_problem_and_names_it(rail):
    short = rail.with_bounds(u_lower=-0.5, u_upper=0.5, T=0.3)  # cannot invert in 0.3 s
    sol = solve(short, Collocation(N=15), raise_on_failure=False,
                strategy=Auto(swings=1, bound_factors=(), terminal_slacks=(),
                              coarse_factor=0))
    own = [a for a in sol.attempts if a["problem_itself"]]
    assert own and len(own) < len(sol.attempts)  # relaxations are not the problem
    closest = min(own, key=lambda a: a["primal_infeasibility"])
    n = sol.cost["strategy_attempt"]
    assert n == closest["attempt"]
    assert sol.objective == sol.attempts[n - 1]["objective"]
    assert f"attempt {n} of the strategy ({closest['what']};" in sol.message
    assert n != len(sol.attempts) or closest is own[-1]


def test_patience_stops_the_starts_and_says_so(rail):
    short = rail.with_bounds(u_lower=-0.5, u_upper=0.5, T=0.3)
    sol = solve(short, Collocation(N=15), raise_on_failure=False,
                strategy=Auto(patience=1, bound_factors=(), terminal_slacks=(),
                              coarse_factor=0))
    starts = {a["guess"].split(":")[0] for a in sol.attempts}
    assert len(starts) == 1  # one start failed: the others were not tried
    assert sol.cost["strategy_stopped"].startswith("1 starts in a row did not converge")
    assert "the strategy stopped" in sol.message


def test_a_coarse_continuation_reaches_the_direct_solve_optimum(rail):
    fine = Collocation(N=40)
    g = Guess.geodesic(rail)
    # 20 iterations: too few from the geodesic on 40 intervals, enough on 10 and to refine
    auto = Auto(relax=False, bound_factors=(), terminal_slacks=(), attempt_max_iter=20)
    sol = solve(rail, fine, guess=g, strategy=auto)
    what = [a["what"] for a in sol.attempts]
    assert sol.attempts[0]["status"] == "MAX_ITERATIONS"
    assert what[1].startswith("coarse") and not sol.attempts[1]["problem_itself"]
    assert what[2].startswith("refined") and sol.attempts[2]["problem_itself"]
    assert sol.cost["strategy_attempt"] == 3
    # the optimum of an unhurried direct solve from the same guess
    direct = solve(rail, fine, guess=g, strategy=Direct())
    assert sol.objective == pytest.approx(direct.objective, rel=1e-7)
    assert np.abs(sol.x - direct.x).max() < 1e-5


def test_the_relaxation_keeps_its_own_iteration_limit(rail):
    sol = solve(rail, Collocation(N=30), strategy=Auto(attempt_max_iter=5))
    relax = sol.attempts[0]
    assert relax["what"] == "ambient relaxation" and relax["status"] == "SUCCESS"
    assert relax["iterations"] > 5  # relax_max_iter = 300 applies, not attempt_max_iter
    assert sol.status.ok and sol.attempts[1]["iterations"] <= 5


def test_structured_starts_are_built_only_as_they_are_tried(rail, monkeypatch):
    import workbench.control.ocp.initial as initial

    made = []
    real = initial.pumping

    def counting(*args, **kwargs):
        out = real(*args, **kwargs)
        made.append(out.name)
        return out

    monkeypatch.setattr(initial, "pumping", counting)
    sol = solve(rail, Collocation(N=30))
    tried = {a["guess"].split(":")[0] for a in sol.attempts}
    # no start was built that was not tried, but the direct path: its input demand
    # decides whether it comes before the pumping start
    assert set(made) <= tried | {"direct path"} and "direct path" not in tried
    assert made.count("direct path") == 1
    made.clear()
    every = structured_guesses(rail)  # the list form builds them all
    assert len(every) > len(tried) and len(made) == len(every) - 1  # (the pumping one
    # is simulated by energy_pumping, the others made by pumping())


def test_the_gauge_resolve_keeps_the_terminal_slack():
    from workbench.control.ocp.solve import settings, solve_direct
    from workbench.core._model import Symbolic

    pend = spherical_pendulum(m=1.0, l=1.0, g=9.81)
    x0 = pend.state(q=[0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    xf = pend.state(q=[0.0, 0.0, -1.0, 0.0, 0.0, 0.0])
    ocp = OCP(pend, x0=x0, target=TargetPoint(pend.manifold, xf), u_lower=-4.0,
              u_upper=4.0, T=4.0, running_cost=lambda x, u: ca.dot(u, u))
    assert ocp.symmetry is not None  # rotation about e3; the box bounds break it
    exact = solve(ocp, Collocation(N=30))
    slack = solve_direct(ocp, Collocation(N=30), ManifoldHandling.PROJECTED, Symbolic.SX,
                         exact, settings(), terminal_slack=0.1)
    assert slack.status.ok and "iterations_gauged" in slack.cost  # re-solved ungauged
    # the re-solve is of the relaxed terminal condition: the slack is used, and it pays
    assert slack.error["target_residual"] == pytest.approx(0.1, abs=1e-6)
    assert slack.objective < exact.objective - 0.1


def test_structured_starts_of_a_problem_with_other_bounds_are_its_own():
    from workbench.control.ocp.strategies import _structured

    ocp = _rail(10.0, (1.0, 3.0))
    wide = ocp.with_bounds(u_lower=-40.0, u_upper=40.0)  # shares ocp's cache
    a = [g.description for g in _structured(ocp)]
    b = [g.description for g in _structured(wide)]
    assert b == [g.description for g in structured_guesses(wide)]
    assert a != b  # the input demand is read against each problem's bounds


def test_describe_on_an_executor_sees_a_solved_solution():
    from concurrent.futures import ThreadPoolExecutor

    from workbench.control.ocp import multistart

    seen = []

    def describe(s):
        seen.append(s)
        return {"defect": s.error["local_defect"], "described_cost": s.objective}

    ocp = rail_builder()
    with ThreadPoolExecutor(1) as pool:
        best, records = multistart(ocp, Collocation(N=20), starts="structured",
                                   executor=pool, build=rail_builder, describe=describe,
                                   max_iter=150, defect_tol=None)
    ok = [r for r in records if r["status"] in ("SUCCESS", "ACCEPTABLE")]
    assert ok and len(seen) == len(ok)
    for r in ok:  # a real solve's numbers, at the worker's optimum
        assert np.isfinite(r["defect"])
        assert r["described_cost"] == pytest.approx(r["objective"], rel=1e-7)
    assert all(s.status.ok and s.cost["iterations"] <= 10 for s in seen)


def test_an_x0_on_the_manifold_to_the_ocp_tolerance_does_not_fail_manifold_tol(rail):
    x0 = rail.x0.copy()
    q = rail.model.manifold.slices["q"]
    x0[q.start:q.start + 3] *= 1 + 4e-10  # |q| - 1 = 4e-10: within the OCP's tol (1e-9)
    ocp = OCP(rail.model, x0=x0, target=rail.target, u_lower=rail.u_lower,
              u_upper=rail.u_upper, T=3.0, running_cost=lambda x, u: ca.dot(u, u))
    sol = solve(ocp, Collocation(N=30))
    assert sol.status.ok
    assert sol.error["x0_manifold_residual"] > 1e-10  # the caller's, reported
    assert sol.error["manifold_residual"] <= 1e-10  # the nodes the solve chose


def test_polish_meets_a_tight_manifold_tol():
    rail = _rail()
    loose = solve(rail, Collocation(N=30), strategy=Direct(), tol=1e-3, manifold_tol=None)
    assert loose.error["manifold_residual"] > 1e-13  # Ipopt stops with some violation
    sol = solve(rail, Collocation(N=30), strategy=Direct(), tol=1e-3, manifold_tol=1e-13)
    assert sol.cost["polish_iterations"] >= 1
    assert sol.error["manifold_residual"] <= 1e-13 and sol.status.ok


def test_the_pumped_energy_keeps_every_velocity_its_kinematics_uses(rail):
    st = structure(rail.model)
    rng = np.random.default_rng(3)
    seen = np.zeros_like(st.pattern)
    for _ in range(20):
        K = np.asarray(st.kinematics(rail.model.manifold.random_point(rng), rail.model.p))
        assert not np.any((K != 0) & ~st.pattern)  # the pattern holds every nonzero ...
        seen |= K != 0
    assert np.array_equal(seen, st.pattern)  # ... and each of its entries is one somewhere
    K0 = np.asarray(st.kinematics(rail.x0, rail.model.p))
    assert np.count_nonzero(K0) < np.count_nonzero(st.pattern)  # x0 alone would miss some


def test_diagnosis_ignores_violations_within_tol(rail):
    from workbench.control.ocp.solve import _start, transcribe

    short = rail.with_bounds(u_lower=-0.5, u_upper=0.5, T=0.3)
    sol = solve(short, Collocation(N=15), strategy=Direct(), raise_on_failure=False)
    assert sol.diagnosis["worst_constraint"]["kind"] is not None
    tr, _ = transcribe(short, Collocation(N=15))
    args, _ = _start(tr, short, None, {}, warm_options=False)
    v = sol.diagnosis["worst_constraint"]["violation"]
    assert diagnose(sol, tr, args, tol=0.0)["worst_constraint"]["violation"] == v
    assert diagnose(sol, tr, args, tol=2 * v)["worst_constraint"]["kind"] is None


def test_target_gaps_agree_with_the_targets_own_distance_and_domain(rail):
    # the vectorised gap of the pumping runs against the target's numeric distance and its
    # chart domain evaluated one state at a time (casadi's evalf)
    from workbench.control.ocp.pumping import target_gap, target_gaps

    rng = np.random.default_rng(5)
    X = np.array([rail.model.manifold.random_point(rng) for _ in range(40)]
                 + [rail.x0, rail.target.witness])
    got = target_gaps(rail, X)
    for xi, g in zip(X, got):
        dom = [float(ca.evalf(e)) for e in rail.target.domain(ca.DM(xi))]
        want = 1.0 - min(dom) if dom and min(dom) < 0 else rail.target.distance(xi)
        assert g == pytest.approx(want, rel=1e-13, abs=1e-15)
        assert target_gap(rail, xi) == g
    assert got[-1] <= 1e-12  # the witness is in the target
    assert got[-2] > 1.0  # hanging is the inverted target's antipode: outside the domain
    assert np.any(got < 1.0) and np.any(got > 1.0)  # both branches among the random states


def test_pumping_holds_at_least_20_samples_per_period_and_stops_after_its_approach():
    # 400 samples over T <= 100 s would hold each control for 0.25 s, against the spherical
    # cart's 0.58 s period: the samples are raised to 20 per period, and the free-time run
    # stops three periods after its closest approach instead of simulating 100 s
    from problems.swingup_spherical_cart import problem
    from workbench.control.ocp.initial import natural_frequency
    from workbench.control.ocp.pumping import STOP_PERIODS, energy_pumping, target_gaps

    ocp = problem(T=(0.5, 100.0))
    period = 2 * np.pi / natural_frequency(ocp, ["link1"])
    g = energy_pumping(ocp).guess
    h = g.T / (len(g.s) - 1)
    assert h <= period / 20 * (1 + 1e-12)
    assert ocp.T_range[0] <= g.T <= 10 * period  # the approach, not the longest horizon
    link = ocp.model.manifold.slices["link1"]
    probe = np.tile(ocp.target.witness, (len(g.s), 1))
    probe[:, link] = g.x[:, link]  # the pumped factor's gap, as the pumping measures it
    gaps = target_gaps(ocp, probe)
    late = g.s * g.T >= ocp.T_range[0] - 1e-12
    assert gaps[-1] == gaps[late].min()  # it ends at its closest approach after T_min
    # the fixed-horizon guess rests first so that the approach falls at T, on a grid of
    # the same resolution that spans T exactly
    fixed = energy_pumping(problem(T=100.0)).guess
    assert fixed.T == 100.0 and 100.0 / (len(fixed.s) - 1) <= period / 20 * (1 + 1e-12)
    assert np.array_equal(fixed.x[0], fixed.x[len(fixed.s) // 2])  # resting at x0
    assert STOP_PERIODS >= 2


def test_the_direct_path_comes_first_where_the_inputs_can_follow_it():
    # the acrobot's elbow follows the direct path with 0.35 of its bound: that start comes
    # before the pumping; the spherical cart's direct path asks for 3x its bound: pumping
    # first, as for a weak motor
    from problems.swingup_acrobot import problem as acrobot
    from problems.swingup_spherical_cart import problem as cart
    from workbench.control.ocp.initial import iter_structured_guesses

    starts = iter_structured_guesses(acrobot())
    first, second, third = next(starts), next(starts), next(starts)
    assert [first.name, second.name, third.name] == ["direct path (+)", "direct path (-)",
                                                     "energy pumping"]
    assert first.demand <= 1 and second.demand <= 1
    names = [s.name for s in structured_guesses(cart())]
    assert names[:2] == ["energy pumping", "direct path"]
    assert structured_guesses(cart())[1].demand > 1
