"""Work-precision measurement: errors fall with the knob at the method's order, the
fastest-method logic, long-time growth exponents, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.spherical import spherical_pendulum
from workbench.core.errors import ModelError, ParameterError
from workbench.simulation._simulate import Method
from workbench.simulation.accuracy import (
    AccuracySweep,
    Cost,
    Knob,
    Run,
    RunStatus,
    WorkPrecision,
    default_reference,
    long_time,
    work_precision,
)


@pytest.fixture(scope="module")
def sphere():
    return spherical_pendulum()


@pytest.fixture(scope="module")
def x0(sphere):
    q = np.array([np.sin(1.0), 0.0, np.cos(1.0)])
    return sphere.state(q=np.concatenate([q, np.cross(q, [0.3, 0.8, -0.2])]))


@pytest.fixture(scope="module")
def wp(sphere, x0):
    sweeps = [AccuracySweep(Method.CVODES, [1e-4, 1e-7, 1e-10]),
              AccuracySweep(Method.RK, [0.05, 0.025, 0.0125]),
              AccuracySweep(Method.S2_VARIATIONAL, [0.05, 0.025, 0.0125]),
              AccuracySweep(Method.RKMK4, [0.05, 0.025, 0.0125])]
    return work_precision(sphere, x0, 2.0, sweeps, n_samples=5)


def test_reference_is_accurate_and_checked(wp):
    assert wp.reference.error_estimate < 1e-12
    assert wp.reference.labels[0].startswith("reference")


def test_reference_error_estimate_falls_as_the_fourth_power_of_its_step(sphere, x0):
    # RK4's Richardson estimate |x(h) - x(2h)| ~ (2^4 - 1) C h^4: two halvings fewer,
    # 4^4 = 256 times larger
    est = {}
    for k in (9, 11):
        refs = default_reference(2.0, halvings=k)
        assert [r.values for r in refs] == [(2.0 / 2**k,), (2.0 / 2**(k - 1),)]
        assert refs[0].label == f"reference rk h=T/2^{k}"
        est[k] = work_precision(sphere, x0, 2.0, [AccuracySweep(Method.RK, [0.05])],
                                reference=refs, n_samples=5).reference.error_estimate
    assert 150 < est[9] / est[11] < 400


@pytest.mark.parametrize("bad", [3, 0, 15.0, True, "16"])
def test_reference_halvings_must_be_an_integer_of_at_least_four(bad):
    with pytest.raises(ParameterError, match=r"halvings must be an integer >= 4( and <= 26)?; got"):
        default_reference(1.0, halvings=bad)


def test_errors_fall_with_the_knob_and_orders_match_theory(wp):
    for lab in ("cvodes", "rk", "s2_variational", "rkmk4"):
        errs = [r.final_error for r in wp.runs if r.label == lab]
        assert all(a > b for a, b in zip(errs, errs[1:])), (lab, errs)
    orders = wp.orders()
    assert "cvodes" not in orders  # no step, no order
    for lab, theory in (("rk", 4), ("s2_variational", 2), ("rkmk4", 4)):
        assert orders[lab]["theory"] == theory
        assert abs(orders[lab]["fitted"] - theory) < 0.3, orders[lab]


def test_runs_measure_energy_constraint_and_cost(wp):
    for r in wp.runs:
        # the cost is recorded (a count where the method keeps one), not judged: speed is
        # measured in benchmarks/
        assert r.ok and np.isfinite(r.wall_seconds) and r.constraint_residual >= 0
        assert r.steps is None or r.steps > 0
        assert r.energy_error is not None and r.energy_error > 0
    geo = [r for r in wp.runs if r.label in ("s2_variational", "rkmk4")]
    assert max(r.constraint_residual for r in geo) < 1e-13
    rk = [r for r in wp.runs if r.label == "rk"]
    assert [r.evaluations for r in rk] == [4 * r.steps for r in rk]
    assert rk[0].step == pytest.approx(0.05) and rk[0].knob == "step"
    table = wp.table()
    assert len(table) == 12 and {"final_error", "wall_seconds", "status"} <= set(table[0])


def _run(label, err, wall, evals=None, status="ok", step=None):
    return Run(label, label, "step", 0.1, step, err, None, 0.0, wall, evals, None,
               *RunStatus.of(status))


def test_fastest_and_winners_pick_the_cheapest_run_reaching_the_accuracy(wp):
    synthetic = WorkPrecision("m", 1.0, wp.reference, [
        _run("a", 1e-3, 1.0, 100), _run("a", 1e-6, 4.0, 400),
        _run("b", 1e-4, 2.0, 50), _run("b", 1e-8, 3.0, 80),
        _run("c", math.inf, math.nan, status="failed: x"),
    ], {"a": 2, "b": 4, "c": 4})
    assert synthetic.fastest(1e-2).label == "a"
    assert synthetic.fastest(1e-5).label == "b" and synthetic.fastest(1e-5).wall_seconds == 3.0
    assert synthetic.fastest(1e-9) is None
    assert synthetic.fastest(1e-2, cost=Cost.EVALUATIONS).label == "b"
    w = synthetic.winners([1e-2, 1e-5])
    assert w[0]["fastest"] == "a" and w[0]["ratio_to_fastest"]["b"] == 2.0
    assert w[1]["costs"] == {"a": 4.0, "b": 3.0, "c": None} and w[1]["fastest"] == "b"


def test_failed_runs_are_recorded_not_raised(sphere, x0):
    cheap = [AccuracySweep(Method.CVODES, [1e-12], label="ref"),
             AccuracySweep(Method.RK, [1e-3], label="chk")]
    res = work_precision(sphere, x0, 2.0, [AccuracySweep(Method.S2_VARIATIONAL, [2.0, 0.05])],
                         n_samples=2, reference=cheap)
    assert res.reference.labels == ["ref", "chk"] and res.reference.error_estimate < 1e-9
    bad, good = res.runs
    assert not bad.ok and bad.status is RunStatus.FAILED and "no solution" in bad.message
    assert bad.final_error == math.inf
    assert good.ok


def test_long_time_bounded_against_drifting(sphere, x0):
    lt = long_time(sphere, x0, 200.0, [AccuracySweep(Method.S2_VARIATIONAL, [0.05]),
                                       AccuracySweep(Method.RK, [0.05])], n_samples=2001)
    vi, rk = (r.summary() for r in lt.runs)
    assert abs(vi["energy_exponent"]) < 0.1 and vi["energy_growth"] < 1.5
    assert rk["energy_exponent"] > 0.5 and rk["energy_growth"] > 3.0
    assert vi["constraint_max"] < 1e-13 and rk["constraint_late"] > rk["constraint_early"]
    assert lt.run("rk").energy_error.shape == (2001,)
    with pytest.raises(ModelError, match="no long-time run"):
        lt.run("lgvi")


@pytest.mark.parametrize(("make", "match"), [
    (lambda: AccuracySweep(Method.RK, []), "at least one"),
    (lambda: AccuracySweep(Method.RK, [0.1, -0.1]), "positive finite"),
    (lambda: AccuracySweep(Method.RK, [0.0]), "positive finite"),
    (lambda: AccuracySweep(Method.RK, [float("nan")]), "positive finite"),
    (lambda: AccuracySweep("euler", [0.1]), "AccuracySweep.method"),
    (lambda: AccuracySweep(Method.RK, [0.1], {"step": 0.2}), "must not set"),
])
def test_bad_sweeps_are_rejected(make, match):
    with pytest.raises(ParameterError, match=match):
        make()


def test_sweep_knobs_and_orders():
    assert AccuracySweep(Method.CVODES, [1e-6]).knob is Knob.RTOL
    assert AccuracySweep(Method.CVODES, [1e-6]).order is None
    assert AccuracySweep(Method.COLLOCATION, [0.1], {"degree": 3}).order == 6
    assert AccuracySweep(Method.COLLOCATION, [0.1], {"degree": 3}).label == "collocation d=3"
    assert AccuracySweep(Method.LGVI, [0.1]).keywords(0.1) == {"method": Method.LGVI, "step": 0.1}


def test_bad_measurement_input_is_rejected(sphere, x0):
    ok = [AccuracySweep(Method.RK, [0.1])]
    with pytest.raises(ParameterError, match="must not exceed the horizon"):
        work_precision(sphere, x0, 1.0, [AccuracySweep(Method.RK, [2.0])])
    with pytest.raises(ParameterError, match="horizon"):
        work_precision(sphere, x0, -1.0, ok)
    with pytest.raises(ParameterError, match="labels must be unique"):
        work_precision(sphere, x0, 1.0, ok + ok)
    with pytest.raises(ParameterError, match="repeats"):
        work_precision(sphere, x0, 1.0, ok, repeats=0)
    with pytest.raises(ParameterError, match="n_samples"):
        work_precision(sphere, x0, 1.0, ok, n_samples=1)
    with pytest.raises(ModelError, match="energy must name"):
        work_precision(sphere, x0, 1.0, ok, energy="momentum")
    with pytest.raises(ParameterError, match="one knob value"):
        long_time(sphere, x0, 1.0, [AccuracySweep(Method.RK, [0.1, 0.05])])


@pytest.mark.slow
def test_ten_thousand_periods_lgvi_bounded_rk_drifts():
    """The long-time claim of the work-precision problem, at full length (slow)."""
    from models import pendulum3d as p3
    from problems.work_precision import BODY, C_CHAOTIC, slowest_period

    body = p3.full(**BODY)
    x0 = body.state(R=np.eye(3), omega=C_CHAOTIC * np.ones(3))
    period = slowest_period(body, body.state(R=np.eye(3), omega=np.zeros(3)))
    horizon = round(10_000 * period / 0.2) * 0.2
    lt = long_time(body, x0, horizon,
                   [AccuracySweep(Method.LGVI, [0.01]), AccuracySweep(Method.RK, [0.01])],
                   n_samples=int(round(horizon / 0.2)) + 1)
    vi, rk = (r.summary() for r in lt.runs)
    assert abs(vi["energy_exponent"]) < 0.1 and vi["energy_growth"] < 1.2
    assert vi["constraint_max"] < 1e-12
    assert abs(rk["energy_exponent"] - 1.0) < 0.2 and rk["energy_growth"] > 5.0
