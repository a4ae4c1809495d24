"""The argument checks at the boundary of a public function (part of :mod:`validate`).

Re-exported by :mod:`workbench.core.validate`, which is the one validation layer; kept in
its own file only for size.
"""

from __future__ import annotations

import functools
import inspect
from typing import Any

import numpy as np

from workbench.core.errors import ParameterError, WorkbenchError
from workbench.core.validate import _show

__all__ = ["optional", "instance", "arguments", "bound", "text", "parameter"]


def optional(check: Any) -> Any:
    """A check that lets ``None`` through (for arguments documented as optional).

    Parameters
    ----------
    check : callable
        ``check(name, value, error=...)``.

    Returns
    -------
    callable
    """

    def checked(name: str, value: Any, *, error: type[WorkbenchError] = ParameterError) -> Any:
        return None if value is None else check(name, value, error=error)

    return checked


def instance(cls: type | tuple[type, ...], what: str,
             error: type[WorkbenchError] | None = None) -> Any:
    """A check that ``value`` is an instance of ``cls`` (described as ``what``).

    Parameters
    ----------
    cls : type or tuple of type
        The accepted classes.
    what : str
        How the message names the expected kind (e.g. ``"a workbench Model"``).
    error : type of WorkbenchError, optional
        The class raised, instead of the decorator's (e.g. ModelError for a model).

    Returns
    -------
    callable
    """
    own = error

    def checked(name: str, value: Any, *, error: type[WorkbenchError] = ParameterError) -> Any:
        if not isinstance(value, cls):
            raise (own or error)(f"{name} must be {what}; got {type(value).__name__} "
                                 f"{_show(value)}")
        return value

    return checked


def arguments(*, error: type[WorkbenchError] = ParameterError, **checks: Any) -> Any:
    """Decorate a public function so that the named arguments pass these checks first.

    The arguments are checked by name at the function's boundary, whether passed
    positionally, by keyword or left at their defaults, so every caller gets the same
    refusal and the message names the argument::

        @validate.arguments(error=ModelError, tol=validate.tolerance,
                            model=validate.instance(Model, "a workbench Model"))
        def linearize(model, x_e, *, tol=1e-8): ...

    Parameters
    ----------
    error : type of WorkbenchError
        The class the function documents for bad input.
    **checks : callable
        ``check(name, value, error=...)`` by argument name (e.g. :func:`tolerance`,
        :func:`positive`, :func:`count`, ``optional(tolerance)``, ``instance(...)``); the
        checked value (e.g. the float) replaces the argument.

    Returns
    -------
    callable
        The decorator; the decorated function keeps its signature and docstring.
    """
    def decorate(fn: Any) -> Any:
        sig = inspect.signature(fn)
        unknown = set(checks) - set(sig.parameters)
        if unknown:
            raise TypeError(f"{fn.__qualname__} has no arguments {sorted(unknown)}")

        @functools.wraps(fn)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            try:
                bound = sig.bind(*args, **kwargs)
            except TypeError:
                return fn(*args, **kwargs)  # Python's own message for a wrong call
            bound.apply_defaults()
            for name, check in checks.items():
                bound.arguments[name] = check(name, bound.arguments[name], error=error)
            return fn(*bound.args, **bound.kwargs)

        return wrapper

    return decorate


def bound(name: str, value: Any, *, error: type[WorkbenchError] = ParameterError) -> Any:
    """A real bound or array of bounds: ``+-inf`` allowed, NaN, complex, bool, str refused.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : float or array-like
        The bound(s).
    error : type of WorkbenchError
        Raised for anything else.

    Returns
    -------
    float or ndarray
        A float for a scalar, else a float array.
    """
    from workbench.core.validate import array

    arr = array(name, value, finite=False, error=error)
    if np.isnan(arr).any():
        raise error(f"{name} must be real bounds (+-inf allowed, never NaN); got {_show(value)}")
    return float(arr) if arr.ndim == 0 else arr


def text(name: str, value: Any, *, error: type[WorkbenchError] = ParameterError) -> str:
    """Free text: a str (escaped wherever it is written), nothing else.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : str
        The text.
    error : type of WorkbenchError
        Raised for anything else.

    Returns
    -------
    str
    """
    if not isinstance(value, str):
        raise error(f"{name} must be a str; got {type(value).__name__} {_show(value)}")
    return value


def parameter(check: Any, **options: Any) -> Any:
    """A check of a model builder's argument, named ``parameter '<name>'`` in messages.

    The value passes through unchanged (the builder's :class:`Parameter` converts it); the
    check only refuses what no parameter may be (complex, bool, str, None, NaN...).

    Parameters
    ----------
    check : callable
        ``check(name, value, error=..., **options)``, e.g. :func:`validate.array`.
    **options
        Passed to ``check`` (e.g. ``shape=()``).

    Returns
    -------
    callable
    """

    def checked(name: str, value: Any, *, error: type[WorkbenchError] = ParameterError) -> Any:
        check(f"parameter {name!r}", value, error=error, **options)
        return value

    return checked
