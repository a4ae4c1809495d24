"""Poincare sections and the constraint-stabilised field used to integrate up to them.

A :class:`Section` is a hypersurface ``{x : g(x) = 0}`` of a model's state space with an
optional side condition ``s(x) > 0`` and a crossing direction; ``g`` and ``s`` are written
as casadi expressions of the model's symbolic state. :func:`turning_section` is the
section P of paper 000 Section 5.6 on a TS^2 factor, and :func:`turning_section_state`
puts a point on it at a given energy. :func:`stabilized_field` is the model's field with a
stabilising term that vanishes on the manifold (see :mod:`workbench.global_dynamics._poincare`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from functools import partial
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Context, Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import TS2
from workbench.core.types import ArrayLike

__all__ = [
    "Direction",
    "Section",
    "turning_section",
    "turning_section_state",
    "stabilized_field",
]


class Direction(Enum):
    """Which sign changes of the event function ``g`` count as crossings."""

    BOTH = 0
    INCREASING = 1
    DECREASING = -1



# ----------------------------------------------------------------------------------------
# sections


Builder = Callable[[Context], Any]


@dataclass(frozen=True)
class Section:
    """A Poincare section ``{x : g(x) = 0, s(x) > 0}`` crossed in a given direction.

    Parameters
    ----------
    name : str
        Identifier.
    event : callable
        ``event(ctx) -> g``, a scalar casadi expression of the model's symbolic state.
    side : callable, optional
        ``side(ctx) -> s``; only crossings with ``s(x*) > 0`` count.
    direction : Direction
        Sign changes of ``g`` that count.
    description : str
        The section in words or LaTeX, with its source.

    Notes
    -----
    Builders must be module-level functions (or ``functools.partial`` of them) for a
    section to be picklable into a process pool.
    """

    name: str
    event: Builder
    side: Builder | None = None
    direction: Direction = Direction.BOTH
    description: str = ""

    def __post_init__(self) -> None:
        validate.text("name", self.name)
        if not callable(self.event) or (self.side is not None and not callable(self.side)):
            raise ParameterError(f"section {self.name!r}: event (and side) must be builders "
                                 f"ctx -> casadi expression; got {type(self.event).__name__}")


def _axis(axis: ArrayLike) -> np.ndarray:
    a = validate.array("axis", axis, size=3).reshape(-1)
    if abs(np.linalg.norm(a) - 1) > 1e-12:
        raise ParameterError(f"axis must be a finite unit 3-vector; got {axis!r}")
    return a


def _ts2_part(factor: str, ctx: Context) -> Any:
    """The symbolic ``(q, q-dot)`` of the TS2 factor ``factor``, or ModelError."""
    man = ctx.model.manifold
    if factor not in man.names or not isinstance(man.factor(factor), TS2):
        raise ModelError(
            f"turning_section(factor={factor!r}) needs a TS2 factor of that name storing "
            f"(q, q-dot); model {ctx.model.name!r} has {man.describe()}")
    return ctx[factor]


def _turning_event(factor: str, axis: tuple[float, ...], ctx: Context) -> Any:
    x = _ts2_part(factor, ctx)
    return ca.dot(ca.DM(axis), x[3:6])


def _turning_side(factor: str, axis: tuple[float, ...], ctx: Context) -> Any:
    x = _ts2_part(factor, ctx)
    return ca.dot(ca.DM(axis), ca.cross(x[0:3], x[3:6]))


def turning_section(
    *, factor: str = "Gamma", axis: ArrayLike = (0.0, 0.0, 1.0), direction: Direction =
    Direction.BOTH
) -> Section:
    """The section ``{a . q-dot = 0, a . (q x q-dot) > 0}`` on a TS^2 factor ``(q, q-dot)``.

    With ``a = e3`` this is the section P of paper 000 Section 5.6: turning points of the
    height ``e3 . Gamma``, passed while ``Gamma`` moves in the positive sense about ``e3``.
    On an energy level it is a 2-manifold parametrised by ``q`` (``q != +-a``), see
    :func:`turning_section_state`.

    Parameters
    ----------
    factor : str
        Name of a TS2 factor storing ``(q, q-dot)``.
    axis : array-like, shape=(3,)
        The unit axis ``a``.
    direction : Direction
        Which sign changes of ``a . q-dot`` count (both, as in the paper, by default).

    Returns
    -------
    Section
    """
    validate.identifier("factor", factor)
    a = tuple(float(v) for v in _axis(axis))
    try:
        direction = Direction(direction)
    except ValueError as exc:
        raise ParameterError(f"direction must be a Direction {[d.name for d in Direction]}; "
                             f"got {direction!r}") from exc
    return Section(
        name=f"turning[{factor}, a={a}]",
        event=partial(_turning_event, factor, a),
        side=partial(_turning_side, factor, a),
        direction=direction,
        description=r"\{a^T\dot q = 0,\ a^T(q\times\dot q) > 0\} (paper 000 Sec. 5.6, a = e_3)",
    )


def turning_section_state(
    model: Model, q: ArrayLike, *, level: float, factor: str = "Gamma",
    axis: ArrayLike = (0.0, 0.0, 1.0), invariant: str = "energy", tol: float = 1e-13,
) -> np.ndarray:
    """The state on :func:`turning_section` over ``q`` at an invariant level.

    ``q-dot = s d`` with ``d = a x q / |a x q|`` (then ``a . q-dot = 0`` and
    ``a . (q x q-dot) = s |a x q| > 0`` for ``s > 0``), and ``s > 0`` solves
    ``I(q, s d) = level`` by safeguarded Newton with ``dI/ds`` from the graph. The
    invariant must increase with ``s`` on ``s > 0`` (a kinetic energy does).

    Parameters
    ----------
    model : Model
        A model whose only factor is a TS2 factor ``factor``.
    q : array-like, shape=(3,)
        Point of S^2, not parallel to ``axis``.
    level : float
        The invariant's value.
    factor, axis
        As in :func:`turning_section`.
    invariant : str
        Name of the model invariant fixing the level.
    tol : float
        Accepted ``|I - level| / max(1, |level|)``.

    Returns
    -------
    ndarray, shape=(6,)

    Raises
    ------
    ParameterError
        If ``q`` is parallel to the axis, or ``level`` is below the invariant at rest.
    """
    a = _axis(axis)
    if model.manifold.names != [factor]:
        raise ModelError(
            f"turning_section_state needs a model whose state is the single TS2 factor "
            f"{factor!r}; got factors {model.manifold.names}"
        )
    qv = model.manifold.factor(factor).check(np.r_[np.asarray(q, float).ravel(), 0, 0, 0],
                                             name="q")[:3]
    axq = np.cross(a, qv)
    if np.linalg.norm(axq) < 1e-8:
        raise ParameterError(
            f"q must not be parallel to the section axis {a.tolist()} (the section is "
            f"degenerate there); got q = {qv.tolist()}"
        )
    d = axq / np.linalg.norm(axq)
    s = ca.SX.sym("s")
    inv = model.function(invariant)
    val = inv(ca.vertcat(ca.DM(qv), s * ca.DM(d)), ca.DM(model.p))
    fn = ca.Function("level", [s], [val, ca.jacobian(val, s)])
    scale = max(1.0, abs(level))

    def value(sv: float) -> tuple[float, float]:
        v, dv = fn(sv)
        return float(v) - level, float(dv)

    r0, _ = value(0.0)
    if r0 > 0:
        raise ParameterError(
            f"level = {level:.12g} is below {invariant} = {r0 + level:.12g} of q at rest "
            f"(q-dot = 0); no point of the section lies over q = {qv.tolist()}"
        )
    lo, hi = 0.0, 1.0
    while value(hi)[0] < 0:
        lo, hi = hi, 2 * hi
        if hi > 1e12:
            raise SolverError(f"{invariant} does not reach level {level} along q-dot = s d",
                              status="no bracket")
    sv = hi
    for _ in range(100):
        r, dr = value(sv)
        if abs(r) <= tol * scale:
            return np.r_[qv, sv * d]
        lo, hi = (sv, hi) if r < 0 else (lo, sv)
        step = sv - r / dr if dr > 0 else 0.5 * (lo + hi)
        sv = step if lo < step < hi else 0.5 * (lo + hi)
    raise SolverError(f"no convergence solving {invariant} = {level} on the section",
                      status="newton")


# ----------------------------------------------------------------------------------------
# stabilised field


def stabilized_field(model: Model, *, gain: float) -> ca.Function:
    """``(x, p) -> f(x, 0, p) - gain H^T (H H^T)^-1 h(x)``, ``h`` the manifold residual.

    On the manifold (``h = 0``) this is the model's field; off it the residual obeys
    ``h-dot = H f - gain h``, so residuals decay at rate ``gain`` wherever that dominates
    the drift ``H f`` of the model's ambient extension. ``H`` comes from the graph.

    Parameters
    ----------
    model : Model
        The model (inputs are set to zero).
    gain : float
        Non-negative rate [1/s]; ``0`` gives the model's field unchanged.

    Returns
    -------
    casadi.Function
    """
    if not (np.isfinite(gain) and gain >= 0):
        raise ParameterError(f"stabilization gain must be finite and >= 0; got {gain!r}")
    S = model.sym
    x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
    xdot = model.function("f")(x, S.zeros(model.n_inputs), p)
    if gain > 0:
        h = model.manifold.residual(x)
        if h.numel() > 0:
            H = ca.jacobian(h, x)
            xdot = xdot - gain * (H.T @ ca.solve(H @ H.T, h))
    return ca.Function("f_stab", [x, p], [xdot], ["x", "p"], ["xdot"])
