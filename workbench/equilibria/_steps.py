"""The steps of a pseudo-arclength continuation, one small function each.

:func:`workbench.equilibria._continuation.continue_branch` reads as the algorithm; the
steps it takes are here:

* **start** (:func:`start_point`): Newton onto the zero set, check that it is a curve there,
  orient its tangent;
* **predictor and corrector** (:func:`correct_point`): ``retract(y, h t)``, then Newton on
  the manifold for ``F(z) = 0`` and Keller's condition ``d . (z - y) = h``;
* **acceptance** (:func:`try_step`): the corrector converged and the tangent turned by at
  most ``max_turn``;
* **step control** (:func:`next_step`): grow towards a turn of ``max_turn / 2`` per step,
  shrink after a hard correction; halve on a rejection (in the loop);
* **event detection** (:class:`Detector`): monitor zero crossings, bounds, sign changes of
  the bordered determinant (simple branch points), changes of a classification, each
  located inside the accepted step by re-correcting points;
* **bookkeeping** (:class:`Trace`): the accepted points, their monitors and labels, the
  special points, and the :class:`~workbench.equilibria._branch.Branch` at the end.

A point's data travels as a dict: ``y`` (the zero), ``F``, ``A`` (tangent Jacobian),
``N`` (tangent basis), ``t`` / ``d`` (unit tangent in tangent / ambient coordinates),
``U`` (range basis), ``sigma`` (singular values), ``nulldim``, ``mon`` (monitors).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import Any

import numpy as np
from scipy.optimize import brentq

from workbench.core.errors import ManifoldError, ParameterError, SolverError
from workbench.core.types import ArrayLike, Matrix, Vector
from workbench.equilibria._branch import (
    Branch,
    EndReason,
    PointKind,
    SpecialPoint,
    StepControl,
)
from workbench.equilibria._roots import Root, ZeroProblem, newton_on_manifold

Point = dict[str, Any]
Stop = tuple[EndReason, float, Point, str]


# ----------------------------------------------------------------------------------------
# geometry of one point


def _null_tangent(A: Matrix, N: Matrix, rank_rtol: float) -> tuple[Vector, int, Matrix, Vector]:
    """Null vector of A (last right singular vector), its null dimension, U and sigma."""
    U, s, Vt = np.linalg.svd(A, full_matrices=A.shape[0] < A.shape[1])
    n = A.shape[1]
    rank = int(np.sum(s > rank_rtol * s[0])) if s.size and s[0] > 0 else 0
    t = Vt[-1]
    t = t / np.linalg.norm(N @ t)
    return t, n - rank, U[:, : n - 1], s


def _bordered_sign(U: Matrix, A: Matrix, t: Vector) -> float:
    return float(np.sign(np.linalg.det(np.vstack([U.T @ A, t]))))


def point_info(problem: ZeroProblem, y: Vector, d_ref: Vector | None,
               rank_rtol: float) -> Point:
    """A point's data, its tangent oriented along ``d_ref`` when given."""
    F, A, N = problem.linearization(y)
    t, nulldim, U, s = _null_tangent(A, N, rank_rtol)
    d = N @ t
    if d_ref is not None and d @ d_ref < 0:
        t, d = -t, -d
    return {"y": y, "F": F, "A": A, "N": N, "t": t, "d": d, "U": U, "sigma": s,
            "nulldim": nulldim, "mon": problem.monitors(y)}


# ----------------------------------------------------------------------------------------
# predictor, corrector, acceptance, step control


def correct_point(
    problem: ZeroProblem,
    y: ArrayLike,
    d: ArrayLike,
    h: float,
    *,
    control: StepControl,
    t: ArrayLike | None = None,
) -> Root:
    """One predictor-corrector step: from ``y`` along the unit ambient direction ``d``.

    Parameters
    ----------
    problem : ZeroProblem
    y : array-like
        A zero of the problem.
    d : array-like, shape=(ambient_dim,)
        Unit ambient direction (the tangent).
    h : float
        Step length.
    control : StepControl
    t : array-like, optional
        ``d`` in the tangent coordinates at ``y`` (computed if omitted).

    Returns
    -------
    Root
        The corrected point, with status (never raises on non-convergence).
    """
    man = problem.manifold
    yv = np.asarray(y, dtype=float)
    dv = np.asarray(d, dtype=float)
    if t is None:
        t = np.linalg.lstsq(man.tangent_basis(yv), dv, rcond=None)[0]
    z0 = man.retract(yv, h * np.asarray(t))  # the predictor, exactly on the manifold

    def fun(z: Vector) -> tuple[Vector, Matrix]:
        F, A, N = problem.linearization(z)
        return np.append(F, dv @ (z - yv) - h), np.vstack([A, dv @ N])

    return newton_on_manifold(fun, man, z0, tol=control.tol,
                              max_iterations=control.max_corrector_iterations,
                              rank_rtol=1e-14, step_tol=control.step_tol, diagnostics=False,
                              raise_on_failure=False)


