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

Every knob that trades speed for accuracy is a field of :class:`StepControl`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import Any

import numpy as np
from scipy.optimize import brentq

from workbench.core.errors import ManifoldError, ParameterError, SolverError
from workbench.core.types import ArrayLike, Matrix, Vector
from workbench.equilibria._branch import (
    Branch,
    BranchSwitch,
    EndReason,
    PointKind,
    SpecialPoint,
    StepControl,
)
from workbench.equilibria._roots import (
    Root,
    ZeroProblem,
    check_count,
    check_positive,
    newton_on_manifold,
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


# ----------------------------------------------------------------------------------------
# geometry helpers


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
        The corrected point, with status.
    """
    man = problem.manifold
    yv = np.asarray(y, dtype=float)
    dv = np.asarray(d, dtype=float)
    if t is None:
        t = np.linalg.lstsq(man.tangent_basis(yv), dv, rcond=None)[0]
    z0 = man.retract(yv, h * np.asarray(t))

    def fun(z: Vector) -> tuple[Vector, Matrix]:
        F, A, N = problem.linearization(z)
        return np.append(F, dv @ (z - yv) - h), np.vstack([A, dv @ N])

    return newton_on_manifold(fun, man, z0, tol=control.tol,
                              max_iterations=control.max_corrector_iterations,
                              rank_rtol=1e-14, step_tol=control.step_tol, diagnostics=False,
                              raise_on_failure=False)


# ----------------------------------------------------------------------------------------
# the continuation


class _Tracer:
    """State of one continuation run (kept out of the public function for size)."""

    def __init__(self, problem: ZeroProblem, control: StepControl, events: Sequence[str],
                 stop_at: Sequence[str], bounds: Mapping[str, tuple[float, float]],
                 classify: Callable[[Vector], Hashable] | None,
                 detect_branch_points: bool) -> None:
        self.problem, self.c = problem, control
        self.events, self.stop_at = list(events), set(stop_at)
        self.bounds = dict(bounds)
        known = problem.monitor_names
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
        self.classify = classify
        self.detect = detect_branch_points

    # one point's data
    def info(self, y: Vector, d_ref: Vector | None) -> dict[str, Any]:
        F, A, N = self.problem.linearization(y)
        t, nulldim, U, s = _null_tangent(A, N, self.c.rank_rtol)
        d = N @ t
        if d_ref is not None and d @ d_ref < 0:
            t, d = -t, -d
        return {"y": y, "F": F, "A": A, "N": N, "t": t, "d": d, "U": U, "sigma": s,
                "nulldim": nulldim, "mon": self.problem.monitors(y)}

    def crossing_sign(self, prev: dict[str, Any], new: dict[str, Any]) -> tuple[float, float]:
        """Bordered-determinant signs at prev and new in prev's range frame."""
        if "bsign" not in prev:
            prev["bsign"] = _bordered_sign(prev["U"], prev["A"], prev["t"])
        # sign of det(pinv(N_new) N_prev) = sign of det(N_new^T N_prev): the orientation
        # change between the two tangent bases
        flip = np.sign(np.linalg.det(new["N"].T @ prev["N"]))
        return prev["bsign"], _bordered_sign(prev["U"], new["A"], new["t"]) * flip

    def point_at(self, prev: dict[str, Any], theta: float, h: float) -> dict[str, Any]:
        root = correct_point(self.problem, prev["y"], prev["d"], theta * h, control=self.c,
                             t=prev["t"])
        if not root.ok:
            raise SolverError(f"locating a special point: corrector failed ({root.message})",
                              status=root.status.code)
        return self.info(root.x, prev["d"])

    def locate_scalar(self, prev: dict[str, Any], new: dict[str, Any], h: float,
                      g: Callable[[dict[str, Any]], float],
                      ) -> tuple[dict[str, Any], float, dict[str, Any]]:
        """Zero of ``g`` inside the step (Brent on the step fraction, points re-corrected).

        If a re-correction fails (near a singular point), the crossing is reported at the
        end point of the step with ``located = False`` and the bracket width.
        """
        cache: dict[float, dict[str, Any]] = {}

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

    def locate_change(self, prev: dict[str, Any], new: dict[str, Any], h: float,
                      same: Callable[[dict[str, Any]], bool],
                      ) -> tuple[dict[str, Any], float, dict[str, Any]]:
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
) -> Branch:
    """Trace the branch of zeros through ``start`` in one direction.

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

    Returns
    -------
    Branch

    Raises
    ------
    ManifoldError
        If ``start`` is off the manifold.
    SolverError
        If the start cannot be corrected onto the zero set, or the zero set is not a
        curve there (null space of dimension other than 1: an isolated zero, a surface of
        zeros, or a branch point; see :func:`switch_branch`).
    """
    t_start = time.perf_counter()
    c = control or StepControl()
    max_points = check_count("max_points", max_points, minimum=2)
    tr = _Tracer(problem, c, events, stop_at, bounds or {}, classify, detect_branch_points)
    man = problem.manifold
    y0 = man.check(start, name="start", tol=start_tol)
    ev0 = problem.evaluations

    def fun(z: Vector) -> tuple[Vector, Matrix]:
        F, A, _ = problem.linearization(z)
        return F, A

    root = newton_on_manifold(fun, man, y0, tol=c.tol, max_iterations=30,
                              rank_rtol=c.rank_rtol, step_tol=c.step_tol,
                              raise_on_failure=False)
    if not root.ok:
        raise SolverError(f"continue_branch({problem.name}): the start is not near a zero: "
                          f"{root.message}", status=root.status.code)
    d_hint = None if direction is None else np.asarray(direction, dtype=float).ravel()
    cur = tr.info(root.x, None)
    if cur["nulldim"] != 1:
        raise SolverError(
            f"continue_branch({problem.name}): the zero set at the start is not a curve: "
            f"the Jacobian has a null space of dimension {cur['nulldim']} (singular values "
            f"{np.array2string(cur['sigma'], precision=3)}); 0 means an isolated zero, 2 or "
            f"more a surface of zeros or a branch point (use switch_branch)",
            status="not_a_curve",
        )
    if d_hint is not None:
        if d_hint.size != man.ambient_dim:
            raise ManifoldError(f"direction must have {man.ambient_dim} entries; "
                                f"got {d_hint.size}")
        proj = float(cur["d"] @ d_hint)
        if abs(proj) <= 1e-6 * np.linalg.norm(d_hint):
            raise ParameterError(
                "direction is orthogonal to the branch tangent at the start; it cannot "
                f"choose an orientation (tangent {np.round(cur['d'], 6).tolist()})"
            )
        if proj < 0:
            cur["t"], cur["d"] = -cur["t"], -cur["d"]

    pts, tans, arc, res, iters = [cur["y"]], [cur["d"]], [0.0], [root.residual], [0]
    nulls = [cur["nulldim"]]
    mons = {k: [v] for k, v in cur["mon"].items()}
    labels = [classify(cur["y"])] if classify else []
    special: list[SpecialPoint] = []
    first = cur
    h, rejected, s = c.step, 0, 0.0
    end, end_msg = EndReason.MAX_POINTS, f"reached max_points = {max_points}"

    def record(pt: dict[str, Any], s_pt: float, it: int, residual: float,
               label: Hashable = None) -> None:
        pts.append(pt["y"])
        tans.append(pt["d"])
        arc.append(s_pt)
        res.append(residual)
        iters.append(it)
        nulls.append(pt["nulldim"])
        for k, v in pt["mon"].items():
            mons[k].append(v)
        if classify:
            labels.append(classify(pt["y"]) if label is None else label)

    def special_at(kind: PointKind, name: str, pt: dict[str, Any], s_pt: float,
                   data: dict[str, Any]) -> SpecialPoint:
        sp = SpecialPoint(kind, name, pt["y"], s_pt, len(pts) - 1,
                          float(np.max(np.abs(pt["F"]))), pt["d"], {**pt["mon"], **data})
        special.append(sp)
        return sp

    while len(pts) < max_points:
        if s >= max_arclength:
            end, end_msg = EndReason.MAX_ARCLENGTH, f"reached max_arclength = {max_arclength}"
            break
        h = min(h, max_arclength - s) if math.isfinite(max_arclength) else h
        root = correct_point(problem, cur["y"], cur["d"], h, control=c, t=cur["t"])
        new = tr.info(root.x, cur["d"]) if root.ok else None
        turn = (float(np.arccos(np.clip(new["d"] @ cur["d"], -1.0, 1.0)))
                if new is not None else math.inf)
        if new is None or turn > c.max_turn:
            rejected += 1
            if h <= c.min_step:
                end = EndReason.STEP_TOO_SMALL
                end_msg = (f"step failed at min_step = {c.min_step:g} "
                           f"({root.message if not root.ok else f'turn {turn:.3g} rad'}): "
                           f"a singular point or the end of the zero set")
                break
            h = max(0.5 * h, c.min_step)
            continue
        # special points inside the accepted step [cur, new]
        stop = None
        crossings = [("event", n) for n in tr.events if cur["mon"][n] * new["mon"][n] < 0]
        crossings += [("bound", n) for n, (lo, hi) in tr.bounds.items()
                      if not lo <= new["mon"][n] <= hi]
        for kind, name in crossings:
            if kind == "event":
                pt, th, how = tr.locate_scalar(cur, new, h, lambda p, n=name: p["mon"][n])
                special_at(PointKind.EVENT, name, pt, s + th * h, how)
                if name in tr.stop_at and (stop is None or th < stop[1]):
                    stop = (EndReason.STOP_EVENT, th, pt, f"stopped at the event {name} = 0")
            else:
                lo, hi = tr.bounds[name]
                edge = hi if new["mon"][name] > hi else lo
                pt, th, how = tr.locate_scalar(cur, new, h,
                                               lambda p, n=name, e=edge: p["mon"][n] - e)
                special_at(PointKind.BOUND, name, pt, s + th * h, {"bound": edge, **how})
                if stop is None or th < stop[1]:
                    stop = (EndReason.BOUND, th, pt, f"{name} reached its bound {edge:g}")
        if tr.detect:
            s_prev, s_new = tr.crossing_sign(cur, new)
            if s_prev * s_new < 0:
                ref = cur

                def same_side(p: dict[str, Any], ref: dict[str, Any] = ref) -> bool:
                    a, b = tr.crossing_sign(ref, p)
                    return a * b > 0

                pt, th, how = tr.locate_change(cur, new, h, same_side)
                if stop is None or th < stop[1]:
                    special_at(PointKind.BRANCH_POINT, "branch point", pt, s + th * h,
                               {"sigma": pt["sigma"], **how})
        lab_new = None
        if classify and stop is None:
            lab_new = classify(new["y"])
            if lab_new != labels[-1]:
                before = labels[-1]
                pt, th, how = tr.locate_change(cur, new, h,
                                               lambda p, b=before: classify(p["y"]) == b)
                special_at(PointKind.CLASS_CHANGE, "classification", pt, s + th * h,
                           {"before": before, "after": lab_new, **how})
        special.sort(key=lambda p: p.s)
        if stop is not None:
            end, th, pt, end_msg = stop[0], stop[1], stop[2], stop[3]
            record(pt, s + th * h, root.iterations, float(np.max(np.abs(pt["F"]))))
            s += th * h
            special = [p for p in special if p.s <= s + c.locate_tol]
            break
        s += h
        record(new, s, root.iterations, root.residual, lab_new)
        cur = new
        # closed curve: back at the start, same orientation
        if s > 4 * h and np.linalg.norm(cur["y"] - first["y"]) < 0.5 * h and \
                cur["d"] @ first["d"] > 0:
            end, end_msg = EndReason.CLOSED, "returned to the start: a closed curve of zeros"
            break
        factor = min(c.growth, max(0.5, 0.5 * c.max_turn / max(turn, 1e-12)))
        if root.iterations >= c.max_corrector_iterations - 1:
            factor = min(factor, 0.7)
        h = float(np.clip(h * factor, c.min_step, c.max_step))

    return Branch(
        problem=problem.name,
        points=np.array(pts),
        tangents=np.array(tans),
        s=np.array(arc),
        residuals=np.array(res),
        monitors={k: np.array(v) for k, v in mons.items()},
        labels=labels,
        special=special,
        end=end,
        end_message=end_msg,
        corrector_iterations=np.array(iters),
        rejected_steps=rejected,
        evaluations=problem.evaluations - ev0,
        wall_time=time.perf_counter() - t_start,
        null_dimensions=np.array(nulls, dtype=int),
    )


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
