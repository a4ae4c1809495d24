"""The quotient by world rotations about an axis, with a reference SO(3) factor.

See :mod:`._reduction_geometry` for what a quotient provides and for the coordinates.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.core.manifolds import S2
from workbench.mechanics._engine import SO3, TS2, ModelError, Rn
from workbench.mechanics._factors import RnFactor, S2Factor, SO3Factor
from workbench.mechanics._reduction_geometry import (
    Kind,
    Quotient,
    matrix,
    named_parts,
    normal_part,
)

__all__ = ["Rotation", "frame_section", "axis_frame"]


def axis_frame(a: np.ndarray) -> np.ndarray:
    """A constant rotation ``B`` with ``B e3 = a`` (the identity for ``a = e3``).

    Parameters
    ----------
    a : ndarray, shape=(3,)
        The unit axis.

    Returns
    -------
    ndarray, shape=(3, 3)
    """
    e = np.eye(3)[int(np.argmin(np.abs(a)))]
    b1 = e - (e @ a) * a
    b1 = b1 / np.linalg.norm(b1)
    return np.column_stack([b1, np.cross(a, b1), a])


def frame_section(gamma: Any, a: np.ndarray) -> tuple[Any, Any]:
    """Rotations over ``gamma``: ``R = B A^T`` with ``R^T a = gamma / |gamma|``, two charts.

    ``B`` is :func:`axis_frame` and ``A = [c1, c2, g]`` an orthonormal frame whose third
    column is ``g = gamma / |gamma|`` itself (so ``R^T a = A e3`` is ``g`` as an
    expression, not a combination of chart entries): the rotation taking ``e3`` to ``g``
    where ``g3 >= 0`` (singular only at ``g = -e3``) and the one taking ``e3`` to ``-g``
    followed by a half turn about ``e1`` elsewhere (singular only at ``g = e3``), switched
    with ``casadi.if_else`` (both charts are a few products of ``g``; the reduced field
    does not depend on the chart because the full field is invariant). Only the first two
    columns depend on the chart: a full field that sees the attitude through ``R^T a``
    alone (gravity along the axis) never evaluates a chart.

    Parameters
    ----------
    gamma : casadi.SX or casadi.MX, shape=(3, 1)
        The reduced attitude, any nonzero vector.
    a : ndarray, shape=(3,)
        The unit axis.

    Returns
    -------
    R : casadi.SX or casadi.MX, shape=(3, 3)
        The rotation ``B A^T``.
    R_scaled : casadi.SX or casadi.MX, shape=(3, 3)
        ``B [c1, c2, gamma]^T = R + a (gamma - g)^T``: equal to ``R`` on the sphere, and
        off it the rotation with its component along ``a`` stretched by ``|gamma|``, so
        that ``R_scaled^T a = gamma`` exactly (the lift of an ambient ``gamma``).
    """
    g = gamma / ca.norm_2(gamma)
    g0, g1, g2 = g[0], g[1], g[2]
    s, t = 1 + g2, 1 - g2
    near1 = ca.vertcat(1 - g0 * g0 / s, -g0 * g1 / s, -g0)
    near2 = ca.vertcat(-g0 * g1 / s, 1 - g1 * g1 / s, -g1)
    far1 = ca.vertcat(1 - g0 * g0 / t, -g0 * g1 / t, g0)
    far2 = ca.vertcat(g0 * g1 / t, g1 * g1 / t - 1, -g1)
    up = g2 >= 0
    c1, c2 = ca.if_else(up, near1, far1), ca.if_else(up, near2, far2)
    B = ca.DM(axis_frame(a))
    return B @ ca.horzcat(c1, c2, g).T, B @ ca.horzcat(c1, c2, gamma).T


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

    def unit(self, R: Any, gam: Any) -> Any:
        """``R`` with its component along ``a`` scaled to unit length.

        ``R + (1 / |gam| - 1) a gam^T`` for ``gam = R^T a``: the identity on SO(3), and
        the rotation under the lift's stretched reference attitude, from which the other
        turning factors are seen.
        """
        return R + (1 / ca.norm_2(gam) - 1) * (ca.DM(self.a) @ gam.T)

    def quotient(self, c: list, nu: list, kind: Kind) -> list:  # noqa: D102
        Rs, W0 = matrix(c[self.k0]), nu[self.k0]
        gam = Rs.T @ ca.DM(self.a)
        R0 = self.unit(Rs, gam)
        lp = kind is Kind.LAGRANGE_POINCARE
        out: list = []
        for j, f in enumerate(self.factors):
            if j == self.k0:
                out += [gam, W0] if lp else [ca.vertcat(gam, -normal_part(gam, W0))]
            elif j not in self.turning:
                out += self._passthrough_parts(f, c[j], nu[j])
            elif isinstance(f, SO3Factor):
                Q = R0.T @ matrix(c[j])
                out += [ca.vec(Q), nu[j] if lp else nu[j] - Q.T @ W0]
            elif isinstance(f, S2Factor):
                q, w = R0.T @ c[j], R0.T @ nu[j]
                out.append(ca.vertcat(q, w if lp else normal_part(q, w - W0)))
            else:
                x, v = R0.T @ c[j], R0.T @ nu[j]
                out += [x, v if lp else v - ca.cross(W0, x)]
        return out

    def _named(self, r: list, kind: Kind) -> dict:
        return named_parts(self.storage(kind), r)

    def section(self, r: list, kind: Kind) -> list:  # noqa: D102
        parts = self._named(r, kind)
        R0, Rs = frame_section(parts[self.gamma_name][0:3], self.a)
        out = []
        for j, f in enumerate(self.factors):
            if j == self.k0:
                out.append(ca.vec(Rs))
            elif j not in self.turning:
                k = [n for n, _ in f.storage()]
                out.append(self._passthrough_from(f, [parts[n] for n in k])[0])
            elif isinstance(f, SO3Factor):
                out.append(ca.vec(R0 @ matrix(parts[self._rel(f.name)])))
            else:
                out.append(R0 @ parts[self._rel(f.name)][0:3])
        return out

    def velocity(self, c: list, r: list, kind: Kind, xi: Any) -> list:  # noqa: D102
        parts = self._named(r, kind)
        lp = kind is Kind.LAGRANGE_POINCARE
        Rs = matrix(c[self.k0])
        gam = Rs.T @ ca.DM(self.a)
        R0 = self.unit(Rs, gam)
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
                out.append(W if lp else W + (R0.T @ matrix(c[j])).T @ W0)
            elif isinstance(f, S2Factor):
                w = parts[self._rel(f.name)][3:6]
                q = R0.T @ c[j]
                out.append(R0 @ w if lp else R0 @ (w + normal_part(q, W0)))
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
                    x = ca.vec(G @ matrix(x))
                else:  # S^2 and R^3 turn as vectors, with their velocities
                    x, v = G @ x, G @ v
            cs.append(x)
            vs.append(v)
        return cs, vs
