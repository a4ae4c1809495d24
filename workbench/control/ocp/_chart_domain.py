"""The domain of a target's chart: where the chart around a point is injective."""

from __future__ import annotations

import casadi as ca

from workbench.core.manifolds import S1, S2, SO3, TS2, ProductManifold
from workbench.core.types import Expr, Vector

__all__ = ["chart_domain"]


def chart_domain(manifold: ProductManifold, centre: Vector, x: Expr) -> list[Expr]:
    """Expressions ``>= 0`` on the neighbourhood where the chart around ``centre`` is injective.

    Parameters
    ----------
    manifold : ProductManifold
        The manifold of the chart.
    centre : ndarray, shape=(ambient_dim,)
        The chart's centre.
    x : casadi expression, shape=(ambient_dim,)
        The point.

    Returns
    -------
    list of casadi expressions
        ``q* . q`` for S1, S2 and TS2 factors (the open hemisphere around ``q*``), and
        ``tr(R*^T R) - 1 = 2 cos(angle)`` for SO3 factors (rotations closer than 90 deg).
    """
    out = []
    for name, f in manifold.factors:
        sl = manifold.slices[name]
        c, xs = ca.DM(centre[sl]), x[sl]
        if isinstance(f, (S1, S2)):
            out.append(ca.dot(c, xs))
        elif isinstance(f, TS2):
            out.append(ca.dot(c[0:3], xs[0:3]))
        elif isinstance(f, SO3):
            out.append(ca.trace(SO3.matrix(c).T @ SO3.matrix(xs)) - 1)
    return out
