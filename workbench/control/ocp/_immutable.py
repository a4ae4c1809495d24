"""Immutable data of an optimal control problem: arrays that cannot be made writable again.

A problem's transcriptions are built once from its data and cached on it, so the data must not
change under them: every array a problem or its parts hold is made by :func:`frozen`, and
copying or pickling one makes it again through its constructor (:class:`Remade`).
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any

import numpy as np

from workbench.core.types import ArrayLike

__all__ = ["frozen", "frozen_bound", "Remade"]


def frozen(value: ArrayLike) -> np.ndarray:
    """A float copy of ``value`` that cannot be written, nor made writable again.

    A problem's data cannot change under the transcriptions built from it. A read-only copy
    that owns its memory is not enough: ``setflags(write=True)`` on it (or on the base of a
    view of it) succeeds. This copy's memory is an immutable ``bytes`` object, so numpy
    refuses ``setflags(write=True)`` on it, on any view of it and on its base
    (``ValueError``). ``np.array(a)`` and ``a.copy()`` give writable copies, which the
    problem does not see.
    """
    arr = np.ascontiguousarray(value, dtype=float)
    return np.frombuffer(arr.tobytes(), dtype=float).reshape(arr.shape)


def frozen_bound(value: float | np.ndarray) -> float | np.ndarray:
    """A bound from :func:`validate.bound` kept as a float, or its array made unwritable."""
    return value if np.ndim(value) == 0 else frozen(value)


def rebuild(cls: type, kwargs: dict[str, Any]) -> Any:
    """``cls(**kwargs)``: copies and unpickled objects are made (and validated) again."""
    return cls(**kwargs)


class Remade:
    """Copying or pickling makes the object again through its constructor.

    The default would restore the attributes as they are (a deep copy or an unpickled
    array is writable, and a problem's cached transcriptions would travel with it); the
    constructor validates and freezes the copy's data instead.
    """

    def __reduce__(self) -> tuple[Any, ...]:
        return rebuild, (type(self), {f.name: getattr(self, f.name)
                                       for f in fields(self) if f.init})
