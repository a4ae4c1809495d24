"""Measures of curves and surfaces on S^2 and SO(3), for comparisons with a paper's words.

Papers describe computed invariant manifolds qualitatively ("the trajectories are great
circles", "the boundary is a circle about the vertical", "the manifold covers the sphere
more than once"); these functions turn such statements into numbers:

* :func:`great_circle_defect` -- how far a curve is from a great circle;
* :func:`circle_defect` -- how far points are from a circle about ``e3``;
* :func:`cover_counts` -- how many times a surface swept by curves covers given points;
* :func:`angle_travelled` -- the angle travelled along curves;
* :func:`axis_shares`, :func:`body_axis_angle` -- which body axis a rotation away from a
  reference turns about, and how far a body axis has moved;
* :func:`rotation_cover_fraction` -- how much of SO(3) lies near a set of rotations.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from workbench.core.manifolds import so3_log

__all__ = ["angle_travelled", "axis_shares", "body_axis_angle", "circle_defect", "cover_counts",
           "great_circle_defect", "rotation_cover_fraction"]

E3 = np.array([0.0, 0.0, 1.0])


def great_circle_defect(q: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """Largest distance of a curve to its best plane through 0, and sin(omega, normal).

    Parameters
    ----------
    q, w : ndarray, shape=(n_t, 3)
        Points of the curve and the angular velocities.

    Returns
    -------
    (float, float)
        ``max |n . q|`` and ``max |w x n| / |w|`` (``n`` the smallest right singular
        vector of ``q``).
    """
    n = np.linalg.svd(q)[2][-1]
    wn = np.linalg.norm(w, axis=1)
    keep = wn > 0
    sin = np.linalg.norm(np.cross(w[keep], n), axis=1) / wn[keep]
    return float(np.max(np.abs(q @ n))), float(np.max(sin))


def circle_defect(P: np.ndarray) -> tuple[float, float]:
    """Largest distance of points to their best-fitting plane, and the normal's tilt from e3.

    Parameters
    ----------
    P : ndarray, shape=(m, 3)
        Points.

    Returns
    -------
    (float, float)
        ``max |n . (p - mean)|`` and ``|n x e3|``.
    """
    c = P.mean(axis=0)
    n = np.linalg.svd(P - c)[2][-1]
    return float(np.max(np.abs((P - c) @ n))), float(np.linalg.norm(np.cross(n, E3)))


def cover_counts(Q: np.ndarray, points: np.ndarray) -> np.ndarray:
    """How many triangles of the (direction, t) grid of curves contain each test point.

    Parameters
    ----------
    Q : ndarray, shape=(n_t, n_curves, 3)
        Curves on S^2, ordered by the angle of their seed direction (closing the loop).
    points : ndarray, shape=(m, 3)
        Unit test points.

    Returns
    -------
    ndarray of int, shape=(m,)
        Number of spherical triangles (two per grid cell) that contain each point.
    """
    A, B = Q[:-1], Q[1:]  # consecutive times
    A2, B2 = np.roll(A, -1, axis=1), np.roll(B, -1, axis=1)  # neighbouring curves
    tri = np.concatenate([np.stack([A, B, B2], axis=-2).reshape(-1, 3, 3),
                          np.stack([A, B2, A2], axis=-2).reshape(-1, 3, 3)])
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    nab, nbc, nca, cen = np.cross(a, b), np.cross(b, c), np.cross(c, a), a + b + c
    counts = np.zeros(len(points), dtype=int)
    for k in range(0, len(points), 64):
        p = points[k:k + 64]
        s1, s2, s3 = p @ nab.T, p @ nbc.T, p @ nca.T
        inside = (((s1 > 0) & (s2 > 0) & (s3 > 0)) | ((s1 < 0) & (s2 < 0) & (s3 < 0)))
        counts[k:k + 64] = np.sum(inside & (p @ cen.T > 0), axis=1)
    return counts


def angle_travelled(q: np.ndarray) -> np.ndarray:
    """Angle travelled along each curve on S^2 up to each sample (sum of the chord angles).

    Parameters
    ----------
    q : ndarray, shape=(n_t, n_curves, 3)
        Unit vectors along curves.

    Returns
    -------
    ndarray, shape=(n_t, n_curves)
        Zero at the first sample.
    """
    q = np.asarray(q, dtype=float)
    step = np.arccos(np.clip(np.einsum("tnk,tnk->tn", q[1:], q[:-1]), -1.0, 1.0))
    return np.vstack([np.zeros((1, q.shape[1])), np.cumsum(step, axis=0)])


def axis_shares(R: np.ndarray, R_e: np.ndarray) -> np.ndarray:
    """``eta_i^2 / |eta|^2`` of ``eta = log(R_e^T R)`` for a stack of rotations.

    Parameters
    ----------
    R : ndarray, shape=(n, 3, 3)
        Rotations.
    R_e : ndarray, shape=(3, 3)
        The reference rotation.

    Returns
    -------
    ndarray, shape=(n, 3)
        Rows summing to 1 (0 for ``R = R_e``): the share of each body axis in the rotation
        from ``R_e`` to ``R``.
    """
    eta = np.array([so3_log(R_e.T @ r) for r in R])
    n2 = np.sum(eta**2, axis=1, keepdims=True)
    return eta**2 / np.maximum(n2, 1e-300)


def body_axis_angle(R: np.ndarray, R_e: np.ndarray, i: int) -> np.ndarray:
    """Angle [deg] between body axis ``i`` (column ``i``) of each ``R`` and of ``R_e``.

    Parameters
    ----------
    R : ndarray, shape=(n, 3, 3)
        Rotations.
    R_e : ndarray, shape=(3, 3)
        The reference rotation.
    i : int
        The body axis, 0, 1 or 2.

    Returns
    -------
    ndarray, shape=(n,)
        In degrees, by ``atan2`` (accurate near 0 and 180).
    """
    a, b = R[:, :, i], R_e[:, i]
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), a @ b))


def rotation_cover_fraction(R: np.ndarray, test: np.ndarray, angle: float) -> float:
    """Fraction of the ``test`` rotations within rotation angle ``angle`` of one of ``R``.

    Distances are taken between unit quaternions (both signs), where the chord
    ``2 sin(angle / 4)`` corresponds to the rotation angle ``angle``.

    Parameters
    ----------
    R : ndarray, shape=(n, 3, 3)
        The set (e.g. the running states of a computed manifold).
    test : ndarray, shape=(m, 3, 3)
        Test rotations (e.g. Haar-uniform samples).
    angle : float
        Rotation angle [rad].

    Returns
    -------
    float
    """
    q = Rotation.from_matrix(R).as_quat()
    d, _ = cKDTree(np.vstack([q, -q])).query(Rotation.from_matrix(test).as_quat())
    return float(np.mean(d <= 2 * np.sin(angle / 4)))
