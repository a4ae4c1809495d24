"""The problem registry: names, modules and titles of the define-and-solve scripts.

Each module ``problems/NAME.py`` (names not starting with ``_``) defines ``TITLE`` (one
line) and ``solve(*, quick=False) -> workbench.study.Result``. Modules are imported only
when their problem is asked for, so running one problem builds nothing for the others.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

import problems
from workbench.core.errors import ModelError

__all__ = ["names", "load", "title"]


def names() -> list[str]:
    """Names of all problems, sorted.

    Returns
    -------
    list of str
    """
    return sorted(
        m.name for m in pkgutil.iter_modules(problems.__path__) if not m.name.startswith("_")
    )


def load(name: str) -> ModuleType:
    """Import the problem module ``name``.

    Parameters
    ----------
    name : str
        A name from :func:`names`.

    Returns
    -------
    module

    Raises
    ------
    ModelError
        If there is no such problem (the message lists the known ones).
    """
    known = names()
    if name not in known:
        raise ModelError(f"unknown problem {name!r}; known problems: {', '.join(known)}")
    return importlib.import_module(f"problems.{name}")


def title(name: str) -> str:
    """The one-line title of a problem (its module's ``TITLE``).

    Parameters
    ----------
    name : str
        A name from :func:`names`.

    Returns
    -------
    str
    """
    return str(load(name).TITLE)
