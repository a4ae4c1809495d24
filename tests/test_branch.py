"""What a continuation returns and the knobs it takes (workbench/equilibria/_branch.py)."""

from __future__ import annotations

import numpy as np
import pytest

from workbench.core.errors import ParameterError
from workbench.equilibria._branch import Branch, EndReason, PointKind, SpecialPoint, StepControl


@pytest.mark.parametrize(("knobs", "words"), [
    ({"step": 0.0}, "step"),
    ({"min_step": 0.5}, "min_step <= step <= max_step"),
    ({"max_step": 0.01}, "min_step <= step <= max_step"),
    ({"growth": 0.5}, "growth must be >= 1"),
    ({"max_corrector_iterations": 0}, "max_corrector_iterations"),
    ({"locate_tol": float("nan")}, "locate_tol"),
])
def test_step_control_refuses_inconsistent_knobs(knobs, words):
    with pytest.raises(ParameterError, match=words):
        StepControl(**knobs)


def _branch(end: EndReason) -> Branch:
    s = np.array([0.0, 0.1, 0.25])
    pts = np.column_stack([np.cos(s), np.sin(s)])
    sp = SpecialPoint(PointKind.EVENT, "x", pts[1], 0.1, 1, 1e-13, pts[1][::-1], {"x": 0.0})
    return Branch(problem="arc", points=pts, tangents=np.column_stack([-np.sin(s), np.cos(s)]),
                  s=s, residuals=np.array([0.0, 1e-13, 2e-13]), monitors={"x": pts[:, 0]},
                  labels=[], special=[sp], end=end, end_message=end.value,
                  corrector_iterations=np.array([0, 2, 3]), rejected_steps=1, evaluations=9,
                  wall_time=0.0, null_dimensions=np.array([1, 1, 2]))


@pytest.mark.parametrize("end", list(EndReason))
def test_a_branch_reports_its_end_as_its_status(end):
    b = _branch(end)
    assert b.status is end and b.ok is (end is not EndReason.STEP_TOO_SMALL)
    summary = b.summary()
    assert summary["end"] == end.name.lower() and summary["end_message"] == end.value
    assert summary["n_points"] == 3 and summary["arclength"] == 0.25
    assert summary["max_residual"] == 2e-13 and summary["points_off_a_curve"] == 1
    assert summary["mean_corrector_iterations"] == 2.5 and b.iterations == 5
    assert b.specials(PointKind.EVENT, "x") == [b.special[0]]
    assert b.specials(PointKind.BOUND) == []
