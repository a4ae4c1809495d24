"""Fixes from the engine review: validation helpers, branch switching, evaluators, caches."""

from __future__ import annotations

import pytest

from models import pendulum3d as p3
from workbench import _validate
from workbench.errors import ModelError, ParameterError
from workbench.integrators import integrate, rkmk4
from workbench.roots import check_count, check_positive
from workbench.simulate import simulate


@pytest.fixture(scope="module")
def planar():
    return p3.planar(Jt=0.2, rho_s=0.3)


def planar_state(model):
    return model.state(p=[0.0, 1.0], omega_y=[1.0])


# ----------------------------------------------------------------------------------------
# one implementation of positive numbers, counts and steps


def test_roots_validators_are_the_shared_ones():
    assert check_positive is _validate.positive
    assert check_count is _validate.count
    with pytest.raises(ParameterError, match="tol must be a positive number; got -1"):
        check_positive("tol", -1)
    with pytest.raises(ParameterError, match="n must be an integer >= 2; got True"):
        check_count("n", True, minimum=2)


@pytest.mark.parametrize(("step", "match"), [
    ("fast", "step must be a positive number; got 'fast'"),
    (float("inf"), "step must be a positive finite number; got inf"),
    (float("nan"), "step must be a positive number; got nan"),
    (-0.1, "step must be a positive number; got -0.1"),
    (5.0, "step must not exceed the horizon"),
])
def test_simulate_and_integrate_check_a_step_alike(planar, step, match):
    """One check, the same words; simulate raises its documented ModelError."""
    x0 = planar_state(planar)
    with pytest.raises(ModelError, match=match):
        simulate(planar, x0, [0.0, 0.5, 1.0], method="rk", step=step)
    with pytest.raises(ParameterError, match=match):
        integrate(planar, rkmk4(planar), x0, [0.0, 0.5, 1.0], step=step)


def test_simulate_refuses_a_boolean_degree(planar):
    with pytest.raises(ModelError, match="degree must be an integer >= 1; got True"):
        simulate(planar, planar_state(planar), [0.0, 1.0], method="collocation", step=0.1,
                 degree=True)
