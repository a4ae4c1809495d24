"""Collocation coefficients: the points, derivative matrix, end weights and quadrature.

Used by :class:`workbench.control.ocp.transcription.Transcription` (and re-exported there).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

if TYPE_CHECKING:
    from workbench.control.ocp.transcription import Scheme

__all__ = ["collocation_coefficients"]


def collocation_coefficients(degree: int, scheme: Scheme) -> tuple[np.ndarray, ...]:
    """Points ``tau`` (with 0), derivative matrix ``C``, end weights ``D``, quadrature ``B``.

    ``C[r, j]`` is the derivative at ``tau_j`` of the Lagrange polynomial of ``tau_r``;
    ``D[r]`` its value at 1; ``B[j]`` its integral over ``[0, 1]``.
    """
    tau = np.append(0.0, ca.collocation_points(degree, scheme.value))
    d = degree
    C = np.zeros((d + 1, d + 1))
    D = np.zeros(d + 1)
    B = np.zeros(d + 1)
    for r in range(d + 1):
        coeff = np.poly1d([1.0])
        for s in range(d + 1):
            if s != r:
                coeff *= np.poly1d([1.0, -tau[s]]) / (tau[r] - tau[s])
        D[r] = coeff(1.0)
        dp = np.polyder(coeff)
        for j in range(d + 1):
            C[r, j] = dp(tau[j])
        B[r] = np.polyint(coeff)(1.0)
    return tau, C, D, B
