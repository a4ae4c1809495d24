"""Validation of options shared by the engine: enum choices, positive numbers, counts.

Each helper returns the value in its canonical type (the enum member, a float, an int) or
raises a workbench exception whose message names the argument, what was expected and what
was got. The exception class is :class:`~workbench.core.errors.ParameterError` unless the
caller documents another one (``error=``), so a module keeps the type it promises.
"""

from __future__ import annotations

import math
from enum import Enum
from typing import Any, TypeVar

import numpy as np

from workbench.core.errors import ParameterError, WorkbenchError

__all__ = ["choice", "positive", "count"]

E = TypeVar("E", bound=Enum)


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
            f"{name} must be one of {[m.value for m in enum_type]}; got {value!r}"
        ) from exc


def positive(
    name: str,
    value: Any,
    *,
    allow_inf: bool = False,
    error: type[WorkbenchError] = ParameterError,
) -> float:
    """A positive (finite unless ``allow_inf``) number, as a float.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : float
        The value to check.
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
        Of class ``error``.
    """
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise error(f"{name} must be a positive number; got {value!r}") from exc
    if not v > 0:  # also nan
        raise error(f"{name} must be a positive number; got {value!r}")
    if math.isinf(v) and not allow_inf:
        raise error(f"{name} must be a positive finite number; got {value!r}")
    return v


def count(
    name: str,
    value: Any,
    *,
    minimum: int = 1,
    error: type[WorkbenchError] = ParameterError,
) -> int:
    """An integer of at least ``minimum`` (booleans refused), as an int.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : int
        The value to check.
    minimum : int
        The smallest accepted value.
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
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise error(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)
