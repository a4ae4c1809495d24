"""The cheap case groups of the extremes study, one at a time (problems/_extremes/).

The groups are the same definitions the problem runs (tests/extremes/test_extreme_problem.py
runs them all, once); here each runs alone, so a failing group is named by its test.
"""

from __future__ import annotations

import numpy as np
import pytest

from problems._extremes import bad_inputs, continuation, near_balanced
from workbench.study import CLEAR, CORRECT, Cases, Result

GROUPS = {
    "near_balanced": lambda cases, res: near_balanced(cases, res, [1e-2, 1e-8, 0.0]),
    "continuation": lambda cases, res: continuation(cases, res, quick=True),
    "bad_input": lambda cases, res: bad_inputs(cases),
}


@pytest.mark.parametrize("group", sorted(GROUPS))
def test_group_is_correct_or_fails_clearly(group):
    cases, res = Cases(), Result("extremes", "one group")
    GROUPS[group](cases, res)
    rows = cases.groups[group]
    assert rows, f"group {group} ran no case"
    bad = [(r["case"], r["did"], r["measure"]) for r in rows
           if r["outcome"] not in (CORRECT, CLEAR)]
    assert not bad, bad
    for r in rows:
        if r["outcome"] == CORRECT:
            assert np.isfinite(r["error"]) and r["error"] <= r["tolerance"], r
    assert all(c.ok for c in res.comparisons), [c.as_dict() for c in res.comparisons
                                                if not c.ok]
    if group == "bad_input":
        assert all(r["outcome"] == CLEAR for r in rows)
    if group == "near_balanced":  # the balanced body has no isolated static equilibria
        (row,) = [r for r in rows if r["case"] == "|rho| = 0: static equilibria"]
        assert row["outcome"] == CLEAR and "balanced" in row["did"]
