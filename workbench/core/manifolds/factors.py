"""The factors: R^n, S^1, S^2, TS^2 and SO(3)."""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core.errors import ManifoldError
from workbench.core.manifolds.base import DEFAULT_TOL, Factor
from workbench.core.manifolds.lie import (  # noqa: F401
    _finite_array,
    _hat_array,
    _is_casadi,
    _so3_exp_array,
    _vec,
    hat,
    so3_exp,
    sphere_basis,
    vee,
)
from workbench.core.types import ArrayLike, Expr, Matrix, Vector

__all__ = ["Rn", "S1", "S2", "TS2", "SO3"]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` of two numeric 3-vectors, as ``np.cross`` computes it, without its overhead.

    The same operations in the same order (bitwise the same result), about 10 times
    faster on single 3-vectors, which the charts of a closed loop evaluate at every step.
    Anything but two vectors of shape (3,) goes to ``np.cross`` (and its errors).
    """
    if a.shape != (3,) or b.shape != (3,):
        return np.cross(a, b)
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def _exp(xi: np.ndarray) -> np.ndarray:
    """``so3_exp(xi)`` of a rotation vector made from already checked numbers.

    Bit for bit :func:`so3_exp`, without checking ``xi`` again unless it is not finite
    (an overflow), so that the error is :func:`so3_exp`'s own.
    """
    return _so3_exp_array(xi) if np.all(np.isfinite(xi)) else so3_exp(xi)


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
        if (isinstance(self.n, (bool, np.bool_)) or not isinstance(self.n, (int, np.integer))
                or not 1 <= self.n <= validate.MAX_DIM):
            raise ManifoldError(f"Rn needs an integer n >= 1 (and <= validate.MAX_DIM = "
                                f"{validate.MAX_DIM}); got n={self.n!r}")

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
        return self._numeric(x) + self._tangent(v)

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
        p, a = self._numeric(x), float(self._tangent(v)[0])
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
        B = sphere_basis(q)  # checks q
        return -_hat_array(q) @ B  # columns b_k x q

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:  # noqa: D102
        q = self._numeric(x)
        xi = sphere_basis(q) @ self._tangent(v)
        return _exp(xi) @ q

    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:  # noqa: D102
        qe = self._numeric(x_e)
        B = sphere_basis(qe)
        q = _vec(x)
        if _is_casadi(q):
            return ca.DM(B.T) @ ca.cross(ca.DM(qe), q)
        return B.T @ _cross(qe, q)

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
            N[:3, k] = _cross(B[:, k], q)
            N[3:, k] = _cross(B[:, k], w)
            N[3:, 2 + k] = B[:, k]
        return N

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:  # noqa: D102
        xv, v = self._numeric(x), self._tangent(v)
        q, w = xv[:3], xv[3:]
        B = sphere_basis(q)
        Q = _exp(B @ v[:2])
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
        return np.concatenate([B.T @ _cross(qe, q), B.T @ (w - we)])

    def project(self, x: ArrayLike) -> Vector:  # noqa: D102
        xv = _finite_array(x, "x (TS2.project)", (6,))
        q = S2().project(xv[:3])
        w = xv[3:] - (q @ xv[3:]) * q
        return np.concatenate([q, w])

    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:  # noqa: D102
        q = S2().random_point(rng)
        w = scale * (sphere_basis(q) @ rng.standard_normal(2))
        return np.concatenate([q, w])

    def residual_scales(self, x: Vector) -> Vector:
        """``(1, |w|)``: tangency ``q . w = 0`` is checked relative to ``|w|``."""
        return np.array([1.0, float(np.linalg.norm(np.asarray(x, dtype=float)[3:]))])

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

    def _numeric(self, x: ArrayLike, name: str = "R") -> Vector:
        a = validate.array(name, x, finite=False, error=ManifoldError)
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
        return self.flat(R @ _exp(self._tangent(v)))

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
