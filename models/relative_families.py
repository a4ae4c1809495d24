"""All families of relative equilibria of a rigid-body pendulum, traced by continuation.

:func:`trace_relative_equilibria` follows the zero set of
:func:`models.relative_equilibria.rotation_problem` (unknowns ``(Gamma, k)``,
``omega = k Gamma``) from every start the structure offers: the static equilibria (in both
directions of ``k``), the ends at infinity (the isolated zeros on the slices
``k = +-k_max``), and the other branch at every simple branch point. Surfaces of zeros
(two-dimensional families, paper 000 Prop. 9 case 7(a)) are reported from the slices, not
traced. :func:`at_alpha` finds the points of the traced branches with a given family
parameter ``alpha``, or the branches that lie entirely at it.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from models.relative_equilibria import (
    SliceZero,
    rotation_problem,
    slice_zeros,
    sphere_points,
    stability_label,
    static_equilibria,
)
from workbench.core import Model
from workbench.core.errors import ParameterError
from workbench.core.types import Vector
from workbench.core.validate import positive
from workbench.equilibria import (
    Branch,
    EndReason,
    Equilibrium,
    PointKind,
    SpecialPoint,
    StepControl,
    ZeroProblem,
    continue_branch,
    locate_on_branch,
    switch_branch,
)

__all__ = ["RelativeEquilibria", "trace_relative_equilibria", "at_alpha", "family_name"]


@dataclass
class RelativeEquilibria:
    """All branches of relative equilibria found from the static equilibria and infinity.

    Attributes
    ----------
    problem : ZeroProblem
    static : dict of str to Equilibrium
        ``hanging`` and ``inverted``.
    branches : list of Branch
        Traced branches (each from one start in one direction).
    origins : list of str
        How each branch was started ("hanging +k", "end at k = 100 (Gamma ...)",
        "branch point of branch 3").
    surfaces : list of SliceZero
        Zeros at which the zero set is (at least) two-dimensional (not traced).
    ends : list of SliceZero
        The isolated zeros on the slices ``k = +-k_max``.
    k_max : float
    slice_failures : int
        Guesses on the slices from which Newton did not converge.
    wall_time : float
    notes : list of str
        What was not traced and why: a side of a branch point where the other branch was
        not picked up (with the corrector's status), ``max_branches`` reached, branches
        that ended otherwise than at a bound or a stop event.
    """

    problem: ZeroProblem
    static: dict[str, Equilibrium]
    branches: list[Branch]
    origins: list[str]
    surfaces: list[SliceZero]
    ends: list[SliceZero]
    k_max: float
    slice_failures: int
    wall_time: float
    notes: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """Plain data."""
        return {
            "n_branches": len(self.branches),
            "origins": self.origins,
            "branches": [b.summary() for b in self.branches],
            "n_surface_points": len(self.surfaces),
            "k_max": self.k_max,
            "slice_failures": self.slice_failures,
            "wall_time": self.wall_time,
            "notes": list(self.notes),
        }


def _near_branch(y: Vector, branches: Sequence[Branch], tol: float) -> bool:
    """Whether ``y`` is within ``tol`` of a traced polyline."""
    for b in branches:
        P = b.points
        if len(P) == 1:
            if np.linalg.norm(P[0] - y) <= tol:
                return True
            continue
        a, d = P[:-1], P[1:] - P[:-1]
        L2 = np.einsum("ij,ij->i", d, d)
        t = np.clip(np.einsum("ij,ij->i", y - a, d) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        dist = np.linalg.norm(a + t[:, None] * d - y, axis=1)
        if float(np.min(dist)) <= tol:
            return True
    return False


def trace_relative_equilibria(
    model: Model,
    *,
    k_max: float = 100.0,
    control: StepControl | None = None,
    max_points: int = 2000,
    with_stability: bool = True,
    stability_tol: float | None = None,
    n_guesses: int = 64,
    switch_step: float = 1e-3,
    max_branches: int = 40,
    attitude: str = "Gamma",
    velocity: str = "omega",
) -> RelativeEquilibria:
    """Trace every family of relative equilibria reachable from the statics and infinity.

    Parameters
    ----------
    model : Model
        A model accepted by :func:`rotation_problem`.
    k_max : float
        Branches end where ``|k|`` reaches it (a family going to infinity); the slices
        ``k = +-k_max`` give the starts of families that do not reach ``k = 0``.
    control : StepControl, optional
        Continuation knobs.
    max_points : int
        Point limit per branch.
    with_stability : bool
        Classify every point by :func:`stability_label` and locate the changes.
    stability_tol : float, optional
        Real-part tolerance of the classification.
    n_guesses : int
        Attitude guesses (:func:`sphere_points`) on each slice.
    switch_step : float
        Distance from a branch point at which the other branch is picked up.
    max_branches : int
        Safety limit on the number of branches traced.
    attitude, velocity : str
        Factor names.

    Returns
    -------
    RelativeEquilibria

    Raises
    ------
    ParameterError
        For a balanced body (from :func:`static_equilibria`), or bad knobs.
    """
    t0 = time.perf_counter()
    k_max = positive("k_max", k_max)
    control = control or StepControl()
    problem = rotation_problem(model, attitude=attitude, velocity=velocity)
    static = static_equilibria(model, attitude=attitude, velocity=velocity)
    classify = None
    if with_stability:
        def classify(y: Vector) -> tuple[int, int]:
            return stability_label(model, problem.state(y), tol=stability_tol)

    opts = dict(control=control, max_points=max_points, events=("k", "k1"), stop_at=("k",),
                bounds={"k": (-k_max, k_max)}, classify=classify)
    ez = np.array([0.0, 0.0, 0.0, 1.0])
    queue: list[tuple[Vector, Vector, str]] = []
    for name, eq in static.items():
        y = np.append(eq.x[:3], 0.0)
        queue += [(y, ez, f"{name} +k"), (y, -ez, f"{name} -k")]
    guesses = sphere_points(n_guesses)
    ends: list[SliceZero] = []
    surfaces: list[SliceZero] = []
    failures = 0
    for kk in (k_max, -k_max):
        zs, nf = slice_zeros(problem, kk, guesses, tol=control.tol)
        failures += nf
        ends += [z for z in zs if z.local_dimension == 0]
        surfaces += [z for z in zs if z.local_dimension > 0]
    branches: list[Branch] = []
    origins: list[str] = []
    notes: list[str] = []
    pending_ends = list(ends)

    def run(y: Vector, d: Vector, origin: str) -> None:
        b = continue_branch(problem, y, direction=d, raise_on_failure=False, **opts)
        branches.append(b)
        origins.append(origin)
        for sp in b.specials(PointKind.BRANCH_POINT):
            where = f"branch point of branch {len(branches) - 1} (k = {sp.y[3]:.6g})"
            switch = switch_branch(problem, sp, step=switch_step, control=control,
                                   raise_on_failure=False)
            if switch.failed:
                notes.append(f"{where}: the other branch was not picked up on "
                             f"{len(switch.failed)} of 2 sides at switch_step = "
                             f"{switch_step:g} ({switch.describe_failures()})")
            for ys, ds in switch:
                queue.append((ys, ds, where))

    while queue or pending_ends:
        if len(branches) >= max_branches:
            notes.append(f"stopped after max_branches = {max_branches}; "
                         f"{len(queue) + len(pending_ends)} starts not traced")
            break
        if queue:
            y, d, origin = queue.pop(0)
            if origin.startswith("branch point") and _near_branch(y, branches,
                                                                  0.5 * switch_step):
                continue
            run(y, d, origin)
            continue
        z = pending_ends.pop(0)
        if _near_branch(z.y, branches, 1e-6):
            continue
        run(z.y, -np.sign(z.y[3]) * ez,
            f"end at k = {z.y[3]:g} (Gamma = {np.round(z.y[:3], 6).tolist()})")
    for b, o in zip(branches, origins):
        if b.end not in (EndReason.BOUND, EndReason.STOP_EVENT):
            notes.append(f"branch from {o} ended by {b.end.code}: {b.end_message}")
    return RelativeEquilibria(problem, static, branches, origins, surfaces, ends, k_max,
                              failures, time.perf_counter() - t0, notes)


def at_alpha(
    atlas: RelativeEquilibria,
    value: float,
    *,
    control: StepControl | None = None,
    identically_rtol: float = 1e-8,
) -> dict[str, Any]:
    """Relative equilibria with a given family parameter ``alpha`` on the traced branches.

    The points are the zeros of ``g = k1 - k^2 / value`` (``k1`` for ``value = +-inf``)
    along every branch, each located by re-correcting inside the step (they are zeros of
    the model's field to the corrector tolerance). A branch on which ``g`` vanishes at
    every point lies entirely at ``alpha = value`` (a whole family, as at ``1/J_i`` for a
    zero component of ``rho``); it is reported as such, not as a list of crossings.

    Parameters
    ----------
    atlas : RelativeEquilibria
        From :func:`trace_relative_equilibria`.
    value : float
        The family parameter; ``+-inf`` is allowed (the equilibria (4.10)), 0 is not (the
        static limit ``k = 0``, see :func:`static_equilibria`).
    control : StepControl, optional
        Corrector settings for the location.
    identically_rtol : float
        ``|g| <= identically_rtol (|k1| + k^2 / |value|)`` at every point of a branch makes
        it a branch at constant ``alpha``.

    Returns
    -------
    dict
        ``points`` (list of SpecialPoint, with the branch index in ``data["branch"]``),
        ``whole_branches`` (indices of branches at constant ``alpha = value``) and
        ``message``.

    Raises
    ------
    ParameterError
        For ``value = 0`` or a non-number.
    """
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"value (alpha) must be a number; got {value!r}") from exc
    if v == 0.0 or np.isnan(v):
        raise ParameterError(
            "value (alpha) must be nonzero: alpha -> 0 is the static limit k = 0 (the "
            f"hanging and inverted equilibria, static_equilibria); got {value!r}")
    beta = 0.0 if np.isinf(v) else 1.0 / v
    P = atlas.problem

    def g(y: Vector) -> float:
        m = P.monitors(y)
        return m["k1"] - beta * m["k"] ** 2

    points: list[SpecialPoint] = []
    whole: list[int] = []
    for i, b in enumerate(atlas.branches):
        k, k1 = b.monitors["k"], b.monitors["k1"]
        gv = k1 - beta * k**2
        if np.all(np.abs(gv) <= identically_rtol * (np.abs(k1) + abs(beta) * k**2)):
            whole.append(i)
            continue
        for sp in locate_on_branch(P, b, g, control=control, name=f"alpha = {v:g}"):
            sp.data["branch"] = i
            points.append(sp)
    if points or whole:
        msg = (f"{len(points)} point(s) with alpha = {v:g} on the traced branches; "
               f"{len(whole)} branch(es) entirely at it")
    else:
        msg = (f"no point of the traced branches (|k| <= k_max = {atlas.k_max:g}) has alpha "
               f"= {v:g}; if a branch tends to it as |k| -> infinity, limit_at_infinity "
               f"shows it")
    return {"points": points, "whole_branches": whole, "message": msg}


def family_name(alphas: np.ndarray, J_diag: np.ndarray) -> str:
    """Paper 000 Section 4.3's name L1..L4 of a branch, from the alpha values along it.

    With ``1/J1 < 1/J2 < 1/J3``: L2 has ``0 < alpha < 1/J1``, L3 lies between ``1/J1`` and
    ``1/J2``, L4 between ``1/J2`` and ``1/J3``, and L1 contains negative alpha or alpha
    beyond ``1/J3``.

    Parameters
    ----------
    alphas : ndarray, shape=(n,)
        The family parameter along the branch (non-finite and zero values are skipped).
    J_diag : ndarray, shape=(3,)
        Principal moments, ``J1 >= J2 >= J3``.

    Returns
    -------
    str
        ``"L1"`` .. ``"L4"``, or ``"other"``.
    """
    a = alphas[np.isfinite(alphas) & (alphas != 0.0)]
    inv = np.sort(1.0 / np.asarray(J_diag, dtype=float))
    if np.any(a < 0) or np.any(a > inv[2]):
        return "L1"
    if np.all(a < inv[0]):
        return "L2"
    if np.all((a > inv[0]) & (a < inv[1])):
        return "L3"
    if np.all((a > inv[1]) & (a < inv[2])):
        return "L4"
    return "other"
