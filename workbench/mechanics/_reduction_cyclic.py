"""Quotients by cyclic coordinates: translations of R^k factors, shifts of S^1 angles.

See :mod:`._reduction_geometry` for what a quotient provides.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.core.manifolds import S1
from workbench.mechanics._engine import Rn
from workbench.mechanics._reduction_geometry import Kind, Quotient

__all__ = ["Translation", "Shift"]


class Translation(Quotient):
    """Translations along constant directions ``d_f`` of R^k factors (:mod:`._reduction_geometry`).

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


def _turn(p: Any, q: Any) -> Any:
    """The unit vector ``p`` turned by the angle of ``q`` (complex product ``p q``)."""
    return ca.vertcat(p[0] * q[0] - p[1] * q[1], p[0] * q[1] + p[1] * q[0])


def _conj(q: Any) -> Any:
    return ca.vertcat(q[0], -q[1])


class Shift(Quotient):
    """Shifts ``theta_f -> theta_f + c_f t`` of S^1 angles (:mod:`._reduction_geometry`).

    Parameters
    ----------
    factors : list of Factor
        The system's factors.
    rates : dict of int to float
        ``c_f`` by factor index (S^1 factors; every ``|c_f|`` equal).
    description : str
        In words.
    """

    def __init__(self, factors: list, rates: dict[int, float], description: str) -> None:
        super().__init__(factors, description)
        self.c = {j: float(v) for j, v in rates.items() if v != 0}
        self.f0 = min(self.c)
        self.sign = {j: v / self.c[self.f0] for j, v in self.c.items()}  # +-1

    def _rel(self, name: str) -> str:
        return f"{name}_rel"

    def storage(self, kind: Kind) -> list[tuple[str, Any]]:  # noqa: D102
        out: list[tuple[str, Any]] = []
        for j, f in enumerate(self.factors):
            if j == self.f0:
                if kind is Kind.LAGRANGE_POINCARE:
                    out.append((f.velocity_name, Rn(1)))
            elif j in self.c:
                out += [(self._rel(f.name), S1()),
                        (self._rel(f.velocity_name) if kind is Kind.ROUTH else f.velocity_name,
                         Rn(1))]
            else:
                out += self._passthrough_storage(f)
        return out

    def _seen(self, j: int, p: Any, p0: Any) -> Any:
        """Angle ``j`` turned back by ``sign_j theta0``."""
        return _turn(p, _conj(p0) if self.sign[j] > 0 else p0)

    def quotient(self, c: list, nu: list, kind: Kind) -> list:  # noqa: D102
        out: list = []
        p0, r0 = c[self.f0], nu[self.f0]
        for j, f in enumerate(self.factors):
            if j == self.f0:
                if kind is Kind.LAGRANGE_POINCARE:
                    out.append(r0)
            elif j in self.c:
                out += [self._seen(j, c[j], p0),
                        nu[j] - self.sign[j] * r0 if kind is Kind.ROUTH else nu[j]]
            else:
                out += self._passthrough_parts(f, c[j], nu[j])
        return out

    def _parts(self, r: list, kind: Kind) -> list[tuple[Any, Any]]:
        out, k = [], 0
        for j, f in enumerate(self.factors):
            if j == self.f0:
                rate = r[k] if kind is Kind.LAGRANGE_POINCARE else ca.DM.zeros(1, 1)
                k += kind is Kind.LAGRANGE_POINCARE
                out.append((ca.DM([1.0, 0.0]), rate))
                continue
            n = len(f.storage())
            out.append(self._passthrough_from(f, r[k : k + n]))
            k += n
        return out

    def section(self, r: list, kind: Kind) -> list:  # noqa: D102
        return [x for x, _ in self._parts(r, kind)]

    def velocity(self, c: list, r: list, kind: Kind, xi: Any) -> list:  # noqa: D102
        vs = [v for _, v in self._parts(r, kind)]
        if kind is Kind.LAGRANGE_POINCARE:
            return vs
        return [v + xi * self.c[j] if j in self.c else v for j, v in enumerate(vs)]

    def act(self, theta: Any, c: list, nu: list) -> tuple[list, list]:  # noqa: D102
        return ([_turn(x, ca.vertcat(ca.cos(self.c[j] * theta), ca.sin(self.c[j] * theta)))
                 if j in self.c else x for j, x in enumerate(c)], list(nu))
