"""Closed forms of paper 003 for the chain pendulum on a cart: independent references.

:func:`paper_matrices` types the second-order linearisation (16) at the vertical
equilibria from the paper (with the errata of the papers' README); the problems and tests
compare the graph's second-order form with it. Nothing here is derived from a model.
"""

from __future__ import annotations

import numpy as np

from models.chain_cart import link_state
from workbench.core.types import ArrayLike

__all__ = ["equilibrium", "paper_matrices"]

E3 = np.array([0.0, 0.0, 1.0])


def paper_matrices(n: int, s: tuple[float, ...], *, m: float, masses: ArrayLike,
                   lengths: ArrayLike, g: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, G, B of paper 003 (16) (with the errata of papers/README.md), typed from the paper.

    ``M_xq = [-s_i M_0i hat(e3) C]``, ``M_qq = [s_i s_j M_ij I2]`` (``M_ii I2`` on the
    diagonal), ``G_qq = diag(s_i sum_{a >= i} m_a g l_i I2)``, ``B = [I2; 0]``. The
    independent reference for the graph's second-order form (here and in
    tests/test_controllability.py); never used by the engine.

    Parameters
    ----------
    n : int
        Number of links.
    s : tuple of float
        The signs ``s_i`` of the equilibrium ``q_i = s_i e3``.
    m : float
        Cart mass.
    masses, lengths : float or array-like, shape=(n,)
        Link masses and lengths (a scalar for equal links).
    g : float
        Gravitational acceleration.

    Returns
    -------
    M, G : ndarray, shape=(2n + 2, 2n + 2)
    B : ndarray, shape=(2n + 2, 2)
    """
    mi = np.broadcast_to(np.asarray(masses, dtype=float), (n,))
    li = np.broadcast_to(np.asarray(lengths, dtype=float), (n,))
    tail = [mi[i:].sum() for i in range(n)]
    e3C = np.array([[0.0, -1.0], [1.0, 0.0]])  # C^T hat(e3) C
    k = 2 * n + 2
    M, G, B = np.zeros((k, k)), np.zeros((k, k)), np.zeros((k, 2))
    M[:2, :2] = (m + mi.sum()) * np.eye(2)
    B[:2] = np.eye(2)
    for i in range(n):
        bi = slice(2 + 2 * i, 4 + 2 * i)
        M[:2, bi] = -s[i] * tail[i] * li[i] * e3C  # M_xq = -s_i M_0i hat(e3) C
        M[bi, :2] = M[:2, bi].T
        for j in range(n):
            sij = 1.0 if i == j else s[i] * s[j]
            M[bi, 2 + 2 * j:4 + 2 * j] = sij * tail[max(i, j)] * li[i] * li[j] * np.eye(2)
        G[bi, bi] = s[i] * tail[i] * g * li[i] * np.eye(2)  # erratum: last block s_n m_n g l_n
    return M, G, B


def equilibrium(n: int, s: tuple[float, ...]) -> np.ndarray:
    """The stored state of the equilibrium ``x = 0``, ``q_i = s_i e3``, at rest.

    Parameters
    ----------
    n : int
        Number of links.
    s : tuple of float
        The signs ``s_i``.

    Returns
    -------
    ndarray, shape=(4 + 6 n,)
    """
    return np.concatenate([np.zeros(4)] + [link_state(si * E3) for si in s])
