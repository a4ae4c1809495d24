"""Closed forms of paper 003 for the chain pendulum on a cart: independent references.

:func:`paper_matrices` types the second-order linearisation (16) at the vertical
equilibria from the paper (with the errata of the papers' README); the problems and tests
compare the graph's second-order form with it. Section 5's LQR weights, printed initial
states (Figs. 3, 4) and error measures are here too. Nothing here is derived from a model.
"""

from __future__ import annotations

import numpy as np

from models.chain_cart import link_state
from workbench.core.types import ArrayLike

__all__ = ["attitude_errors", "equilibrium", "lqr_weights", "paper_matrices",
           "printed_initial_states"]

E3 = np.array([0.0, 0.0, 1.0])
DEG = np.pi / 180


def paper_matrices(n: int, s: tuple[float, ...], *, m: float, masses: ArrayLike,
                   lengths: ArrayLike, g: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, G, B of paper 003 (16) (with the errata of docs/science.md), typed from the paper.

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


def lqr_weights(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Section 5: ``Q = diag[8 I2, I_2n, 8 I2, I_2n]``, ``R = I2`` (paper order).

    Parameters
    ----------
    n : int
        Number of links.

    Returns
    -------
    Q : ndarray, shape=(4n + 4, 4n + 4)
    R : ndarray, shape=(2, 2)
    """
    q = np.r_[8.0, 8.0, np.ones(2 * n), 8.0, 8.0, np.ones(2 * n)]
    return np.diag(q), np.eye(2)


def printed_initial_states() -> dict[str, np.ndarray]:
    """The printed initial states of Figs. 3 and 4 (stored ambient coordinates).

    Fig. 3, (27): x = (0.2, 0.1), x-dot = (0, -0.1), q_i = (-1)^i e3 for i <= 4,
    q5 = (sin 1 deg, 0, -cos 1 deg), omega_i = 0. Fig. 4: the same x, x-dot, omega and
    q1 = -(sin 6, 0, cos 6), q2 = q3 = -(0, sin 4, cos 4) (printed with a spurious fourth
    entry), q4 = (sin 5 cos 4, -sin 5 sin 4, cos 5), q5 = (-sin 35, 0, cos 35) (degrees).

    Returns
    -------
    dict
        ``fig3`` and ``fig4``: stored states of the five-link chain, shape=(34,).
    """
    cart = [np.array([0.2, 0.1]), np.array([0.0, -0.1])]
    q3 = [(-1.0) ** i * E3 for i in range(1, 5)] + [np.array([np.sin(DEG), 0, -np.cos(DEG)])]
    s, c = np.sin, np.cos
    q4 = [-np.array([s(6 * DEG), 0.0, c(6 * DEG)]),
          -np.array([0.0, s(4 * DEG), c(4 * DEG)]),
          -np.array([0.0, s(4 * DEG), c(4 * DEG)]),
          np.array([s(5 * DEG) * c(4 * DEG), -s(5 * DEG) * s(4 * DEG), c(5 * DEG)]),
          np.array([-s(35 * DEG), 0.0, c(35 * DEG)])]
    return {"fig3": np.concatenate(cart + [link_state(q) for q in q3]),
            "fig4": np.concatenate(cart + [link_state(q) for q in q4])}


def attitude_errors(x: np.ndarray, s: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Section 5: ``e_q = sum_i |q_i - s_i e3|``, ``e_omega = sum_i |omega_i|`` (erratum s_i e3).

    Parameters
    ----------
    x : ndarray, shape=(k, 4 + 6n) or (4 + 6n,)
        Stored states along a trajectory.
    s : tuple of float
        The signs of the target equilibrium.

    Returns
    -------
    e_q, e_omega : ndarray, shape=(k,)
    """
    X = np.atleast_2d(x)
    eq = sum(np.linalg.norm(X[:, 4 + 6 * i:7 + 6 * i] - s[i] * E3, axis=1)
             for i in range(len(s)))
    ew = sum(np.linalg.norm(X[:, 7 + 6 * i:10 + 6 * i], axis=1) for i in range(len(s)))
    return eq, ew