def try_step(problem: ZeroProblem, cur: Point, h: float,
             c: StepControl) -> tuple[Root, Point | None, float]:
    """Predict and correct from ``cur``; the new point is ``None`` when rejected.

    Returns
    -------
    (Root, dict or None, float)
        The corrector's result, the new point (``None`` if the corrector failed or the
        tangent turned by more than ``max_turn``) and the turn in radians (``inf`` when
        the corrector failed).
    """
    root = correct_point(problem, cur["y"], cur["d"], h, control=c, t=cur["t"])
    new = point_info(problem, root.x, cur["d"], c.rank_rtol) if root.ok else None
    turn = (float(np.arccos(np.clip(new["d"] @ cur["d"], -1.0, 1.0)))
            if new is not None else math.inf)
    if new is not None and turn > c.max_turn:
        new = None
    return root, new, turn


def rejection_message(root: Root, turn: float, c: StepControl) -> str:
    """Why the branch ends when a step fails at ``min_step``."""
    why = root.message if not root.ok else f"turn {turn:.3g} rad"
    return (f"step failed at min_step = {c.min_step:g} ({why}): a singular point or the "
            f"end of the zero set")


def next_step(h: float, turn: float, corrector_iterations: int, c: StepControl) -> float:
    """The next step length after an accepted step.

    Grows by at most ``growth`` towards a turn of ``max_turn / 2`` per step (at least
    halves), at most ``0.7`` after a correction that needed nearly all its iterations,
    clipped to ``[min_step, max_step]``.
    """
    factor = min(c.growth, max(0.5, 0.5 * c.max_turn / max(turn, 1e-12)))
    if corrector_iterations >= c.max_corrector_iterations - 1:
        factor = min(factor, 0.7)
    return float(np.clip(h * factor, c.min_step, c.max_step))


def is_closed(s: float, h: float, cur: Point, first: Point) -> bool:
    """Back at the start with the same orientation, after more than four steps."""
    return bool(s > 4 * h and np.linalg.norm(cur["y"] - first["y"]) < 0.5 * h
                and cur["d"] @ first["d"] > 0)


# ----------------------------------------------------------------------------------------
# the start


def _orient(cur: Point, direction: ArrayLike | None, ambient_dim: int) -> None:
    """Flip the start's tangent to have a positive inner product with ``direction``."""
    if direction is None:
        return
    d_hint = np.asarray(direction, dtype=float).ravel()
    if d_hint.size != ambient_dim:
        raise ManifoldError(f"direction must have {ambient_dim} entries; got {d_hint.size}")
    proj = float(cur["d"] @ d_hint)
    if abs(proj) <= 1e-6 * np.linalg.norm(d_hint):
        raise ParameterError(
            "direction is orthogonal to the branch tangent at the start; it cannot "
            f"choose an orientation (tangent {np.round(cur['d'], 6).tolist()})"
        )
    if proj < 0:
        cur["t"], cur["d"] = -cur["t"], -cur["d"]


def start_point(problem: ZeroProblem, y0: Vector, direction: ArrayLike | None,
                c: StepControl) -> tuple[Point, Root]:
    """Correct ``y0`` onto the zero set, check that it is a curve there, orient it.

    Raises
    ------
    SolverError
        The start is not near a zero, or the null space there is not one-dimensional.
    ManifoldError, ParameterError
        ``direction`` has the wrong size or is orthogonal to the tangent.
    """

    def fun(z: Vector) -> tuple[Vector, Matrix]:
        F, A, _ = problem.linearization(z)
        return F, A

    root = newton_on_manifold(fun, problem.manifold, y0, tol=c.tol, max_iterations=30,
                              rank_rtol=c.rank_rtol, step_tol=c.step_tol,
                              raise_on_failure=False)
    if not root.ok:
        raise SolverError(f"continue_branch({problem.name}): the start is not near a zero: "
                          f"{root.message}", status=root.status.code)
    cur = point_info(problem, root.x, None, c.rank_rtol)
    if cur["nulldim"] != 1:
        raise SolverError(
            f"continue_branch({problem.name}): the zero set at the start is not a curve: "
            f"the Jacobian has a null space of dimension {cur['nulldim']} (singular values "
            f"{np.array2string(cur['sigma'], precision=3)}); 0 means an isolated zero, 2 or "
            f"more a surface of zeros or a branch point (use switch_branch)",
            status="not_a_curve",
        )
    _orient(cur, direction, problem.manifold.ambient_dim)
    return cur, root


# ----------------------------------------------------------------------------------------
# bookkeeping


