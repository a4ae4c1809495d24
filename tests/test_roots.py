"""Zero problems and Newton on manifolds (workbench/equilibria/_roots.py)."""

from __future__ import annotations

import pytest

from workbench.core import validate as _validate
from workbench.core.errors import ParameterError
from workbench.equilibria._roots import check_count, check_positive


def test_roots_validators_are_the_shared_ones():
    assert check_positive is _validate.positive
    assert check_count is _validate.count
    with pytest.raises(ParameterError, match="tol must be a positive number; got -1"):
        check_positive("tol", -1)
    with pytest.raises(ParameterError, match="n must be an integer >= 2; got True"):
        check_count("n", True, minimum=2)
