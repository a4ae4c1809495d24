"""Exceptions of the report package."""

from __future__ import annotations

from workbench.core.errors import WorkbenchError

__all__ = ["ReportError", "ReportInputError"]


class ReportError(WorkbenchError, RuntimeError):
    """A report could not be produced (template missing, Typst failure)."""


class ReportInputError(WorkbenchError, ValueError):
    """Bad input to a report: an unknown problem, an output directory that cannot be written."""
