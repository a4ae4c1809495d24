"""Manifold factors as level sets, and their products.

Every factor is a level set ``M = {x in R^N : h(x) = 0}`` of a submersion ``h`` on its
ambient space, stored in ambient (embedding) coordinates: a unit vector is 3 numbers, a
rotation matrix is 9 (stacked column by column, the casadi ``reshape`` order). From the
submersion follow ``belongs`` and ``is_tangent``; each factor adds a tangent basis, a
retraction, a smooth first-order chart and an explicit projection.

The three maps agree with each other to first order at every point ``x``::

    N = tangent_basis(x)                       # columns span T_x M, shape (N_amb, dim)
    d/dv retract(x, v) at v = 0      == N
    d/dy chart(x, y) at y = x   @ N  == I_dim

so tangent coordinates mean the same thing whether they come from a linearisation
(``pinv(N) df/dx N``), a gain, or a feedback law written through the chart.

Hat, vee, exp and log of SO(3) accept numpy arrays and casadi expressions alike, and are
accurate near rotation angles 0 and pi. Nothing here projects or renormalises silently:
``project`` is only ever called explicitly.
"""

from workbench.core.manifolds.base import DEFAULT_TOL, Factor
from workbench.core.manifolds.factors import S1, S2, SO3, TS2, Rn
from workbench.core.manifolds.lie import (
    _exp_coefficients,
    _is_casadi,
    _vec,
    hat,
    so3_exp,
    so3_log,
    sphere_basis,
    vee,
)
from workbench.core.manifolds.product import ProductManifold

__all__ = [
    "Factor",
    "Rn",
    "S1",
    "S2",
    "SO3",
    "TS2",
    "ProductManifold",
    "hat",
    "vee",
    "so3_exp",
    "so3_log",
    "sphere_basis",
    "DEFAULT_TOL",
]
# private helpers other engine modules use (the LGVI reuses the exp coefficients)
_PRIVATE = (_exp_coefficients, _is_casadi, _vec)
