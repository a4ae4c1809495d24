"""Names, one-line texts and output paths: part of :mod:`workbench.core.validate`.

Re-exported there (``validate.identifier``, ``validate.single_line``,
``validate.output_path``); see that module for the conventions every helper follows.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

from workbench.core._arguments import text
from workbench.core.errors import ParameterError, WorkbenchError
from workbench.core.validate import _show

__all__ = ["identifier", "single_line", "output_path"]

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def identifier(
    name: str, value: Any, *, error: type[WorkbenchError] = ParameterError
) -> str:
    """An ASCII identifier (``[A-Za-z_][A-Za-z0-9_]*``): usable by casadi, C and Python.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : str
        The identifier.
    error : type of WorkbenchError
        Raised for anything else.

    Returns
    -------
    str

    Raises
    ------
    WorkbenchError
        Of class ``error``: ``"<name> must be an identifier ...; got <value>"``.
    """
    if not isinstance(value, str) or not _IDENTIFIER.match(value):
        raise error(
            f"{name} must be an identifier (ASCII letters, digits and '_', not starting "
            f"with a digit); got {_show(value)}"
        )
    return value


def single_line(
    name: str, value: Any, *, error: type[WorkbenchError] = ParameterError
) -> str:
    """A str without line breaks or control characters (for generated file headers).

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

    Raises
    ------
    WorkbenchError
        Of class ``error``.
    """
    text(name, value, error=error)
    bad = [c for c in value if ord(c) < 32 or ord(c) == 127]
    if bad:
        raise error(f"{name} must be one line of text without control characters; got "
                    f"{_show(value)}")
    return value


def output_path(
    name: str, value: Any, *, error: type[WorkbenchError] = ParameterError
) -> Path:
    """A non-empty output path (str or os.PathLike) as a :class:`pathlib.Path`.

    Parameters
    ----------
    name : str
        The argument's name, for the message.
    value : str or os.PathLike
        The path; ``""`` (which would be the current directory) is refused.
    error : type of WorkbenchError
        Raised for anything else.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    WorkbenchError
        Of class ``error``: ``"<name> must be a non-empty path; got <value>"``.
    """
    if not isinstance(value, (str, os.PathLike)):
        raise error(f"{name} must be a non-empty path (str or os.PathLike); got "
                    f"{type(value).__name__} {_show(value)}")
    text = os.fspath(value)
    if isinstance(text, bytes) or not text.strip() or "\x00" in text:
        raise error(f"{name} must be a non-empty path; got {_show(value)}")
    return Path(text)
