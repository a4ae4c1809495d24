"""Continuation of one-dimensional zero sets on manifolds (pseudo-arclength).

A branch is a curve of zeros of a :class:`~workbench.equilibria._equilibria.ZeroProblem`
``F: P -> R^m`` whose tangent Jacobian ``A = dF/dy N`` has rank ``dim P - 1`` (redundant
rows are allowed: the rank, not the row count, decides). From a point ``y`` with unit
tangent ``d`` (ambient coordinates; the null vector of ``A``) a step of length ``h``

* predicts ``retract(y, h t)``, so the predictor is exactly on ``P``;
* corrects by Newton on the manifold for ``F(z) = 0`` and Keller's arclength condition
  ``d . (z - y) = h`` (ambient inner product);
* is accepted if the corrector converges within ``max_corrector_iterations`` and the
  tangent turns by less than ``max_turn``; otherwise ``h`` is halved, down to
  ``min_step``. Accepted steps grow towards a turn of ``max_turn / 2`` per step.

Along the branch the continuation records the problem's monitors, and reports special
points, each located to ``locate_tol`` by re-correcting points inside the step:

* events: zero crossings of named monitors (e.g. ``k = 0``, a static equilibrium);
* bounds: a monitor leaving a declared interval ends the branch there (e.g. ``|k| = k_max``
  on a branch that goes to infinity);
* simple branch points: sign changes of the bordered determinant
  ``det [U^T A; t^T]`` (``U`` a range basis carried from the previous point, the sign
  corrected for the change of tangent basis), where two branches cross;
  :func:`switch_branch` follows the other one;
* changes of a user classification (the stability from the eigenstructure).

Every knob that trades speed for accuracy is a field of :class:`StepControl`. The steps
(predictor, corrector, step control, event detection, bookkeeping) are small functions in
:mod:`workbench.equilibria._steps`; :func:`continue_branch` is the loop that calls them.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Hashable, Mapping, Sequence

import numpy as np
from scipy.optimize import brentq

from workbench.core import validate
from workbench.core.errors import ParameterError, SolverError
from workbench.core.status import raise_if
from workbench.core.types import ArrayLike, Vector
from workbench.equilibria._branch import (
    Branch,
    BranchSwitch,
    EndReason,
    PointKind,
    SpecialPoint,
    StepControl,
)
from workbench.equilibria._roots import (
    ZeroProblem,
    check_count,
    check_positive,
)
from workbench.equilibria._steps import (
    Detector,
    Trace,
    correct_point,
    is_closed,
    next_step,
    rejection_message,
    start_point,
    try_step,
)

__all__ = [
    "StepControl",
    "EndReason",
    "PointKind",
    "SpecialPoint",
    "Branch",
    "BranchSwitch",
    "continue_branch",
    "switch_branch",
    "correct_point",
    "locate_on_branch",
]


@validate.arguments(start_tol=validate.tolerance, max_points=validate.count,
                    direction=validate.optional(validate.array),
                    problem=validate.instance(ZeroProblem, "a ZeroProblem"))
def continue_branch(
    problem: ZeroProblem,
    start: ArrayLike,
    *,
    direction: ArrayLike | None = None,
    control: StepControl | None = None,
    max_points: int = 1000,
    max_arclength: float = math.inf,
    events: Sequence[str] = (),
    stop_at: Sequence[str] = (),
    bounds: Mapping[str, tuple[float, float]] | None = None,
    classify: Callable[[Vector], Hashable] | None = None,
    detect_branch_points: bool = True,
    start_tol: float = 1e-9,
    raise_on_failure: bool = True,
) -> Branch:
    """Trace the branch of zeros through ``start`` in one direction.

    The steps (predictor, corrector, step control, event detection, bookkeeping) are the
    small functions of :mod:`workbench.equilibria._steps`; this function is the loop.

    Parameters
    ----------
    problem : ZeroProblem
        The map whose zero set is followed.
    start : array-like, shape=(ambient_dim,)
        A point on the manifold near the branch (corrected by Newton first; its residual
        must reach ``control.tol``).
    direction : array-like, shape=(ambient_dim,), optional
        Ambient vector choosing the orientation: the first tangent has a positive inner
        product with it. Without it, the sign of the computed null vector is used.
    control : StepControl, optional
        Step and accuracy knobs.
    max_points, max_arclength
        Limits (ends MAX_POINTS, MAX_ARCLENGTH).
    events : sequence of str
        Monitors whose zero crossings are located and reported.
    stop_at : sequence of str
        Events that end the branch (the end point is the located event).
    bounds : mapping of str to (float, float)
        Monitor ranges; leaving one ends the branch on the bound (BOUND).
    classify : callable, optional
        ``classify(y) -> label`` at every point; label changes are located.
    detect_branch_points : bool
        Locate sign changes of the bordered determinant (simple branch points).
    start_tol : float
        Largest constraint residual accepted for ``start`` on the manifold.
    raise_on_failure : bool
        Raise when the branch ends with STEP_TOO_SMALL (the corrector failed down to
        ``min_step``); ``False`` returns the branch traced so far with that status.

    Returns
    -------
    Branch
        Its ``status`` is its :class:`EndReason`.

    Raises
    ------
    ManifoldError
        If ``start`` is off the manifold.
    SolverError
        If the start cannot be corrected onto the zero set, or the zero set is not a
        curve there (null space of dimension other than 1: an isolated zero, a surface of
        zeros, or a branch point; see :func:`switch_branch`); or the branch ended with
        STEP_TOO_SMALL and ``raise_on_failure``.
    """
    t_start = time.perf_counter()
    c = control or StepControl()
    max_points = check_count("max_points", max_points, minimum=2)
    detector = Detector(problem, c, events, stop_at, bounds or {}, classify,
                        detect_branch_points)
    y0 = problem.manifold.check(start, name="start", tol=start_tol)
    ev0 = problem.evaluations
    cur, root = start_point(problem, y0, direction, c)
    first, trace = cur, Trace(cur, root.residual, classify)
    h, rejected, s = c.step, 0, 0.0
    end, end_msg = EndReason.MAX_POINTS, f"reached max_points = {max_points}"
    while len(trace) < max_points:
        if s >= max_arclength:
            end, end_msg = EndReason.MAX_ARCLENGTH, f"reached max_arclength = {max_arclength}"
            break
        h = min(h, max_arclength - s) if math.isfinite(max_arclength) else h
        root, new, turn = try_step(problem, cur, h, c)  # predictor and corrector
        if new is None:  # rejected: halve the step, down to min_step
            rejected += 1
            if h <= c.min_step:
                end, end_msg = EndReason.STEP_TOO_SMALL, rejection_message(root, turn, c)
                break
            h = max(0.5 * h, c.min_step)
            continue
        stop, label = detector.special_points(trace, cur, new, h, s)
        if stop is not None:  # a terminal event or a bound inside the step ends the branch
            end, th, pt, end_msg = stop
            trace.record(pt, s + th * h, root.iterations, float(np.max(np.abs(pt["F"]))))
            s += th * h
            trace.special = [p for p in trace.special if p.s <= s + c.locate_tol]
            break
        s += h
        trace.record(new, s, root.iterations, root.residual, label)
        cur = new
        if is_closed(s, h, cur, first):
            end, end_msg = EndReason.CLOSED, "returned to the start: a closed curve of zeros"
            break
        h = next_step(h, turn, root.iterations, c)
    branch = trace.branch(problem.name, end, end_msg, rejected,
                          problem.evaluations - ev0, time.perf_counter() - t_start)
    return raise_if(branch, raise_on_failure)


def switch_branch(
    problem: ZeroProblem,
    point: SpecialPoint,
    *,
    step: float,
    control: StepControl | None = None,
    raise_on_failure: bool = True,
) -> BranchSwitch:
    """Starts on the other branch through a located simple branch point.

    At the branch point the Jacobian has a two-dimensional null space containing the
    incoming tangent; the other branch leaves along (approximately) the null direction
    orthogonal to it. From the branch point, a step of length ``step`` along each sign of
    that direction is corrected with Keller's condition (which selects the branch that
    crosses the hyperplane at distance ``step``).

    Parameters
    ----------
    problem : ZeroProblem
    point : SpecialPoint
        A BRANCH_POINT of a traced branch.
    step : float
        Distance from the branch point.
    control : StepControl, optional
    raise_on_failure : bool
        Raise when the corrector converges on neither side; otherwise return the result
        with no starts (its ``sides`` say why).

    Returns
    -------
    BranchSwitch
        A sequence of ``(start, direction)`` pairs for :func:`continue_branch`, one per
        side that converged (each start a zero at distance ``step`` from the branch
        point), with the corrector result of both sides in ``sides``.

    Raises
    ------
    SolverError
        If the corrector converges on neither side and ``raise_on_failure``; the status
        is the two sides' statuses.
    """
    if point.kind is not PointKind.BRANCH_POINT:
        raise ParameterError(f"point must be a branch point; got a {point.kind.value}")
    c = control or StepControl()
    step = check_positive("step", step)
    _, A, N = problem.linearization(point.y)
    _, _, Vt = np.linalg.svd(A)
    Q = np.linalg.qr(N @ Vt[-2:].T)[0]  # ambient basis of the two-dimensional null space
    a, b = Q.T @ point.tangent
    d = Q @ np.array([-b, a])  # the null direction orthogonal to the incoming tangent
    d /= np.linalg.norm(d)
    t = np.linalg.lstsq(N, d, rcond=None)[0]
    sides = [correct_point(problem, point.y, sign * d, step, control=c, t=sign * t)
             for sign in (1.0, -1.0)]
    out = BranchSwitch(point, step, np.array([d, -d]), sides)
    if raise_on_failure and not out.starts:
        raise SolverError(
            f"switch_branch: the corrector converged on neither side of the branch point "
            f"at s = {point.s:.6g} (y = {np.round(point.y, 6).tolist()}) at distance "
            f"{step:g}: {out.describe_failures()}. Try another step, or pass "
            f"raise_on_failure=False to get the result",
            status="/".join(r.status.code for r in sides),
        )
    return out


def locate_on_branch(
    problem: ZeroProblem,
    branch: Branch,
    g: Callable[[Vector], float],
    *,
    control: StepControl | None = None,
    name: str = "g",
) -> list[SpecialPoint]:
    """Points of a traced branch where a scalar function of the point vanishes.

    Sign changes of ``g`` between consecutive points are located by Brent's method on the
    fraction of the step, each trial point re-corrected from the earlier point along its
    tangent with Keller's condition, so the located points are zeros of the problem.

    Parameters
    ----------
    problem : ZeroProblem
        The problem the branch was traced on.
    branch : Branch
    g : callable
        ``g(y) -> float``, continuous along the branch.
    control : StepControl, optional
        Corrector and location settings.
    name : str
        Name recorded on the special points.

    Returns
    -------
    list of SpecialPoint
        EVENT points, in order of arclength (points where ``g`` is exactly 0 included).
    """
    c = control or StepControl()
    vals = [float(g(y)) for y in branch.points]
    out: list[SpecialPoint] = []

    def special(y: Vector, s: float, i: int, d: Vector) -> SpecialPoint:
        F = problem.residual(y)
        return SpecialPoint(PointKind.EVENT, name, y, s, i, float(np.max(np.abs(F))), d,
                            problem.monitors(y))

    for i in range(len(vals)):
        y, d = branch.points[i], branch.tangents[i]
        if vals[i] == 0.0:
            out.append(special(y, float(branch.s[i]), i, d))
            continue
        if i + 1 == len(vals) or vals[i] * vals[i + 1] >= 0:
            continue
        h = float(d @ (branch.points[i + 1] - y))
        cache: dict[float, Vector] = {}

        def fn(theta: float, y: Vector = y, d: Vector = d, h: float = h,
               cache: dict[float, Vector] = cache) -> float:
            root = correct_point(problem, y, d, theta * h, control=c)
            if not root.ok:
                raise SolverError(f"locate_on_branch: corrector failed ({root.message})",
                                  status=root.status.code)
            cache[theta] = root.x
            return float(g(root.x))

        theta = brentq(fn, 0.0, 1.0, xtol=c.locate_tol / max(abs(h), 1e-300),
                       rtol=4 * np.finfo(float).eps)
        z = cache.get(theta)
        if z is None:
            fn(theta)
            z = cache[theta]
        out.append(special(z, float(branch.s[i]) + theta * h, i, d))
    return out
