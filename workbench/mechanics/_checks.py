"""Validation of what a user hands to the mechanics layer: numbers, expressions, inertias.

Numbers are refused when they are bool, complex, non-numeric or non-finite; expressions
must be casadi ``SX`` built from the system's own symbols (or plain numbers); shapes are
checked against what the argument means. Every failure names the argument, says what was
expected and what was got. Nothing is converted silently beyond numbers -> ``SX``
constants and flat vectors -> columns.
"""

from __future__ import annotations

import functools
from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._engine import ModelError, ParameterError

__all__ = ["as_number_array", "as_expr", "inertia", "check_inertia_value", "shape_of",
           "parameter_value", "identifier", "com_inertia", "check_origin_inertia",
           "named_check", "one_line"]


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) < 120 else text[:117] + "..."


def identifier(value: Any, what: str) -> str:
    """``value`` if it is an identifier string, else ModelError naming ``what``."""
    if not isinstance(value, str) or not value.isidentifier():
        raise ModelError(f"{what} must be an identifier string; got {value!r}")
    return value


def one_line(value: Any, what: str) -> str:
    """``value`` if it is one line of text (a str without control characters), else ModelError.

    Parameters
    ----------
    value : str
        The text.
    what : str
        The argument, for the message.

    Returns
    -------
    str
    """
    if not isinstance(value, str):
        raise ModelError(f"{what} must be a str (one line of text); got {type(value).__name__} "
                         f"{_describe(value)}")
    if any(ord(c) < 32 or ord(c) == 127 for c in value):
        raise ModelError(f"{what} must be one line of text without control characters; got "
                         f"{_describe(value)}")
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


