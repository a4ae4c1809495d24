"""The engine's exceptions (workbench/core/errors.py): each subclasses a builtin."""

from __future__ import annotations

import inspect

import pytest

import workbench.core.errors as errors
from workbench.core.errors import SolverError, WorkbenchError

BUILTIN = (ValueError, RuntimeError, OSError, ImportError, TypeError, KeyError)
EXCEPTIONS = [obj for _, obj in inspect.getmembers(errors, inspect.isclass)
              if issubclass(obj, WorkbenchError) and obj is not WorkbenchError]


@pytest.mark.parametrize("cls", EXCEPTIONS, ids=lambda c: c.__name__)
def test_every_exception_is_a_workbench_error_and_a_builtin(cls):
    assert issubclass(cls, WorkbenchError) and issubclass(cls, BUILTIN), cls.__mro__


def test_solver_error_carries_its_status_in_the_message():
    err = SolverError("Newton did not converge", status="max_iterations")
    assert err.status == "max_iterations"
    assert str(err) == "Newton did not converge [status: max_iterations]"
    assert str(SolverError("plain")) == "plain" and SolverError("plain").status == ""
    assert isinstance(err, RuntimeError)
