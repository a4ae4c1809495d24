"""The extremes problem: every case correct with an error estimate, or a clear failure.

The quick run is shared by the tests of this module (one run, about 25 s on two cores).
The full run (n = 50 chain, 10^5 s horizons) is marked slow.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from problems import extremes
from workbench.app.report.tables import MAX_ROWS, value_tables
from workbench.core.errors import ModelError, SolverError
from workbench.study import CLEAR, CORRECT, DEFECT, Cases, Check

GROUPS = ("near_balanced", "ill_conditioned", "fast_and_slow", "continuation", "large_chains",
          "optimisation", "bad_input")


@pytest.fixture(scope="module")
def quick():
    return extremes.solve(quick=True)


def _rows(result):
    return [(g, r) for g, rows in result.values.items() if g != "outcomes" for r in rows]


def _check_result(result):
    rows = _rows(result)
    assert set(GROUPS) <= set(result.values)
    defects = [(g, r["case"], r["did"], r["measure"]) for g, r in rows if r["outcome"] != CORRECT
               and r["outcome"] != CLEAR]
    assert not defects, defects
    for _, r in rows:
        assert r["cost [s]"] >= 0
        if r["outcome"] == CORRECT:
            assert np.isfinite(r["error"]) and r["error"] <= r["tolerance"], r
            assert r["measure"], r
        else:  # a documented exception, named, with a message
            assert r["did"].split(":")[0] in ("ManifoldError", "ParameterError", "ModelError",
                                              "SolverError"), r["did"]
            assert len(r["did"]) > 40, r["did"]
    bad = [c.as_dict() for c in result.comparisons if not c.ok]
    assert not bad, bad
    assert result.values["outcomes"][CORRECT] + result.values["outcomes"][CLEAR] == len(rows)


def test_quick_run_has_no_defect_and_every_comparison_holds(quick):
    _check_result(quick)
    assert len(quick.comparisons) >= 20


def test_the_cases_that_must_fail_do_so_clearly(quick):
    rows = {(g, r["case"]): r for g, r in _rows(quick)}
    must_fail = {
        ("near_balanced", "|rho| = 0: static equilibria"): "balanced",
        ("continuation", "alpha = 0"): "nonzero",
        ("fast_and_slow", "spin 1e3 rad/s: lgvi h = 1e-3 (h s = 1)"): "Newton did not converge",
        ("ill_conditioned", "cond J = 1e+08: LQR"): "uncontrollable mode",
        ("ill_conditioned", "cond J = 1e+08: lgvi h = 2.5e-6"): "rounding level",
        ("fast_and_slow", "separatrix: theta0 = pi - 1e-06"): "separatrix",
        # (which exit a hopeless solve takes is path dependent: with the mass matrix
        # solved as L D L^T instead of QR, rounding-level differences, T = 0.05 s wanders
        # to 300 iterations where it failed its restoration after 85)
        ("optimisation", "T = 0.05 s fixed (too short)"): ("Infeasible_Problem_Detected",
                                                           "Restoration_Failed",
                                                           "Maximum_Iterations_Exceeded"),
        ("optimisation", "T = 100 s fixed on N = 20 (too coarse)"): ("INACCURATE",
                                                                     "Maximum_Iterations_Exceeded"),
    }
    # |u| <= 1 N ran out of iterations from the geodesic guess; the default strategy's
    # structured starts may solve it within the case's iteration cap (to the defect
    # tolerance) or not (then with Ipopt's status): either, never a wrong answer
    row = rows[("optimisation", "|u| <= 1 N")]
    assert row["outcome"] in ("correct", CLEAR), row
    assert row["outcome"] == "correct" or "Maximum_Iterations_Exceeded" in row["did"], row
    for key, word in must_fail.items():
        assert rows[key]["outcome"] == CLEAR, (key, rows[key])
        words = (word,) if isinstance(word, str) else word
        assert any(w in rows[key]["did"] for w in words), (key, rows[key]["did"])
    assert all(r["outcome"] == CLEAR for g, r in _rows(quick) if g == "bad_input")


def test_near_balanced_and_ill_conditioned_numbers_meet_the_closed_forms(quick):
    rows = {r["case"]: r for g, r in _rows(quick) if g in ("near_balanced", "ill_conditioned")}
    for s in ("0.01", "1e-06", "1e-10"):
        assert rows[f"|rho| = {s}: static equilibria"]["error"] <= 1e-12
        assert rows[f"|rho| = {s}: spectra"]["error"] <= 1e-9
        assert rows[f"|rho| = {s}: LQR"]["error"] <= 1e-12
    assert rows["|rho| = 0: spectra"]["error"] == 0.0  # nilpotent: every eigenvalue exactly 0
    assert rows["cond J = 1e+08: static equilibria"]["error"] <= 1e-12
    assert rows["cond J = 1e+08: spectra"]["error"] <= 1e-6
    assert rows["J1 - J2 = 1e-12: relative equilibria"]["outcome"] == CORRECT
    assert "local dimension [1]" in rows["J1 - J2 = 1e-12: relative equilibria"]["did"]
    sources = {c.source for c in quick.comparisons}
    assert "paper 000 (3.22)-(3.28)" in sources and "Prop. 9 (erratum)" in sources


def test_large_chain_reports_time_memory_and_finite_results(quick):
    (row,) = [r for g, r in _rows(quick) if g == "large_chains"]
    assert row["outcome"] == CORRECT
    assert 10 < row["memory added [MB]"] < 4000  # the case's own, measured in its process
    assert "dim 84" in row["did"] and "all finite" in row["did"]


def test_report_engine_lays_out_one_table_per_group_and_json_round_trips(quick, tmp_path):
    tables = {t.title.split("  ")[0]: t for t in value_tables(quick)}
    for g in GROUPS:
        assert g in tables, sorted(tables)
        t = tables[g]
        assert len(t.rows) == len(quick.values[g]) <= MAX_ROWS
        for col in ("case", "did", "outcome", "error", "cost [s]"):
            assert col in t.header
    path = quick.write_json(tmp_path / "extremes.json")
    data = json.loads(path.read_text())
    assert data["ok"] and data["values"]["outcomes"] == quick.values["outcomes"]


# ----------------------------------------------------------------------------------------
# the case runner itself


def test_case_runner_classifies_results_failures_and_defects():
    cases = Cases()
    cases.run("g", "ok", lambda: Check("did", 1e-14, "m", 1e-12))
    cases.run("g", "inaccurate", lambda: Check("did", 1e-3, "m", 1e-12))
    cases.run("g", "nan", lambda: Check("did", float("nan"), "m", 1e-12))
    cases.run("g", "clear", lambda: (_ for _ in ()).throw(SolverError("it failed", status="x")))
    cases.run("g", "raw", lambda: [][1])
    cases.run("g", "should fail", lambda: Check("did", 0.0, "m", 1.0), expect_failure=True)

    def documented():
        raise ModelError("bad name 'zz'; known: a, b")

    cases.run("g", "expected", documented, expect_failure=True)
    out = {r["case"]: r["outcome"] for r in cases.groups["g"]}
    assert out == {"ok": CORRECT, "inaccurate": DEFECT, "nan": DEFECT, "clear": CLEAR,
                   "raw": DEFECT, "should fail": DEFECT, "expected": CLEAR}
    raw = cases.groups["g"][4]
    assert raw["did"].startswith("IndexError") and raw["measure"] == "undocumented exception"


def test_converged_swing_up_follows_the_dynamics(quick):
    rows = {r["case"]: r for r in quick.values["optimisation"]}
    ref = rows["reference: |u| <= 10 N, T in [0.5, 3] s"]
    assert ref["outcome"] == CORRECT and ref["error"] < 1e-4
    assert "SUCCESS (Ipopt Solve_Succeeded" in ref["did"]


@pytest.mark.slow
def test_full_run_has_no_defect():
    result = extremes.solve(quick=False)
    _check_result(result)
    chains = {r["case"]: r for r in result.values["large_chains"]}
    assert chains["chain n = 50"]["outcome"] == CORRECT
    long = [r for r in result.values["fast_and_slow"] if r["case"].startswith("1e+05 s")]
    assert len(long) == 3 and all(r["outcome"] == CORRECT for r in long)
