"""The sphere B_delta in an eigenspace: evenly spread directions, the distance (12), seeds.

The global stable manifold of paper 002 Section II-D is grown from a small sphere
``B_delta`` of the local stable eigenspace, whose points are at distance exactly ``delta``
from the equilibrium in the distance (12),
``d((q1, w1), (q2, w2)) = sqrt(Psi(q1, q2)) + |w1 - w2|`` with ``Psi = 1 - q1 . q2``, and
its TSO(3) analogue. This module provides the three pieces:

* :func:`sphere_directions` -- ``n`` unit vectors spread evenly over ``S^{k-1}``
  (``k = 1 .. 5`` here; any ``k``), and :func:`direction_spread` to measure how evenly;
* :func:`equilibrium_distance` -- the distance (12), generalised factor by factor;
* :func:`ball_points` -- the seeds ``retract(x_e, r_j W u_j)`` with ``d = delta`` exactly,
  placed in the chart of the retraction at ``x_e`` (:func:`chart_increments`): the
  increment ``x - x_e`` and its distance come from the tangent vector in closed form, so
  the distance is ``delta`` to rounding for any equilibrium, not only one with exact
  coordinates. Measured again from the stored coordinates it differs by their rounding,
  at most :func:`rounding_bound` (``~EPS / delta`` relative); :func:`seed_report` gives both.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Evaluator, Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import S1, S2, SO3, TS2, Rn, sphere_basis
from workbench.core.types import ArrayLike

__all__ = [
    "sphere_directions",
    "direction_spread",
    "equilibrium_distance",
    "distances",
    "ball_points",
    "batch_evaluate",
    "chart_increments",
    "rounding_bound",
    "seed_report",
    "EPS",
    "SEED_TOL",
]

BATCH = 1024
"""Rows evaluated per casadi call by :func:`batch_evaluate`."""


def positive_int(value: Any, name: str, minimum: int = 1) -> int:
    """Return ``value`` as an int ``>= minimum``: :func:`workbench.core.validate.count`."""
    return validate.count(name, value, minimum=minimum)


def positive_float(value: Any, name: str, *, allow_inf: bool = False) -> float:
    """A positive float (finite unless ``allow_inf``): :func:`workbench.core.validate.positive`."""
    return validate.positive(name, value, allow_inf=allow_inf)


def sphere_directions(k: int, n: int, *, seed: int = 0, iterations: int = 50) -> np.ndarray:
    """``n`` unit vectors spread evenly over the sphere ``S^{k-1}`` of ``R^k``.

    ``k = 1``: the two points ``+-1`` (``n`` must be 2). ``k = 2``: ``n`` equally spaced
    angles. ``k = 3``: the Fibonacci lattice (equal-area bands, golden-angle longitudes).
    ``k >= 4``: seeded Gaussian directions relaxed by ``iterations`` steps of Riesz
    ``(k-1)``-energy repulsion on the sphere (deterministic for a given seed).

    Parameters
    ----------
    k : int
        Dimension of the space (of the eigenspace), ``>= 1``.
    n : int
        Number of directions.
    seed : int
        Seed of the starting directions for ``k >= 4``.
    iterations : int
        Repulsion steps for ``k >= 4`` (0 keeps the random start).

    Returns
    -------
    ndarray, shape=(n, k)
        Unit vectors.
    """
    k = positive_int(k, "k")
    n = positive_int(n, "n")
    iterations = positive_int(iterations, "iterations", 0)
    if k == 1:
        if n != 2:
            raise ParameterError(f"a one-dimensional eigenspace meets the sphere in exactly 2 "
                                 f"points; n must be 2, got {n}")
        return np.array([[1.0], [-1.0]])
    j = np.arange(n)
    if k == 2:
        a = 2 * np.pi * j / n
        return np.column_stack([np.cos(a), np.sin(a)])
    if k == 3:
        z = 1 - (2 * j + 1) / n
        phi = j * np.pi * (3 - np.sqrt(5))
        s = np.sqrt(1 - z * z)
        return np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
    X = np.random.default_rng(seed).standard_normal((n, k))
    X /= np.linalg.norm(X, axis=1, keepdims=True)
    if n < 2:
        return X
    s = k - 1
    for it in range(iterations):
        r2 = np.maximum(2.0 - 2.0 * (X @ X.T), 1e-300)  # |x_i - x_j|^2 of unit vectors
        np.fill_diagonal(r2, np.inf)
        inv = 1.0 / r2
        w = np.sqrt(inv) if s % 2 else np.ones_like(inv)  # |x_i - x_j|^-(s+2) by products
        for _ in range((s + 2) // 2):
            w = w * inv
        F = X * w.sum(axis=1, keepdims=True) - w @ X  # sum_j w_ij (x_i - x_j)
        F -= np.einsum("ij,ij->i", F, X)[:, None] * X  # tangent part
        nn = np.sqrt(r2.min(axis=1))
        Fn = np.linalg.norm(F, axis=1, keepdims=True)
        move = 0.5 * (1 - it / max(iterations, 1)) * nn[:, None] * F / np.maximum(Fn, 1e-300)
        X = X + move
        X /= np.linalg.norm(X, axis=1, keepdims=True)
    return X


def direction_spread(U: ArrayLike) -> dict[str, float]:
    """Nearest-neighbour angles of unit vectors: how evenly they cover the sphere.

    Parameters
    ----------
    U : array-like, shape=(n, k)
        Unit vectors, ``n >= 2``.

    Returns
    -------
    dict
        ``min_angle``, ``max_angle`` (radians, over points, of the angle to the nearest
        other point) and ``mesh_ratio = max_angle / min_angle`` (1 for a perfect lattice).
    """
    U = np.asarray(U, dtype=float)
    if U.ndim != 2 or U.shape[0] < 2:
        raise ParameterError(f"U must have shape (n, k) with n >= 2; got {U.shape}")
    C = np.clip(U @ U.T, -1.0, 1.0)  # cosines, for arccos only
    np.fill_diagonal(C, -np.inf)
    nn = np.arccos(C.max(axis=1))
    return {"min_angle": float(nn.min()), "max_angle": float(nn.max()),
            "mesh_ratio": float(nn.max() / max(nn.min(), 1e-300))}


# ----------------------------------------------------------------------------------------
# distance (12) and the sphere B_delta


def _distance_expr(model: Model, x: Any, x_e: Any) -> Any:
    terms = []
    for name, f in model.manifold.factors:
        a, b = x[model.manifold.slices[name]], x_e[model.manifold.slices[name]]
        if isinstance(f, (S2, S1)):
            terms.append(ca.norm_2(a - b) / np.sqrt(2.0))
        elif isinstance(f, TS2):
            terms.append(ca.norm_2(a[0:3] - b[0:3]) / np.sqrt(2.0) + ca.norm_2(a[3:6] - b[3:6]))
        elif isinstance(f, SO3):
            terms.append(ca.norm_fro(a - b) / 2)
        elif isinstance(f, Rn):
            terms.append(ca.norm_2(a - b))
        else:
            raise ModelError(f"no distance (12) for factor {name!r} of kind {f.kind}; "
                             f"supported: R^n, S1, S2, SO3, TS2")
    return sum(terms[1:], terms[0])


def equilibrium_distance(model: Model) -> ca.Function:
    """``(x, x_e) -> d``, the distance (12) of paper 002 and its analogue on other factors.

    ``sqrt(Psi)`` of every configuration factor plus the Euclidean norm of every velocity
    difference: ``|q - q_e| / sqrt(2)`` on S^2 and S^1 (``Psi = 1 - q . q_e``),
    ``|R - R_e|_F / 2`` on SO(3) (``Psi = tr(I - R_e^T R) / 2``), ``|q - q_e| / sqrt(2) +
    |w - w_e|`` on TS^2 (exactly (12)) and ``|v - v_e|`` on R^n. The forms used are exact
    on the manifold and free of cancellation near ``x_e``.

    Parameters
    ----------
    model : Model
        The model (its factors).

    Returns
    -------
    casadi.Function
        SX function of the stored states ``x`` and ``x_e``.
    """
    n = model.manifold.ambient_dim
    x, xe = ca.SX.sym("x", n), ca.SX.sym("x_e", n)
    return ca.Function("equilibrium_distance", [x, xe], [_distance_expr(model, x, xe)],
                       ["x", "x_e"], ["d"])


def batch_evaluate(fn: ca.Function, X: ArrayLike, *shared: ArrayLike, chunk: int = BATCH
                   ) -> np.ndarray:
    """Evaluate ``fn(x, *shared)`` on every row ``x`` of ``X``, in chunks of one casadi call.

    Parameters
    ----------
    fn : casadi.Function
        Dense inputs; the first is the row, the others are the same for every row.
    X : array-like, shape=(n, fn.nnz_in(0))
        The rows.
    *shared : array-like
        The other inputs.
    chunk : int
        Rows per call (the mapped function and its buffers are built once).

    Returns
    -------
    ndarray, shape=(n, fn.nnz_out(0))
        The first output of every row.
    """
    X2 = np.atleast_2d(np.asarray(X, dtype=float))
    n, m = X2.shape[0], fn.nnz_out(0)
    if n == 0:
        return np.zeros((0, m))
    size = min(int(chunk), n)
    args = [ca.MX.sym(f"a{i}", fn.size_in(i)) for i in range(fn.n_in())]
    rows = ca.MX.sym("X", fn.nnz_in(0), size)
    ev = Evaluator(ca.Function("batch", [rows, *args[1:]],
                               [fn.map(size).call([rows, *args[1:]])[0]]))
    out = np.empty((n, m))
    for a in range(0, n, size):
        block = X2[a:a + size]
        k = block.shape[0]
        if k < size:
            block = np.vstack([block, np.repeat(block[:1], size - k, axis=0)])
        out[a:a + k] = np.asarray(ev(block, *shared)).reshape(size, m)[:k]
    return out


def distances(model: Model, X: ArrayLike, x_e: ArrayLike) -> np.ndarray:
    """Distance (12) of each row of ``X`` (stored states) to ``x_e``, shape ``(n,)``."""
    xe = np.asarray(x_e, dtype=float).ravel()
    return batch_evaluate(equilibrium_distance(model), X, xe).reshape(-1)


EPS = float(np.finfo(float).eps)
"""Spacing of float64 numbers at 1 (twice the unit roundoff)."""

SEED_TOL = 16 * EPS
"""Default relative tolerance of the seeds' chart distance (about 3.6e-15).

