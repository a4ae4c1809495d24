"""Define-and-solve scripts, one per reproduced paper result or study.

Each module ``problems/NAME.py`` defines ``TITLE`` (one line) and
``solve(*, quick=False) -> workbench.result.Result``, and runs as a script. Modules are
imported only when their problem is run, so running one problem builds nothing for the
others.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

from workbench.errors import ModelError

__all__ = ["names", "load"]


def names() -> list[str]:
    """Names of all problems, sorted."""
    return sorted(
        m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")
    )


def load(name: str) -> ModuleType:
    """Import the problem module ``name``.

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
    """The one-line title of a problem (reads the module's ``TITLE``)."""
    return str(load(name).TITLE)
