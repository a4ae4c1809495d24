"""The swing-ups solved from the OCP's defaults: the rail pendulum and the double cartpole.

Each problem runs in quick mode and must be ok (every comparison within tolerance: solved
from the defaults, on the manifold, the bound, the closed forms, the independent models,
the TVLQR closed loop). Faster checks: the problems pass neither ``guess=`` nor
``handling=`` to any call, and the planar model the rail pendulum's TVLQR uses is the S^2
model on the rail's plane (the same field at random planar states).
"""

from __future__ import annotations

import ast
import inspect

import numpy as np
import pytest

from problems import _swingup
from problems import swingup_double_cartpole as dcp
from problems import swingup_rail_pendulum as rail


@pytest.mark.parametrize("module", [rail, dcp, _swingup],
                         ids=["rail_pendulum", "double_cartpole", "shared_swingup"])
def test_problem_passes_no_guess_and_no_handling(module):
    tree = ast.parse(inspect.getsource(module))
    passed = {kw.arg for node in ast.walk(tree) if isinstance(node, ast.Call)
              for kw in node.keywords}
    assert not passed & {"guess", "handling", "strategy"}, passed


def test_planar_model_is_the_rail_pendulum_on_its_plane():
    ocp = rail.problem()
    model, plane = ocp.model, rail.planar_model()
    rng = np.random.default_rng(3)
    for _ in range(5):
        phi, rate, x, v, u = rng.uniform(-3, 3, 5)
        s2 = model.state(x=[x], v=[v], q=np.r_[np.sin(phi), 0.0, np.cos(phi), 0.0, rate, 0.0])
        mapped = rail.to_plane(s2)[0]
        plane.check_state(mapped, name="mapped")
        f3 = np.asarray(model.rhs(s2, [u]), float)
        f2 = np.asarray(plane.rhs(mapped, [u]), float)
        assert np.max(np.abs(f3[rail.ACROSS])) <= 1e-12  # the plane is invariant
        np.testing.assert_allclose(rail.to_plane(f3)[0], f2, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("module", [rail, dcp], ids=["rail_pendulum", "double_cartpole"])
def test_problem_quick_is_ok(module):
    res = module.solve(quick=True)
    bad = [(c.quantity, c.reference, c.workbench, c.tolerance) for c in res.comparisons
           if not c.ok]
    assert res.ok, bad
    attempts = res.values["attempts"]
    assert attempts and attempts[-1]["status"] in ("SUCCESS", "ACCEPTABLE")
    assert res.values["solution"]["node_manifold_residual"] <= 1e-10
