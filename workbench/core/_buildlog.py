"""The build log of a model: which casadi functions it built, their sizes and times."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["BuildRecord", "BuildLog"]


@dataclass(frozen=True)
class BuildRecord:
    """One built casadi.Function: its name, size and the time it took."""

    name: str
    n_nodes: int
    seconds: float
    symbolic: str

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-serialisable form."""
        return {"function": self.name, "n_nodes": self.n_nodes, "build_seconds": self.seconds,
                "symbolic": self.symbolic}


@dataclass
class BuildLog:
    """The functions a model has built, in build order."""

    records: list[BuildRecord] = field(default_factory=list)

    def add(self, record: BuildRecord) -> None:
        """Append a record."""
        self.records.append(record)

    def as_list(self) -> list[dict[str, Any]]:
        """Plain JSON-serialisable form."""
        return [r.as_dict() for r in self.records]

    def names(self) -> list[str]:
        """Names of the built functions."""
        return [r.name for r in self.records]

    def __len__(self) -> int:
        return len(self.records)
