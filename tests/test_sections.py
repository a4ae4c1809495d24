"""Poincare sections and the stabilised field (workbench/global_dynamics/_sections.py).

The turning section ``{e3 . q-dot = 0, e3 . (q x q-dot) > 0}`` on the TS^2 factor of the
Routh model, at a given energy level; the stabilised field equals the model's on the
manifold and adds ``-k h`` to the rate of the constraint residual ``h`` off it.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from test_poincare import E3, routh_for

from workbench.core.errors import ParameterError
from workbench.global_dynamics._sections import (
    stabilized_field,
    turning_section,
    turning_section_state,
)


def test_stabilized_field_equals_model_field_on_the_manifold():
    model, _ = routh_for(2.0)
    f = stabilized_field(model, gain=10.0)
    rng = np.random.default_rng(1)
    for _ in range(5):
        x = model.manifold.random_point(rng)
        np.testing.assert_allclose(np.asarray(f(x, model.p)).ravel(), model.rhs(x),
                                   atol=1e-12)
    # off the manifold the residual h obeys h-dot = H f - k h
    x = model.manifold.random_point(rng) * 1.001
    h = model.manifold.residual(x)
    H = np.asarray(ca.Function("H", [xs := ca.SX.sym("x", 6)],
                               [ca.jacobian(model.manifold.residual(xs), xs)])(x))
    hdot_k = H @ np.asarray(f(x, model.p)).ravel()
    hdot_0 = H @ model.rhs(x)
    np.testing.assert_allclose(hdot_k - hdot_0, -10.0 * h, atol=1e-12)


def test_turning_section_state_lies_on_the_section_at_the_level():
    model, x0 = routh_for(3.0)
    E = model.invariants(x0)["energy"]
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = rng.standard_normal(3)
        q /= np.linalg.norm(q)
        x = turning_section_state(model, q, level=E + 6.0)
        assert abs(x[5]) < 1e-15 and np.cross(x[:3], x[3:])[2] > 0
        assert model.manifold.factor("Gamma").residual_norm(x) < 1e-14
        assert abs(model.invariants(x)["energy"] - (E + 6.0)) < 1e-12


def test_turning_section_state_rejects_bad_input():
    model, _ = routh_for(1.0)
    with pytest.raises(ParameterError, match="parallel"):
        turning_section_state(model, E3, level=0.0)
    with pytest.raises(ParameterError, match="below"):
        turning_section_state(model, [1.0, 0.0, 0.0], level=-100.0)
    with pytest.raises(ParameterError, match="axis"):
        turning_section(axis=[0, 0, 2])
