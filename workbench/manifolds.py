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

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import casadi as ca
import numpy as np

from workbench._types import ArrayLike, Expr, Matrix, Vector
from workbench.errors import ManifoldError

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

DEFAULT_TOL = 1e-9
"""Default tolerance on constraint residuals when a point is checked to lie on a factor."""

_SMALL_ANGLE2 = 1e-6  # below this squared angle the Taylor series of exp is used (error ~1e-19)


# ----------------------------------------------------------------------------------------
# numeric / symbolic helpers


def _is_casadi(x: object) -> bool:
    return isinstance(x, (ca.SX, ca.MX, ca.DM))


def _vec(x: Expr) -> Expr:
    """Flatten to a column (casadi) or a 1-D array (numpy)."""
    if _is_casadi(x):
        return ca.vec(x)
    return np.asarray(x, dtype=float).reshape(-1, order="F")


def _finite_array(v: ArrayLike, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``v`` as a finite float array of ``shape``, or ManifoldError naming ``name``."""
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ManifoldError(
            f"{name} must be a numeric array of shape {shape}; got {type(v).__name__} {v!r}"
        ) from exc
    if a.size != int(np.prod(shape)):
        raise ManifoldError(f"{name} must have shape {shape}; got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ManifoldError(f"{name} must be finite; got {a.tolist()}")
    return a.reshape(shape)


def hat(v: Expr) -> Expr:
    """Skew-symmetric matrix of a 3-vector, ``hat(a) @ b == cross(a, b)``.

    Parameters
    ----------
    v : array-like or casadi expression, shape=(3,)
        The vector.

    Returns
    -------
    array or casadi expression, shape=(3, 3)
        ``[[0, -v3, v2], [v3, 0, -v1], [-v2, v1, 0]]``.
    """
    if _is_casadi(v):
        return ca.skew(v)
    v = _finite_array(v, "v (hat)", (3,))
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def vee(m: Expr) -> Expr:
    """Inverse of :func:`hat`: the vector of the skew part of a 3x3 matrix.

    Parameters
    ----------
    m : array-like or casadi expression, shape=(3, 3)
        A skew-symmetric matrix (only its skew part is read).

    Returns
    -------
    array or casadi expression, shape=(3,)
        ``vee(m)`` with ``vee(hat(v)) == v``.
    """
    if _is_casadi(m):
        return ca.vertcat(m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]) / 2
    m = _finite_array(m, "m (vee)", (3, 3))
    return 0.5 * np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])


def _exp_coefficients(theta2: Expr) -> tuple[Expr, Expr]:
    """Return ``sin(t)/t`` and ``(1 - cos(t))/t^2`` as functions of ``t^2``, safe at 0."""
    if _is_casadi(theta2):
        safe = ca.if_else(theta2 < _SMALL_ANGLE2, 1.0, theta2)
        t = ca.sqrt(safe)
        a_exact, b_exact = ca.sin(t) / t, (1 - ca.cos(t)) / safe
        a_series = 1 - theta2 / 6 + theta2**2 / 120
        b_series = 0.5 - theta2 / 24 + theta2**2 / 720
        small = theta2 < _SMALL_ANGLE2
        return ca.if_else(small, a_series, a_exact), ca.if_else(small, b_series, b_exact)
    if theta2 < _SMALL_ANGLE2:
        return 1 - theta2 / 6 + theta2**2 / 120, 0.5 - theta2 / 24 + theta2**2 / 720
    t = np.sqrt(theta2)
    # (1 - cos t) = 2 sin^2(t/2) avoids cancellation for moderate t
    return np.sin(t) / t, 2.0 * np.sin(t / 2) ** 2 / theta2


def so3_exp(v: Expr) -> Expr:
    """Exponential map of SO(3) (Rodrigues' formula), accurate for small angles.

    Parameters
    ----------
    v : array-like or casadi expression, shape=(3,)
        Rotation vector (axis times angle).

    Returns
    -------
    array or casadi expression, shape=(3, 3)
        ``I + a hat(v) + b hat(v)^2`` with ``a = sin|v|/|v|``, ``b = (1-cos|v|)/|v|^2``.
    """
    if _is_casadi(v):
        v = ca.vec(v)
        a, b = _exp_coefficients(ca.dot(v, v))
        k = hat(v)
        return ca.DM.eye(3) + a * k + b * (k @ k)
    v = _finite_array(v, "v (so3_exp)", (3,))
    a, b = _exp_coefficients(float(v @ v))
    k = hat(v)
    return np.eye(3) + a * k + b * (k @ k)


def so3_log(R: ArrayLike, *, tol: float = 1e-6) -> Vector:
    """Logarithm of SO(3) (numeric), accurate near angles 0 and pi.

    Parameters
    ----------
    R : array-like, shape=(3, 3)
        A rotation matrix.
    tol : float
        Largest accepted max-norm of ``R^T R - I`` (loose, for iterates of solvers; the
        result is accurate to about the same size). Farther from SO(3), or with
        ``det R < 0``, nothing meaningful can be returned and ManifoldError is raised.

    Returns
    -------
    ndarray, shape=(3,)
        Rotation vector ``v`` with ``so3_exp(v) == R`` and ``|v| <= pi``.

    Raises
    ------
    ManifoldError
        ``R`` not a finite 3x3 matrix, not orthogonal to ``tol``, or a reflection.

    Notes
    -----
    The angle comes from ``atan2(|vee(R - R^T)|/2, (tr R - 1)/2)``, which is well
    conditioned everywhere. Away from pi the axis is ``vee(R - R^T)/(2 sin t)``; near pi it
    is read from the symmetric part ``(R + R^T)/2 - cos t I = (1 - cos t) k k^T`` with the
    sign fixed by ``vee(R - R^T)``.
    """
    R = _finite_array(R, "R (so3_log)", (3, 3))
    orth = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if orth > tol or np.linalg.det(R) < 0:
        raise ManifoldError(
            f"R (so3_log) must be a rotation; got max |R^T R - I| = {orth:.3g} (tol "
            f"{tol:.1g}), det R = {np.linalg.det(R):.6g}. Project it explicitly with "
            f"SO3().project(R) first, or pass a larger tol"
        )
    w = 0.5 * vee(R - R.T)  # = sin(t) k  (vee(R - R^T) = 2 sin(t) k)
    s = float(np.linalg.norm(w))
    c = (np.trace(R) - 1.0) / 2.0
    t = float(np.arctan2(s, c))
    if t < 1e-4:
        # t/sin t = 1 + t^2/6 + 7 t^4/360
        return w * (1.0 + t * t / 6.0 + 7.0 * t**4 / 360.0)
    if c >= 0.0:  # t <= pi/2: the axis from the skew part is well conditioned
        return w * (t / s)
    S = 0.5 * (R + R.T) - c * np.eye(3)  # (1 - c) k k^T
    j = int(np.argmax(np.diag(S)))
    k = S[:, j] / np.linalg.norm(S[:, j])  # = +-k
    if k @ w < 0:
        k = -k
    # refine the angle with the sign-consistent axis: sin t = k.w, cos t = c
    return k * float(np.arctan2(k @ w, c))


def sphere_basis(q: ArrayLike) -> Matrix:
    """Orthonormal basis of the plane normal to a unit vector.

    Parameters
    ----------
    q : array-like, shape=(3,)
        A unit vector.

    Returns
    -------
    ndarray, shape=(3, 2)
        Columns ``b1, b2`` orthonormal and normal to ``q``: Gram-Schmidt of the two
        coordinate axes along which ``q`` has its smallest components. At ``q = +-e3``
        this is ``[e1, e2]``, the tangent coordinates ``C^T xi`` of the chain-pendulum paper.
    """
    q = _finite_array(q, "q (sphere_basis)", (3,))
    if not q @ q > 0:
        raise ManifoldError("q (sphere_basis) must be a unit vector; got the zero vector")
    order = np.argsort(np.abs(q), kind="stable")
    basis = []
    for j in order[:2]:
        b = np.eye(3)[j] - (q[j] / (q @ q)) * q
        for c in basis:
            b = b - (c @ b) * c
        basis.append(b / np.linalg.norm(b))
    return np.column_stack(basis)


# ----------------------------------------------------------------------------------------
# factors


def _build_constraint_functions(factor: Factor) -> tuple[ca.Function, ca.Function] | None:
    xs = ca.SX.sym("x", factor.ambient_dim)
    h = ca.vec(ca.SX(factor.residual(xs)))
    if h.numel() == 0:
        return None
    return (ca.Function("h", [xs], [h], ["x"], ["h"]),
            ca.Function("dh", [xs], [ca.jacobian(h, xs)], ["x"], ["dh"]))


_constraint_functions = lru_cache(maxsize=256)(_build_constraint_functions)


class Factor(ABC):
    """A manifold factor, the level set ``{x in R^N : h(x) = 0}`` of a submersion ``h``.

    Subclasses define the submersion (:meth:`residual`), its Jacobian, a tangent basis, a
    retraction and a chart that agree to first order (see the module docstring), and an
    explicit projection. :meth:`belongs`, :meth:`is_tangent` and :meth:`check` are derived
    here once.

    Attributes
    ----------
    ambient_dim : int
        ``N``, the number of stored coordinates.
    dim : int
        Dimension of the manifold (``N`` minus the number of independent constraints).
    kind : str
        Short name used in messages ("S2", "SO3", ...).
    """

    ambient_dim: int
    dim: int
    kind: str
    projection_hint: str = "Factor.project(x)"

    @abstractmethod
    def residual(self, x: Expr) -> Expr:
        """Constraint residual ``h(x)``, zero exactly on the manifold.

        Parameters
        ----------
        x : array-like or casadi expression, shape=(ambient_dim,)
            Ambient coordinates.

        Returns
        -------
        array or casadi expression
            The residual (shape depends on the factor; empty for R^n).
        """

    def residual_norm(self, x: ArrayLike) -> float:
        """Max-norm of :meth:`residual` at a numeric point."""
        r = np.asarray(self.residual(self._numeric(x)), dtype=float).ravel()
        return float(np.max(np.abs(r))) if r.size else 0.0

    @abstractmethod
    def tangent_basis(self, x: ArrayLike) -> Matrix:
        """Basis of the tangent space at a numeric point.

        Parameters
        ----------
        x : array-like, shape=(ambient_dim,)
            A point on the factor.

        Returns
        -------
        ndarray, shape=(ambient_dim, dim)
            Columns spanning ``T_x M``; they are the derivative of :meth:`retract`.
        """

    @abstractmethod
    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:
        """Move from ``x`` along tangent coordinates ``v`` and land exactly on the factor.

        Parameters
        ----------
        x : array-like, shape=(ambient_dim,)
            A point on the factor.
        v : array-like, shape=(dim,)
            Tangent coordinates in the basis of :meth:`tangent_basis`.

        Returns
        -------
        ndarray, shape=(ambient_dim,)
            The new point.
        """

    @abstractmethod
    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:
        """Smooth local coordinates of ``x`` around ``x_e``, first-order inverse of retract.

        Parameters
        ----------
        x_e : array-like, shape=(ambient_dim,)
            The chart's centre (numeric).
        x : array-like or casadi expression, shape=(ambient_dim,)
            The point (numeric or symbolic).

        Returns
        -------
        array or casadi expression, shape=(dim,)
            Zero at ``x_e``, derivative the left inverse of the tangent basis there.
        """

    @abstractmethod
    def project(self, x: ArrayLike) -> Vector:
        """Closest point on the factor (explicit; never applied automatically).

        Parameters
        ----------
        x : array-like, shape=(ambient_dim,)
            A point near the factor.

        Returns
        -------
        ndarray, shape=(ambient_dim,)
            The projected point.
        """

    @abstractmethod
    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:
        """A random point (velocity parts scaled by ``scale``), for tests and sampling."""

    def constraint_functions(self) -> tuple[ca.Function, ca.Function] | None:
        """``x -> vec(h(x))`` and ``x -> dh/dx`` as casadi.Functions, built once per factor.

        Returns
        -------
        (casadi.Function, casadi.Function) or None
            On SX symbols, cached for the factor (the 256 most recent factors); None for a
            factor without constraints (R^n). Numeric calls take one point or a matrix of
            points as columns.
        """
        try:
            hash(self)
        except TypeError:  # an unhashable (user) factor: built on every call
            return _build_constraint_functions(self)
        return _constraint_functions(self)

    def constraint_jacobian(self, x: ArrayLike) -> Matrix:
        """Jacobian ``dh/dx`` at a numeric point, shape ``(n_constraints, ambient_dim)``."""
        fns = self.constraint_functions()
        if fns is None:
            return np.zeros((0, self.ambient_dim))
        return np.asarray(fns[1](self._numeric(x)), dtype=float)

    # derived ------------------------------------------------------------------------------

    def _numeric(self, x: ArrayLike) -> Vector:
        return np.asarray(x, dtype=float).reshape(-1, order="F")

    def belongs(self, x: ArrayLike, *, tol: float = DEFAULT_TOL) -> bool:
        """Whether ``x`` has the right size and constraint residual at most ``tol``."""
        xv = self._numeric(x)
        return xv.size == self.ambient_dim and bool(np.all(np.isfinite(xv))) and (
            self.residual_norm(xv) <= tol
        )

    def is_tangent(self, x: ArrayLike, v: ArrayLike, *, tol: float = DEFAULT_TOL) -> bool:
        """Whether the ambient vector ``v`` is tangent at ``x``: ``dh/dx(x) v = 0``."""
        return bool(
            np.all(np.abs(self.constraint_jacobian(x) @ self._numeric(v)) <= tol)
        )

    def check(self, x: ArrayLike, *, name: str = "x", tol: float = DEFAULT_TOL) -> Vector:
        """Validate a numeric point and return it as a flat array, unchanged.

        Parameters
        ----------
        x : array-like
            The point, either flat ``(ambient_dim,)`` or in the factor's natural shape.
        name : str
            Name of the argument, used in the error message.
        tol : float
            Largest accepted constraint residual (max-norm).

        Returns
        -------
        ndarray, shape=(ambient_dim,)
            The same numbers, flattened.

        Raises
        ------
        ManifoldError
            With the residual and the explicit projection to use, if ``x`` is off the factor.
        """
        try:
            xv = self._numeric(x)
        except (TypeError, ValueError) as exc:
            raise ManifoldError(
                f"{name} must be a numeric array for {self.kind}; got {type(x).__name__}"
            ) from exc
        if xv.size != self.ambient_dim:
            raise ManifoldError(
                f"{name} must have {self.ambient_dim} entries for {self.kind}; "
                f"got shape {np.shape(x)}"
            )
        if not np.all(np.isfinite(xv)):
            raise ManifoldError(f"{name} must be finite; got {xv.tolist()}")
        res = self.residual_norm(xv)
        if res > tol:
            raise ManifoldError(
                f"{name} is not on {self.kind}: {self.describe_residual(xv)} "
                f"(max constraint residual {res:.3g} > tol {tol:.1g}). Nothing is "
                f"normalised silently; project it explicitly with {self.projection_hint} "
                f"and report the change, or pass a larger tol."
            )
        return xv

    def describe_residual(self, x: Vector) -> str:
        """Readable account of how ``x`` violates the constraints."""
        return f"|h(x)| = {self.residual_norm(x):.3g}"

    def __repr__(self) -> str:
        return f"{self.kind}()"


@dataclass(frozen=True, repr=False)
class Rn(Factor):
    """Euclidean space R^n (no constraint).

    Parameters
    ----------
    n : int
        Dimension, at least 1.
    """

    n: int

    def __post_init__(self) -> None:
        if not isinstance(self.n, (int, np.integer)) or self.n < 1:
            raise ManifoldError(f"Rn needs an integer n >= 1; got n={self.n!r}")

    @property
    def ambient_dim(self) -> int:  # type: ignore[override]
        """``n``."""
        return int(self.n)

    @property
    def dim(self) -> int:  # type: ignore[override]
        """``n``."""
        return int(self.n)

    @property
    def kind(self) -> str:  # type: ignore[override]
        """``"R^n"``."""
        return f"R^{self.n}"

    def residual(self, x: Expr) -> Expr:  # noqa: D102
        if isinstance(x, ca.MX):
            return ca.MX(0, 1)
        return ca.SX(0, 1) if _is_casadi(x) else np.zeros(0)

    def tangent_basis(self, x: ArrayLike) -> Matrix:  # noqa: D102
        return np.eye(self.n)

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:  # noqa: D102
        return self._numeric(x) + self._numeric(v)

    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:  # noqa: D102
        return _vec(x) - self._numeric(x_e)

    def project(self, x: ArrayLike) -> Vector:  # noqa: D102
        return self._numeric(x).copy()

    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:  # noqa: D102
        return scale * rng.standard_normal(self.n)

    def __repr__(self) -> str:
        return f"Rn({self.n})"


class S1(Factor):
    """The unit circle in R^2, ``h(p) = |p|^2 - 1``; tangent coordinate is the angle rate.

    Tangent basis ``J p = (-p2, p1)``, retraction by planar rotation, chart
    ``p_e x p = p_e1 p2 - p_e2 p1`` (sine of the angle from ``p_e``).
    """

    ambient_dim = 2
    dim = 1
    kind = "S1"
    projection_hint = "S1().project(p) (p / |p|)"

    def residual(self, x: Expr) -> Expr:  # noqa: D102
        x = _vec(x)
        return ca.dot(x, x) - 1 if _is_casadi(x) else np.array([x @ x - 1.0])

    def tangent_basis(self, x: ArrayLike) -> Matrix:  # noqa: D102
        p = self._numeric(x)
        return np.array([[-p[1]], [p[0]]])

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:  # noqa: D102
        p, a = self._numeric(x), float(np.ravel(v)[0])
        c, s = np.cos(a), np.sin(a)
        return np.array([c * p[0] - s * p[1], s * p[0] + c * p[1]])

    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:  # noqa: D102
        pe, p = self._numeric(x_e), _vec(x)
        return pe[0] * p[1] - pe[1] * p[0]

    def project(self, x: ArrayLike) -> Vector:  # noqa: D102
        p = _finite_array(x, "p (S1.project)", (2,))
        n = np.linalg.norm(p)
        if n == 0:
            raise ManifoldError("cannot project the zero vector onto S1: it has no direction")
        return p / n

    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:  # noqa: D102
        a = rng.uniform(-np.pi, np.pi)
        return np.array([np.cos(a), np.sin(a)])

    def describe_residual(self, x: Vector) -> str:  # noqa: D102
        return f"|p| = {np.linalg.norm(x):.12g} (expected 1)"


class S2(Factor):
    """The unit sphere in R^3, ``h(q) = |q|^2 - 1``.

    Tangent vectors are written ``delta q = xi x q`` with ``xi = B v`` in the plane normal
    to ``q`` (``B = sphere_basis(q)``); the retraction is ``exp(hat(xi)) q`` and the chart
    ``B(q_e)^T (q_e x q)``, as in the papers' linearisations on S^2.
    """

    ambient_dim = 3
    dim = 2
    kind = "S2"
    projection_hint = "S2().project(q) (q / |q|)"

    def residual(self, x: Expr) -> Expr:  # noqa: D102
        q = _vec(x)
        return ca.dot(q, q) - 1 if _is_casadi(q) else np.array([q @ q - 1.0])

    def tangent_basis(self, x: ArrayLike) -> Matrix:  # noqa: D102
        q = self._numeric(x)
        return -hat(q) @ sphere_basis(q)  # columns b_k x q

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:  # noqa: D102
        q = self._numeric(x)
        xi = sphere_basis(q) @ np.asarray(v, dtype=float).reshape(2)
        return so3_exp(xi) @ q

    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:  # noqa: D102
        qe = self._numeric(x_e)
        B = sphere_basis(qe)
        q = _vec(x)
        if _is_casadi(q):
            return ca.DM(B.T) @ ca.cross(ca.DM(qe), q)
        return B.T @ np.cross(qe, q)

    def project(self, x: ArrayLike) -> Vector:  # noqa: D102
        q = _finite_array(x, "q (S2.project)", (3,))
        n = np.linalg.norm(q)
        if n == 0:
            raise ManifoldError("cannot project the zero vector onto S2: it has no direction")
        return q / n

    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:  # noqa: D102
        q = rng.standard_normal(3)
        return q / np.linalg.norm(q)

    def describe_residual(self, x: Vector) -> str:  # noqa: D102
        return f"|q| = {np.linalg.norm(x):.12g} (expected 1)"


class TS2(Factor):
    """The tangent bundle of S^2: pairs ``(q, w)`` with ``|q| = 1`` and ``q . w = 0``.

    Stored as 6 numbers ``(q, w)``. Whether ``w`` is the velocity ``q-dot`` or an angular
    velocity with ``q-dot = w x q`` is the model's choice; both satisfy the constraints.
    Tangent coordinates are ``(v, eta)`` in ``R^2 x R^2``: ``xi = B v``, ``delta q = xi x q``,
    ``delta w = xi x w + B eta``; the retraction rotates both parts by ``exp(hat(xi))``, and
    the chart is ``(B^T (q_e x q), B^T (w - w_e))`` with ``B = sphere_basis(q_e)``.
    """

    ambient_dim = 6
    dim = 4
    kind = "TS2"
    projection_hint = "TS2().project(x) (q / |q|, then w minus its component along q)"

    def residual(self, x: Expr) -> Expr:  # noqa: D102
        x = _vec(x)
        q, w = x[0:3], x[3:6]
        if _is_casadi(x):
            return ca.vertcat(ca.dot(q, q) - 1, ca.dot(q, w))
        return np.array([q @ q - 1.0, q @ w])

    def tangent_basis(self, x: ArrayLike) -> Matrix:  # noqa: D102
        xv = self._numeric(x)
        q, w = xv[:3], xv[3:]
        B = sphere_basis(q)
        N = np.zeros((6, 4))
        for k in range(2):
            N[:3, k] = np.cross(B[:, k], q)
            N[3:, k] = np.cross(B[:, k], w)
            N[3:, 2 + k] = B[:, k]
        return N

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:  # noqa: D102
        xv, v = self._numeric(x), np.asarray(v, dtype=float).reshape(4)
        q, w = xv[:3], xv[3:]
        B = sphere_basis(q)
        Q = so3_exp(B @ v[:2])
        return np.concatenate([Q @ q, Q @ (w + B @ v[2:])])

    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:  # noqa: D102
        xe = self._numeric(x_e)
        qe, we = xe[:3], xe[3:]
        B = sphere_basis(qe)
        xv = _vec(x)
        q, w = xv[0:3], xv[3:6]
        if _is_casadi(xv):
            Bt = ca.DM(B.T)
            return ca.vertcat(Bt @ ca.cross(ca.DM(qe), q), Bt @ (w - ca.DM(we)))
        return np.concatenate([B.T @ np.cross(qe, q), B.T @ (w - we)])

    def project(self, x: ArrayLike) -> Vector:  # noqa: D102
        xv = _finite_array(x, "x (TS2.project)", (6,))
        q = S2().project(xv[:3])
        w = xv[3:] - (q @ xv[3:]) * q
        return np.concatenate([q, w])

    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:  # noqa: D102
        q = S2().random_point(rng)
        w = scale * (sphere_basis(q) @ rng.standard_normal(2))
        return np.concatenate([q, w])

    def describe_residual(self, x: Vector) -> str:  # noqa: D102
        q, w = x[:3], x[3:]
        return f"|q| = {np.linalg.norm(q):.12g} (expected 1), q.w = {q @ w:.3g} (expected 0)"


class SO3(Factor):
    """The rotation group, ``h(R) = upper triangle of (R^T R - I)``, stored column-major.

    Tangent vectors are ``delta R = R hat(eta)`` (body-fixed perturbations, as in
    ``R = R_e exp(hat(eta))``); the retraction is ``R exp(hat(v))`` and the chart
    ``vee(R_e^T R - R^T R_e) / 2``. The determinant sign is not a smooth constraint; it is
    checked by :meth:`check` (a reflection is reported as such).
    """

    ambient_dim = 9
    dim = 3
    kind = "SO3"
    projection_hint = "SO3().project(R) (the closest rotation, by SVD)"

    @staticmethod
    def matrix(x: Expr) -> Expr:
        """The 3x3 matrix of a stored rotation (column-major, as casadi ``reshape``)."""
        if _is_casadi(x):
            return ca.reshape(x, 3, 3)
        return np.asarray(x, dtype=float).reshape(3, 3, order="F")

    @staticmethod
    def flat(R: ArrayLike) -> Vector:
        """The 9 stored numbers of a 3x3 rotation matrix (column-major)."""
        return np.asarray(R, dtype=float).reshape(3, 3).reshape(9, order="F")

    def _numeric(self, x: ArrayLike) -> Vector:
        a = np.asarray(x, dtype=float)
        if a.shape == (3, 3):
            return a.reshape(9, order="F")
        return a.reshape(-1)

    def residual(self, x: Expr) -> Expr:  # noqa: D102
        R = self.matrix(_vec(x) if _is_casadi(x) else self._numeric(x))
        E = R.T @ R - (ca.DM.eye(3) if _is_casadi(R) else np.eye(3))
        idx = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]
        if _is_casadi(E):
            return ca.vertcat(*[E[i, j] for i, j in idx])
        return np.array([E[i, j] for i, j in idx])

    def tangent_basis(self, x: ArrayLike) -> Matrix:  # noqa: D102
        R = self.matrix(self._numeric(x))
        return np.column_stack([self.flat(R @ hat(e)) for e in np.eye(3)])

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:  # noqa: D102
        R = self.matrix(self._numeric(x))
        return self.flat(R @ so3_exp(np.asarray(v, dtype=float).reshape(3)))

    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:  # noqa: D102
        Re = self.matrix(self._numeric(x_e))
        if _is_casadi(x):
            R = self.matrix(ca.vec(x))
            Red = ca.DM(Re)
            return vee(Red.T @ R - R.T @ Red) / 2
        R = self.matrix(self._numeric(x))
        return vee(Re.T @ R - R.T @ Re) / 2

    def project(self, x: ArrayLike) -> Vector:  # noqa: D102
        M = self.matrix(_finite_array(self._numeric(x), "R (SO3.project)", (9,)))
        U, sv, Vt = np.linalg.svd(M)
        if not sv[1] > 1e-12 * sv[0]:
            raise ManifoldError(
                f"cannot project R onto SO3: its rank is below 2 (singular values "
                f"{np.array2string(sv, precision=3)}), so the closest rotation is not unique"
            )
        D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
        return self.flat(U @ D @ Vt)

    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:  # noqa: D102
        q = rng.standard_normal(4)
        w, x, y, z = q / np.linalg.norm(q)
        R = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )
        return self.flat(R)

    def check(self, x: ArrayLike, *, name: str = "R", tol: float = DEFAULT_TOL) -> Vector:  # noqa: D102
        xv = super().check(x, name=name, tol=tol)
        det = float(np.linalg.det(self.matrix(xv)))
        if det < 0:
            raise ManifoldError(
                f"{name} is orthogonal but a reflection (det = {det:.6g}, expected +1); "
                f"it is not a rotation"
            )
        return xv

    def describe_residual(self, x: Vector) -> str:  # noqa: D102
        R = self.matrix(x)
        err = np.linalg.norm(R.T @ R - np.eye(3))
        return f"|R^T R - I|_F = {err:.3g} (expected 0), det R = {np.linalg.det(R):.12g}"


# ----------------------------------------------------------------------------------------
# products


class ProductManifold:
    """An ordered product of named factors, stored as one concatenated ambient vector.

    Parameters
    ----------
    factors : sequence of (str, Factor)
        Names and factors, in storage order. Names must be unique identifiers.
    """

    def __init__(self, factors: Sequence[tuple[str, Factor]]) -> None:
        if not factors:
            raise ManifoldError("a product manifold needs at least one factor; got none")
        names = [n for n, _ in factors]
        if len(set(names)) != len(names):
            raise ManifoldError(f"factor names must be unique; got {names}")
        for n, f in factors:
            if not isinstance(f, Factor):
                raise ManifoldError(f"factor {n!r} must be a Factor; got {type(f).__name__}")
        self.factors: tuple[tuple[str, Factor], ...] = tuple(factors)
        self.slices: dict[str, slice] = {}
        self.tangent_slices: dict[str, slice] = {}
        a = t = 0
        for n, f in self.factors:
            self.slices[n] = slice(a, a + f.ambient_dim)
            self.tangent_slices[n] = slice(t, t + f.dim)
            a += f.ambient_dim
            t += f.dim
        self.ambient_dim = a
        self.dim = t

    @property
    def names(self) -> list[str]:
        """Factor names in storage order."""
        return [n for n, _ in self.factors]

    def factor(self, name: str) -> Factor:
        """The factor called ``name``."""
        for n, f in self.factors:
            if n == name:
                return f
        raise ManifoldError(f"unknown factor {name!r}; this manifold has {self.names}")

    def split(self, x: Expr) -> dict[str, Expr]:
        """Named parts of a stored point (numeric or symbolic)."""
        return {n: x[self.slices[n]] for n, _ in self.factors}

    def join(self, parts: dict[str, ArrayLike]) -> Vector:
        """Concatenate named numeric parts in storage order (each flattened column-major)."""
        missing = [n for n in self.names if n not in parts]
        extra = [n for n in parts if n not in self.slices]
        if missing or extra:
            raise ManifoldError(
                f"parts must name exactly the factors {self.names}; "
                f"missing {missing}, unknown {extra}"
            )
        out = []
        for n, f in self.factors:
            try:
                a = np.asarray(parts[n], dtype=float).reshape(-1, order="F")
            except (TypeError, ValueError) as exc:
                raise ManifoldError(f"part {n!r} must be numeric; got {parts[n]!r}") from exc
            if a.size != f.ambient_dim:
                raise ManifoldError(
                    f"part {n!r} must have {f.ambient_dim} entries for {f.kind}; got shape "
                    f"{np.shape(parts[n])}"
                )
            out.append(a)
        return np.concatenate(out)

    def residual(self, x: Expr) -> Expr:
        """Concatenated constraint residuals of all factors."""
        parts = [f.residual(x[self.slices[n]]) for n, f in self.factors]
        if _is_casadi(x):
            return ca.vertcat(*parts)
        return np.concatenate([np.ravel(np.asarray(p, dtype=float)) for p in parts])

    def residual_norms(self, x: ArrayLike) -> dict[str, float]:
        """Max-norm constraint residual of each factor at a numeric point."""
        xv = np.asarray(x, dtype=float).ravel()
        return {n: f.residual_norm(xv[self.slices[n]]) for n, f in self.factors}

    def tangent_basis(self, x: ArrayLike) -> Matrix:
        """Block-diagonal tangent basis, shape ``(ambient_dim, dim)``."""
        xv = np.asarray(x, dtype=float).ravel()
        N = np.zeros((self.ambient_dim, self.dim))
        for n, f in self.factors:
            N[self.slices[n], self.tangent_slices[n]] = f.tangent_basis(xv[self.slices[n]])
        return N

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:
        """Factor-wise retraction of tangent coordinates ``v`` (shape ``(dim,)``)."""
        xv, vv = np.asarray(x, dtype=float).ravel(), np.asarray(v, dtype=float).ravel()
        if vv.size != self.dim:
            raise ManifoldError(f"v must have {self.dim} tangent coordinates ({self.describe()});"
                                f" got shape {np.shape(v)}")
        return np.concatenate(
            [f.retract(xv[self.slices[n]], vv[self.tangent_slices[n]]) for n, f in self.factors]
        )

    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:
        """Factor-wise chart around ``x_e`` (numeric centre, numeric or symbolic point)."""
        xe = np.asarray(x_e, dtype=float).ravel()
        parts = [f.chart(xe[self.slices[n]], x[self.slices[n]]) for n, f in self.factors]
        if _is_casadi(x):
            return ca.vertcat(*parts)
        return np.concatenate([np.ravel(p) for p in parts])

    def project(self, x: ArrayLike) -> Vector:
        """Factor-wise explicit projection."""
        xv = np.asarray(x, dtype=float).ravel()
        return np.concatenate([f.project(xv[self.slices[n]]) for n, f in self.factors])

    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:
        """A random point, factor by factor."""
        return np.concatenate([f.random_point(rng, scale=scale) for _, f in self.factors])

    def check(self, x: ArrayLike, *, name: str = "x", tol: float = DEFAULT_TOL) -> Vector:
        """Validate a numeric point factor by factor; return it flat and unchanged.

        Raises
        ------
        ManifoldError
            Naming the factor that is violated, its residual and the projection to use.
        """
        try:
            xv = np.asarray(x, dtype=float).ravel()
        except (TypeError, ValueError) as exc:
            raise ManifoldError(
                f"{name} must be a numeric array; got {type(x).__name__}"
            ) from exc
        if xv.size != self.ambient_dim:
            raise ManifoldError(
                f"{name} must have {self.ambient_dim} entries ({self.describe()}); "
                f"got shape {np.shape(x)}"
            )
        for n, f in self.factors:
            f.check(xv[self.slices[n]], name=f"{name}[{n!r}]", tol=tol)
        return xv

    def describe(self) -> str:
        """E.g. ``"R: SO3 (9), omega: R^3 (3)"``."""
        return ", ".join(f"{n}: {f.kind} ({f.ambient_dim})" for n, f in self.factors)

    def __repr__(self) -> str:
        return f"ProductManifold([{self.describe()}], dim={self.dim})"
