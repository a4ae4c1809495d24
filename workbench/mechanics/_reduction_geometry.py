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

Two geometries:

* :class:`Translation`: constant generators ``d_f`` on R^k factors (a cart's translation,
  several factors together). The pivot coordinate ``(f0, i0)`` (the largest entry of
  ``d``) is the group coordinate: shape coordinates are ``x_f - (x_f0[i0] / d_f0[i0]) d_f``
  with the pivot dropped, the section puts ``x_f0[i0] = 0``.
* :class:`Rotation`: a world rotation about a constant unit axis ``a`` turning a
  *reference* SO(3) factor ``R0`` (the first one). Shape coordinates: ``Gamma = R0^T a``
  on S^2 and every other turning factor seen from the reference body: ``R0^T R`` (SO(3)),
  ``R0^T q`` (S^2), ``R0^T x`` (R^3). Invariant velocities (Lagrange-Poincare): the body
  angular velocities, ``R0^T omega`` (S^2), ``R0^T v`` (R^3). Shape velocities (Routh): the
  velocities relative to the reference body: ``w = -P(Gamma) Omega0`` with
  ``Gamma-dot = w x Gamma`` (the S^2 convention of the mechanics layer), ``Omega - Q^T
  Omega0`` for ``Q = R0^T R``, ``P(q') (R0^T omega - Omega0)`` for ``q' = R0^T q``, and
  ``R0^T v - Omega0 x x'`` for ``x' = R0^T x``. The group velocity is ``xi = Gamma .
  Omega0``. The section is ``R0 = sigma(Gamma)`` with ``sigma(Gamma)^T a = Gamma``: the
  smallest rotation taking ``Gamma`` to ``a`` where ``Gamma . a >= 0`` and the one
  taking it to ``-a`` followed by a half turn about an axis normal to ``a`` elsewhere
  (two Rodrigues charts switched with ``casadi.if_else``: automatic differentiation sees
  the active one, and the reduced field does not depend on the chart because the full
  field is invariant; :func:`workbench.mechanics.reduce` checks that numerically).

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
import numpy as np

from workbench.core.manifolds import S2
from workbench.mechanics._engine import SO3, TS2, ModelError, Rn
from workbench.mechanics._factors import RnFactor, S2Factor, SO3Factor

__all__ = ["Kind", "Quotient", "Translation", "Rotation", "classify", "split_state",
           "join_state", "split_reduced", "split_velocity", "GENERATOR_RTOL"]

GENERATOR_RTOL = 1e-10
"""A generator matches a translation or a rotation when it agrees to this relative
tolerance at seeded random configurations."""


class Kind(StrEnum):
    """Which reduced model: ``ROUTH`` (at a momentum value) or ``LAGRANGE_POINCARE``."""

    ROUTH = "routh"
    LAGRANGE_POINCARE = "lagrange_poincare"


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


def _proj(q: Any, v: Any) -> Any:
    """The part of ``v`` normal to the unit vector ``q``."""
    return v - ca.dot(q, v) * q


def _rot(M: Any) -> Any:
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


def _named(storage: list, parts: list) -> dict:
    return {n: p for (n, _), p in zip(storage, parts)}


class Translation(Quotient):
    """Translations along constant directions ``d_f`` of R^k factors (see module docstring).

    Parameters
    ----------
    factors : list of Factor
        The system's factors.
    directions : dict of int to ndarray
        ``d_f`` by factor index (only R^k factors).
    description : str
        In words.
    """

    def __init__(self, factors: list, directions: dict[int, np.ndarray],
                 description: str) -> None:
        super().__init__(factors, description)
        self.d = directions
        best = max(((j, i, abs(float(d[i]))) for j, d in directions.items()
                    for i in range(d.size)), key=lambda t: t[2])
        self.f0, self.i0 = best[0], best[1]
        self.d0 = float(directions[self.f0][self.i0])

    def _drop(self, v: Any) -> Any:
        # element by element: casadi slices an empty range of a 1x1 matrix as 1x0
        return ca.vertcat(*[v[i] for i in range(v.shape[0]) if i != self.i0])

    def _insert(self, v: Any, value: Any) -> Any:
        els = [v[i] for i in range(v.shape[0])]
        return ca.vertcat(*els[: self.i0], value, *els[self.i0 :])

    def storage(self, kind: Kind) -> list[tuple[str, Any]]:  # noqa: D102
        out: list[tuple[str, Any]] = []
        for j, f in enumerate(self.factors):
            if j != self.f0:
                out += self._passthrough_storage(f)
                continue
            k = f.dim
            if k > 1:
                out.append((f.name, Rn(k - 1)))
            if kind is Kind.LAGRANGE_POINCARE:
                out.append((f.velocity_name, Rn(k)))
            elif k > 1:
                out.append((f.velocity_name, Rn(k - 1)))
        return out

    def quotient(self, c: list, nu: list, kind: Kind) -> list:  # noqa: D102
        s = c[self.f0][self.i0] / self.d0
        sv = nu[self.f0][self.i0] / self.d0
        out: list = []
        for j, f in enumerate(self.factors):
            x, v = c[j], nu[j]
            if j in self.d:
                x = x - s * ca.DM(self.d[j])
                if kind is Kind.ROUTH:
                    v = v - sv * ca.DM(self.d[j])
            if j != self.f0:
                out += self._passthrough_parts(f, x, v)
                continue
            if f.dim > 1:
                out.append(self._drop(x))
            if kind is Kind.LAGRANGE_POINCARE:
                out.append(v)
            elif f.dim > 1:
                out.append(self._drop(v))
        return out

    def _parts(self, r: list, kind: Kind) -> list[tuple[Any, Any]]:
        """Per factor ``(config, velocity)`` as stored in ``r`` (pivot: zero inserted)."""
        out, k = [], 0
        for j, f in enumerate(self.factors):
            if j != self.f0:
                n = len(f.storage())
                out.append(self._passthrough_from(f, r[k : k + n]))
                k += n
                continue
            if f.dim > 1:
                x = self._insert(r[k], 0)
                k += 1
            else:
                x = ca.DM.zeros(1, 1)
            if kind is Kind.LAGRANGE_POINCARE:
                v = r[k]
                k += 1
            elif f.dim > 1:
                v = self._insert(r[k], 0)
                k += 1
            else:
                v = ca.DM.zeros(1, 1)
            out.append((x, v))
        return out

    def section(self, r: list, kind: Kind) -> list:  # noqa: D102
        return [x for x, _ in self._parts(r, kind)]

    def velocity(self, c: list, r: list, kind: Kind, xi: Any) -> list:  # noqa: D102
        vs = [v for _, v in self._parts(r, kind)]
        if kind is Kind.LAGRANGE_POINCARE:
            return vs
        return [v + xi * ca.DM(self.d[j]) if j in self.d else v for j, v in enumerate(vs)]

    def act(self, theta: Any, c: list, nu: list) -> tuple[list, list]:  # noqa: D102
        return ([x + theta * ca.DM(self.d[j]) if j in self.d else x
                 for j, x in enumerate(c)], list(nu))


def _half_turn_axis(a: np.ndarray) -> np.ndarray:
    """A unit vector normal to ``a`` (the axis of the second chart's half turn)."""
    e = np.eye(3)[int(np.argmin(np.abs(a)))]
    b = np.cross(a, e)
    return b / np.linalg.norm(b)


def rodrigues_section(gamma: Any, a: np.ndarray) -> Any:
    """A rotation ``R`` with ``R^T a = gamma / |gamma|``, two charts (module docstring).

    Parameters
    ----------
    gamma : casadi.SX or casadi.MX, shape=(3, 1)
        The reduced attitude (normalised here: the section is a rotation for any nonzero
        ``gamma``).
    a : ndarray, shape=(3,)
        The unit axis.

    Returns
    -------
    casadi.SX or casadi.MX, shape=(3, 3)
    """
    A = ca.DM(a)
    g = gamma / ca.norm_2(gamma)
    c = ca.dot(g, A)
    K = ca.skew(ca.cross(g, A))
    near = ca.DM.eye(3) + K + (K @ K) / (1 + c)  # takes g to a, singular at g = -a
    Km = -K
    b = ca.DM(_half_turn_axis(a))
    F = 2 * (b @ b.T) - ca.DM.eye(3)  # half turn about b: -a -> a
    far = F @ (ca.DM.eye(3) + Km + (Km @ Km) / (1 - c))  # g -> -a -> a, singular at g = a
    return ca.if_else(c >= 0, near, far)


class Rotation(Quotient):
    """World rotations about a unit axis ``a`` with a reference SO(3) factor (module doc).

    Parameters
    ----------
    factors : list of Factor
        The system's factors.
    axis : ndarray, shape=(3,)
        The unit axis.
    turning : set of int
        Indices of the factors the rotation moves.
    description : str
        In words.
    """

    def __init__(self, factors: list, axis: np.ndarray, turning: set[int],
                 description: str) -> None:
        super().__init__(factors, description)
        self.a = np.asarray(axis, dtype=float)
        self.turning = set(turning)
        refs = [j for j in sorted(turning) if isinstance(factors[j], SO3Factor)]
        if not refs:
            raise ModelError(
                "reduction by a rotation needs an SO(3) factor that turns (its reduced "
                "attitude Gamma = R^T a is the quotient coordinate); with S^2, R^2 or R^3 "
                "factors only the action has fixed points (e.g. a link along the axis) and "
                "the quotient has no global ambient coordinates")
        self.k0 = refs[0]
        for j in sorted(turning):
            f = factors[j]
            if isinstance(f, RnFactor) and f.dim == 2:
                raise ModelError(
                    f"factor {f.name!r} (R^2) turns with the rotation: seen from the "
                    f"reference body {factors[self.k0].name!r} it is a vector in a plane "
                    "that moves with the attitude, not a product-manifold coordinate; "
                    "declare it as R^3 (with its third coordinate) to reduce")
        names = {n for f in factors for n, _ in f.storage()}
        self.gamma_name = "Gamma" if "Gamma" not in names else f"Gamma_{factors[self.k0].name}"

    def _rel(self, name: str) -> str:
        return f"{name}_rel"

    def storage(self, kind: Kind) -> list[tuple[str, Any]]:  # noqa: D102
        out: list[tuple[str, Any]] = []
        lp = kind is Kind.LAGRANGE_POINCARE
        for j, f in enumerate(self.factors):
            if j == self.k0:
                out += ([(self.gamma_name, S2()), (f.velocity_name, Rn(3))] if lp
                        else [(self.gamma_name, TS2())])
            elif j not in self.turning:
                out += self._passthrough_storage(f)
            elif isinstance(f, SO3Factor):
                out += [(self._rel(f.name), SO3()),
                        (f.velocity_name if lp else self._rel(f.velocity_name), Rn(3))]
            elif isinstance(f, S2Factor):
                out.append((self._rel(f.name), TS2()))
            else:  # R^3
                out += [(self._rel(f.name), Rn(3)), (self._rel(f.velocity_name), Rn(3))]
        return out

    def quotient(self, c: list, nu: list, kind: Kind) -> list:  # noqa: D102
        R0, W0 = _rot(c[self.k0]), nu[self.k0]
        gam = R0.T @ ca.DM(self.a)
        lp = kind is Kind.LAGRANGE_POINCARE
        out: list = []
        for j, f in enumerate(self.factors):
            if j == self.k0:
                out += [gam, W0] if lp else [ca.vertcat(gam, -_proj(gam, W0))]
            elif j not in self.turning:
                out += self._passthrough_parts(f, c[j], nu[j])
            elif isinstance(f, SO3Factor):
                Q = R0.T @ _rot(c[j])
                out += [ca.vec(Q), nu[j] if lp else nu[j] - Q.T @ W0]
            elif isinstance(f, S2Factor):
                q, w = R0.T @ c[j], R0.T @ nu[j]
                out.append(ca.vertcat(q, w if lp else _proj(q, w - W0)))
            else:
                x, v = R0.T @ c[j], R0.T @ nu[j]
                out += [x, v if lp else v - ca.cross(W0, x)]
        return out

    def _named(self, r: list, kind: Kind) -> dict:
        return _named(self.storage(kind), r)

    def section(self, r: list, kind: Kind) -> list:  # noqa: D102
        parts = self._named(r, kind)
        R0 = rodrigues_section(parts[self.gamma_name][0:3], self.a)
        out = []
        for j, f in enumerate(self.factors):
            if j == self.k0:
                out.append(ca.vec(R0))
            elif j not in self.turning:
                k = [n for n, _ in f.storage()]
                out.append(self._passthrough_from(f, [parts[n] for n in k])[0])
            elif isinstance(f, SO3Factor):
                out.append(ca.vec(R0 @ _rot(parts[self._rel(f.name)])))
            else:
                out.append(R0 @ parts[self._rel(f.name)][0:3])
        return out

    def velocity(self, c: list, r: list, kind: Kind, xi: Any) -> list:  # noqa: D102
        parts = self._named(r, kind)
        lp = kind is Kind.LAGRANGE_POINCARE
        R0 = _rot(c[self.k0])
        gam = R0.T @ ca.DM(self.a)
        W0 = (parts[self.factors[self.k0].velocity_name] if lp
              else -parts[self.gamma_name][3:6] + xi * gam)
        out = []
        for j, f in enumerate(self.factors):
            if j == self.k0:
                out.append(W0)
            elif j not in self.turning:
                k = [n for n, _ in f.storage()]
                out.append(self._passthrough_from(f, [parts[n] for n in k])[1])
            elif isinstance(f, SO3Factor):
                W = parts[f.velocity_name if lp else self._rel(f.velocity_name)]
                out.append(W if lp else W + (R0.T @ _rot(c[j])).T @ W0)
            elif isinstance(f, S2Factor):
                w = parts[self._rel(f.name)][3:6]
                q = R0.T @ c[j]
                out.append(R0 @ w if lp else R0 @ (w + _proj(q, W0)))
            else:
                v = parts[self._rel(f.velocity_name)]
                out.append(R0 @ v if lp else R0 @ (v + ca.cross(W0, R0.T @ c[j])))
        return out

    def rotation(self, theta: Any) -> Any:
        """``exp(theta hat(a))``, shape=(3, 3)."""
        a = self.a
        K = ca.DM([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])  # hat(a)
        return ca.DM.eye(3) + ca.sin(theta) * K + (1 - ca.cos(theta)) * (K @ K)

    def act(self, theta: Any, c: list, nu: list) -> tuple[list, list]:  # noqa: D102
        G = self.rotation(theta)
        cs, vs = [], []
        for j, f in enumerate(self.factors):
            x, v = c[j], nu[j]
            if j in self.turning:
                if isinstance(f, SO3Factor):
                    x = ca.vec(G @ _rot(x))
                else:  # S^2 and R^3 turn as vectors, with their velocities
                    x, v = G @ x, G @ v
            cs.append(x)
            vs.append(v)
        return cs, vs


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
        A :class:`Translation` or a :class:`Rotation`.

    Raises
    ------
    ModelError
        A generator that is neither a translation nor a rotation about a constant axis, or
        a mixture of the two (a screw motion).
    """
    moved = {j: generators[id(f)] for j, f in enumerate(factors) if id(f) in generators}
    consts = {j: ca.SX(g).is_constant() for j, g in moved.items()}
    if all(isinstance(factors[j], RnFactor) and consts[j] for j in moved):
        d = {j: np.asarray(ca.DM(ca.SX(g)), dtype=float).ravel() for j, g in moved.items()}
        d = {j: v for j, v in d.items() if np.any(v != 0)}
        what = ", ".join(f"{factors[j].name} along {np.round(v, 6).tolist()}"
                         for j, v in d.items())
        return Translation(factors, d, f"translation of {what} (momentum {name!r})")
    axis = None
    for j, g in moved.items():
        f = factors[j]
        vals = [evaluate(g, x) for x in states]
        if isinstance(f, S2Factor):
            axes = vals
        elif isinstance(f, SO3Factor):
            c0 = [f.config_sym.shape[0] for f in factors]
            axes = []
            for x, v in zip(states, vals):
                k = sum(c0[i] + factors[i].velocity_sym.shape[0] for i in range(j))
                R = x[k : k + 9].reshape(3, 3).T
                axes.append(R @ v)
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
