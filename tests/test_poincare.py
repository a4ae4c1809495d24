"""Poincare sections: event residuals, energy level, agreement between independent methods."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import pendulum3d as p3
from workbench.core._model import Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import S1, ProductManifold, Rn
from workbench.global_dynamics._poincare import (
    Direction,
    OrbitStatus,
    Section,
    poincare_map,
    turning_section,
)

BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
        "g": 9.81}
E3 = np.array([0.0, 0.0, 1.0])


def routh_for(c: float):
    full = p3.full(**BODY)
    x0, mu = p3.routh_state_from_full(full, full.state(R=np.eye(3), omega=c * np.ones(3)))
    return p3.routh(**BODY, mu=mu), x0


# a harmonic oscillator on R^2 (closed forms for crossing times) ----------------------------

def _osc_field(ctx):
    x = ctx["q"]
    return ca.vertcat(x[1], -ctx["w"] ** 2 * x[0])


def _osc_energy(ctx):
    x = ctx["q"]
    return 0.5 * x[1] ** 2 + 0.5 * ctx["w"] ** 2 * x[0] ** 2


def oscillator(w: float) -> Model:
    from workbench.core._model import Parameter, positive

    return Model(name="oscillator", manifold=ProductManifold([("q", Rn(2))]), n_inputs=0,
                 parameters=[Parameter("w", (), "frequency", positive)], values={"w": w},
                 vector_field=_osc_field, invariants={"energy": _osc_energy})


def _pos(ctx):
    return ctx["q"][0]


def _vel(ctx):
    return ctx["q"][1]


def test_oscillator_crossing_times_match_closed_form():
    # x = cos(w t): x = 0 at t = (k + 1/2) pi / w; increasing at odd k
    w = 2.3
    model = oscillator(w)
    for direction, first in ((Direction.BOTH, 0), (Direction.INCREASING, 1),
                             (Direction.DECREASING, 0)):
        sec = Section("x=0", _pos, direction=direction)
        orb = poincare_map(model, [1.0, 0.0], sec, n_crossings=12, t_max=100.0, rtol=1e-12,
                           atol=1e-12, sample_step=0.05, chunk=5.0)
        step = 1 if direction is Direction.BOTH else 2
        expect = (np.arange(first, first + step * 12, step) + 0.5) * np.pi / w
        assert orb.status is OrbitStatus.COMPLETE
        np.testing.assert_allclose(orb.t, expect, rtol=0, atol=1e-9)
        assert orb.diagnostics["max_event_residual"] < 1e-13
        np.testing.assert_allclose(np.abs(orb.event_rate), w, rtol=1e-9)


def test_side_condition_selects_half_of_the_crossings():
    model = oscillator(1.0)
    both = poincare_map(model, [1.0, 0.0], Section("x=0", _pos), n_crossings=10, t_max=50.0)
    half = poincare_map(model, [1.0, 0.0], Section("x=0, v>0", _pos, side=_vel),
                        n_crossings=5, t_max=50.0)
    np.testing.assert_allclose(half.t, both.t[1::2], atol=1e-9)
    assert np.all(half.x[:, 1] > 0)
    assert half.diagnostics["rejected_side"] >= 4


def test_horizon_status_when_too_few_crossings():
    orb = poincare_map(oscillator(1.0), [1.0, 0.0], Section("x=0", _pos), n_crossings=50,
                       t_max=10.0, chunk=2.0, raise_on_failure=False)
    assert orb.status is OrbitStatus.HORIZON
    assert orb.n == 3  # pi/2, 3pi/2, 5pi/2 < 10


def test_routh_section_crossings_residuals_and_energy():
    model, x0 = routh_for(1.0)
    orb = poincare_map(model, x0, turning_section(), n_crossings=60, t_max=1e3, rtol=1e-11,
                       atol=1e-11, stabilization=10.0)
    g = orb.part("Gamma")
    assert orb.n == 60
    assert np.max(np.abs(g[:, 5])) < 1e-12                                   # e3 . Gamma-dot = 0
    assert np.all(np.cross(g[:, :3], g[:, 3:])[:, 2] > 0)                    # side of P
    assert orb.diagnostics["max_relative_invariant_error"] < 1e-8           # energy level
    assert orb.diagnostics["suspect_intervals"] == 0
    assert orb.diagnostics["max_refine_error"] < 1e-10
    assert orb.diagnostics["max_constraint_residual"] < 1e-8
    # the energy at every crossing is the orbit's (5.16), evaluated independently
    E = [model.invariants(x)["energy"] for x in orb.x]
    np.testing.assert_allclose(E, model.invariants(x0)["energy"], atol=1e-8)


def test_routh_and_lagrange_poincare_crossings_agree():
    # two models, two section formulas: (Gamma, Gamma-dot) vs (Gamma, Gamma x omega)
    from problems.poincare_3d_pendulum import LP_SECTION

    model, x0 = routh_for(1.0)
    a = poincare_map(model, x0, turning_section(), n_crossings=25, t_max=1e3, rtol=1e-12,
                     atol=1e-12, stabilization=10.0)
    red = p3.reduced(**BODY)
    b = poincare_map(red, red.state(Gamma=E3, omega=np.ones(3)), LP_SECTION, n_crossings=25,
                     t_max=1e3, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(a.t, b.t, atol=1e-8)
    np.testing.assert_allclose(a.x[:, :3], b.x[:, :3], atol=1e-8)


def test_crossings_converge_with_tolerance():
    model, x0 = routh_for(1.0)  # a regular orbit: errors are not amplified exponentially
    ref = poincare_map(model, x0, turning_section(), n_crossings=10, t_max=1e3, rtol=1e-13,
                       atol=1e-13, stabilization=10.0)
    errs = []
    for tol in (1e-8, 1e-10):
        o = poincare_map(model, x0, turning_section(), n_crossings=10, t_max=1e3, rtol=tol,
                         atol=tol, stabilization=10.0)
        errs.append(np.max(np.abs(o.x - ref.x)))
    assert errs[1] < errs[0] / 10
    assert errs[1] < 1e-7  # global error of ~ 200 x rtol after ten returns


def test_unstabilised_routh_field_drifts_and_fails_clearly():
    model, x0 = routh_for(3.0)
    with pytest.raises(SolverError, match="stabilization"):
        poincare_map(model, x0, turning_section(), n_crossings=10_000, t_max=200.0,
                     constraint_tol=1e-6)


def test_bad_options_raise():
    model, x0 = routh_for(1.0)
    sec = turning_section()
    with pytest.raises(ParameterError, match="n_crossings"):
        poincare_map(model, x0, sec, n_crossings=0, t_max=1.0)
    with pytest.raises(ParameterError, match="sample_step"):
        poincare_map(model, x0, sec, n_crossings=1, t_max=1.0, sample_step=-1.0)
    with pytest.raises(ModelError, match="invariant"):
        poincare_map(model, x0, sec, n_crossings=1, t_max=1.0, invariant="momentum")
    with pytest.raises(ModelError, match="Section"):
        poincare_map(model, x0, "P", n_crossings=1, t_max=1.0)
    from workbench.core.errors import ManifoldError

    with pytest.raises(ManifoldError):
        poincare_map(model, x0 * 1.1, sec, n_crossings=1, t_max=1.0)


def test_circle_model_without_invariant():
    # a rotation on S^1: crossings of the x-axis every pi / w, no invariant declared
    def field(ctx):
        p = ctx["p"]
        return 1.5 * ca.vertcat(-p[1], p[0])

    m = Model(name="rotation", manifold=ProductManifold([("p", S1())]), n_inputs=0,
              parameters=[], values={}, vector_field=field)
    orb = poincare_map(m, [1.0, 0.0], Section("y=0", lambda ctx: ctx["p"][1]),
                       n_crossings=4, t_max=20.0, invariant=None, stabilization=1.0)
    np.testing.assert_allclose(orb.t, np.pi / 1.5 * np.arange(1, 5), atol=1e-9)
