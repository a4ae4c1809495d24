"""The controller problems run in quick mode, meet their comparisons and report their cost."""

from __future__ import annotations

import json

import numpy as np
import pytest

from problems import load, names

PROBLEMS = ["velocity_feedback_hanging", "so3_pd_closed_loop", "cart_nonlinear_inverted"]


@pytest.fixture(scope="module")
def results():
    return {name: load(name).solve(quick=True) for name in PROBLEMS}


@pytest.mark.parametrize("name", PROBLEMS)
def test_quick_run_meets_every_comparison(results, name, tmp_path):
    res = results[name]
    assert res.ok, [c.as_dict() for c in res.comparisons if not c.ok]
    assert name in names()
    assert res.build_log and res.timings and res.figures
    data = json.loads(res.write_json(tmp_path / "r.json").read_text())
    assert data["ok"] and data["quick"]


def test_velocity_feedback_numbers(results):
    v = results["velocity_feedback_hanging"].values
    assert v["max_u"] <= 10.0
    assert 0 < v["R0_projection_change"] < 1e-5  # the printed R(0) needed a tiny projection
    assert v["monte_carlo_global"]["n_converged"] == v["monte_carlo_global"]["n_samples"]
    assert v["V"]["Vf"] < 1e-10 * v["V"]["V0"]


def test_so3_saddles_have_the_papers_unstable_dimensions(results):
    spectra = results["so3_pd_closed_loop"].values["spectra"]
    assert [spectra[k]["n_unstable"] for k in ("I", "e1", "e2", "e3")] == [0, 3, 2, 1]


def test_cart_certificate_is_consistent(results):
    v = results["cart_nonlinear_inverted"].values
    assert 0 < v["K"] < 1
    assert v["certified_level"] == pytest.approx(v["K"] * v["step1_V_tilde"], rel=1e-12)
    assert not v["fig5_initial_state_in_certified_set"]  # outside the certificate, converges
    assert v["V_x0"] > v["certified_level"]
    axes = np.array(list(v["certified_extent_along_tangent_axes"].values()))
    assert np.all(np.isfinite(axes)) and np.all(axes > 0)
    assert v["basin"]["n_certified_not_converged"] == 0
