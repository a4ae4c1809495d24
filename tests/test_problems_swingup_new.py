"""The Furuta and acrobot swing-ups: solved from the OCP's defaults, in quick mode.

Each problem must meet its comparisons (target, bound, manifold, defect, the energy and
momentum balances the optimiser does not impose, the TVLQR Monte Carlo) with no guess and
no handling given; the mathematics the problems use is checked on its own too.
"""

from __future__ import annotations

import inspect
import json

import numpy as np
import pytest

from models.acrobot import acrobot
from models.acrobot import hanging as acro_hanging
from models.acrobot import upright as acro_upright
from models.furuta import furuta
from models.furuta import hanging as furuta_hanging
from models.furuta import upright as furuta_upright
from problems import _swingup, swingup_acrobot, swingup_furuta
from workbench.app.registry import names

PROBLEMS = {"swingup_furuta": swingup_furuta, "swingup_acrobot": swingup_acrobot}


@pytest.fixture(scope="module")
def results():
    return {name: module.solve(quick=True) for name, module in PROBLEMS.items()}


@pytest.mark.parametrize("name", list(PROBLEMS))
def test_quick_run_meets_every_comparison(results, name, tmp_path):
    res = results[name]
    assert res.ok, [c.as_dict() for c in res.comparisons if not c.ok]
    assert name in names()
    assert res.build_log and res.timings and res.figures
    attempts = res.values["attempts"]
    assert attempts and attempts[-1]["status"] in ("SUCCESS", "ACCEPTABLE")
    assert all({"what", "status", "iterations", "objective", "cpu_seconds"} <= set(a)
               for a in attempts)
    data = json.loads(res.write_json(tmp_path / "r.json").read_text())
    assert data["ok"] and data["quick"]


@pytest.mark.parametrize("module", list(PROBLEMS.values()))
def test_solved_from_the_defaults(module):
    """No guess and no handling anywhere in the problem: the defaults solve it."""
    source = inspect.getsource(module)
    assert "guess=" not in source and "handling=" not in source


def test_furuta_pumps_from_the_energy_feedback(results):
    v = results["swingup_furuta"].values
    assert v["attempts"][0]["guess"].startswith("energy pumping")
    bang = v["bang_bang"]
    assert bang["switches"] >= 4  # it swings: several reversals of the weak torque
    assert bang["at_bound"] >= 0.8 * (bang["at_bound"] + bang["inside"])


def test_energy_gains_in_closed_form():
    m = furuta()
    p = swingup_furuta.QUBE_SERVO_2
    gain = m.invariants(furuta_upright(m, theta=1.3))["energy"] - m.invariants(
        furuta_hanging(m))["energy"]
    assert gain == pytest.approx(p["mp"] * p["g"] * p["Lp"], rel=1e-12)
    a = acrobot()
    gain = a.invariants(acro_upright(a))["energy"] - a.invariants(acro_hanging(a))["energy"]
    assert gain == pytest.approx(swingup_acrobot.energy_gain(), rel=1e-12)


def test_bang_bang_classification():
    u = np.array([-1.0, -1.0, 0.3, 1.0, 1.0, -1.0, -1.0])  # switches inside and on a node
    assert swingup_furuta.bang_bang(u, 1.0) == {
        "at_bound": 6, "inside": 1, "switches": 2, "inside_without_switch": 0}
    u = np.array([1.0, 0.5, 1.0, -1.0])  # an interval off the bound between equal neighbours
    assert swingup_furuta.bang_bang(u, 1.0)["inside_without_switch"] == 1


def test_furuta_angles_unwrap_across_pi():
    m = furuta()
    th = np.linspace(0.0, 3 * np.pi, 50)
    X = np.array([furuta_upright(m, theta=t) for t in th])
    a = _swingup.coordinates(m, X, ("theta", "alpha"))
    assert np.allclose(a[:, 0], th, atol=1e-12) and np.allclose(a[:, 1], np.pi)


def test_steps_cross_the_cut_and_sum_to_the_turn():
    """Wrapped increments of an S^1 factor add up to the unwrapped turn; R^1 ones subtract."""
    m = furuta()
    rng = np.random.default_rng(5)
    th = np.cumsum(rng.uniform(-2.5, 2.5, 40))  # crosses +-pi many times, |step| < pi
    X = np.array([furuta_upright(m, theta=t) for t in th])
    d = _swingup.steps(m, X[:-1], X[1:], "theta")
    np.testing.assert_allclose(d, np.diff(th), atol=1e-12)
    np.testing.assert_allclose(_swingup.coordinates(m, X, ["theta"])[:, 0], th, atol=1e-9)
    X[:, m.manifold.slices["theta_dot"]] = th[:, None]  # an R^1 factor: plain differences
    np.testing.assert_allclose(_swingup.steps(m, X[:-1], X[1:], "theta_dot"), np.diff(th))
