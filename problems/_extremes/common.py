"""What every group of the extremes study shares: the body, closed forms, conventions.

The elliptic cylinder of paper 000 Section 4.3 (m = 1, g = 9.81) is the body of most
cases; the closed forms are paper 000's (models.pendulum3d_reference).
"""

from __future__ import annotations

import numpy as np

from models.pendulum3d_reference import frequencies, prop9, rotation_taking

__all__ = ["E3", "J_CYL", "MG", "RHO_CYL", "RHO_HAT", "frequencies", "prop9",
           "rotation_taking", "spectrum_error"]

MG = 9.81
E3 = np.array([0.0, 0.0, 1.0])
J_CYL = np.diag([0.4486, 0.3943, 0.0772])
RHO_CYL = np.array([-0.0140, 0.1044, 0.4989])
"""The elliptic cylinder of paper 000 Section 4.3 (m = 1, g = 9.81)."""
RHO_HAT = RHO_CYL / np.linalg.norm(RHO_CYL)


def spectrum_error(ev: np.ndarray, w: np.ndarray, *, inverted: bool) -> float:
    """Largest relative deviation of the four largest eigenvalues from +-i w (+-w inverted)."""
    ev = ev[np.argsort(-np.abs(ev))]
    big = ev[:4]
    ref = np.sort(np.r_[w, w])[::-1]
    mag = np.max(np.abs(np.abs(big) - ref) / ref)
    axis = np.max((np.abs(big.imag) if inverted else np.abs(big.real)) / ref)
    return float(max(mag, axis))


