"""Branches of zeros: what a continuation returns, and the knobs it takes.

:class:`StepControl` holds every knob of
:func:`workbench.equilibria._continuation.continue_branch` that trades speed for accuracy;
:class:`Branch` is a traced branch with its cost and accuracy;
:class:`SpecialPoint` a located event, bound, branch point or change of classification;
:class:`BranchSwitch` the starts on the other branch through a branch point.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterator
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import numpy as np

from workbench.core.errors import ParameterError
from workbench.core.status import StatusEnum, StatusResult
from workbench.core.types import Vector
from workbench.equilibria._roots import Root, check_count, check_positive

__all__ = ["StepControl", "EndReason", "PointKind", "SpecialPoint", "Branch", "BranchSwitch"]


@dataclass(frozen=True)
class StepControl:
    """Accuracy and step-size knobs of the continuation.

    Attributes
    ----------
    step : float
        First step length (ambient arclength).
    min_step : float
        A step that fails at this length ends the branch (STEP_TOO_SMALL).
    max_step : float
        Largest step length.
    max_turn : float
        Largest angle [rad] between consecutive tangents; steps aim at half of it.
    growth : float
        Largest factor by which a step grows after an easy one.
    tol : float
        Corrector convergence: ``max |F| <= tol`` (absolute).
    step_tol : float
        The corrector also stops when its Newton step is below this (roundoff level).
    max_corrector_iterations : int
        Corrector iterations allowed per step.
    rank_rtol : float
        Relative singular-value cutoff for ranks and null spaces.
    locate_tol : float
        Special points are located to this arclength.
    """

    step: float = 0.02
    min_step: float = 1e-8
    max_step: float = 0.25
    max_turn: float = 0.15
    growth: float = 2.0
    tol: float = 1e-11
    step_tol: float = 1e-14
    max_corrector_iterations: int = 6
    rank_rtol: float = 1e-8
    locate_tol: float = 1e-10

    def __post_init__(self) -> None:
        for name in ("step", "min_step", "max_step", "max_turn", "tol", "step_tol",
                     "rank_rtol", "locate_tol"):
            check_positive(name, getattr(self, name))
        check_count("max_corrector_iterations", self.max_corrector_iterations)
        if not self.min_step <= self.step <= self.max_step:
            raise ParameterError(
                f"need min_step <= step <= max_step; got {self.min_step}, {self.step}, "
                f"{self.max_step}"
            )
        if not self.growth >= 1.0:
            raise ParameterError(f"growth must be >= 1; got {self.growth}")


class EndReason(StatusEnum):
    """Why a branch ended; the value is a readable message, ``.code`` the short name.

    Every end but STEP_TOO_SMALL is ``ok`` (the branch was traced as far as asked).

    Attributes
    ----------
    BOUND
        A monitor reached a bound (the end point lies on it).
    STOP_EVENT
        A terminal event was reached (the end point is the event).
    MAX_POINTS
        The point limit.
    MAX_ARCLENGTH
        The arclength limit.
    CLOSED
        The branch returned to its start (a closed curve).
    STEP_TOO_SMALL
        The corrector failed down to ``min_step``: a singular point the method could not
        pass, or the end of the zero set.
    """

    BOUND = "a monitor reached its bound"
    STOP_EVENT = "a terminal event was reached"
    MAX_POINTS = "the point limit was reached"
    MAX_ARCLENGTH = "the arclength limit was reached"
    CLOSED = "the branch returned to its start (a closed curve)"
    STEP_TOO_SMALL = ("the corrector failed down to min_step: a singular point the method "
                      "could not pass, or the end of the zero set")

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"BOUND", "STOP_EVENT", "MAX_POINTS", "MAX_ARCLENGTH", "CLOSED"})


class PointKind(Enum):
    """Kinds of special points on a branch."""

    EVENT = "event"
    BOUND = "bound"
    BRANCH_POINT = "branch_point"
    CLASS_CHANGE = "class_change"


@dataclass
class SpecialPoint:
    """A located special point.

    Attributes
    ----------
    kind : PointKind
    name : str
        The monitor's name, ``"branch point"`` or ``"classification"``.
    y : ndarray
        The located point (a zero of F).
    s : float
        Its arclength along the branch.
    index : int
        Index of the branch point just before it.
    residual : float
        ``max |F(y)|``.
    tangent : ndarray
        Unit ambient tangent of the branch there (incoming orientation).
    data : dict
        The monitor values there; ``located`` (False when a re-correction inside the step
        failed, near a singular point: the point is then the end of the step, ``bracket``
        the arclength it is known to, and ``message`` why); kind-specific entries: for a
        branch point the singular values ``sigma`` of A, for a class change ``before``
        and ``after``, for a bound the ``bound``.
    """

    kind: PointKind
    name: str
    y: Vector
    s: float
    index: int
    residual: float
    tangent: Vector
    data: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """Plain data."""
        return {"kind": self.kind.value, "name": self.name, "s": self.s,
                "residual": self.residual, "y": self.y.tolist(),
                "data": {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v)
                         for k, v in self.data.items()}}


@dataclass
class Branch(StatusResult):
    """A traced branch with its cost and accuracy; ``status`` is its :class:`EndReason`.

    Attributes
    ----------
    problem : str
        The problem's name.
    points : ndarray, shape=(n, ambient_dim)
        Zeros along the branch, in order (the start first).
    tangents : ndarray, shape=(n, ambient_dim)
        Unit ambient tangents, oriented along the direction of travel.
    s : ndarray, shape=(n,)
        Arclength (sum of the accepted step lengths).
    residuals : ndarray, shape=(n,)
        ``max |F|`` at every point.
    monitors : dict of str to ndarray
        Every monitor of the problem at every point.
    labels : list
        The classification of every point (empty without ``classify``).
    special : list of SpecialPoint
        Events, bounds, branch points and class changes, in order of arclength.
    end : EndReason
    end_message : str
    corrector_iterations : ndarray
        Per accepted step (0 for the start).
    rejected_steps : int
    evaluations : int
        Evaluations of F with its Jacobian.
    wall_time : float
    null_dimensions : ndarray of int
        Dimension of the null space of the tangent Jacobian at every point (1 on a regular
        curve; more where the branch meets a surface of zeros or passes a singular point).
    """

    problem: str
    points: Vector
    tangents: Vector
    s: Vector
    residuals: Vector
    monitors: dict[str, Vector]
    labels: list[Hashable]
    special: list[SpecialPoint]
    end: EndReason
    end_message: str
    corrector_iterations: Vector
    rejected_steps: int
    evaluations: int
    wall_time: float
    null_dimensions: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))

    @property
    def status(self) -> EndReason:
        """Why the branch ended (the status protocol's name for :attr:`end`)."""
        return self.end

    @property
    def message(self) -> str:
        """:attr:`end_message`."""
        return self.end_message

    @property
    def iterations(self) -> int:
        """Corrector iterations, summed over the accepted steps."""
        return int(np.sum(self.corrector_iterations))

    def __len__(self) -> int:
        return len(self.points)

    def specials(self, kind: PointKind, name: str | None = None) -> list[SpecialPoint]:
        """Special points of one kind (and name)."""
        return [p for p in self.special if p.kind is kind and (name is None or p.name == name)]

    def summary(self) -> dict[str, Any]:
        """Plain data (no per-point arrays)."""
        return {
            "n_points": len(self),
            "arclength": float(self.s[-1]) if len(self.s) else 0.0,
            "max_residual": float(np.max(self.residuals)) if len(self) else 0.0,
            "end": self.end.code,
            "end_message": self.end_message,
            "special": [p.summary() for p in self.special],
            "rejected_steps": self.rejected_steps,
            "points_off_a_curve": int(np.sum(self.null_dimensions > 1)),
            "evaluations": self.evaluations,
            "wall_time": self.wall_time,
            "mean_corrector_iterations": float(np.mean(self.corrector_iterations[1:]))
            if len(self) > 1 else 0.0,
        }


@dataclass
class BranchSwitch:
    """The starts on the other branch through a simple branch point, and how each side went.

    A sequence of the ``(start, direction)`` pairs of the sides whose corrector converged
    (``for y, d in switch_branch(...)``, ``len``, indexing), carrying the corrector result
    of both sides so that a side that failed is reported, not dropped.

    Attributes
    ----------
    point : SpecialPoint
        The branch point.
    step : float
        Distance from the branch point at which the sides were corrected.
    directions : ndarray, shape=(2, ambient_dim)
        The unit ambient directions tried, ``+d`` then ``-d``.
    sides : list of Root
        The corrector result along each direction (same order), converged or not.
    """

    point: SpecialPoint
    step: float
    directions: Vector
    sides: list[Root]

    @property
    def starts(self) -> list[tuple[Vector, Vector]]:
        """``(start, direction)`` of every side that converged, for ``continue_branch``."""
        return [(r.x, d) for r, d in zip(self.sides, self.directions) if r.ok]

    @property
    def failed(self) -> list[tuple[Vector, Root]]:
        """``(direction, root)`` of every side whose corrector did not converge."""
        return [(d, r) for r, d in zip(self.sides, self.directions) if not r.ok]

    def __len__(self) -> int:
        return len(self.starts)

    def __iter__(self) -> Iterator[tuple[Vector, Vector]]:
        return iter(self.starts)

    def __getitem__(self, i: int) -> tuple[Vector, Vector]:
        return self.starts[i]

    def describe_failures(self) -> str:
        """The failed sides in words (empty when both converged)."""
        return "; ".join(
            f"side {'+' if i == 0 else '-'}: {r.status.code} ({r.message})"
            for i, r in enumerate(self.sides) if not r.ok
        )
