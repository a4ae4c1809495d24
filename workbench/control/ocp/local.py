"""Local exponential coordinates of the manifold factors (Lie group actions, RKMK).

Each factor is acted on by a Lie group: ``R^n`` by translations, ``S^1`` by planar
rotations, ``S^2`` by ``SO(3)``, ``SO(3)`` by itself (from the right, body-fixed),
``TS^2`` by ``SO(3)`` rotating ``(q, w)`` together plus a translation of ``w`` in the
tangent plane. Around a point ``x_k`` every nearby point is ``x = act(x_k, y)`` with ``y``
in the Lie algebra (a vector space), and ``x`` lies *exactly* on the factor for every
``y``. A trajectory ``x(t)`` near ``x_k`` is then ``act(x_k, y(t))`` with ``y(0) = 0`` and

    y-dot = dexp^{-1}_y ( lambda(x, x-dot) )                              (RKMK)

where ``lambda`` reads the Lie algebra velocity off the model's ambient vector field
(``q x q-dot`` on S^2, ``vee(R^T R-dot)`` on SO(3)). The transcription
``ManifoldHandling.LIE_GROUP`` integrates ``y`` (an unconstrained vector) on each interval
and sets ``x_{k+1} = act(x_k, y(h))``: no singular coordinates, and the manifold
constraints hold exactly at every node. The ``dexp^{-1}`` of SO(3) is
``I -+ hat(y)/2 + c(|y|) hat(y)^2`` with ``c(t) = (1 - (t/2) cot(t/2)) / t^2``; it is
singular only at ``|y| = 2 pi``, far beyond one interval's rotation.

All maps accept numeric arrays or casadi expressions, except :meth:`Local.log` (numeric).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import casadi as ca
import numpy as np

from workbench.core.errors import ManifoldError
from workbench.core.manifolds import S1, S2, SO3, TS2, Factor, ProductManifold, Rn, so3_exp, so3_log
from workbench.core.types import Expr, Vector

__all__ = ["Local", "local_for", "ProductLocal", "dexpinv"]

_SMALL2 = 1e-4  # below this squared angle the series of c(t) is used (error < 1e-17)


def _is_casadi(x: object) -> bool:
    return isinstance(x, (ca.SX, ca.MX, ca.DM))


def _dexpinv_coefficient(t2: Expr) -> Expr:
    """``c = (1 - (t/2) cot(t/2)) / t^2`` as a function of ``t^2``, safe at 0."""
    series = 1.0 / 12.0 + t2 / 720.0 + t2**2 / 30240.0
    if _is_casadi(t2):
        safe = ca.if_else(t2 < _SMALL2, 1.0, t2)
        t = ca.sqrt(safe)
        exact = (1 - t * ca.sin(t) / (2 * (1 - ca.cos(t)))) / safe
        return ca.if_else(t2 < _SMALL2, series, exact)
    if t2 < _SMALL2:
        return series
    t = np.sqrt(t2)
    return (1 - (t / 2) / np.tan(t / 2)) / t2


def dexpinv(y: Expr, v: Expr, *, left: bool = True) -> Expr:
    """Inverse of the derivative of ``exp`` on so(3), applied to ``v``.

    Parameters
    ----------
    y : array-like or casadi expression, shape=(3,)
        Point of the Lie algebra.
    v : array-like or casadi expression, shape=(3,)
        A velocity in the Lie algebra.
    left : bool
        ``True`` for the left-trivialised map (``d/dt exp(hat y) = hat(J_l y') exp(hat y)``,
        returns ``J_l(y)^{-1} v``), ``False`` for the right one (``exp(hat y) hat(J_r y')``,
        returns ``J_r(y)^{-1} v = J_l(-y)^{-1} v``).

    Returns
    -------
    array or casadi expression, shape=(3,)
    """
    if _is_casadi(y) or _is_casadi(v):
        y, v = ca.vec(y), ca.vec(v)
        c = _dexpinv_coefficient(ca.dot(y, y))
        yv = ca.cross(y, v)
        return v + (-0.5 if left else 0.5) * yv + c * ca.cross(y, yv)
    y, v = np.asarray(y, float).reshape(3), np.asarray(v, float).reshape(3)
    c = _dexpinv_coefficient(float(y @ y))
    yv = np.cross(y, v)
    return v + (-0.5 if left else 0.5) * yv + c * np.cross(y, yv)


def _cat(parts: list, symbolic: bool) -> Expr:
    if symbolic:
        return ca.vertcat(*parts)
    return np.concatenate([np.ravel(np.asarray(p, dtype=float)) for p in parts])


class Local(ABC):
    """Local exponential coordinates ``x = act(x_k, y)`` of one factor.

    Attributes
    ----------
    ydim : int
        Dimension of ``y`` (the Lie algebra acting; at least the factor's dimension).
    """

    ydim: int

    @abstractmethod
    def act(self, xk: Expr, y: Expr) -> Expr:
        """The point ``act(x_k, y)``, exactly on the factor when ``x_k`` is."""

    @abstractmethod
    def ydot(self, xk: Expr, y: Expr, x: Expr, xdot: Expr) -> Expr:
        """``y-dot`` from the ambient velocity ``x-dot`` at ``x = act(x_k, y)``."""

    @abstractmethod
    def log(self, xk: Vector, x: Vector, *, axis: Vector | None = None) -> Vector:
        """Numeric ``y`` with ``act(x_k, y) = x`` (``axis`` resolves antipodal points)."""


class RnLocal(Local):
    """Translations: ``x = x_k + y``."""

    def __init__(self, n: int) -> None:
        self.ydim = n

    def act(self, xk: Expr, y: Expr) -> Expr:  # noqa: D102
        return xk + y

    def ydot(self, xk: Expr, y: Expr, x: Expr, xdot: Expr) -> Expr:  # noqa: D102
        return xdot

    def log(self, xk: Vector, x: Vector, *, axis: Vector | None = None) -> Vector:  # noqa: D102
        return np.asarray(x, float) - np.asarray(xk, float)


class S1Local(Local):
    """Planar rotations: ``p = rot(y) p_k``, ``y-dot = p x p-dot`` (scalar cross)."""

    ydim = 1

    def act(self, xk: Expr, y: Expr) -> Expr:  # noqa: D102
        if _is_casadi(xk) or _is_casadi(y):
            c, s = ca.cos(y), ca.sin(y)
            return ca.vertcat(c * xk[0] - s * xk[1], s * xk[0] + c * xk[1])
        a = float(np.ravel(y)[0])
        c, s = np.cos(a), np.sin(a)
        return np.array([c * xk[0] - s * xk[1], s * xk[0] + c * xk[1]])

    def ydot(self, xk: Expr, y: Expr, x: Expr, xdot: Expr) -> Expr:  # noqa: D102
        return x[0] * xdot[1] - x[1] * xdot[0]

    def log(self, xk: Vector, x: Vector, *, axis: Vector | None = None) -> Vector:  # noqa: D102
        return np.array([np.arctan2(xk[0] * x[1] - xk[1] * x[0], xk @ x)])


def _sphere_log(qk: Vector, q: Vector, axis: Vector | None) -> Vector:
    """Rotation vector ``y`` normal to ``q_k`` and ``q`` with ``exp(hat y) q_k = q``."""
    c = np.cross(qk, q)
    s = float(np.linalg.norm(c))
    angle = float(np.arctan2(s, qk @ q))
    if s > 1e-9:
        return c / s * angle
    if qk @ q > 0:
        return np.zeros(3)
    if axis is None:  # antipodal: any axis normal to q_k; a deterministic one
        axis = np.cross(qk, np.eye(3)[int(np.argmin(np.abs(qk)))])
    axis = np.asarray(axis, float) - (np.asarray(axis, float) @ qk) * qk
    n = float(np.linalg.norm(axis))
    if n < 1e-12:
        raise ManifoldError(f"axis must not be parallel to q_k = {qk.tolist()}; got {axis}")
    return axis / n * np.pi


class S2Local(Local):
    """``q = exp(hat y) q_k``; ``y-dot = dexp^{-1}_y(q x q-dot)`` (left trivialised)."""

    ydim = 3

    def act(self, xk: Expr, y: Expr) -> Expr:  # noqa: D102
        return so3_exp(y) @ xk

    def ydot(self, xk: Expr, y: Expr, x: Expr, xdot: Expr) -> Expr:  # noqa: D102
        xi = ca.cross(x, xdot) if _is_casadi(x) or _is_casadi(xdot) else np.cross(x, xdot)
        return dexpinv(y, xi, left=True)

    def log(self, xk: Vector, x: Vector, *, axis: Vector | None = None) -> Vector:  # noqa: D102
        return _sphere_log(np.asarray(xk, float), np.asarray(x, float), axis)


class SO3Local(Local):
    """``R = R_k exp(hat y)``; ``y-dot = J_r(y)^{-1} vee(R^T R-dot)`` (body velocity)."""

    ydim = 3

    def act(self, xk: Expr, y: Expr) -> Expr:  # noqa: D102
        Rk = SO3.matrix(xk)
        R = Rk @ so3_exp(y)
        return ca.vec(R) if _is_casadi(R) else SO3.flat(R)

    def ydot(self, xk: Expr, y: Expr, x: Expr, xdot: Expr) -> Expr:  # noqa: D102
        R, Rd = SO3.matrix(x), SO3.matrix(xdot)
        W = R.T @ Rd
        if _is_casadi(W):
            w = ca.vertcat(W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]) / 2
        else:
            w = 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])
        return dexpinv(y, w, left=False)

    def log(self, xk: Vector, x: Vector, *, axis: Vector | None = None) -> Vector:  # noqa: D102
        return so3_log(SO3.matrix(xk).T @ SO3.matrix(x))


class TS2Local(Local):
    """``(q, w) = (Q q_k, Q (w_k + P_k z))`` with ``Q = exp(hat a)``, ``P_k = I - q_k q_k^T``.

    ``y = (a, z)``; ``a-dot = dexp^{-1}_a(xi)``, ``xi = q x q-dot``, and
    ``z-dot = Q^T (w-dot - xi x w)``, which is normal to ``q_k`` on the manifold (it is
    ``d/dt (q . w) = 0``), so ``P_k z = z`` along exact trajectories.
    """

    ydim = 6

    def act(self, xk: Expr, y: Expr) -> Expr:  # noqa: D102
        qk, wk, a, z = xk[0:3], xk[3:6], y[0:3], y[3:6]
        Q = so3_exp(a)
        if _is_casadi(xk) or _is_casadi(y):
            Pz = z - ca.dot(qk, z) * qk
            return ca.vertcat(Q @ qk, Q @ (wk + Pz))
        Pz = z - (qk @ z) * qk
        return np.concatenate([Q @ qk, Q @ (wk + Pz)])

    def ydot(self, xk: Expr, y: Expr, x: Expr, xdot: Expr) -> Expr:  # noqa: D102
        q, w, qd, wd = x[0:3], x[3:6], xdot[0:3], xdot[3:6]
        Q = so3_exp(y[0:3])
        if _is_casadi(x) or _is_casadi(xdot) or _is_casadi(y):
            xi = ca.cross(q, qd)
            return ca.vertcat(dexpinv(y[0:3], xi), Q.T @ (wd - ca.cross(xi, w)))
        xi = np.cross(q, qd)
        return np.concatenate([dexpinv(y[0:3], xi), Q.T @ (wd - np.cross(xi, w))])

    def log(self, xk: Vector, x: Vector, *, axis: Vector | None = None) -> Vector:  # noqa: D102
        xk, x = np.asarray(xk, float), np.asarray(x, float)
        a = _sphere_log(xk[:3], x[:3], axis)
        return np.concatenate([a, so3_exp(a).T @ x[3:] - xk[3:]])


def local_for(factor: Factor) -> Local:
    """The local exponential coordinates of a factor.

    Raises
    ------
    ManifoldError
        For a factor kind without a Lie group action here.
    """
    if isinstance(factor, Rn):
        return RnLocal(factor.ambient_dim)
    if isinstance(factor, S1):
        return S1Local()
    if isinstance(factor, S2):
        return S2Local()
    if isinstance(factor, SO3):
        return SO3Local()
    if isinstance(factor, TS2):
        return TS2Local()
    raise ManifoldError(
        f"no Lie group action for factor {factor!r}; known: R^n, S1, S2, SO3, TS2"
    )


class ProductLocal:
    """Factor-wise local coordinates of a product manifold.

    Parameters
    ----------
    manifold : ProductManifold
        The state space.
    """

    def __init__(self, manifold: ProductManifold) -> None:
        self.manifold = manifold
        self.locals = [(name, local_for(f)) for name, f in manifold.factors]
        self.yslices: dict[str, slice] = {}
        k = 0
        for name, loc in self.locals:
            self.yslices[name] = slice(k, k + loc.ydim)
            k += loc.ydim
        self.ydim = k

    def act(self, xk: Expr, y: Expr) -> Expr:
        """``act(x_k, y)`` factor by factor."""
        sym = _is_casadi(xk) or _is_casadi(y)
        s = self.manifold.slices
        return _cat([loc.act(xk[s[n]], y[self.yslices[n]]) for n, loc in self.locals], sym)

    def ydot(self, xk: Expr, y: Expr, x: Expr, xdot: Expr) -> Expr:
        """``y-dot`` factor by factor."""
        sym = any(_is_casadi(v) for v in (xk, y, x, xdot))
        s, ys = self.manifold.slices, self.yslices
        return _cat(
            [loc.ydot(xk[s[n]], y[ys[n]], x[s[n]], xdot[s[n]]) for n, loc in self.locals], sym
        )

    def log(self, xk: Vector, x: Vector, *, axes: dict[str, Vector] | None = None) -> Vector:
        """Numeric ``y`` with ``act(x_k, y) = x``; ``axes`` by factor name for antipodes."""
        s = self.manifold.slices
        xk, x = np.asarray(xk, float), np.asarray(x, float)
        axes = axes or {}
        return np.concatenate(
            [loc.log(xk[s[n]], x[s[n]], axis=axes.get(n)) for n, loc in self.locals]
        )

    def interpolate(self, xa: Vector, xb: Vector, s: float, *,
                    axes: dict[str, Vector] | None = None) -> Vector:
        """The point a fraction ``s`` along the one-parameter curve from ``xa`` to ``xb``."""
        return np.asarray(self.act(xa, s * self.log(xa, xb, axes=axes)), float).ravel()
