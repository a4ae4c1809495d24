"""Symbolic linear solves for the SX graphs."""

from __future__ import annotations

import casadi as ca

__all__ = ["solve_spd"]


def solve_spd(A: ca.SX, b: ca.SX) -> ca.SX:
    """``A^{-1} b`` for a symmetric positive definite ``A``, written symbolically as L D L^T.

    The factorisation (``casadi.ldl`` in a fill-reducing order, without pivoting: a positive
    definite matrix needs none) takes fewer operations than the QR that ``casadi.solve``
    writes for SX, and no square roots. On the double spherical pendulum on a cart (an 8x8
    mass matrix) the accelerations are 729 instead of 1638 instructions and the Hessian of
    ``lambda . nu-dot`` 18k instead of 65k: what an OCP's exact Hessian evaluates at every
    collocation point (``benchmarks/bench_spd_solve.py``).

    Parameters
    ----------
    A : casadi.SX, shape=(n, n)
        Symmetric positive definite: the caller's guarantee (a mass matrix). Only its
        upper triangle is read (``casadi.ldl``), so a non-symmetric ``A`` would be solved
        as its symmetric completion; an indefinite one may break the factorisation down
        (zero or tiny pivots) where QR would not. Nothing here can check either on a
        symbolic matrix.
    b : casadi.SX, shape=(n, k)
        Right-hand sides.

    Returns
    -------
    casadi.SX, shape=(n, k)
    """
    D, LT, p = ca.ldl(A)
    return ca.ldl_solve(b, D, LT, p)
