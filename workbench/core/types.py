"""Type aliases used across the workbench."""

from __future__ import annotations

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

Symbolic = ca.SX | ca.MX
"""A casadi symbolic expression."""

Expr = ca.SX | ca.MX | ca.DM | NDArray[np.float64]
"""Anything the manifold helpers accept: casadi symbolic or numeric, or a numpy array."""

Vector = NDArray[np.float64]
Matrix = NDArray[np.float64]

__all__ = ["ArrayLike", "Expr", "Matrix", "Symbolic", "Vector"]
