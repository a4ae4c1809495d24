"""Samplers of the export catalogue's test states.

Log-uniform scales, unit vectors, rotations, points near a configuration; shared by
:mod:`workbench.app.catalogue` and :mod:`workbench.app.swingup_export`.
"""

from __future__ import annotations

import numpy as np

from workbench.core.manifolds import SO3


def _log_uniform(rng: np.random.Generator, lo: float, hi: float, n: int) -> np.ndarray:
    return np.exp(rng.uniform(np.log(lo), np.log(hi), n))


def _unit(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _near(q: np.ndarray, angles: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Unit vectors at the given angles from the unit vector ``q`` (random directions)."""
    a = np.asarray(angles, dtype=float)
    u = _tangent(np.tile(q, (a.size, 1)), np.ones(a.size), rng)
    out = np.cos(a)[:, None] * q + np.sin(a)[:, None] * np.cross(u, q)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _tangent(q: np.ndarray, scale: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Random vectors normal to each row of ``q`` with the given norms."""
    w = rng.standard_normal(q.shape)
    w -= np.sum(w * q, axis=1, keepdims=True) * q
    return w / np.linalg.norm(w, axis=1, keepdims=True) * scale[:, None]


def _split(n: int, weights: tuple[float, ...]) -> list[int]:
    counts = [int(n * w) for w in weights]
    counts[0] += n - sum(counts)
    return counts


def _rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.array([SO3.matrix(SO3().random_point(rng)) for _ in range(n)])


def _flat_rotations(R: np.ndarray) -> np.ndarray:
    return np.array([SO3.flat(r) for r in R])