The chart distance of a seed is a composition of fewer than 16 correctly rounded
operations of its tangent coordinates (a norm of at most 3 squares, a square root, the
sine of a half angle, a product with sqrt(2), a sum over the factors), each adding at most
``EPS / 2`` relative error; the fixed point ``r <- r delta / d(r)`` settles within that.
"""

_SQRT2 = float(np.sqrt(2.0))


def _rotation_coefficients(t2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sin t / t`` and ``(1 - cos t) / t^2`` of an array of ``t^2`` (series below 1e-6)."""
    small = t2 < 1e-6  # the series' truncation error is below 1e-19 there
    safe = np.where(small, 1.0, t2)
    t = np.sqrt(safe)
    a = np.where(small, 1 - t2 / 6 + t2**2 / 120, np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24 + t2**2 / 720, 2 * np.sin(t / 2) ** 2 / safe)
    return a, b


def _rotate_minus_identity(xi: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``(exp(hat(xi)) - I) y`` row by row, as ``a xi x y + b xi x (xi x y)`` (no cancellation)."""
    a, b = _rotation_coefficients(np.einsum("ij,ij->i", xi, xi))
    k = np.cross(xi, y)
    return a[:, None] * k + b[:, None] * np.cross(xi, k)


def _factor_increment(f: Any, xe: np.ndarray, V: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Increments ``retract(x_e, v) - x_e`` of one factor, their distance (12), their angle.

    The angle is the rotation of the configuration (0 on R^n); the chart of the retraction
    is one-to-one for angles below pi.
    """
    n = V.shape[0]
    if isinstance(f, Rn):
        return V.copy(), np.linalg.norm(V, axis=1), np.zeros(n)
    if isinstance(f, S1):
        a = V[:, 0]
        c1, s = -2 * np.sin(a / 2) ** 2, np.sin(a)  # cos a - 1 without cancellation
        dx = np.column_stack([c1 * xe[0] - s * xe[1], s * xe[0] + c1 * xe[1]])
        return dx, _SQRT2 * np.abs(np.sin(a / 2)), np.abs(a)
    if isinstance(f, (S2, TS2)):
        B = sphere_basis(xe[:3])
        xi = V[:, :2] @ B.T
        theta = np.linalg.norm(xi, axis=1)
        dq = _rotate_minus_identity(xi, np.broadcast_to(xe[:3], xi.shape))
        d = _SQRT2 * np.sin(theta / 2)  # |Q q_e - q_e| / sqrt(2), Q = exp(hat(xi))
        if isinstance(f, S2):
            return dq, d, theta
        Beta = V[:, 2:] @ B.T  # w = Q (w_e + B eta): w - w_e = (Q - I)(w_e + B eta) + B eta
        dw = _rotate_minus_identity(xi, xe[3:] + Beta) + Beta
        return np.hstack([dq, dw]), d + np.linalg.norm(dw, axis=1), theta
    if isinstance(f, SO3):
        theta = np.linalg.norm(V, axis=1)
        a, b = _rotation_coefficients(theta**2)
        K = np.zeros((n, 3, 3))
        K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -V[:, 2], V[:, 1], -V[:, 0]
        K = K - K.transpose(0, 2, 1)
        dR = SO3.matrix(xe) @ (a[:, None, None] * K + b[:, None, None] * (K @ K))
        return dR.transpose(0, 2, 1).reshape(n, 9), _SQRT2 * np.sin(theta / 2), theta
    raise ModelError(f"no chart distance for factor of kind {f.kind}; supported: R^n, S1, S2, "
                     f"SO3, TS2")


def chart_increments(model: Model, x_e: ArrayLike, V: ArrayLike
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``retract(x_e, v) - x_e`` for rows ``v`` of tangent coordinates, without cancellation.

    The retraction of every factor (``exp(hat(xi)) q`` on S^2 and TS^2, ``R exp(hat(v))`` on
    SO(3), planar rotation on S^1, translation on R^n) is written as ``x_e`` plus an
    increment computed from ``v`` (``(exp(hat(xi)) - I) y = a xi x y + b xi x (xi x y)``),
    and the distance (12) of the increment in closed form: ``sqrt(2) sin(theta / 2)`` for a
    configuration turned by ``theta`` (S^1, S^2, SO(3); ``|q - q_e| / sqrt(2)`` and
    ``|R - R_e|_F / 2`` both equal it), ``|w - w_e|`` and ``|v|`` for velocities. Both are
    exact to a few roundings of ``v``, whatever the coordinates of ``x_e``.

    Parameters
    ----------
    model : Model
        The model (factors R^n, S1, S2, SO3, TS2).
    x_e : array-like, shape=(ambient_dim,)
        The centre of the chart.
    V : array-like, shape=(n, dim)
        Tangent coordinates at ``x_e`` (the coordinates of ``Model.manifold.retract``).

    Returns
    -------
    increments : ndarray, shape=(n, ambient_dim)
        ``retract(x_e, v) - x_e``.
    distance : ndarray, shape=(n,)
        Distance (12) of ``retract(x_e, v)`` to ``x_e``.
    angle : ndarray, shape=(n,)
        Largest rotation angle of a configuration factor (the chart is one-to-one below pi).
    """
    man = model.manifold
    xe = np.asarray(x_e, dtype=float).ravel()
    V2 = np.atleast_2d(np.asarray(V, dtype=float))
    n = V2.shape[0]
    D, d, angle = np.empty((n, man.ambient_dim)), np.zeros(n), np.zeros(n)
    for name, f in man.factors:
        dx, df, th = _factor_increment(f, xe[man.slices[name]], V2[:, man.tangent_slices[name]])
        D[:, man.slices[name]] = dx
        d += df
        angle = np.maximum(angle, th)
    return D, d, angle


def rounding_bound(model: Model, x_e: ArrayLike, delta: float) -> float:
    """Bound on ``|d(x, x_e) - delta|`` for seeds stored as ``x = fl(x_e + increment)``.

    Storing ``x_e + increment`` rounds each coordinate by at most ``EPS / 2`` of its size,
    and ``x - x_e`` is then exact (Sterbenz) or rounded relative to itself; the distance (12)
    weighs a factor's coordinates by ``c = 1 / sqrt(2)`` (S^1, S^2, the ``q`` of TS^2),
    ``1 / 2`` (SO(3)) or 1 (velocities). So the distance of a stored seed is within
    ``EPS / 2 * sum_f c_f |x_f|`` of ``delta``, plus the relative rounding of the increment
    and of the distance itself (a few ``EPS delta``). Returned with a factor 2 on the first
    term and 16 on the second: ``EPS * (sum_f c_f |x_e,f| + 16 delta)``.

    Parameters
    ----------
    model : Model
        The model.
    x_e : array-like, shape=(ambient_dim,)
        The equilibrium.
    delta : float
        The distance of the seeds.

    Returns
    -------
    float
        The absolute bound (relative to ``delta``: divide by ``delta``; ``~0.7 EPS / delta``
        on S^2 and TS^2, ``~0.9 EPS / delta`` on SO(3) x R^3).
    """
    xe = np.asarray(x_e, dtype=float).ravel()
    total = 0.0
    for name, f in model.manifold.factors:
        x = xe[model.manifold.slices[name]]
        if isinstance(f, TS2):
            total += np.linalg.norm(x[:3]) / _SQRT2 + np.linalg.norm(x[3:])
        else:
            c = 0.5 if isinstance(f, SO3) else 1 / _SQRT2 if isinstance(f, (S1, S2)) else 1.0
            total += c * np.linalg.norm(x)
    return EPS * (float(total) + 16 * float(delta))


def ball_points(
    model: Model, x_e: ArrayLike, W: ArrayLike, directions: ArrayLike, *, delta: float,
    tol: float = SEED_TOL, max_iter: int = 50,
) -> tuple[np.ndarray, np.ndarray]:
    """States on ``B_delta``: ``retract(x_e, r_j W u_j)`` at distance (12) ``delta``.

    Each seed is placed in the chart of the retraction at ``x_e``: its tangent vector
    ``xi_j = r_j W u_j`` gives the increment ``retract(x_e, xi_j) - x_e`` and its distance
    (12) in closed form (:func:`chart_increments`), the radius ``r_j`` is the fixed point
    of ``r <- r delta / d(r)`` (``d`` is linear in ``r`` to first order), and the seed is
    stored as ``x_e + increment``. The distance of the placed seed is ``delta`` to
    ``tol`` (rounding of the chart, whatever the coordinates of ``x_e``); the distance
    measured again from the stored ambient coordinates differs from it by their rounding
    only, at most :func:`rounding_bound` (``~EPS / delta`` relative).

    Parameters
    ----------
    model : Model
        The model.
    x_e : array-like, shape=(ambient_dim,)
        The equilibrium.
    W : array-like, shape=(dim, k)
        Basis of the eigenspace in the manifold's tangent coordinates at ``x_e``.
    directions : array-like, shape=(n, k)
        Unit directions in the coordinates of ``W``.
    delta : float
        Radius in the distance (12).
    tol : float
        Largest accepted ``|d - delta| / delta`` of the chart distance (default
        :data:`SEED_TOL`, 16 EPS; it cannot usefully be below the chart's rounding, ~8 EPS).
    max_iter : int
        Iterations of ``r <- r delta / d(r)`` (two or three suffice below ``delta = 0.1``).

    Returns
    -------
    points : ndarray, shape=(n, ambient_dim)
    radii : ndarray, shape=(n,)
        ``r_j``: the seeds are ``retract(x_e, r_j W u_j)``.

    Raises
    ------
    SolverError
        ``delta`` is too large for the chart (a configuration would turn by pi or more:
        status ``outside_chart``; use a smaller ``delta``), or the radii did not settle
        within ``tol`` in ``max_iter`` iterations (status ``no_radius``).
    """
    delta = positive_float(delta, "delta")
    tol = positive_float(tol, "tol")
    max_iter = positive_int(max_iter, "max_iter")
    xe = np.asarray(x_e, dtype=float).ravel()
    V = np.asarray(directions, dtype=float) @ np.asarray(W, dtype=float).T  # (n, dim)
    r = np.full(V.shape[0], delta)
    for _ in range(max_iter):
        D, d, angle = chart_increments(model, xe, r[:, None] * V)
        err = np.abs(d - delta) / delta
        # iterate on to a quarter of tol (the rounding of d is ~3 EPS), accept within tol
        if np.all(err <= tol / 4) or np.any(angle >= np.pi):
            break
        r = r * delta / d
    if np.any(angle >= np.pi):
        j = int(np.argmax(angle))
        raise SolverError(
            f"delta = {delta:.3g} is too large for the chart of the retraction at the "
            f"equilibrium: seed {j} would turn a configuration by {angle[j]:.4g} rad >= pi "
            f"(its distance (12) was {d[j]:.4g}), beyond which the chart is not one-to-one; "
            f"use a smaller delta", status="outside_chart")
    if not np.all(err <= tol):
        j = int(np.argmax(err))
        raise SolverError(
            f"could not place seed {j} at distance delta = {delta:.3g} from the equilibrium: "
            f"the relative error of its chart distance is {err[j]:.3g} > tol = {tol:.3g} "
            f"after max_iter = {max_iter} iterations of r <- r delta / d(r); raise max_iter, "
            f"or raise tol (the chart distance is exact only to its rounding, about "
            f"{8 * EPS:.1g} relative)", status="no_radius")
    return xe + D, r


def seed_report(model: Model, x_e: ArrayLike, seeds: ArrayLike, V: ArrayLike, delta: float
                ) -> dict[str, float]:
    """How exactly the seeds lie at distance ``delta``: in the chart and from their coordinates.

    Parameters
    ----------
    model : Model
        The model.
    x_e : array-like, shape=(ambient_dim,)
        The equilibrium.
    seeds : array-like, shape=(n, ambient_dim)
        The stored seeds.
    V : array-like, shape=(n, dim)
        Their tangent vectors ``r_j W u_j``.
    delta : float
        The intended distance.

    Returns
    -------
    dict
        ``seed_distance_error`` (max relative ``|d - delta|`` of the chart distance),
        ``seed_ambient_distance_error`` (the same measured from the stored coordinates by
        :func:`distances`) and ``seed_rounding_bound`` (:func:`rounding_bound` over
        ``delta``: the ambient error cannot exceed it unless the seeds are wrong).
    """
    _, d, _ = chart_increments(model, x_e, V)
    amb = distances(model, seeds, x_e)
    return {"seed_distance_error": float(np.max(np.abs(d - delta)) / delta),
            "seed_ambient_distance_error": float(np.max(np.abs(amb - delta)) / delta),
            "seed_rounding_bound": rounding_bound(model, x_e, delta) / delta}