class Trace:
    """The accepted points of a branch, their data and the special points found so far."""

    def __init__(self, start: Point, residual: float,
                 classify: Callable[[Vector], Hashable] | None) -> None:
        self.classify = classify
        self.pts, self.tans, self.arc = [start["y"]], [start["d"]], [0.0]
        self.res, self.iters, self.nulls = [residual], [0], [start["nulldim"]]
        self.mons = {k: [v] for k, v in start["mon"].items()}
        self.labels = [classify(start["y"])] if classify else []
        self.special: list[SpecialPoint] = []

    def __len__(self) -> int:
        return len(self.pts)

    def record(self, pt: Point, s_pt: float, it: int, residual: float,
               label: Hashable = None) -> None:
        """Append an accepted point (its label computed unless given)."""
        self.pts.append(pt["y"])
        self.tans.append(pt["d"])
        self.arc.append(s_pt)
        self.res.append(residual)
        self.iters.append(it)
        self.nulls.append(pt["nulldim"])
        for k, v in pt["mon"].items():
            self.mons[k].append(v)
        if self.classify:
            self.labels.append(self.classify(pt["y"]) if label is None else label)

    def special_at(self, kind: PointKind, name: str, pt: Point, s_pt: float,
                   data: dict[str, Any]) -> SpecialPoint:
        """Record a special point located at arclength ``s_pt``."""
        sp = SpecialPoint(kind, name, pt["y"], s_pt, len(self.pts) - 1,
                          float(np.max(np.abs(pt["F"]))), pt["d"], {**pt["mon"], **data})
        self.special.append(sp)
        return sp

    def branch(self, name: str, end: EndReason, end_message: str, rejected: int,
               evaluations: int, wall_time: float) -> Branch:
        """The traced branch."""
        return Branch(
            problem=name,
            points=np.array(self.pts),
            tangents=np.array(self.tans),
            s=np.array(self.arc),
            residuals=np.array(self.res),
            monitors={k: np.array(v) for k, v in self.mons.items()},
            labels=self.labels,
            special=self.special,
            end=end,
            end_message=end_message,
            corrector_iterations=np.array(self.iters),
            rejected_steps=rejected,
            evaluations=evaluations,
            wall_time=wall_time,
            null_dimensions=np.array(self.nulls, dtype=int),
        )


# ----------------------------------------------------------------------------------------
# event detection


