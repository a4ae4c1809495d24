"""The ambient linearisation (workbench/linear/_ambient.py)."""

from __future__ import annotations

import sys

import numpy as np
from conftest import assert_close

from models import pendulum3d as p3
from workbench.linear._linearize import linearize, linearize_ambient


def test_linearize_ambient_evaluates_the_jacobians_once(monkeypatch):
    model = p3.reduced(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.3])
    x_e = model.state(Gamma=[0.0, 0.0, 1.0], omega=[0.0, 0.0, 0.0])
    module = sys.modules[linearize_ambient.__module__]
    real, calls = module._jacobians, []

    def counting(model, controller):
        fn = real(model, controller)

        def call(*args):
            calls.append(args)
            return fn(*args)

        return call

    monkeypatch.setattr(module, "_jacobians", counting)
    amb = linearize_ambient(model, x_e)
    assert len(calls) == 1
    lin = linearize(model, x_e)
    assert_close(amb.A @ lin.basis, lin.basis @ lin.A, atol=1e-12,
                 what="df/dx N = N A at an equilibrium")
    assert_close(amb.C @ amb.basis, np.zeros((1, 5)), atol=1e-15, what="basis in ker C")
