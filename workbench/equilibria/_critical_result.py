"""The result of a search for all critical sets: its status, each set, the whole.

:class:`CriticalStatus` says how far the result can be trusted; :func:`status` picks it
from the sets, the Morse-Bott check and how the search ended (:class:`SearchEnd`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from workbench.core.manifolds import ProductManifold
from workbench.core.status import StatusEnum, StatusResult
from workbench.core.types import Vector
from workbench.equilibria._critical_deflation import SearchEnd
from workbench.equilibria._critical_search import PathEnd
from workbench.equilibria._critical_topology import MorseBottCheck

__all__ = ["CriticalStatus", "CriticalSet", "CriticalPoints", "status"]


class CriticalStatus(StatusEnum):
    """How a search for all critical sets ended; the value is a readable message.

    Attributes
    ----------
    CONSISTENT
        Every set is Morse-Bott with a known topology, the Morse-Bott inequalities hold
        (with equality for a perfect function) and the search settled (new sets stopped
        appearing before its budget ran out, :class:`SearchEnd`). The inequalities are
        necessary for completeness, not sufficient: a missing pair of sets whose indices
        differ by one leaves them holding. CONSISTENT is "nothing contradicts completeness",
        not a proof of it.
    UNSETTLED
        The inequalities hold but the deflation's budget (``max_deflation_starts``) ran out
        while it was still short of its patience (new sets may still have been appearing),
        or deflation was off: sets may be missing.
    UNCLASSIFIED
        Some set is degenerate (nullity above its orbit's dimension) or its orbit's
        topology is not known (a non-abelian or screw symmetry): no Morse-Bott check.
    MISSED
        The Morse-Bott inequalities fail: sets were missed (or an index is wrong).
    NOT_EQUILIBRIA
        A critical set of the potential is not an equilibrium of the model (a load at rest
        that is not in the potential).
    """

    CONSISTENT = ("every critical set is Morse-Bott with a known topology, the Morse-Bott "
                  "inequalities hold and the search settled; the inequalities are necessary for "
                  "completeness, not sufficient (a missing pair of sets whose indices differ by "
                  "one leaves them holding)")
    UNSETTLED = ("the Morse-Bott inequalities hold but the search ran out of starts while new "
                 "sets could still appear (or deflation was off): sets may be missing")
    UNCLASSIFIED = ("some critical set is degenerate or of unknown topology: the Morse-Bott "
                    "check could not be made")
    MISSED = "the Morse-Bott inequalities fail: critical sets were missed"
    NOT_EQUILIBRIA = "a critical point of the potential is not an equilibrium of the model"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"CONSISTENT"})


@dataclass
class CriticalSet:
    """One connected critical set, represented by a point of it.

    Attributes
    ----------
    point : ndarray, shape=(config_ambient_dim,)
        A configuration on the set (the gauge point found first).
    state : ndarray
        The state it stands for (a model state at rest for :func:`find_all_equilibria`).
    value : float
        ``V`` on the set.
    index : int
        Negative eigenvalues of the Riemannian Hessian (on the normal space).
    nullity : int
        Its zero eigenvalues.
    dimension : int
        The set's dimension: the orbit's when Morse-Bott, else the nullity (an upper bound).
    orbit_dimension, compact_dimension, translation_dimension : int
        Of the symmetry orbit through the point (compact: rotations and shifts).
    orbit : list of str
        The symmetry generators that move the point.
    morse_bott : bool
        ``nullity == orbit_dimension``: the set is the orbit, nondegenerate normally.
    topology : str
        ``"point"``, ``"circle"``, ``"2-torus"``, ``"point x R^2"``..., or ``"unknown"``.
    betti : tuple of int or None
        Its mod-2 Poincare polynomial (None when the topology is unknown).
    hessian_eigenvalues : ndarray
        Of the Riemannian Hessian in the manifold's tangent coordinates.
    residual : float
        ``max |K^T dV|`` at the point.
    field_residual : float or None
        ``max |f(state, 0)|`` of the model (None without a model: a function alone has no
        field to evaluate).
    points : list of ndarray
        Every gauge point found on the set.
    found_by : list of str
        How each point was found.
    """

    point: Vector
    state: Vector
    value: float
    index: int
    nullity: int
    dimension: int
    orbit_dimension: int
    compact_dimension: int
    translation_dimension: int
    orbit: list[str]
    morse_bott: bool
    topology: str
    betti: tuple[int, ...] | None
    hessian_eigenvalues: Vector
    residual: float
    field_residual: float | None = None
    points: list[Vector] = field(default_factory=list)
    found_by: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """Plain data (no arrays but the point and state)."""
        return {"value": self.value, "index": self.index, "nullity": self.nullity,
                "dimension": self.dimension, "topology": self.topology,
                "betti": list(self.betti) if self.betti else None,
                "morse_bott": self.morse_bott, "orbit": self.orbit,
                "residual": self.residual, "field_residual": self.field_residual,
                "found_by": self.found_by, "point": self.point.tolist(),
                "state": self.state.tolist()}


@dataclass
class CriticalPoints(StatusResult):
    """Every critical set found, with the Morse-Bott check and how each set was found.

    Attributes
    ----------
    function : str
    manifold : ProductManifold
        The configuration space.
    sets : list of CriticalSet
        By increasing value.
    check : MorseBottCheck or None
        None when some set is unclassified.
    status : CriticalStatus
    message : str
    symmetry : list of str
        The generators of the symmetry found (compact first, then translations).
    symmetry_notes : list of str
    paths : list of PathEnd
        One per start of the homotopy.
    deflation : dict
        ``starts``, ``solves`` and ``found`` of the deflation stage.
    evaluations : int
        Evaluations of the homotopy graph.
    wall_time : float
        Seconds.
    search : SearchEnd
        How the search ended: the start at which the last new set was found, of how many,
        the patience, whether it settled, and the bound it gives on the chance that a
        further start would find a new set.
    """

    function: str
    manifold: ProductManifold
    sets: list[CriticalSet]
    check: MorseBottCheck | None
    status: CriticalStatus
    message: str
    symmetry: list[str]
    symmetry_notes: list[str]
    paths: list[PathEnd]
    deflation: dict[str, int]
    evaluations: int
    wall_time: float
    search: SearchEnd

    def __len__(self) -> int:
        return len(self.sets)

    @property
    def indices(self) -> list[int]:
        """The sets' indices, in the order of :attr:`sets`."""
        return [s.index for s in self.sets]

    @property
    def states(self) -> list[Vector]:
        """The sets' representative states."""
        return [s.state for s in self.sets]

    def summary(self) -> dict[str, Any]:
        """Plain data."""
        return {"function": self.function, "status": self.status.code,
                "message": self.message, "sets": [s.summary() for s in self.sets],
                "check": self.check.summary() if self.check else None,
                "symmetry": self.symmetry, "paths_reached": sum(p.reached for p in self.paths),
                "paths": len(self.paths), "deflation": dict(self.deflation),
                "search": self.search.summary(),
                "evaluations": self.evaluations, "wall_time": self.wall_time}


def status(sets: list[CriticalSet], check: MorseBottCheck | None, paths: list[PathEnd],
            defl: dict[str, int], ended: SearchEnd,
            field_tol: float | None) -> tuple[CriticalStatus, str]:
    """The status and message of a search (the checks in order of precedence)."""
    reached = sum(p.reached for p in paths)
    how = (f"{len(sets)} critical sets; {reached} of {len(paths)} homotopy paths reached t = 1"
           f", deflation found {defl['found']} more from {defl['starts']} seeded starts "
           f"({ended.message})")
    if not sets:
        return CriticalStatus.MISSED, (f"{how}: none found (on an R^k factor the function may "
                                       "have no critical point: not bounded below, not proper)")
    odd = [] if field_tol is None else [i for i, s in enumerate(sets)
                                        if not float(s.field_residual) <= field_tol]
    if odd:
        return CriticalStatus.NOT_EQUILIBRIA, (
            f"{how}; sets {odd} are critical points of the potential but max |f(x, 0)| = "
            f"{max(float(sets[i].field_residual) for i in odd):.3g}: the model has loads at "
            "rest that the potential does not contain (a spring written as a force?)")
    if check is None:
        degenerate = [i for i, s in enumerate(sets) if not s.morse_bott]
        unknown = [i for i, s in enumerate(sets) if s.morse_bott and s.betti is None]
        words = ([f"sets {degenerate} are degenerate (Hessian nullity above the dimension of "
                  "the symmetry orbit)"] if degenerate else []) + (
            [f"sets {unknown} are orbits of a non-abelian or screw symmetry, of unknown "
             "topology"] if unknown else [])
        return CriticalStatus.UNCLASSIFIED, (
            f"{how}; {'; '.join(words)}: the Morse-Bott inequalities were not checked")
    if not check.holds:
        return CriticalStatus.MISSED, f"{how}; {check.message}"
    if not ended.settled:
        return CriticalStatus.UNSETTLED, f"{how}; {check.message}; sets may be missing"
    return CriticalStatus.CONSISTENT, (
        f"{how}; {check.message}. The inequalities are necessary for completeness, not "
        "sufficient: a missing pair of sets whose indices differ by one would leave them "
        "holding")
