"""Validation of what a user hands to the mechanics layer: numbers, expressions, inertias.

Numbers are refused when they are bool, complex, non-numeric or non-finite; expressions
must be casadi ``SX`` built from the system's own symbols (or plain numbers); shapes are
checked against what the argument means. Every failure names the argument, says what was
expected and what was got. Nothing is converted silently beyond numbers -> ``SX``
constants and flat vectors -> columns.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._engine import ModelError, ParameterError

__all__ = ["as_number_array", "as_expr", "inertia", "check_inertia_value", "shape_of",
           "parameter_value", "identifier"]


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) < 120 else text[:117] + "..."


def identifier(value: Any, what: str) -> str:
    """``value`` if it is an identifier string, else ModelError naming ``what``."""
    if not isinstance(value, str) or not value.isidentifier():
        raise ModelError(f"{what} must be an identifier string; got {value!r}")
    return value


def as_number_array(value: Any, name: str) -> np.ndarray:
    """``value`` as a finite real float array, or ParameterError naming ``name``.

    Parameters
    ----------
    value : array-like
        Numbers (int or float); bool, complex, strings and non-finite entries are refused.
    name : str
        The argument's name, for the message.

    Returns
    -------
    ndarray
        Float array of the same shape.
    """
    arr = np.asarray(value)
    if arr.dtype == bool or isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{name} must be a real number or array; got a bool "
                             f"{_describe(value)}")
    if np.iscomplexobj(arr):
        raise ParameterError(
            f"{name} must be real; got a complex value {_describe(value)}"
        )
    if arr.dtype.kind not in "iuf":
        raise ParameterError(f"{name} must be numeric; got {type(value).__name__} "
                             f"{_describe(value)}")
    arr = arr.astype(float)
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"{name} must be finite; got {_describe(value)}")
    return arr


def shape_of(expr: ca.SX) -> tuple[int, int]:
    """The (rows, columns) of a casadi expression."""
    return int(expr.shape[0]), int(expr.shape[1])


def as_expr(value: Any, name: str, shape: tuple[int, int] | None = None) -> ca.SX:
    """``value`` as a casadi SX expression of the given shape, or ModelError/ParameterError.

    Parameters
    ----------
    value : casadi.SX or array-like
        A symbolic expression of the system's symbols, or numbers.
    name : str
        The argument's name, for the message.
    shape : tuple of int, optional
        Expected ``(rows, columns)``; a flat numeric vector of the right length is taken as
        a column.

    Returns
    -------
    casadi.SX
    """
    if isinstance(value, ca.MX):
        raise ModelError(
            f"{name} must be built from the System's symbols (casadi SX); got an MX expression"
        )
    if isinstance(value, (ca.SX, ca.DM)):
        expr = ca.SX(value)
    else:
        arr = as_number_array(value, name)
        if arr.ndim == 1:
            arr = arr.reshape(-1, 1)
        if arr.ndim > 2:
            raise ModelError(f"{name} must be a scalar, vector or matrix; got shape {arr.shape}")
        expr = ca.SX(ca.DM(arr))
    if shape is not None:
        got = shape_of(expr)
        if got != shape and not (shape[1] == 1 and got == (1, shape[0])):
            raise ModelError(f"{name} must have shape {shape}; got shape {got}")
        if got != shape:
            expr = expr.T
    return expr


def inertia(value: np.ndarray, *, triangle: bool = True) -> str | None:
    """Check a 3x3 inertia: symmetric, positive definite, triangle inequality.

    The principal moments must satisfy ``J1 + J2 >= J3`` for every ordering.
    Equivalently ``J`` is SPD and ``tr(J)/2 I - J`` (the second moment of the mass
    distribution) is positive semi-definite. Tolerances are relative to ``max |J|``
    (``1e-12`` for symmetry and the triangle inequality).

    Parameters
    ----------
    value : ndarray, shape=(3, 3)
        The inertia matrix.
    triangle : bool
        Check the triangle inequality too (the build checks of a model leave it out:
        its equations are right for any SPD inertia, which models with independent ``J``,
        ``m`` and ``rho`` parameters use).

    Returns
    -------
    str or None
        A message fragment when the inertia is not physical.
    """
    value = np.asarray(value, dtype=float)
    if value.shape != (3, 3):
        return f"must be a 3x3 matrix; got shape {value.shape}"
    if not np.all(np.isfinite(value)):
        return f"must be finite; got {np.array2string(value, precision=6)}"
    scale = max(float(np.max(np.abs(value))), 1e-300)
    asym = float(np.max(np.abs(value - value.T)))
    if asym > 1e-12 * scale:
        return f"must be symmetric; got max |J - J^T| = {asym:.3g}"
    eig = np.linalg.eigvalsh(0.5 * (value + value.T))
    if np.any(eig <= 0):
        return (f"must be positive definite; got principal moments "
                f"{np.array2string(eig, precision=6)}")
    j1, j2, j3 = eig
    if triangle and j1 + j2 < j3 * (1 - 1e-12):
        return (f"must satisfy the triangle inequality of a rigid body (J1 + J2 >= J3 for the "
                f"principal moments); got {j1:.6g} + {j2:.6g} < {j3:.6g}")
    return None


def check_inertia_value(value: Any, name: str) -> np.ndarray:
    """A numeric inertia validated by :func:`inertia`, or ParameterError naming ``name``."""
    arr = as_number_array(value, name)
    msg = inertia(arr)
    if msg:
        raise ParameterError(f"{name} {msg}")
    return arr


def parameter_value(name: str, value: Any, description: str, *, check: Any,
                    shape: tuple[int, ...] | None) -> np.ndarray:
    """A parameter's declared value, checked with its declaration's ``check`` and ``shape``.

    Parameters
    ----------
    name, description : str
        The parameter's name and description, for the messages.
    value : array-like
        Real, finite, at least one entry, at most two dimensions.
    check : callable or None
        ``check(value) -> message or None`` (validated as callable here; applied by
        :class:`~workbench.core.Parameter`).
    shape : tuple of int or None
        The shape ``value`` must have.

    Returns
    -------
    ndarray
    """
    if check is not None and not callable(check):
        raise ModelError(f"check of parameter {name!r} must be callable (value -> message "
                         f"or None) or None; got {check!r}")
    if shape is not None and (not isinstance(shape, tuple) or not all(
            isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n >= 1
            for n in shape)):
        raise ModelError(f"shape of parameter {name!r} must be a tuple of integers >= 1; "
                         f"got {shape!r}")
    arr = as_number_array(value, f"parameter {name!r}")
    if arr.size == 0:
        raise ParameterError(f"parameter {name!r} must have at least one entry; got "
                             f"{_describe(value)}")
    if arr.ndim > 2:
        raise ParameterError(f"parameter {name!r} must be a scalar, vector or matrix; got "
                             f"shape {arr.shape}")
    if shape is not None and arr.shape != tuple(shape):
        raise ParameterError(f"parameter {name!r} ({description or name}) must have shape "
                             f"{tuple(shape)}; got shape {arr.shape}")
    return arr
