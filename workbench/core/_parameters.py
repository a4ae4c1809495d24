"""Model parameters: a named, shaped, validated value, and the usual checks.

A :class:`Parameter` is an input of every function of a model (``f(x, u, p)``); its
``check`` runs on every value given to it (when the model is made and on every
:meth:`~workbench.core._model.Model.with_parameters`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from workbench.core import validate
from workbench.core.errors import ParameterError

__all__ = ["Parameter", "finite", "positive", "nonnegative", "spd3"]


def finite(value: np.ndarray) -> str | None:
    """Check that every entry is finite; return a message fragment on failure.

    A thin use of :func:`workbench.core.validate.entries_finite`.
    """
    return validate.entries_finite(value)


def positive(value: np.ndarray) -> str | None:
    """Check that every entry is finite and strictly positive (a message fragment or None).

    A thin use of :func:`workbench.core.validate.entries_positive`; a parameter *check*
    (``Parameter(check=positive)``), not the scalar validator ``validate.positive``.
    """
    return validate.entries_positive(value)


def nonnegative(value: np.ndarray) -> str | None:
    """Check that every entry is finite and non-negative (a message fragment or None).

    A thin use of :func:`workbench.core.validate.entries_nonnegative`.
    """
    return validate.entries_nonnegative(value)


def spd3(value: np.ndarray) -> str | None:
    """Check a 3x3 matrix is symmetric positive definite (symmetry to 1e-12 relative)."""
    msg = finite(value)
    if msg:
        return msg
    scale = max(float(np.max(np.abs(value))), 1e-300)
    asym = float(np.max(np.abs(value - value.T)))
    if asym > 1e-12 * scale:
        return (
            f"must be symmetric positive definite; got a non-symmetric matrix "
            f"(max |J - J^T| = {asym:.3g})"
        )
    eig = np.linalg.eigvalsh(0.5 * (value + value.T))
    if np.any(eig <= 0):
        return (
            f"must be symmetric positive definite; got eigenvalues "
            f"{np.array2string(eig, precision=6)}"
        )
    return None


@dataclass(frozen=True)
class Parameter:
    """A named model parameter.

    Parameters
    ----------
    name : str
        Identifier, e.g. ``"J"``.
    shape : tuple of int
        ``()`` for a scalar, ``(3,)`` for a vector, ``(3, 3)`` for a matrix.
    description : str
        What it is, with its unit.
    check : callable, optional
        ``check(value) -> message or None``; a message makes the value invalid.
    """

    name: str
    shape: tuple[int, ...]
    description: str
    check: Callable[[np.ndarray], str | None] | None = finite

    def __post_init__(self) -> None:
        validate.identifier("Parameter name", self.name, error=ParameterError)
        shape = self.shape
        if not isinstance(shape, tuple) or not all(
                isinstance(s, (int, np.integer)) and not isinstance(s, bool) and s >= 0
                for s in shape):
            raise ParameterError(f"shape of parameter {self.name!r} must be a tuple of "
                                 f"non-negative ints; got {shape!r}")
        if not isinstance(self.description, str):
            raise ParameterError(f"description of parameter {self.name!r} must be a str; got "
                                 f"{type(self.description).__name__}")

    @property
    def size(self) -> int:
        """Number of scalars."""
        return int(np.prod(self.shape)) if self.shape else 1

    def validate(self, value: Any) -> np.ndarray:
        """Return ``value`` as a real float array of this shape, or raise ParameterError.

        Complex, boolean, string and None values are refused (never truncated or coerced);
        then the parameter's own ``check`` runs.
        """
        label = f"parameter {self.name!r} ({self.description})"
        arr = validate.array(label, value, shape=self.shape)
        if self.check is not None:
            msg = self.check(arr)
            if msg:
                raise ParameterError(f"{label} {msg}")
        return arr
