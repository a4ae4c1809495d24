"""The steps of pseudo-arclength continuation (workbench/equilibria/_steps.py).

Closed forms on the unit circle: from y = (1, 0) with tangent d = (0, 1), Keller's condition
d . (z - y) = h puts the corrected point at z = (sqrt(1 - h^2), h), whose tangent has
turned by arcsin(h).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close
from test_continuation import plane_problem

from workbench.equilibria._branch import EndReason, StepControl
from workbench.equilibria._steps import (
    Trace,
    is_closed,
    next_step,
    point_info,
    rejection_message,
    start_point,
    try_step,
)

C = StepControl(step=0.05, min_step=1e-4, max_step=0.2, max_turn=0.3, growth=1.5)


@pytest.fixture(scope="module")
def circle():
    return plane_problem(lambda y: ca.dot(y, y) - 1, {"x": lambda y: y[0]})


@pytest.mark.parametrize("h", [1e-3, 0.05, 0.2])
def test_predictor_corrector_lands_at_the_keller_distance(circle, h):
    start = point_info(circle, np.array([1.0, 0.0]), np.array([0.0, 1.0]), C.rank_rtol)
    root, new, turn = try_step(circle, start, h, C)
    assert root.ok and new is not None
    assert_close(new["y"], [math.sqrt(1 - h * h), h], atol=1e-12, what="Keller point")
    assert_close(turn, math.asin(h), atol=1e-9, what="turn of the tangent")
    assert new["d"] @ start["d"] > 0  # oriented along the direction of travel


def test_a_step_turning_past_max_turn_is_rejected_with_its_turn(circle):
    start = point_info(circle, np.array([1.0, 0.0]), np.array([0.0, 1.0]), C.rank_rtol)
    h = math.sin(0.4)  # turns by 0.4 rad > max_turn 0.3
    root, new, turn = try_step(circle, start, h, C)
    assert root.ok and new is None and abs(turn - 0.4) < 1e-9
    assert "turn 0.4 rad" in rejection_message(root, turn, C)


def test_step_control_aims_at_half_the_max_turn_within_its_limits():
    # turn = max_turn / 2 keeps the step; a smaller turn grows it, capped by growth
    assert next_step(0.1, 0.15, 1, C) == pytest.approx(0.1)
    assert next_step(0.1, 0.1, 1, C) == pytest.approx(0.15)  # 0.5 * 0.3 / 0.1 = 1.5
    assert next_step(0.1, 1e-6, 1, C) == pytest.approx(0.15)  # growth cap
    assert next_step(0.1, 0.6, 1, C) == pytest.approx(0.05)  # at least halves
    # a correction that needed nearly all its iterations slows down to 0.7
    assert next_step(0.1, 0.1, C.max_corrector_iterations - 1, C) == pytest.approx(0.07)
    assert next_step(0.19, 1e-6, 1, C) == C.max_step
    assert next_step(1.5e-4, 10.0, 1, C) == C.min_step


def test_closed_curve_needs_more_than_four_steps_near_the_start_same_way():
    first = {"y": np.array([1.0, 0.0]), "d": np.array([0.0, 1.0])}
    back = {"y": np.array([1.0, 0.01]), "d": np.array([0.0, 1.0])}
    assert is_closed(6.3, 0.05, back, first)
    assert not is_closed(0.15, 0.05, back, first)  # s <= 4 h: just started
    assert not is_closed(6.3, 0.01, back, first)  # farther than h / 2
    assert not is_closed(6.3, 0.05, {**back, "d": -back["d"]}, first)  # opposite way


def test_start_is_oriented_and_recorded(circle):
    cur, root = start_point(circle, np.array([0.0, 1.0 + 1e-6]), [-1.0, 0.0], C)
    assert root.ok and abs(np.linalg.norm(cur["y"]) - 1) < 1e-12
    assert cur["d"] @ np.array([-1.0, 0.0]) > 0 and cur["nulldim"] == 1
    trace = Trace(cur, root.residual, classify=lambda y: int(y[0] > 0))
    assert len(trace) == 1 and trace.labels == [0] and trace.mons["x"] == [cur["mon"]["x"]]
    b = trace.branch("circle", end=EndReason.MAX_POINTS,
                     end_message="", rejected=0, evaluations=1, wall_time=0.0)
    assert b.points.shape == (1, 2) and b.ok
