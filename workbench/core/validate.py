"""The one validation layer of the workbench: numbers, arrays, tolerances, enums, names, paths.

Every public entry point checks its arguments here, so a class of bad input is refused in
one place for every caller. Each helper returns the value in its canonical type (a float,
an int, a float ndarray, the enum member, a str, a :class:`pathlib.Path`) or raises a
workbench exception whose message names the argument, what was expected and what was got:
``"<name> must be <expected>; got <value>"``. The exception class is
:class:`~workbench.core.errors.ParameterError` unless the caller documents another one
(``error=``), so a module keeps the type it promises.

All helpers take ``(name, value)`` in this order, except :func:`choice`, whose first
argument is the enumeration.

What is refused, everywhere:

- complex numbers (never truncated to their real part, even with a zero imaginary part:
  numpy's ``ComplexWarning`` path is an error here);
- booleans and strings where a number is meant (``m=True``, ``T='1'``), ``None``, objects;
- NaN and infinities (unless ``allow_inf``), wrong shapes, empty arrays where entries are
  needed;
- tolerances and thresholds that are not finite positive numbers (a NaN tolerance would
  turn every ``residual <= tol`` check off).

Thresholds on quantities with a scale are relative: :func:`scaled_tolerance` gives
``tol * max(1, scale)``, used by the manifolds (tangency on TS^2), the equilibrium checks
and the root-finders.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from enum import Enum
from typing import Any, TypeVar

import numpy as np

from workbench.core.errors import ParameterError, WorkbenchError

__all__ = [
    "MAX_DIM",
    "choice",
    "positive",
    "nonnegative",
    "real",
    "count",
    "tolerance",
    "relative_tolerance",
    "array",
    "identifier",
    "single_line",
    "output_path",
    "scaled_tolerance",
    "is_real_array_like",
    "entries_finite",
    "entries_positive",
    "entries_nonnegative",
    "optional",
    "instance",
    "arguments",
    "bound",
    "text",
    "parameter",
]

E = TypeVar("E", bound=Enum)

MAX_DIM = 100_000
"""Largest dimension of a symbolic vector (a state factor R^n, a model's inputs): a casadi
graph over more symbols does not fit in memory in any analysis (a hostile ``n_inputs=10**9``
took 20 GB before it was refused)."""



def _show(value: Any, limit: int = 80) -> str:
    """A short readable form of ``value`` for a message (type name for long reprs)."""
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - a user object whose repr fails
        text = f"<{type(value).__name__}>"
    if len(text) > limit:
        shape = getattr(value, "shape", None)
        extra = f" of shape {tuple(shape)}" if shape is not None else ""
        text = f"{type(value).__name__}{extra} ({text[: limit - 20]}...)"
    return text


# ----------------------------------------------------------------------------------------
# enums


def choice(
    enum_type: type[E], value: Any, name: str, *, error: type[WorkbenchError] = ParameterError
) -> E:
    """The member of ``enum_type`` that ``value`` is or stands for.

    Parameters
    ----------
    enum_type : type of Enum
        The enumeration of the allowed choices.
    value : Enum or object
        A member, or the value of one (e.g. the string ``"cvodes"``).
    name : str
        The argument's name, for the message.
    error : type of WorkbenchError
        Raised for a value that is not a choice.

    Returns
    -------
    Enum
        The member.

    Raises
    ------
    WorkbenchError
        Of class ``error``: ``"<name> must be one of [...]; got <value>"``.
    """
    try:
        return enum_type(value)
    except (ValueError, TypeError) as exc:
        raise error(
            f"{name} must be one of {[m.value for m in enum_type]}; got {_show(value)}"
        ) from exc


# ----------------------------------------------------------------------------------------
# scalars


def _scalar(name: str, value: Any, expected: str, error: type[WorkbenchError]) -> float:
    """``value`` as a float if it is a real number (not bool, str, complex, None)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    bad = (
        isinstance(value, (bool, np.bool_, str, bytes, complex, np.complexfloating))
        or value is None
        or not isinstance(value, (numbers.Real, np.integer, np.floating))
    )
    if bad:
        raise error(f"{name} must be {expected}; got {_show(value)}")
    return float(value)


def real(
    name: str,
    value: Any,
    *,
    allow_inf: bool = False,
    error: type[WorkbenchError] = ParameterError,
) -> float:
    """A real, finite (unless ``allow_inf``) number, as a float.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : float
        The value to check; bool, str, complex and None are refused.
    allow_inf : bool
        Accept ``+inf`` and ``-inf`` (never NaN).
    error : type of WorkbenchError
        Raised for a value that is not such a number.

    Returns
    -------
    float

    Raises
    ------
    WorkbenchError
        Of class ``error``: ``"<name> must be a finite real number; got <value>"``.
    """
    v = _scalar(name, value, "a finite real number", error)
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise error(f"{name} must be a finite real number; got {_show(value)}")
    return v


def positive(
    name: str,
    value: Any,
    *,
    allow_inf: bool = False,
    error: type[WorkbenchError] = ParameterError,
) -> float:
    """A positive (finite unless ``allow_inf``) real number, as a float.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : float
        The value to check; bool, str, complex and None are refused.
    allow_inf : bool
        Accept ``+inf``.
    error : type of WorkbenchError
        Raised for a value that is not a positive number.

    Returns
    -------
    float

    Raises
    ------
    WorkbenchError
        Of class ``error``: ``"<name> must be a positive number; got <value>"``.
    """
    v = _scalar(name, value, "a positive number", error)
    if not v > 0:  # also nan
        raise error(f"{name} must be a positive number; got {_show(value)}")
    if math.isinf(v) and not allow_inf:
        raise error(f"{name} must be a positive finite number; got {_show(value)}")
    return v


def nonnegative(
    name: str, value: Any, *, error: type[WorkbenchError] = ParameterError
) -> float:
    """A finite real number ``>= 0``, as a float.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : float
        The value to check.
    error : type of WorkbenchError
        Raised for a value that is not such a number.

    Returns
    -------
    float

    Raises
    ------
    WorkbenchError
        Of class ``error``: ``"<name> must be a non-negative finite number; got <value>"``.
    """
    v = _scalar(name, value, "a non-negative finite number", error)
    if not (v >= 0 and math.isfinite(v)):
        raise error(f"{name} must be a non-negative finite number; got {_show(value)}")
    return v


def tolerance(
    name: str, value: Any, *, error: type[WorkbenchError] = ParameterError
) -> float:
    """A tolerance or threshold: a positive finite real number, as a float.

    A NaN tolerance would turn a check ``residual <= tol`` off (every comparison with NaN
    is false), an infinite one would accept anything: both are refused, as are
    non-numeric values.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : float
        The tolerance.
    error : type of WorkbenchError
        Raised for a value that is not a usable tolerance.

    Returns
    -------
    float

    Raises
    ------
    WorkbenchError
        Of class ``error``: ``"<name> must be a positive finite tolerance; got <value>"``.
    """
    v = _scalar(name, value, "a positive finite tolerance (a float)", error)
    if not (v > 0 and math.isfinite(v)):
        raise error(f"{name} must be a positive finite tolerance; got {_show(value)}")
    return v


def relative_tolerance(
    name: str, value: Any, *, maximum: float | None = None, why: str = "",
    error: type[WorkbenchError] = ParameterError,
) -> float:
    """A relative tolerance: a :func:`tolerance` below 1 (or at most ``maximum``).

    A relative error of 1 or more accepts any answer of the quantity's size.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : float
        The tolerance.
    maximum : float, optional
        The largest accepted value (inclusive; below 1); None accepts ``(0, 1)``.
    why : str
        Why the bound, appended to the message.
    error : type of WorkbenchError
        Raised for a value that is not such a tolerance.

    Returns
    -------
    float
    """
    v = tolerance(name, value, error=error)
    if not (v <= maximum if maximum is not None else v < 1):
        where = f"(0, {maximum:g}]" if maximum is not None else "(0, 1)"
        raise error(f"{name} must be a relative tolerance in {where}; got {_show(value)}"
                    + (f": {why}" if why else ""))
    return v


def scaled_tolerance(tol: float, scale: float) -> float:
    """The threshold ``tol * max(1, scale)`` for a residual of a quantity of size ``scale``.

    Parameters
    ----------
    tol : float
        Relative tolerance (already validated).
    scale : float
        Size of the quantity the residual is computed from (e.g. ``|omega|``); a
        non-finite scale is treated as 1 (the value it comes from is refused elsewhere).

    Returns
    -------
    float
        The absolute threshold.
    """
    s = float(scale) if math.isfinite(scale) else 1.0
    return tol * max(1.0, abs(s))


def count(
    name: str,
    value: Any,
    *,
    minimum: int = 1,
    maximum: int | None = None,
    error: type[WorkbenchError] = ParameterError,
) -> int:
    """An integer of at least ``minimum`` (booleans and floats refused), as an int.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : int
        The value to check.
    minimum : int
        The smallest accepted value.
    maximum : int, optional
        The largest accepted value.
    error : type of WorkbenchError
        Raised for a value that is not such an integer.

    Returns
    -------
    int

    Raises
    ------
    WorkbenchError
        Of class ``error``: ``"<name> must be an integer >= <minimum>; got <value>"``.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise error(f"{name} must be an integer >= {minimum}; got {_show(value)}")
    if value < minimum or (maximum is not None and value > maximum):
        upper = f" and <= {maximum}" if maximum is not None else ""
        raise error(f"{name} must be an integer >= {minimum}{upper}; got {_show(value)}")
    return int(value)


# ----------------------------------------------------------------------------------------
# arrays


def is_real_array_like(value: Any) -> bool:
    """Whether ``value`` converts to a real numeric array without losing anything.

    Parameters
    ----------
    value : object
        Anything.

    Returns
    -------
    bool
        False for complex, boolean, string, object and None entries.
    """
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        return False
    return arr.dtype.kind in "iuf"


def array(
    name: str,
    value: Any,
    *,
    shape: Sequence[int] | None = None,
    size: int | None = None,
    ndim: int | None = None,
    finite: bool = True,
    allow_empty: bool = True,
    error: type[WorkbenchError] = ParameterError,
) -> np.ndarray:
    """``value`` as a real float array, checked for dtype, shape and finiteness.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : array-like
        Numbers; complex, boolean, string, object or None entries are refused (a complex
        array is never truncated to its real part).
    shape : sequence of int, optional
        Required shape; ``-1`` matches any length on that axis.
    size : int, optional
        Required number of entries (any shape).
    ndim : int, optional
        Required number of dimensions.
    finite : bool
        Refuse NaN and infinite entries.
    allow_empty : bool
        Accept an array with no entries.
    error : type of WorkbenchError
        Raised for a value that is not such an array.

    Returns
    -------
    ndarray of float
        A new array (the caller's data is never modified).

    Raises
    ------
    WorkbenchError
        Of class ``error``, naming ``name``, what was expected and what was got.
    """
    def expected() -> str:  # for the messages only (this check runs in hot loops)
        if shape is not None:
            dims = tuple("n" if w == -1 else int(w) for w in shape)
            return f"a real numeric array of shape {dims}"
        return "a real numeric array" + (f" of {size} entries" if size is not None else "")

    if value is None or isinstance(value, (str, bytes)):
        raise error(f"{name} must be {expected()}; got {type(value).__name__} {_show(value)}")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nested lists
        raise error(f"{name} must be {expected()}; got {_show(value)}") from exc
    kind = raw.dtype.kind
    if kind == "c":
        raise error(f"{name} must be real; got a complex array {_show(value)} (complex "
                    f"numbers are refused, never truncated to their real part)")
    if kind == "b":
        raise error(f"{name} must be {expected()}; got booleans {_show(value)}")
    if kind not in "iuf":
        raise error(f"{name} must be {expected()}; got {raw.dtype} entries {_show(value)}")
    arr = np.array(raw, dtype=float)
    if shape is not None:
        want = tuple(int(s) for s in shape)
        if len(want) != arr.ndim or any(w not in (-1, g) for w, g in zip(want, arr.shape)):
            shown = tuple("n" if w == -1 else w for w in want)
            raise error(f"{name} must have shape {shown}; got shape {arr.shape}")
    if size is not None and arr.size != size:
        raise error(f"{name} must have {size} entries; got shape {arr.shape}")
    if ndim is not None and arr.ndim != ndim:
        raise error(f"{name} must be {ndim}-dimensional; got shape {arr.shape}")
    if not allow_empty and arr.size == 0:
        raise error(f"{name} must not be empty; got shape {arr.shape}")
    if finite and not np.isfinite(arr).all():
        bad = arr[~np.isfinite(arr)]
        raise error(f"{name} must be finite; got {bad.size} non-finite entries "
                    f"(e.g. {bad.ravel()[0]}) in {_show(arr.tolist())}")
    return arr


# message-fragment checks, for Parameter(check=...) and the models' parameter tables


def entries_finite(value: np.ndarray) -> str | None:
    """``None`` if every entry of the real array is finite, else a message fragment."""
    if not np.all(np.isfinite(value)):
        return f"must be finite; got {np.array2string(np.asarray(value), precision=6)}"
    return None


def entries_positive(value: np.ndarray) -> str | None:
    """``None`` if every entry is finite and ``> 0``, else a message fragment."""
    msg = entries_finite(value)
    if msg:
        return msg
    if np.any(np.asarray(value) <= 0):
        return f"must be positive; got {np.array2string(np.asarray(value), precision=6)}"
    return None


def entries_nonnegative(value: np.ndarray) -> str | None:
    """``None`` if every entry is finite and ``>= 0``, else a message fragment."""
    msg = entries_finite(value)
    if msg:
        return msg
    if np.any(np.asarray(value) < 0):
        return f"must be non-negative; got {np.array2string(np.asarray(value), precision=6)}"
    return None


# ----------------------------------------------------------------------------------------
# names and text


# ----------------------------------------------------------------------------------------
# the boundary of a public function (implemented in _arguments, part of this layer), and
# names, one-line texts and output paths (implemented in _validate_text)

from workbench.core._arguments import (  # noqa: E402
    arguments,
    bound,
    instance,
    optional,
    parameter,
    text,
)
from workbench.core._validate_text import identifier, output_path, single_line  # noqa: E402