def inertia(value: np.ndarray, *, triangle: bool = True, definite: bool = True,
            scale: float | None = None) -> str | None:
    """Check a 3x3 inertia: symmetric, positive definite, triangle inequality.

    The principal moments must satisfy ``J1 + J2 >= J3`` for every ordering.
    Equivalently ``J`` is SPD and ``tr(J)/2 I - J`` (the second moment of the mass
    distribution) is positive semi-definite. Tolerances are relative to ``max |J|``
    (``1e-12`` for symmetry and the triangle inequality), or to ``scale`` when given.

    Parameters
    ----------
    value : ndarray, shape=(3, 3)
        The inertia matrix.
    triangle : bool
        Check the triangle inequality too (the build checks of a model leave it out:
        its equations are right for any SPD inertia, which models with independent ``J``,
        ``m`` and ``rho`` parameters use).
    definite : bool
        Require positive definite (default); ``False`` accepts zero principal moments
        down to ``-1e-12 scale`` (an inertia about the centre of mass: a point mass has
        none, a slender rod none about its axis).
    scale : float, optional
        The size of the numbers ``value`` was computed from, for the rounding tolerance
        (an inertia about the centre of mass found as ``J_O - m (|c|^2 I - c c^T)`` carries
        the rounding of ``J_O`` and ``m |c|^2``, not of its own small entries).

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
    own = float(np.max(np.abs(value)))
    scale = max(own if scale is None else max(float(scale), own), 1e-300)
    asym = float(np.max(np.abs(value - value.T)))
    if asym > 1e-12 * scale:
        return f"must be symmetric; got max |J - J^T| = {asym:.3g}"
    eig = np.linalg.eigvalsh(0.5 * (value + value.T))
    if definite and np.any(eig <= 0):
        return (f"must be positive definite; got principal moments "
                f"{np.array2string(eig, precision=6)}")
    if not definite and np.any(eig < -1e-12 * scale):
        return (f"must be positive semi-definite; got principal moments "
                f"{np.array2string(eig, precision=6)}")
    j1, j2, j3 = eig
    if triangle and j1 + j2 < j3 - 1e-12 * scale:
        return (f"must satisfy the triangle inequality of a rigid body (J1 + J2 >= J3 for the "
                f"principal moments); got {j1:.6g} + {j2:.6g} < {j3:.6g}")
    return None


def com_inertia(inertia_origin: np.ndarray, mass: float, com: np.ndarray) -> np.ndarray:
    """``J_com = J_O - m (|c|^2 I - c c^T)``: the parallel-axis theorem, backwards.

    Parameters
    ----------
    inertia_origin : ndarray, shape=(3, 3)
        Inertia about the reference point.
    mass : float
        The mass.
    com : ndarray, shape=(3,)
        Centre of mass relative to the reference point (same frame).

    Returns
    -------
    ndarray, shape=(3, 3)
    """
    c = np.asarray(com, dtype=float).reshape(3)
    return np.asarray(inertia_origin, dtype=float) - mass * (c @ c * np.eye(3) - np.outer(c, c))


def check_origin_inertia(inertia_origin: np.ndarray, mass: float, com: np.ndarray, *,
                         triangle: bool = True) -> str | None:
    """A message when an inertia about the origin has no physical body behind it, or None.

    The inertia about the centre of mass, ``J_com = J_O - m (|c|^2 I - c c^T)``, must be
    symmetric positive semi-definite and (with ``triangle``) satisfy the triangle inequality:
    an inertia about the origin that is positive definite as given can still be the
    parallel-axis image of no mass distribution (``m |c|^2`` larger than its moments).

    Parameters
    ----------
    inertia_origin : ndarray, shape=(3, 3)
        ``J_O``, already checked as an inertia about the origin.
    mass : float
        ``m``.
    com : ndarray, shape=(3,)
        ``c``, the centre of mass relative to the origin.
    triangle : bool
        Check the triangle inequality of ``J_com`` too.

    Returns
    -------
    str or None
    """
    J_O = np.asarray(inertia_origin, dtype=float)
    c = np.asarray(com, dtype=float).reshape(3)
    J_com = com_inertia(J_O, mass, c)
    scale = max(float(np.max(np.abs(J_O))), abs(mass) * float(c @ c))
    msg = inertia(J_com, triangle=triangle, definite=False, scale=scale)
    if msg is None:
        return None
    return (f"the inertia about the origin J_O = {_matrix(J_O)} with mass m = {mass:.6g} and "
            f"centre of mass c = {_matrix(c)} gives the inertia about the centre of mass "
            f"J_com = J_O - m (|c|^2 I - c c^T) = {_matrix(J_com)}, which {msg}: no rigid "
            f"body has these numbers (check J_O, m and c together)")


def _matrix(a: np.ndarray) -> str:
    return np.array2string(np.asarray(a), precision=6, max_line_width=100000,
                           separator=", ").replace("\n", "")


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


def named_check(name: str, check: Any) -> Any:
    """``check`` wrapped so that its failures name the parameter ``name``.

    A parameter's ``check(value) -> message or None`` is the user's code: one that raises
    (a TypeError on a matrix, an IndexError) or returns something other than a message or
    None is reported as a ParameterError naming the parameter and the check, with the
    original exception chained. The wrapper keeps the check's name and ``__wrapped__``.

    Parameters
    ----------
    name : str
        The parameter's name.
    check : callable or None
        The check (None stays None).

    Returns
    -------
    callable or None
    """
    if check is None or getattr(check, "__wrapped_parameter__", None) == name:
        return check
    label = getattr(check, "__name__", type(check).__name__)

    @functools.wraps(check)
    def checked(value: np.ndarray) -> str | None:
        try:
            msg = check(value)
        except Exception as exc:  # noqa: BLE001 - the user's code, re-raised with its name
            raise ParameterError(
                f"check {label!r} of parameter {name!r} raised {type(exc).__name__}: {exc} "
                f"(a check must return a message str, or None for a valid value)") from exc
        if msg is not None and not isinstance(msg, str):
            raise ParameterError(
                f"check {label!r} of parameter {name!r} must return a message str or None; "
                f"got {type(msg).__name__} {msg!r}")
        return msg

    checked.__wrapped_parameter__ = name  # type: ignore[attr-defined]
    return checked
