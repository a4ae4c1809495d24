"""Exceptions of the workbench.

Every exception subclasses a builtin so callers may catch either. Messages name the
argument, what was expected, what was got, and the fix.
"""

from __future__ import annotations

__all__ = [
    "WorkbenchError",
    "ManifoldError",
    "ParameterError",
    "ModelError",
    "SolverError",
    "OutputError",
]


class WorkbenchError(Exception):
    """Base class of all workbench exceptions."""


class ManifoldError(WorkbenchError, ValueError):
    """A point or tangent vector is not on the manifold it is declared on."""


class ParameterError(WorkbenchError, ValueError):
    """A model or method parameter is out of its domain (wrong shape, sign, symmetry...)."""


class ModelError(WorkbenchError, ValueError):
    """A model is used in a way its definition does not allow (unknown name, bad input)."""


class SolverError(WorkbenchError, RuntimeError):
    """A numerical solver (integrator, root-finder, Ipopt) failed.

    Parameters
    ----------
    message : str
        What failed, in words.
    status : str
        The solver's own status string (e.g. CVODES' return flag name).
    """

    def __init__(self, message: str, *, status: str = "") -> None:
        super().__init__(message if not status else f"{message} [status: {status}]")
        self.status = status


class OutputError(WorkbenchError, OSError):
    """An output file or directory cannot be written (missing folder, read-only, full disk).

    Nothing partial is left behind when it is raised (see :mod:`workbench.core.files`).
    """
