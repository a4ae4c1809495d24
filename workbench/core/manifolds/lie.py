"""SO(3) and S^2 helpers: hat, vee, exp and log (accurate near 0 and pi), sphere bases.

Each accepts numpy arrays and casadi expressions alike where it is used symbolically.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core.errors import ManifoldError
from workbench.core.types import ArrayLike, Expr, Matrix, Vector

__all__ = ["hat", "vee", "so3_exp", "so3_log", "sphere_basis"]

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
    """``v`` as a finite real float array of ``shape``, or ManifoldError naming ``name``.

    A thin use of :func:`workbench.core.validate.array` (complex, bool, str refused).
    """
    a = validate.array(name, v, error=ManifoldError)
    if a.size != math.prod(shape):
        raise ManifoldError(f"{name} must have shape {shape}; got shape {a.shape}")
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
    return _hat_array(_finite_array(v, "v (hat)", (3,)))


def _hat_array(v: np.ndarray) -> np.ndarray:
    """:func:`hat` of a float array of shape (3,), without checking it."""
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
    return _so3_exp_array(_finite_array(v, "v (so3_exp)", (3,)))


def _so3_exp_array(v: np.ndarray) -> np.ndarray:
    """:func:`so3_exp` of a finite float array of shape (3,), without checking it.

    For the retractions, whose rotation vector is made from already checked numbers; the
    arithmetic is :func:`so3_exp`'s (bit for bit).
    """
    theta2 = float(v @ v)
    if not np.isfinite(theta2):  # |v| > 1e154: the squares overflow; rotate about the axis
        big = float(np.max(np.abs(v)))
        theta = big * float(np.linalg.norm(v / big))
        k = _hat_array(v / theta)
        return np.eye(3) + np.sin(theta) * k + (1.0 - np.cos(theta)) * (k @ k)
    a, b = _exp_coefficients(theta2)
    k = _hat_array(v)
    return np.eye(3) + a * k + b * (k @ k)


@validate.arguments(error=ManifoldError, tol=validate.tolerance)
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
    i, j = np.argsort(np.abs(q), kind="stable")[:2]
    qq = q @ q
    # Gram-Schmidt of e_i, e_j (the same arithmetic as a loop over np.eye(3)'s rows; this
    # is on the hot path of every Newton step on S^2)
    b1 = 0.0 - (q[i] / qq) * q  # 0 - x, not -x: the same signed zeros as e_i - x
    b1[i] += 1.0
    b1 = b1 / math.sqrt(b1 @ b1)  # = np.linalg.norm, bit for bit
    b2 = 0.0 - (q[j] / qq) * q
    b2[j] += 1.0
    b2 = b2 - (b1 @ b2) * b1
    out = np.empty((3, 2))
    out[:, 0], out[:, 1] = b1, b2 / math.sqrt(b2 @ b2)
    return out
