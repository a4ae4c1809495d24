"""One status protocol for every solver-like result.

A solver-like result says how it ended with a **status enum whose value is a readable
message** (diffrax's ``RESULTS``, rockit's return status), answers ``.ok``, carries its
iterations and its cost where they exist, and raises on failure unless the caller asks
otherwise:

- :class:`StatusEnum` is the base of every status enum of the engine. Its members' values
  are readable messages; a subclass names the members that count as success in
  :meth:`StatusEnum.successes`, from which ``.ok`` follows. ``.code`` is the member's
  name in lower case (stable, for JSON and for the ``status`` of a
  :class:`~workbench.core.errors.SolverError`).
- :class:`StatusResult` is the mixin of results: ``.ok`` from ``.status``,
  :meth:`StatusResult.raise_for_status` raises a :class:`~workbench.core.errors.SolverError`
  (with the result attached as ``.result``) when not ``ok``, and returns the result
  otherwise. Functions that produce such a result take ``raise_on_failure: bool = True``
  and call it (the opt-out returns the failed result with its status).
- :class:`SolverResult` is the structural protocol the tests check every result type
  against (``isinstance(r, SolverResult)``).
- :class:`Record` is the base of typed cost and accuracy records: a frozen dataclass
  that also reads as a mapping of its (non-``None``) fields, so code that indexed the
  former free ``dict`` (``cost["wall_seconds"]``, ``"steps" in cost``, ``dict(cost)``)
  keeps working.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from enum import Enum
from typing import Any, ClassVar, Protocol, TypeVar, runtime_checkable

from workbench.core.errors import SolverError

__all__ = ["StatusEnum", "StatusResult", "SolverResult", "Record", "raise_if"]

R = TypeVar("R", bound="StatusResult")


class StatusEnum(Enum):
    """Base of status enums: the value of a member is a readable message.

    Subclasses list their members (``NAME = "what happened, in words"``) and override
    :meth:`successes` with the names of the members that count as success; ``ok`` is
    membership in that set. A subclass may mix in ``str`` (``class S(str, StatusEnum)``).
    """

    @classmethod
    def successes(cls) -> frozenset[str]:
        """Names of the members that count as success (override in subclasses)."""
        return frozenset()

    @property
    def ok(self) -> bool:
        """Whether this outcome counts as success."""
        return self.name in type(self).successes()

    @property
    def code(self) -> str:
        """The member's name in lower case: a stable short form (JSON, error status)."""
        return self.name.lower()

    @property
    def message(self) -> str:
        """``"NAME: readable message"``."""
        return f"{self.name}: {self.value}"


@runtime_checkable
class SolverResult(Protocol):
    """What every solver-like result provides (checked structurally).

    Attributes
    ----------
    status : StatusEnum
        How it ended; ``status.value`` reads as a message.
    ok : bool
        ``status.ok``.
    """

    @property
    def status(self) -> StatusEnum:
        """How it ended."""

    @property
    def ok(self) -> bool:
        """Whether it succeeded."""

    def raise_for_status(self) -> Any:
        """Raise :class:`SolverError` unless ``ok``; return the result otherwise."""


class StatusResult:
    """Mixin of solver-like results: ``ok`` from ``status``, ``raise_for_status``.

    The class it is mixed into has a ``status`` attribute or property holding a
    :class:`StatusEnum` member. ``failure_message`` may be overridden to say more
    (the default names the result type and the status with its message, and adds the
    result's own ``message`` attribute when it has one).
    """

    status: Any
    error_type: ClassVar[type[SolverError]] = SolverError

    @property
    def ok(self) -> bool:
        """Whether the status counts as success."""
        return bool(self.status.ok)

    def failure_message(self) -> str:
        """The message of the error :meth:`raise_for_status` raises."""
        own = getattr(self, "message", "")
        own = own if isinstance(own, str) and own else ""
        text = f"{type(self).__name__} failed: {self.status.message}"
        return f"{text} ({own})" if own and own != self.status.value else text

    def raise_for_status(self: R) -> R:
        """Return ``self`` when ``ok``; otherwise raise.

        Returns
        -------
        The result itself, so that ``r = solve(...).raise_for_status()`` reads.

        Raises
        ------
        SolverError
            When not ``ok``; the result is attached as ``.result`` and the status code
            as ``.status``.
        """
        if not self.ok:
            err = self.error_type(
                f"{self.failure_message()}. Pass raise_on_failure=False to get the result "
                f"with its status", status=self.status.code)
            err.result = self  # type: ignore[attr-defined]
            raise err
        return self


def raise_if(result: R, raise_on_failure: bool) -> R:
    """``result.raise_for_status()`` when ``raise_on_failure``, else ``result``.

    Parameters
    ----------
    result : StatusResult
        A solver-like result.
    raise_on_failure : bool
        The caller's choice.

    Returns
    -------
    The result.
    """
    return result.raise_for_status() if raise_on_failure else result


@dataclasses.dataclass(frozen=True)
class Record(Mapping):
    """Base of typed records (cost, accuracy): a frozen dataclass read as a mapping.

    Subclasses are ``@dataclass(frozen=True)`` with typed fields. A field whose value is
    ``None`` is absent from the mapping view ("where the method reports it"), so
    ``"steps" in cost`` and ``cost["steps"]`` behave as they did on the former dict.
    """

    def _present(self) -> list[str]:
        return [f.name for f in dataclasses.fields(self) if getattr(self, f.name) is not None]

    def __getitem__(self, key: str) -> Any:
        if key in self._present():
            return getattr(self, key)
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return iter(self._present())

    def __len__(self) -> int:
        return len(self._present())

    def as_dict(self) -> dict[str, Any]:
        """Plain form (the present fields)."""
        return {k: getattr(self, k) for k in self._present()}

    def replace(self, **changes: Any) -> Record:
        """A copy with some fields changed (records are frozen)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any]) -> Record:
        """Build from a mapping with (a subset of) the field names; unknown keys raise."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise TypeError(f"{cls.__name__} has no fields {unknown}; fields: {sorted(names)}")
        return cls(**dict(data))
