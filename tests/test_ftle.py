"""Finite-time Lyapunov exponents (workbench/global_dynamics/_ftle.py) against closed forms."""

from __future__ import annotations

import math

import casadi as ca
import pytest
from test_poincare import oscillator, routh_for

from workbench.core._model import Model, Parameter, positive
from workbench.core.errors import ParameterError
from workbench.core.manifolds import ProductManifold, Rn
from workbench.global_dynamics._ftle import lyapunov_exponent

LAM = 0.5


def saddle(lam: float = LAM) -> Model:
    """x' = lam x, y' = -lam y: the tangent flow is diag(e^(lam t), e^(-lam t))."""
    return Model(name="saddle", manifold=ProductManifold([("q", Rn(2))]), n_inputs=0,
                 parameters=[Parameter("lam", (), "rate [1/s]", positive)],
                 values={"lam": lam},
                 vector_field=lambda ctx: ctx["lam"] * ca.vertcat(ctx["q"][0], -ctx["q"][1]))


def test_linear_saddle_exponent_is_its_rate():
    T = 20.0
    along = lyapunov_exponent(saddle(), [0.3, -0.2], t_final=T, direction=[1.0, 0.0])
    assert abs(along.value - LAM) < 1e-8
    assert along.running.shape == along.times.shape == (4,)  # every 5 s
    # from (1, 1)/sqrt(2): |v(T)| = sqrt(e^(2 lam T) + e^(-2 lam T)) / sqrt(2)
    both = lyapunov_exponent(saddle(), [0.3, -0.2], t_final=T)
    exact = math.log(math.sqrt(math.exp(2 * LAM * T) + math.exp(-2 * LAM * T)) / math.sqrt(2))
    assert abs(both.value - exact / T) < 1e-8
    # the stable direction alone contracts at -lam
    stable = lyapunov_exponent(saddle(), [0.3, -0.2], t_final=T, direction=[0.0, 1.0])
    assert abs(stable.value + LAM) < 1e-8
    assert along.cost["steps"] == along.cost.steps > 0


def test_ftle_separates_regular_from_chaotic():
    reg_model, reg_x0 = routh_for(1.0)
    cha_model, cha_x0 = routh_for(4.5)
    reg = lyapunov_exponent(reg_model, reg_x0, t_final=100.0, stabilization=10.0)
    cha = lyapunov_exponent(cha_model, cha_x0, t_final=100.0, stabilization=10.0)
    assert reg.value < 0.1 < 0.3 < cha.value
    # the linear oscillator has zero exponent (tangent flow bounded)
    osc = lyapunov_exponent(oscillator(2.0), [1.0, 0.0], t_final=50.0)
    assert abs(osc.value) < 0.05


@pytest.mark.parametrize("direction", [[0.0, 0.0], [1.0], [float("nan"), 1.0]])
def test_direction_must_be_a_nonzero_tangent_vector(direction):
    with pytest.raises(ParameterError, match="direction must be a non-zero 2-vector"):
        lyapunov_exponent(saddle(), [0.3, -0.2], t_final=1.0, direction=direction)
