"""Fixes from the engine review: validation helpers, branch switching, evaluators, caches."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import pendulum3d as p3
from workbench import _validate
from workbench.accuracy import Sweep, WorkPrecision
from workbench.attraction import check_convergence
from workbench.codegen import agreement, compile_sources, generate
from workbench.eigen import eigenstructure
from workbench.errors import ModelError, ParameterError
from workbench.integrators import integrate, rkmk4
from workbench.linearize import linearize
from workbench.lqr import lqr
from workbench.roots import check_count, check_positive
from workbench.simulate import Method, simulate


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


# ----------------------------------------------------------------------------------------
# unknown enum values name the argument and the choices


def _distance():
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 4)
    return ca.Function("d", [x, p], [ca.norm_2(x)])


@pytest.mark.parametrize(("call", "name", "choices", "got"), [
    (lambda m, x0: check_convergence(m, None, [x0], distance=_distance(), horizon=1.0,
                                     tolerance=0.1, multistep="gear"),
     "multistep", "['adams', 'bdf']", "'gear'"),
    (lambda m, x0: WorkPrecision("m", 1.0, None, [], {}).fastest(1e-3, cost="speed"),
     "cost", "['wall_seconds', 'evaluations']", "'speed'"),
    (lambda m, x0: WorkPrecision("m", 1.0, None, [], {}).winners([1e-3], cost="speed"),
     "cost", "['wall_seconds', 'evaluations']", "'speed'"),
    (lambda m, x0: eigenstructure(linearize(m, m.state(p=[0.0, -1.0], omega_y=[0.0])))
     .subspace("middle"), "which", "['stable', 'unstable', 'centre']", "'middle'"),
    (lambda m, x0: lqr(np.zeros((1, 1)), [[1.0]], [[1.0]], B=[[1.0]], require="stable"),
     "require", "['controllable', 'stabilizable']", "'stable'"),
    (lambda m, x0: Sweep("rk45", [0.1]), "Sweep.method", "['cvodes', 'rk', ", "'rk45'"),
    (lambda m, x0: generate(None, binding="baked"), "binding", "['", "'baked'"),
    (lambda m, x0: compile_sources(None, optimization="O9"), "optimization", "['", "'O9'"),
    (lambda m, x0: agreement(None, None, np.zeros((1, 3)), binding="frozen", through="air"),
     "through", "['", "'air'"),
])
def test_an_unknown_choice_is_a_parameter_error_listing_the_choices(planar, call, name,
                                                                    choices, got):
    with pytest.raises(ParameterError) as info:
        call(planar, planar_state(planar))
    msg = str(info.value)
    assert msg.startswith(f"{name} must be one of [") and choices in msg and got in msg, msg


def test_simulate_keeps_its_model_error_for_unknown_choices(planar):
    x0 = planar_state(planar)
    with pytest.raises(ModelError, match=r"method must be one of \['cvodes', .*; got 'rk45'"):
        simulate(planar, x0, [0.0, 1.0], method="rk45")
    with pytest.raises(ModelError, match=r"multistep must be one of \['adams', 'bdf'\]"):
        simulate(planar, x0, [0.0, 1.0], multistep="gear")


def test_choice_accepts_members_and_values():
    assert _validate.choice(Method, "rk", "method") is Method.RK
    assert _validate.choice(Method, Method.RK, "method") is Method.RK
    with pytest.raises(ModelError, match=r"method must be one of .*; got \[1\]"):
        _validate.choice(Method, [1], "method", error=ModelError)
