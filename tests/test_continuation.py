"""Pseudo-arclength continuation on manifolds: curves with known geometry."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from workbench.core.errors import ManifoldError, ParameterError, SolverError
from workbench.core.manifolds import S2, ProductManifold, Rn
from workbench.equilibria._branch import EndReason, PointKind, StepControl
from workbench.equilibria._continuation import (
    continue_branch,
    correct_point,
    locate_on_branch,
    switch_branch,
)
from workbench.equilibria._roots import RootStatus, ZeroProblem


def plane_problem(expr_of, monitors=None, n=2) -> ZeroProblem:
    """A zero problem on R^n from an expression builder ``expr_of(y) -> F``."""
    y = ca.SX.sym("y", n)
    u, p = ca.SX.sym("u", 0), ca.SX.sym("p", 0)
    F = expr_of(y)
    mons = monitors or {}
    fn = ca.Function("F", [y, u, p], [F, ca.jacobian(F, y), *[m(y) for m in mons.values()]])
    return ZeroProblem(name="test", manifold=ProductManifold([("y", Rn(n))]), function=fn,
                       u=[], p=[], monitor_names=list(mons))


def test_circle_is_closed_with_length_two_pi():
    prob = plane_problem(lambda y: ca.dot(y, y) - 1, {"x": lambda y: y[0]})
    c = StepControl(step=0.01, max_step=0.05)
    b = continue_branch(prob, [1.0, 0.0], direction=[0.0, 1.0], control=c, events=["x"])
    assert b.end is EndReason.CLOSED
    assert_close(np.linalg.norm(b.points, axis=1), np.ones(len(b)), atol=1e-11,
                 what="points on the circle")
    # Keller steps are projections of the chords onto the tangent: error O(h^2) per length
    assert abs(b.s[-1] - 2 * np.pi) < 2 * np.pi * 0.05**2
    ev = b.specials(PointKind.EVENT, "x")
    assert len(ev) == 2
    assert_close(np.array([p.y for p in ev]), np.array([[0.0, 1.0], [0.0, -1.0]]),
                 atol=1e-10, what="x = 0 located")
    assert np.all(b.tangents[:, 0] * b.points[:, 1] <= 1e-12)  # counter-clockwise


def test_parabola_bounds_events_stop_and_classification():
    prob = plane_problem(lambda y: y[1] - y[0] ** 2,
                         {"x": lambda y: y[0], "y_minus_1": lambda y: y[1] - 1.0})
    labels = lambda y: int(y[0] > 0.3)  # noqa: E731
    b = continue_branch(prob, [-1.5, 2.25], direction=[1.0, 0.0],
                        control=StepControl(step=0.05, max_step=0.1),
                        bounds={"x": (-2.0, 2.0)}, events=["y_minus_1"], classify=labels)
    assert b.end is EndReason.BOUND
    assert_close(b.points[-1], [2.0, 4.0], atol=1e-10, what="end on the bound x = 2")
    ev = b.specials(PointKind.EVENT, "y_minus_1")
    assert_close(np.array([p.y[0] for p in ev]), [-1.0, 1.0], atol=1e-10, what="y = 1")
    ch = b.specials(PointKind.CLASS_CHANGE)
    assert len(ch) == 1 and ch[0].data["before"] == 0 and ch[0].data["after"] == 1
    assert abs(ch[0].y[0] - 0.3) <= 1e-9
    assert b.labels[0] == 0 and b.labels[-1] == 1
    # terminal event: stop at y = 1
    b2 = continue_branch(prob, [-1.5, 2.25], direction=[1.0, 0.0], events=["y_minus_1"],
                         stop_at=["y_minus_1"])
    assert b2.end is EndReason.STOP_EVENT
    assert_close(b2.points[-1], [-1.0, 1.0], atol=1e-10, what="stopped at y = 1")
    # locate_on_branch finds the same points afterwards
    pts = locate_on_branch(prob, b, lambda y: y[1] - 1.0)
    assert_close(np.array([p.y[0] for p in pts]), [-1.0, 1.0], atol=1e-10, what="located")


def test_branch_point_of_two_crossing_lines_and_switch():
    """x y = 0: the axes cross at the origin, a simple branch point."""
    prob = plane_problem(lambda y: y[0] * y[1])
    b = continue_branch(prob, [-1.0, 0.0], direction=[1.0, 0.0], max_arclength=2.0,
                        control=StepControl(step=0.07, max_step=0.1))
    bp = b.specials(PointKind.BRANCH_POINT)
    assert len(bp) == 1
    assert_close(bp[0].y, [0.0, 0.0], atol=1e-9, what="branch point at the origin")
    assert_close(b.points[:, 1], np.zeros(len(b)), atol=1e-12, what="stayed on y = 0")
    starts = switch_branch(prob, bp[0], step=0.05)
    assert len(starts) == 2
    ys = np.array([s[0] for s in starts])
    assert_close(np.abs(ys[:, 1]), [0.05, 0.05], atol=1e-10, what="on the other axis")
    assert_close(ys[:, 0], [0.0, 0.0], atol=1e-10, what="x = 0")
    other = continue_branch(prob, starts[0][0], direction=starts[0][1], max_points=20)
    assert_close(other.points[:, 0], np.zeros(len(other)), atol=1e-12, what="x = 0 branch")


def test_no_false_branch_point_on_a_hyperbola():
    prob = plane_problem(lambda y: y[0] * y[1] - 1e-3)
    b = continue_branch(prob, [-1.0, -1e-3], direction=[1.0, 0.0], max_points=60,
                        control=StepControl(step=0.05, max_step=0.1))
    assert not b.specials(PointKind.BRANCH_POINT)


def test_cusp_ends_the_branch_with_a_status():
    """y^2 = x^3 has a cusp at the origin, where the curve cannot be continued smoothly."""
    prob = plane_problem(lambda y: y[1] ** 2 - y[0] ** 3)
    b = continue_branch(prob, [1.0, 1.0], direction=[-1.0, -1.0], max_points=500,
                        control=StepControl(step=0.05, max_step=0.1, min_step=1e-6),
                        raise_on_failure=False)
    assert b.end in (EndReason.STEP_TOO_SMALL, EndReason.MAX_POINTS)
    assert np.linalg.norm(b.points[-1]) < 0.05  # it got to the cusp and stopped there
    assert np.max(b.residuals) <= 1e-11
    # the cusp (rank drop of the Jacobian) is reported as a singular point
    assert any(np.linalg.norm(p.y) < 1e-2 for p in b.specials(PointKind.BRANCH_POINT))


def test_great_circle_on_the_sphere_stays_on_it():
    """F(q, k) = (q3, k - q1) on S^2 x R: a great circle, traced with the retraction."""
    y = ca.SX.sym("y", 4)
    F = ca.vertcat(y[2], y[3] - y[0])
    fn = ca.Function("F", [y, ca.SX.sym("u", 0), ca.SX.sym("p", 0)],
                     [F, ca.jacobian(F, y), y[1]])
    prob = ZeroProblem(name="great circle",
                       manifold=ProductManifold([("q", S2()), ("k", Rn(1))]), function=fn,
                       u=[], p=[], monitor_names=["q2"])
    b = continue_branch(prob, [1.0, 0.0, 0.0, 1.0], direction=[0, 1, 0, 0],
                        control=StepControl(step=0.05, max_step=0.2), events=["q2"])
    assert b.end is EndReason.CLOSED
    assert_close(np.linalg.norm(b.points[:, :3], axis=1), np.ones(len(b)), atol=1e-14,
                 what="|q| = 1 at every point (retraction)")
    assert_close(b.points[:, 2], np.zeros(len(b)), atol=1e-11, what="q3 = 0")
    assert len(b.specials(PointKind.EVENT, "q2")) == 2


def test_correct_point_lands_at_the_prescribed_distance():
    prob = plane_problem(lambda y: ca.dot(y, y) - 1)
    root = correct_point(prob, [1.0, 0.0], [0.0, 1.0], 0.3, control=StepControl())
    assert root.ok
    assert_close(root.x, [np.sqrt(1 - 0.09), 0.3], atol=1e-12, what="Keller condition")


def test_bad_input():
    prob = plane_problem(lambda y: ca.dot(y, y) - 1, {"x": lambda y: y[0]})
    with pytest.raises(SolverError, match="not near a zero"):
        continue_branch(prob, [0.0, 0.0])
    iso = plane_problem(lambda y: y, n=2)  # isolated zero: the origin
    with pytest.raises(SolverError, match="not a curve") as err:
        continue_branch(iso, [0.0, 0.0])
    assert err.value.status == "not_a_curve"
    with pytest.raises(ParameterError, match="orthogonal"):
        continue_branch(prob, [1.0, 0.0], direction=[1.0, 0.0])
    with pytest.raises(ParameterError, match="unknown monitor"):
        continue_branch(prob, [1.0, 0.0], events=["k"])
    with pytest.raises(ParameterError, match="stop_at"):
        continue_branch(prob, [1.0, 0.0], stop_at=["x"])
    with pytest.raises(ParameterError, match="lo < hi"):
        continue_branch(prob, [1.0, 0.0], bounds={"x": (1.0, -1.0)})
    with pytest.raises(ParameterError, match="min_step <= step <= max_step"):
        StepControl(step=1.0, max_step=0.5)
    with pytest.raises(ParameterError, match="tol"):
        StepControl(tol=0.0)
    y = ca.SX.sym("y", 4)
    fn = ca.Function("F", [y, ca.SX.sym("u", 0), ca.SX.sym("p", 0)],
                     [y[2], ca.jacobian(y[2], y)])
    sph = ZeroProblem(name="s", manifold=ProductManifold([("q", S2()), ("k", Rn(1))]),
                      function=fn, u=[], p=[])
    with pytest.raises(ManifoldError, match="start"):
        continue_branch(sph, [1.0, 1.0, 0.0, 0.0])


# ----------------------------------------------------------------------------------------
# moved from test_review_engine.py


@pytest.fixture(scope="module")
def line_and_circle():
    """y ((x - 1)^2 + y^2 - 1) = 0: the x-axis crosses the unit circle about (1, 0) at 0."""
    prob = plane_problem(lambda y: y[1] * ((y[0] - 1) ** 2 + y[1] ** 2 - 1))
    b = continue_branch(prob, [-1.0, 0.0], direction=[1.0, 0.0], max_arclength=1.5,
                        control=StepControl(step=0.07, max_step=0.1))
    (bp,) = b.specials(PointKind.BRANCH_POINT)
    return prob, bp


def test_switch_branch_returns_both_sides(line_and_circle):
    prob, bp = line_and_circle
    sw = switch_branch(prob, bp, step=0.1)
    assert len(sw) == 2 and not sw.failed and sw.describe_failures() == ""
    assert [r.status for r in sw.sides] == [RootStatus.CONVERGED] * 2
    for (y, d), r in zip(sw, sw.sides):
        assert y is r.x
        assert_close(abs(y[1]), 0.1, atol=1e-12, what="Keller distance along the y-axis")
        assert_close((y[0] - 1) ** 2 + y[1] ** 2, 1.0, atol=1e-12, what="on the circle")
        assert_close(abs(d[1]), 1.0, atol=1e-9, what="leaves vertically")


def test_switch_branch_raises_with_the_statuses_when_no_side_converges(line_and_circle):
    """At distance 1.5 from the origin the circle (|y| <= 1) has no point: both sides fail."""
    prob, bp = line_and_circle
    with pytest.raises(SolverError, match="neither side") as info:
        switch_branch(prob, bp, step=1.5)
    statuses = info.value.status.split("/")
    assert len(statuses) == 2 and "converged" not in statuses
    sw = switch_branch(prob, bp, step=1.5, raise_on_failure=False)
    assert len(sw) == 0 and list(sw) == [] and len(sw.failed) == 2
    assert all(not r.ok and r.message for r in sw.sides)
    assert "side +" in sw.describe_failures() and "side -" in sw.describe_failures()
