"""Problem mechanics_paper_models: derived vs printed vector fields, every model within 1e-11."""

from __future__ import annotations

from problems import mechanics_paper_models as problem


def test_quick_run_compares_every_model_within_tolerance():
    res = problem.solve(quick=True)
    assert res.ok, [c for c in res.comparisons if not c.ok]
    labels = set(res.values["max_deviation"])
    assert len(labels) == 6  # 3D pendulum, spherical pendulum, chains n = 1, 2, 3, 5
    assert all(v <= problem.TOL for v in res.values["max_deviation"].values())
    assert all(v <= problem.TOL for v in res.values["invariant_deviation"].values())
    assert len(res.comparisons) == 2 * len(labels)
    assert "deviations" in res.figures and res.captions["deviations"]
