"""The one validation layer (workbench/core/validate.py): choices name the argument and
the choices, wherever they are taken."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import pendulum3d as p3
from workbench.codegen import agreement, compile_sources, generate
from workbench.control._attraction import check_convergence
from workbench.core import validate as _validate
from workbench.core.errors import ModelError, ParameterError
from workbench.linear._eigen import eigenstructure
from workbench.linear._linearize import linearize
from workbench.linear._lqr import lqr
from workbench.simulation._simulate import Method
from workbench.simulation.accuracy import AccuracySweep, WorkPrecision


@pytest.fixture(scope="module")
def planar():
    return p3.planar(Jt=0.2, rho_s=0.3)


def planar_state(model):
    return model.state(p=[0.0, 1.0], omega_y=[1.0])


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
    (lambda m, x0: AccuracySweep("rk45", [0.1]), "AccuracySweep.method", "['cvodes', 'rk', ",
     "'rk45'"),
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


def test_choice_accepts_members_and_values():
    assert _validate.choice(Method, "rk", "method") is Method.RK
    assert _validate.choice(Method, Method.RK, "method") is Method.RK
    with pytest.raises(ModelError, match=r"method must be one of .*; got \[1\]"):
        _validate.choice(Method, [1], "method", error=ModelError)
