"""The work-precision problem runs in quick mode, meets its comparisons and reports its
tables, figures and build log."""

from __future__ import annotations

import json

import numpy as np
import pytest

from models import pendulum3d as p3
from problems.work_precision import BODY, slowest_period, solve
from workbench.app.registry import load, names


@pytest.fixture(scope="module")
def result():
    return solve(quick=True)


def test_quick_run_meets_every_comparison(result):
    assert result.ok, [c.as_dict() for c in result.comparisons if not c.ok]
    quantities = " | ".join(c.quantity for c in result.comparisons)
    for needed in ("fitted order of lgvi", "fitted order of rkmk4", "fitted order of rk",
                   "lgvi: growth exponent", "s2_variational: growth exponent",
                   "lgvi: constraint residual", "vertical angular momentum"):
        assert needed in quantities, needed


def test_tables_figures_and_build_log(result, tmp_path):
    v = result.values
    for scene in ("pendulum3d", "chain3"):
        runs = v[scene]["runs"]
        assert {r["method"] for r in runs} >= {"cvodes", "rk", "collocation", "rkmk4"}
        assert all(np.isfinite(r["final_error"]) for r in runs)
        assert [w["accuracy"] for w in v[scene]["fastest"]] == [1e-2, 1e-4, 1e-6, 1e-8]
    assert "lgvi" in {r["method"] for r in v["pendulum3d"]["runs"]}
    lt = {r["label"]: r for r in v["long_time"]["pendulum3d"]}
    # the variational integrator's energy error stays put; RK4's grows
    assert lt["lgvi"]["energy_growth"] < 1.5 < lt["rk"]["energy_growth"]
    assert set(v["per_step_cost"]) >= {"rk", "lgvi", "lgvi jit", "rkmk4"}
    assert set(result.figures) == {"work_precision_pendulum3d", "work_precision_chain3",
                                   "long_time_pendulum3d", "long_time_spherical",
                                   "convergence_orders"}
    built = {r["function"] for r in result.build_log}
    assert any(f.startswith("pendulum3d_full.lgvi_step") for f in built)
    assert any(f.startswith("chain_cart_n3.rkmk4_step") for f in built)
    data = json.loads(json.dumps(result.as_dict()))
    assert data["name"] == "work_precision"
    assert json.loads(result.write_json(tmp_path / "r.json").read_text())["ok"] is True


def test_slowest_period_matches_the_closed_form():
    body = p3.full(**BODY)
    x_hang = body.state(R=np.eye(3), omega=np.zeros(3))
    closed = 2 * np.pi * np.sqrt(0.28 / (1.0 * 9.81 * 0.3))  # about e2, largest inertia
    assert slowest_period(body, x_hang) == pytest.approx(closed, rel=1e-10)


def test_registered():
    assert "work_precision" in names()
    assert load("work_precision").TITLE
