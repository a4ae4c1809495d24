"""The invariant-manifold problems run in quick mode and hold their comparisons."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402

from workbench.app import registry as problems  # noqa: E402

NAMES = ["stable_manifold_s2", "stable_manifolds_so3", "inverted_manifold_velocity_feedback"]


@pytest.fixture(scope="module")
def results():
    return {name: problems.load(name).solve(quick=True) for name in NAMES}


@pytest.mark.parametrize("name", NAMES)
def test_problem_comparisons_hold(results, name):
    res = results[name]
    bad = [f"{c.quantity}: {c.workbench} vs {c.reference} (tol {c.tolerance})"
           for c in res.comparisons if not c.ok]
    assert not bad, bad
    assert len(res.comparisons) >= 8
    assert res.figures and res.build_log
    res.as_dict()  # JSON-serialisable


def test_s2_values(results):
    v = results["stable_manifold_s2"].values
    assert v["angle_travelled_max"][10.0] > 3.14  # past the hanging point: covers twice
    assert v["validation"]["worst_ratio"] < 1e-3
    assert v["manifold"]["cost"]["point_steps"] == 24 * 5000


def test_so3_observations(results):
    v = results["stable_manifolds_so3"].values
    assert v["e2"]["cover_fraction_0.4rad"] > v["e1"]["cover_fraction_0.4rad"]
    assert v["e3"]["observations"]["max_axis3_angle_deg"] < 1.0
    assert v["e1"]["manifold"]["dimension"] == 3 and v["e3"]["manifold"]["dimension"] == 5


def test_slice_avoids_N(results):
    v = results["inverted_manifold_velocity_feedback"].values
    assert v["min_margin"] > 0 and v["min_margin_over_d2"] > 0
