"""The sphere B_delta in an eigenspace: evenly spread directions, the distance (12), seeds.

The global stable manifold of paper 002 Section II-D is grown from a small sphere
``B_delta`` of the local stable eigenspace, whose points are at distance exactly ``delta``
from the equilibrium in the distance (12),
``d((q1, w1), (q2, w2)) = sqrt(Psi(q1, q2)) + |w1 - w2|`` with ``Psi = 1 - q1 . q2``, and
its TSO(3) analogue. This module provides the three pieces:

* :func:`sphere_directions` -- ``n`` unit vectors spread evenly over ``S^{k-1}``
  (``k = 1 .. 5`` here; any ``k``), and :func:`direction_spread` to measure how evenly;
* :func:`equilibrium_distance` -- the distance (12), generalised factor by factor;
* :func:`ball_points` -- the seeds ``retract(x_e, r_j W u_j)`` with ``d = delta`` exactly.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Evaluator, Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import S1, S2, SO3, TS2, Rn
from workbench.core.types import ArrayLike

__all__ = [
    "sphere_directions",
    "direction_spread",
    "equilibrium_distance",
    "distances",
    "ball_points",
    "batch_evaluate",
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


def ball_points(
    model: Model, x_e: ArrayLike, W: ArrayLike, directions: ArrayLike, *, delta: float,
    tol: float = 1e-12, max_iter: int = 50,
) -> tuple[np.ndarray, np.ndarray]:
    """States on ``B_delta``: ``retract(x_e, r_j W u_j)`` at distance (12) exactly ``delta``.

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
        Largest accepted ``|d - delta| / delta``.
    max_iter : int
        Iterations of ``r <- r delta / d(r)`` (``d`` is linear in ``r`` to first order).

    Returns
    -------
    points : ndarray, shape=(n, ambient_dim)
    radii : ndarray, shape=(n,)
        ``r_j``, the tangent-coordinate length of ``r_j W u_j`` divided by ``|W u_j|``.

    Raises
    ------
    SolverError
        If the radii do not reach the tolerance (``delta`` too large for the retraction).
    """
    delta = positive_float(delta, "delta")
    man = model.manifold
    xe = np.asarray(x_e, dtype=float).ravel()
    V = np.asarray(directions, dtype=float) @ np.asarray(W, dtype=float).T  # (n, dim)
    r = np.full(V.shape[0], delta)
    for _ in range(max_iter):
        P = np.array([man.retract(xe, ri * v) for ri, v in zip(r, V)])
        d = distances(model, P, xe)
        err = np.abs(d - delta) / delta
        if np.all(err <= tol):
            return P, r
        r = r * delta / d
    raise SolverError(
        f"could not place points at distance delta = {delta:.3g} from the equilibrium: "
        f"relative error {float(err.max()):.3g} > {tol:.1g} after {max_iter} iterations "
        f"(delta is too large for the retraction); use a smaller delta", status="no_radius")