class Detector:
    """Special points inside an accepted step: events, bounds, branch points, class changes.

    Each is located by re-correcting points inside the step ``[cur, new]`` (Brent on a
    scalar, bisection on a predicate) to ``locate_tol`` in arclength.
    """

    def __init__(self, problem: ZeroProblem, control: StepControl, events: Sequence[str],
                 stop_at: Sequence[str], bounds: Mapping[str, tuple[float, float]],
                 classify: Callable[[Vector], Hashable] | None,
                 detect_branch_points: bool) -> None:
        self.problem, self.c = problem, control
        self.events, self.stop_at = list(events), set(stop_at)
        self.bounds = dict(bounds)
        self._check_names()
        self.classify = classify
        self.detect = detect_branch_points

    def _check_names(self) -> None:
        known = self.problem.monitor_names
        for name in [*self.events, *self.bounds]:
            if name not in known:
                raise ParameterError(
                    f"unknown monitor {name!r} in events/bounds; the problem's monitors are "
                    f"{known}"
                )
        for name in self.stop_at:
            if name not in self.events:
                raise ParameterError(f"stop_at names {name!r}, which is not in events")
        for name, (lo, hi) in self.bounds.items():
            if not lo < hi:
                raise ParameterError(f"bounds[{name!r}] must be (lo, hi) with lo < hi; "
                                     f"got {(lo, hi)}")

    # locating inside the step
    def crossing_sign(self, prev: Point, new: Point) -> tuple[float, float]:
        """Bordered-determinant signs at prev and new in prev's range frame."""
        if "bsign" not in prev:
            prev["bsign"] = _bordered_sign(prev["U"], prev["A"], prev["t"])
        # sign of det(pinv(N_new) N_prev) = sign of det(N_new^T N_prev): the orientation
        # change between the two tangent bases
        flip = np.sign(np.linalg.det(new["N"].T @ prev["N"]))
        return prev["bsign"], _bordered_sign(prev["U"], new["A"], new["t"]) * flip

    def point_at(self, prev: Point, theta: float, h: float) -> Point:
        """The zero at the fraction ``theta`` of the step from ``prev`` (or raise)."""
        root = correct_point(self.problem, prev["y"], prev["d"], theta * h, control=self.c,
                             t=prev["t"])
        if not root.ok:
            raise SolverError(f"locating a special point: corrector failed ({root.message})",
                              status=root.status.code)
        return point_info(self.problem, root.x, prev["d"], self.c.rank_rtol)

    def locate_scalar(self, prev: Point, new: Point, h: float, g: Callable[[Point], float],
                      ) -> tuple[Point, float, dict[str, Any]]:
        """Zero of ``g`` inside the step (Brent on the step fraction, points re-corrected).

        If a re-correction fails (near a singular point), the crossing is reported at the
        end point of the step with ``located = False`` and the bracket width.
        """
        cache: dict[float, Point] = {}

        def fn(theta: float) -> float:
            if theta == 0.0:
                return g(prev)
            cache[theta] = self.point_at(prev, theta, h)
            return g(cache[theta])

        try:
            theta = brentq(fn, 0.0, 1.0, xtol=self.c.locate_tol / h,
                           rtol=4 * np.finfo(float).eps)
            pt = cache.get(theta) or self.point_at(prev, theta, h)
        except (SolverError, ValueError) as exc:
            return new, 1.0, {"located": False, "bracket": h, "message": str(exc)}
        return pt, theta, {"located": True}

    def locate_change(self, prev: Point, new: Point, h: float, same: Callable[[Point], bool],
                      ) -> tuple[Point, float, dict[str, Any]]:
        """Bisection on the step fraction for the first point where ``same`` turns false."""
        lo, hi, best = 0.0, 1.0, new
        while (hi - lo) * h > self.c.locate_tol and hi - lo > 1e-14:
            mid = 0.5 * (lo + hi)
            try:
                pt = self.point_at(prev, mid, h)
            except SolverError as exc:
                return best, hi, {"located": False, "bracket": (hi - lo) * h,
                                  "message": str(exc)}
            if same(pt):
                lo = mid
            else:
                hi, best = mid, pt
        return best, hi, {"located": True, "bracket": (hi - lo) * h}

    # the four kinds
    def events_and_bounds(self, trace: Trace, cur: Point, new: Point, h: float,
                          s: float) -> Stop | None:
        """Locate monitor crossings and bounds; the earliest terminal one, if any."""
        stop: Stop | None = None
        for name in self.events:
            if cur["mon"][name] * new["mon"][name] < 0:
                pt, th, how = self.locate_scalar(cur, new, h, lambda p, n=name: p["mon"][n])
                trace.special_at(PointKind.EVENT, name, pt, s + th * h, how)
                if name in self.stop_at and (stop is None or th < stop[1]):
                    stop = (EndReason.STOP_EVENT, th, pt, f"stopped at the event {name} = 0")
        for name, (lo, hi) in self.bounds.items():
            if lo <= new["mon"][name] <= hi:
                continue
            edge = hi if new["mon"][name] > hi else lo
            pt, th, how = self.locate_scalar(cur, new, h,
                                             lambda p, n=name, e=edge: p["mon"][n] - e)
            trace.special_at(PointKind.BOUND, name, pt, s + th * h, {"bound": edge, **how})
            if stop is None or th < stop[1]:
                stop = (EndReason.BOUND, th, pt, f"{name} reached its bound {edge:g}")
        return stop

    def branch_point(self, trace: Trace, cur: Point, new: Point, h: float, s: float,
                     stop: Stop | None) -> None:
        """Locate a sign change of the bordered determinant (before any stop)."""
        if not self.detect:
            return
        s_prev, s_new = self.crossing_sign(cur, new)
        if s_prev * s_new >= 0:
            return

        def same_side(p: Point) -> bool:
            a, b = self.crossing_sign(cur, p)
            return a * b > 0

        pt, th, how = self.locate_change(cur, new, h, same_side)
        if stop is None or th < stop[1]:
            trace.special_at(PointKind.BRANCH_POINT, "branch point", pt, s + th * h,
                             {"sigma": pt["sigma"], **how})

    def class_change(self, trace: Trace, cur: Point, new: Point, h: float,
                     s: float) -> Hashable:
        """Locate a change of the classification; return the new point's label."""
        classify = self.classify
        assert classify is not None
        lab_new = classify(new["y"])
        before = trace.labels[-1]
        if lab_new != before:
            pt, th, how = self.locate_change(cur, new, h,
                                             lambda p: classify(p["y"]) == before)
            trace.special_at(PointKind.CLASS_CHANGE, "classification", pt, s + th * h,
                             {"before": before, "after": lab_new, **how})
        return lab_new

    def special_points(self, trace: Trace, cur: Point, new: Point, h: float,
                       s: float) -> tuple[Stop | None, Hashable]:
        """All four kinds in order; the terminal stop (if any) and the new label."""
        stop = self.events_and_bounds(trace, cur, new, h, s)
        self.branch_point(trace, cur, new, h, s, stop)
        lab_new = None
        if self.classify and stop is None:
            lab_new = self.class_change(trace, cur, new, h, s)
        trace.special.sort(key=lambda p: p.s)
        return stop, lab_new
