"""The geometry of an abelian symmetry of a system: quotient coordinates, section, action.

A one-parameter group ``G`` acts on the configuration (and, by its tangent map, on the
velocities); its generator ``eta(c)`` is the velocity of each factor at unit group speed,
the one of the declared momentum ``J = sum_f Pi_f . eta_f``. A :class:`Quotient` gives, in
ambient coordinates and as casadi expressions:

* ``quotient(c, nu, kind)``: the reduced state of a full state (invariant under ``G``):
  the shape configuration with, for the Lagrange-Poincare kind, every velocity in an
  invariant form (the group velocity kept), for the Routh kind only the shape velocities
  (the group velocity eliminated);
* ``section(r)``: a full configuration over the shape configuration of ``r``;
* ``velocity(c, r, kind, xi)``: the full velocity at a configuration ``c`` over the shape
  of ``r`` with the velocities of ``r`` (Routh: plus ``xi eta(c)``; ``xi`` is the group
  velocity), affine in ``xi``;
* ``act(theta, c, nu)``: the group element ``theta`` applied to a full state.

Three geometries:

* :class:`~._reduction_cyclic.Translation`: constant generators ``d_f`` on R^k factors (a
  cart's translation, several factors together). The pivot coordinate ``(f0, i0)`` (the
  largest entry of ``d``) is the group coordinate: shape coordinates are
  ``x_f - (x_f0[i0] / d_f0[i0]) d_f`` with the pivot dropped, the section puts
  ``x_f0[i0] = 0``.
* :class:`~._reduction_cyclic.Shift`: constant rates ``c_f = +-c`` on S^1 angles (an arm
  angle, several angles together). The first shifted angle ``p0 = (cos theta0, sin
  theta0)`` is the group coordinate; the others are seen from it, ``p_f`` turned by
  ``-(c_f / c_0) theta0``, with rates ``rate_f - (c_f / c_0) rate0`` (Routh); the section
  puts ``p0 = (1, 0)``.
* :class:`~._reduction_rotation.Rotation`: a world rotation about a constant unit axis
  ``a`` turning a *reference* SO(3) factor ``R0`` (the first one). Shape coordinates:
  ``Gamma = R0^T a`` on S^2 and every other turning factor seen from the reference body:
  ``R0^T R`` (SO(3)), ``R0^T q`` (S^2), ``R0^T x`` (R^3) (the double 3D pendulum by yaw of
  the pair: ``Gamma = R1^T e3`` and the relative attitude ``R1^T R2``). Invariant
  velocities (Lagrange-Poincare): the body angular velocities, ``R0^T omega`` (S^2),
  ``R0^T v`` (R^3). Shape velocities (Routh): the velocities relative to the reference
  body: ``w = -P(Gamma) Omega0`` with ``Gamma-dot = w x Gamma`` (the S^2 convention of the mechanics
  layer), ``Omega - Q^T Omega0`` for ``Q = R0^T R``, ``P(q') (R0^T omega - Omega0)`` for
  ``q' = R0^T q``, and ``R0^T v - Omega0 x x'`` for ``x' = R0^T x``. The group velocity is
  ``xi = Gamma . Omega0``. The section is ``R0 = sigma(Gamma)`` with ``sigma(Gamma)^T a =
  Gamma``: ``R0 = B A^T`` with ``B`` a constant rotation taking ``e3`` to ``a`` and ``A`` an
  orthonormal frame whose third column is ``Gamma / |Gamma|`` itself, its first two
  columns from one of two charts switched with ``casadi.if_else`` (automatic
  differentiation sees the active one, and the reduced field does not depend on the chart
  because the full field is invariant; :func:`workbench.mechanics.reduce` checks that
  numerically; :func:`~._reduction_rotation.frame_section`).

Off the manifold (an integrator's drift, an optimiser's iterates) the reduced field is
evaluated at any ambient reduced state ``r``, and the lift is one of *that* state: the
quotient of the lift is ``r`` itself (for TS^2 parts: where ``q . w = 0``), so the derived
rates are the full model's own ambient extension seen through the quotient, which keeps
each factor's constraints (``|q|``, ``q . omega``, ``|p|``) as the full model does. Every
part except the reference attitude enters the lift linearly (``R0 Q``, ``R0 q'``,
``R0 x'``, the angles seen from the first one, the pivot-shifted translations; projections
normal to ``q`` divide by ``q . q``). The reference attitude of the lift is the section at
``Gamma / |Gamma|`` with its component along ``a`` stretched by ``|Gamma|``, so that
``R0^T a = Gamma`` exactly: then ``Gamma-dot = Gamma x Omega0`` (Lagrange-Poincare) and
``w x Gamma`` (Routh, where ``Omega0 = -w + xi Gamma``) for any ``|Gamma|``, ``|Gamma|``
is a first integral of the ambient field (Routh: ``Gamma . w`` too), and the full field
sees ``Gamma`` as it sees ``R^T a`` (gravity's moment ``m g rho x Gamma``, as in paper
000's transcribed models). What the full model makes of a stretched attitude elsewhere is
its own extension: a body moment ``u`` acts through ``R^T R = I + (s^2 - 1) g g^T``
(``s = |Gamma|``, ``g = Gamma / s``), i.e. as ``u + (s^2 - 1)/2 (I - g g^T) u``: exact on
the sphere, never below half of it off the sphere (what wins: the phase of ``Gamma``
under the integrator's drift over an input exact off the manifold). The other turning
factors are seen from the reference attitude with that component scaled back to unit
length (:meth:`Rotation.unit`, the identity on SO(3)), which turns rigidly with
``Omega0`` along the flow. (A lift at the
normalised ``Gamma / |Gamma|`` would turn ``Gamma`` at ``(Gamma / |Gamma|) x Omega0``: a
drift of ``|Gamma|`` by the integrator would become a phase error growing like spin times
time.)

A quotient by rotations with no SO(3) factor turning (S^2 factors only, or R^2/R^3
factors) is not a manifold with global ambient coordinates (the action has fixed points:
a link hanging straight down), and an R^2 factor turning with an SO(3) reference has no
product-manifold quotient coordinate; both are refused with a message.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import casadi as ca

__all__ = ["ReductionKind", "Kind", "Quotient", "split_state", "join_state", "split_reduced",
           "split_velocity", "named_parts", "normal_part", "matrix", "GENERATOR_RTOL"]

GENERATOR_RTOL = 1e-10
"""A generator matches a translation or a rotation when it agrees to this relative
tolerance at seeded random configurations."""


class ReductionKind(StrEnum):
    """Which reduced model: ``ROUTH`` (at a momentum value) or ``LAGRANGE_POINCARE``."""

    ROUTH = "routh"
    LAGRANGE_POINCARE = "lagrange_poincare"


Kind = ReductionKind
"""Short name used inside the reduction modules."""


def split_state(factors: list, x: Any) -> tuple[list, list]:
    """Per-factor configurations and velocities of a full state (each factor stores both)."""
    c, nu, k = [], [], 0
    for f in factors:
        nc, nv = f.config_sym.shape[0], f.velocity_sym.shape[0]
        c.append(x[k : k + nc])
        nu.append(x[k + nc : k + nc + nv])
        k += nc + nv
    return c, nu


def join_state(c: list, nu: list) -> Any:
    """Inverse of :func:`split_state`."""
    return ca.vertcat(*[ca.vertcat(ci, vi) for ci, vi in zip(c, nu)])


def split_reduced(storage: list, r: Any) -> list:
    """The parts of a reduced state, one per ``(name, manifold)`` storage pair."""
    parts, k = [], 0
    for _, m in storage:
        n = m.ambient_dim
        parts.append(r[k : k + n])
        k += n
    return parts


def split_velocity(factors: list, v: Any) -> list:
    """Per-factor pieces of a stacked velocity."""
    out, k = [], 0
    for f in factors:
        n = f.velocity_sym.shape[0]
        out.append(v[k : k + n])
        k += n
    return out


def normal_part(q: Any, v: Any) -> Any:
    """The part of ``v`` normal to ``q`` (any nonzero ``q``: the orthogonal projection)."""
    return v - (ca.dot(q, v) / ca.dot(q, q)) * q


def matrix(M: Any) -> Any:
    """A 3x3 matrix from its 9 stored numbers (column by column)."""
    return ca.reshape(M, 3, 3)


@dataclass
class Quotient:
    """Base of the geometries; see the module docstring.

    Attributes
    ----------
    factors : list of Factor
        The system's factors, in storage order.
    description : str
        What the group does and which coordinates the quotient has, in words.
    """

    factors: list
    description: str

    def storage(self, kind: Kind) -> list[tuple[str, Any]]:
        """The reduced state's ``(name, manifold factor)`` pairs in storage order."""
        raise NotImplementedError

    def quotient(self, c: list, nu: list, kind: Kind) -> list:
        """The reduced state's parts (one per storage pair) of a full state."""
        raise NotImplementedError

    def section(self, r: list, kind: Kind) -> list:
        """A full configuration (per factor) over the shape configuration of ``r``."""
        raise NotImplementedError

    def velocity(self, c: list, r: list, kind: Kind, xi: Any) -> list:
        """The full velocity (per factor) at ``c`` with the velocities of ``r``; see above."""
        raise NotImplementedError

    def act(self, theta: Any, c: list, nu: list) -> tuple[list, list]:
        """The group element ``theta`` applied to a full state."""
        raise NotImplementedError

    def _passthrough_storage(self, f: Any) -> list[tuple[str, Any]]:
        return list(f.storage())

    @staticmethod
    def _passthrough_parts(f: Any, c: Any, v: Any) -> list:
        return [ca.vertcat(c, v)] if len(f.storage()) == 1 else [c, v]

    @staticmethod
    def _passthrough_from(f: Any, parts: list) -> tuple[Any, Any]:
        if len(f.storage()) == 1:
            nc = f.config_sym.shape[0]
            return parts[0][:nc], parts[0][nc:]
        return parts[0], parts[1]


def named_parts(storage: list, parts: list) -> dict:
    """The parts of a reduced state by storage name."""
    return {n: p for (n, _), p in zip(storage, parts)}
