"""A smooth projection of ambient points onto the state manifold (``ManifoldHandling.PROJECTED``).

The projected transcriptions integrate each interval in ambient coordinates, as
``ManifoldHandling.AMBIENT`` does, and impose continuity on the *projected* end point,

    X_(k+1) = Pi(x_end(X_k, U_k, ...)),

so every node that satisfies the continuity constraints lies on the manifold exactly (to
the constraints' tolerance), whatever the scheme's local error does to the invariants
(Hermite-Simpson, Radau collocation and Runge-Kutta shooting conserve none of them). This
is the projection method of Hairer, Lubich and Wanner (*Geometric Numerical Integration*,
Sec. IV.4): a projection after each step keeps the order of the underlying scheme.

``Pi`` acts factor by factor and is smooth near the manifold (so Ipopt gets exact first and
second derivatives), equal to the identity on it:

* ``R^n``: the identity;
* ``S^1``, ``S^2``: ``p / |p|``;
* ``TS^2`` ``(q, w)``: ``q' = q / |q|`` and ``w' = w - (q' . w) q'`` (the tangent part);
* ``SO(3)``: Gram-Schmidt on the columns, ``c1' = c1/|c1|``,
  ``c2' = (c2 - (c1' . c2) c1') / |...|``, ``c3' = c1' x c2'`` (the QR retraction: exactly
  orthonormal with determinant 1, smooth wherever the first two columns are independent).

Unlike the Lie-group handling (:mod:`workbench.control.ocp.local`) the NLP keeps the size
and the per-iteration cost of the ambient one: one normalisation per interval end.
"""

from __future__ import annotations

import casadi as ca

from workbench.core.errors import ManifoldError
from workbench.core.manifolds import S1, S2, SO3, TS2, Factor, ProductManifold, Rn
from workbench.core.types import Expr

__all__ = ["smooth_projection", "projection_function"]


def _unit(v: Expr) -> Expr:
    return v / ca.sqrt(ca.dot(v, v))


def _factor_projection(factor: Factor, x: Expr) -> Expr:
    if isinstance(factor, Rn):
        return x
    if isinstance(factor, (S1, S2)):
        return _unit(x)
    if isinstance(factor, TS2):
        q = _unit(x[0:3])
        w = x[3:6]
        return ca.vertcat(q, w - ca.dot(q, w) * q)
    if isinstance(factor, SO3):
        c1, c2 = x[0:3], x[3:6]  # columns: R is stored column by column
        e1 = _unit(c1)
        e2 = _unit(c2 - ca.dot(e1, c2) * e1)
        return ca.vertcat(e1, e2, ca.cross(e1, e2))
    raise ManifoldError(f"no smooth projection for factor {factor!r}; known: R^n, S1, S2, "
                        f"TS2, SO3")


def smooth_projection(manifold: ProductManifold, x: Expr) -> Expr:
    """``Pi(x)``: the factor-wise smooth projection of a symbolic ambient point.

    Parameters
    ----------
    manifold : ProductManifold
        The state manifold.
    x : casadi.SX or casadi.MX, shape=(ambient_dim,)
        An ambient point near the manifold.

    Returns
    -------
    casadi expression, shape=(ambient_dim,)
        A point on the manifold; ``Pi(x) = x`` for ``x`` on it.
    """
    return ca.vertcat(*[_factor_projection(f, x[manifold.slices[name]])
                        for name, f in manifold.factors])


def projection_function(manifold: ProductManifold) -> ca.Function:
    """``Pi`` as an SX function ``x -> Pi(x)`` (inlined in SX graphs, one node in MX ones)."""
    x = ca.SX.sym("x", manifold.ambient_dim)
    return ca.Function("project", [x], [smooth_projection(manifold, x)], {"cse": True})
