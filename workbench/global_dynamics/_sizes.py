"""Size guards of the invariant-manifold computation: refuse past stated limits.

Nothing is truncated: a request past a limit is refused with the knobs to change.
"""

from __future__ import annotations

from workbench.core.errors import ParameterError

__all__ = ["MAX_STORED", "MAX_STEPS", "check_size"]

MAX_STORED = 10**9
"""Largest number of stored numbers (points x output times x state size) of one manifold."""

MAX_STEPS = 10**10
"""Largest number of point-steps (points x steps) of one manifold."""


def check_size(n_points: int, horizon: float, step: float, dt_out: float, nx: int) -> None:
    """Refuse requests past the stated limits, naming the knobs (nothing is truncated)."""
    stored = n_points * (horizon / dt_out + 1) * nx
    if stored > MAX_STORED:
        raise ParameterError(
            f"n_points = {n_points}, horizon / output_step = {horizon / dt_out:.3g} and "
            f"{nx} state entries would store {stored:.3g} numbers ({stored * 8 / 1e9:.3g} GB) "
            f"> MAX_STORED = {MAX_STORED:.0e}; use fewer n_points, a shorter horizon or a "
            f"larger output_step")
    steps = n_points * horizon / step
    if steps > MAX_STEPS:
        raise ParameterError(
            f"n_points = {n_points}, horizon = {horizon:.3g} and step = {step:.3g} need "
            f"{steps:.3g} point-steps > MAX_STEPS = {MAX_STEPS:.0e}; use a larger step, "
            f"fewer n_points or a shorter horizon")
