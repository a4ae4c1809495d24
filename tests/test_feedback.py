"""The controller in the loop (workbench/core/_feedback.py): one composition, one refusal.

A double integrator x = (q, v) with u = -k (q, v) . (1, 2) written as k(x) and as k(x, p)
(the gain a parameter) gives the same u; no controller gives u = 0.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from workbench.core._feedback import feedback_function
from workbench.core._model import Model, Parameter
from workbench.core.errors import ModelError
from workbench.core.manifolds import ProductManifold, Rn


def double_integrator() -> Model:
    return Model(name="double_integrator", manifold=ProductManifold([("x", Rn(2))]),
                 n_inputs=1, parameters=[Parameter("k", (), "gain")], values={"k": 3.0},
                 vector_field=lambda ctx: ca.vertcat(ctx["x"][1], ctx.u[0]))


def test_state_and_parameter_controllers_compose_to_the_same_law():
    model = double_integrator()
    xs, ps = ca.SX.sym("x", 2), ca.SX.sym("p", 1)
    of_x = ca.Function("k", [xs], [-3.0 * (xs[0] + 2 * xs[1])])
    of_xp = ca.Function("k", [xs, ps], [-ps[0] * (xs[0] + 2 * xs[1])])
    rng = np.random.default_rng(3)
    for x in rng.standard_normal((5, 2)):
        expected = -3.0 * (x[0] + 2 * x[1])
        for ctrl in (of_x, of_xp):
            u = float(feedback_function(model, ctrl)(x, model.p))
            assert abs(u - expected) <= 1e-15 * max(1.0, abs(expected))
        assert float(feedback_function(model, None)(x, model.p)) == 0.0


@pytest.mark.parametrize(("controller", "words"), [
    ("not a function", "must be a casadi.Function"),
    (ca.Function("k", [ca.SX.sym("x", 3)], [ca.SX(0)]), "got inputs of sizes [3]"),
    (ca.Function("k", [ca.SX.sym("x", 2), ca.SX.sym("p", 2)], [ca.SX(0)]),
     "got inputs of sizes [2, 2]"),
    (ca.Function("k", [ca.SX.sym("x", 2)], [ca.SX.zeros(2)]), "must return 1 inputs; got 2"),
])
def test_a_controller_that_does_not_fit_is_refused_naming_the_sizes(controller, words):
    with pytest.raises(ModelError) as info:
        feedback_function(double_integrator(), controller)
    assert words in str(info.value)
