"""Which quotient a momentum's generators describe, checked numerically."""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._engine import ModelError
from workbench.mechanics._factors import RnFactor, S2Factor, SO3Factor
from workbench.mechanics._reduction_cyclic import Shift, Translation
from workbench.mechanics._reduction_geometry import GENERATOR_RTOL, Quotient
from workbench.mechanics._reduction_rotation import Rotation

__all__ = ["classify"]


def _is_angle(f: object) -> bool:
    """An S^1 factor (an angle stored as (cos, sin) with its rate)."""
    return getattr(f, "kind", None) == "S^1"


def classify(factors: list, generators: dict, evaluate: Any, states: list[np.ndarray],
             name: str) -> Quotient:
    """The geometry of a momentum's symmetry from its generators, checked numerically.

    Parameters
    ----------
    factors : list of Factor
        The system's factors.
    generators : dict of int to casadi.SX
        The momentum's generators by ``id(factor)``.
    evaluate : callable
        ``evaluate(expr, x) -> ndarray``: a generator's value at a full state.
    states : list of ndarray
        Seeded random full states (on the manifold).
    name : str
        The momentum's name, for messages.

    Returns
    -------
    Quotient
        A :class:`Translation`, a :class:`Shift` or a :class:`Rotation`.

    Raises
    ------
    ModelError
        A generator that is neither a translation, a shift of angles nor a rotation about
        a constant axis, or a mixture of them (a screw motion).
    """
    moved = {j: generators[id(f)] for j, f in enumerate(factors) if id(f) in generators}
    consts = {j: ca.SX(g).is_constant() for j, g in moved.items()}
    if moved and all(_is_angle(factors[j]) and consts[j] for j in moved):
        c = {j: float(ca.DM(ca.SX(g))) for j, g in moved.items()}
        c = {j: v for j, v in c.items() if v != 0}
        if len({abs(v) for v in c.values()}) != 1:
            raise ModelError(f"momentum {name!r}: its angles shift at rates {list(c.values())}"
                             "; only shifts at equal speeds (+-c) are reduced")
        what = ", ".join(f"{factors[j].name} at rate {v:g}" for j, v in c.items())
        return Shift(factors, c, f"shift of {what} (momentum {name!r})")
    if all(isinstance(factors[j], RnFactor) and consts[j] for j in moved):
        d = {j: np.asarray(ca.DM(ca.SX(g)), dtype=float).ravel() for j, g in moved.items()}
        d = {j: v for j, v in d.items() if np.any(v != 0)}
        what = ", ".join(f"{factors[j].name} along {np.round(v, 6).tolist()}"
                         for j, v in d.items())
        return Translation(factors, d, f"translation of {what} (momentum {name!r})")
    axis = None
    # first at the identity attitudes: there R @ eta = eta is the axis as declared (e3
    # exactly, not e3 up to rounding), so that the section sees R^T a as Gamma itself
    starts = [x.copy() for x in states[:1]]
    offsets = np.cumsum([0] + [f.config_sym.shape[0] + f.velocity_sym.shape[0]
                               for f in factors])
    for i, f in enumerate(factors):
        if isinstance(f, SO3Factor):
            starts[0][offsets[i] : offsets[i] + 9] = np.eye(3).reshape(9)
    for j, g in moved.items():
        f = factors[j]
        at = [*starts, *states]
        vals = [evaluate(g, x) for x in at]
        if isinstance(f, S2Factor):
            axes = vals
        elif isinstance(f, SO3Factor):
            axes = [x[offsets[j] : offsets[j] + 9].reshape(3, 3).T @ v for x, v in zip(at, vals)]
        else:
            continue
        for ax in axes:
            axis = ax if axis is None else axis
            if not np.allclose(ax, axis, rtol=GENERATOR_RTOL, atol=GENERATOR_RTOL):
                raise ModelError(
                    f"momentum {name!r}: the generator on factor {f.name!r} is not a rotation "
                    f"about one constant axis ({np.round(axis, 6).tolist()} and "
                    f"{np.round(ax, 6).tolist()} at two configurations); only translations "
                    "and rotations about a constant axis are reduced")
    if axis is None or abs(np.linalg.norm(axis) - 1) > GENERATOR_RTOL:
        raise ModelError(
            f"momentum {name!r}: its generators are neither constant translations of R^k "
            "factors nor a rotation about a unit axis turning an S^2 or SO(3) factor; "
            "only those symmetries are reduced")
    turning = set(moved)
    for j in moved:
        f = factors[j]
        if not isinstance(f, (RnFactor, S2Factor, SO3Factor)):
            raise ModelError(
                f"momentum {name!r}: factor {f.name!r} ({f.kind}) moves with a rotation; only "
                "SO(3), S^2 and R^k factors turning together are reduced")
        if not isinstance(f, RnFactor):
            continue
        expect = (ca.cross(ca.DM(axis), f.x) if f.dim == 3 else
                  float(axis[2]) * ca.vertcat(-f.x[1], f.x[0]) if f.dim == 2 else None)
        ok = expect is not None and all(
            np.allclose(evaluate(moved[j], x), evaluate(expect, x), rtol=GENERATOR_RTOL,
                        atol=GENERATOR_RTOL) for x in states)
        if not ok:
            raise ModelError(
                f"momentum {name!r}: factor {f.name!r} ({f.kind}) moves, but not as a vector "
                f"turning about the axis {np.round(axis, 6).tolist()} of the S^2/SO(3) "
                "factors (a screw motion or another action is not reduced)")
    what = ", ".join(factors[j].name for j in sorted(turning))
    return Rotation(factors, axis, turning,
                    f"rotation about {np.round(axis, 12).tolist()} turning {what} "
                    f"(momentum {name!r})")
