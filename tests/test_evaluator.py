"""Evaluators of casadi Functions (workbench/core/_evaluator.py) check their arguments."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from workbench.core._evaluator import DenseEvaluator, Evaluator
from workbench.core.errors import ModelError


@pytest.fixture(scope="module")
def planar():
    return p3.planar(Jt=0.2, rho_s=0.3)


def planar_state(model):
    return model.state(p=[0.0, 1.0], omega_y=[1.0])


@pytest.fixture(scope="module")
def f_and_state(planar):
    return planar.function("f"), planar_state(planar)


@pytest.mark.parametrize("cls", [Evaluator, DenseEvaluator])
def test_evaluators_refuse_missing_and_extra_arguments(f_and_state, planar, cls):
    f, x = f_and_state
    ev = cls(f)
    first = ev(x, np.zeros(0), planar.p)
    with pytest.raises(ModelError, match=r"f takes 3 inputs \[x \(3\), u \(0\), p \(4\)\]; "
                                         r"got 2 arguments"):
        ev(2 * x, np.zeros(0))  # p would have kept its value from the first call
    with pytest.raises(ModelError, match="got 4 arguments"):
        ev(x, np.zeros(0), planar.p, planar.p)
    again = ev(x, np.zeros(0), planar.p)
    assert_close(np.ravel(again[0] if isinstance(again, tuple) else again),
                 np.ravel(first[0] if isinstance(first, tuple) else first), atol=0.0,
                 what="refused calls leave nothing behind")


@pytest.mark.parametrize("cls", [Evaluator, DenseEvaluator])
def test_evaluators_refuse_wrong_sizes_instead_of_broadcasting(f_and_state, planar, cls):
    f, x = f_and_state
    ev = cls(f)
    with pytest.raises(ModelError, match=r"f: input 'p' must have 4 entries; got shape \(\)"):
        ev(x, np.zeros(0), 1.0)  # numpy would broadcast the scalar
    with pytest.raises(ModelError, match=r"input 'x' must have 3 entries; got shape \(2,\)"):
        ev(x[:2], np.zeros(0), planar.p)
    with pytest.raises(ModelError, match="input 'x' must be numeric"):
        ev(["a", "b", "c"], np.zeros(0), planar.p)
    # any shape with the right number of entries is accepted (column, row, matrix)
    ev(x.reshape(3, 1), np.zeros((0, 1)), planar.p.reshape(2, 2))


def test_dense_evaluator_is_an_evaluator_with_dense_outputs(planar):
    fx = planar.function("f_x")
    ev = DenseEvaluator(fx)
    assert isinstance(ev, Evaluator)
    (J,) = ev(planar_state(planar), np.zeros(0), planar.p)
    assert_close(J, np.asarray(fx(planar_state(planar), np.zeros(0), planar.p)), atol=0.0,
                 what="dense Jacobian")
