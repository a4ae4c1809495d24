"""Choosing a model's level for a scene: errors against closed forms, refusals, the choice.

The levels' errors are checked against closed forms where there are some (a harmonic
oscillator, whose linearisation is exact; the linearisation of the 3D pendulum near
hanging, whose error is second order in the amplitude; RK4's fourth order), the special
cases against their assumptions, and the choice against the measured costs and errors it
reports (never against a clock).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import pendulum3d as p3
from models.pendulum3d_levels import at_tilt, com_position, gamma, special_cases
from problems._model_choice_levels import TOP
from tests.conftest import assert_close
from workbench import mechanics, simulate
from workbench.core import Model, Parameter
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import ProductManifold, Rn
from workbench.study import (
    ChoiceStatus,
    FullLevel,
    Integration,
    LevelKind,
    LinearLevel,
    ReductionLevel,
    Scene,
    compare_models,
    output_invariance,
)

BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
        "g": 9.81}  # not axisymmetric (Jx != Jy), centre of mass on e3
TIGHT = {"rtol": 1e-11, "atol": 1e-11, "reference_rtol": 1e-13, "check_rtol": 1e-12,
         "repeats": 1}


def _oscillator(k: float = 4.0) -> Model:
    def field(ctx):
        x = ctx["x"]
        return ca.vertcat(x[1], -ctx["k"] * x[0])

    return Model(name="oscillator", manifold=ProductManifold([("x", Rn(2))]), n_inputs=0,
                 parameters=(Parameter("k", (), "stiffness [1/s^2]"),), values={"k": k},
                 vector_field=field)


def _pendulum(body=BODY):
    full = p3.full(**body)
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")
    down = body["rho"] / np.linalg.norm(body["rho"])
    return full, lp, lp.full_state(np.r_[down, 0.0, 0.0, 0.0]), down


def _near(lp, down, a, n=2, seed=0):
    angles = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, n)
    return [at_tilt(lp, down, a * np.r_[np.cos(t), np.sin(t), 0.0], np.zeros(3))
            for t in angles]


def test_levels_of_a_linear_system_match_its_closed_form():
    """x'' = -k x: the full level's integration and the (exact) linearisation, vs cos/sin."""
    model = _oscillator(4.0)
    x0 = np.array([[0.3, -0.5], [-0.1, 0.2]])
    scene = Scene(model, x0, 10.0, lambda X: X[:, :1], 1e-6, n_times=201)
    t, w = scene.times, 2.0
    exact = [x[0] * np.cos(w * t) + x[1] / w * np.sin(w * t) for x in x0]
    for level in (FullLevel(model), LinearLevel(model, [0.0, 0.0], radius=1.0)):
        run = level.prepare(scene, Integration(rtol=1e-12, atol=1e-12)).run()
        for X, e in zip(run, exact, strict=True):
            assert_close(X[:, 0], e, atol=1e-9, what=level.name)
    ch = compare_models(scene, [FullLevel(model), LinearLevel(model, [0.0, 0.0], radius=1.0)],
                        **TIGHT)
    assert ch.level("linearisation").error <= 1e-9  # a linear system: no second-order term


def test_full_level_runs_as_simulate():
    """The level's own integrator reproduces simulate() with the same CVODES options."""
    full, lp, _, down = _pendulum()
    scene = Scene(full, _near(lp, down, 0.3, n=1), 3.0, gamma, 1e-6, n_times=31)
    X = FullLevel(full).prepare(scene, Integration(rtol=1e-9, atol=1e-9)).run()[0]
    ref = simulate(full, scene.states[0], scene.times, rtol=1e-9, atol=1e-9).x
    assert_close(X, ref, atol=1e-13)


def test_rk4_level_converges_at_fourth_order():
    model = _oscillator(4.0)
    scene = Scene(model, [0.3, -0.5], 4.0, lambda X: X, 1.0, n_times=21)
    t = scene.times
    exact = np.column_stack([0.3 * np.cos(2 * t) - 0.25 * np.sin(2 * t),
                             -0.6 * np.sin(2 * t) - 0.5 * np.cos(2 * t)])
    errs = [float(np.max(np.abs(FullLevel(model).prepare(
        scene, Integration(method="rk", step=h)).run()[0] - exact))) for h in (0.05, 0.025)]
    assert 14.0 < errs[0] / errs[1] < 18.0, errs  # 2^4 = 16


def test_linearisation_error_is_second_order_in_the_amplitude():
    """Halving the tilt from hanging quarters the linearisation's error on Gamma."""
    full, lp, hanging, down = _pendulum()
    errors = []
    for a in (2e-3, 1e-3):
        scene = Scene(full, _near(lp, down, a), 10.0, gamma, 1e-3, n_times=101)
        ch = compare_models(scene, [FullLevel(full), LinearLevel(full, hanging, radius=0.01)],
                            **TIGHT)
        assert ch.reference["difference"] < 1e-3 * ch.level("linearisation").error
        errors.append(ch.level("linearisation").error)
    assert 3.7 < errors[0] / errors[1] < 4.3, errors


def test_linearisation_refused_beyond_its_radius():
    full, lp, hanging, down = _pendulum()
    scene = Scene(full, _near(lp, down, 0.2), 1.0, gamma, 1e-3)
    level = LinearLevel(full, hanging, radius=0.05)
    d = max(level.distance(x) for x in scene.states)
    assert np.sin(0.2) / 2 < d <= np.sin(0.2) + 1e-12  # a tilt of 0.2 rad, in chart units
    assert level.refusal(scene) == (f"the scene's states are up to {d:.3g} from the "
                                    "equilibrium (chart max-norm), beyond the radius 0.05")
    assert LinearLevel(full, hanging, radius=0.25).refusal(scene) is None


def test_special_cases_refused_with_the_failing_assumption():
    full, lp, _, down = _pendulum()  # Jx != Jy
    scene = Scene(full, _near(lp, down, 0.3, n=1), 1.0, gamma, 1e-3)
    top, spherical, planar = special_cases(full)
    assert "not axisymmetric" in top.refusal(scene)
    assert "not axisymmetric" in spherical.refusal(scene)
    # the planar case needs only e2 principal and rho on e3 (both hold): the state fails
    assert "Gamma_2" in planar.refusal(scene)

    axi, alp, _, e3 = _pendulum(TOP)
    top, spherical, planar = special_cases(axi)
    spinning = Scene(axi, at_tilt(alp, e3, np.r_[0.5, 0.0, 0.0], np.r_[0.0, 0.3, 4.0]), 1.0,
                     gamma, 1e-3)
    assert top.refusal(spinning) is None
    assert "omega_3" in spherical.refusal(spinning)
    assert "Gamma_2" in planar.refusal(spinning)
    # the centre of mass in space changes under rotation about gravity: the cases give the
    # state only up to that rotation
    com = Scene(axi, spinning.states, 1.0, com_position(TOP["rho"]), 1e-3)
    assert "under the symmetry" in top.refusal(com)


def test_special_cases_that_apply_agree_with_the_full_model():
    axi, alp, _, e3 = _pendulum(TOP)
    swinging = Scene(axi, at_tilt(alp, e3, np.r_[0.0, 0.6, 0.0], np.r_[0.0, 0.8, 0.0]), 5.0,
                     gamma, 1e-7, n_times=51)
    ch = compare_models(swinging, special_cases=special_cases(axi), symmetries=(), **TIGHT)
    for name in ("Lagrange top", "spherical", "planar"):
        run = ch.level(name)
        assert run.applies and run.error <= 1e-8, (name, run.error)


def test_reduced_levels_reconstruct_outputs_that_are_not_invariant():
    full, lp, _, down = _pendulum()
    x0 = at_tilt(lp, down, np.r_[0.4, 0.1, 0.0], np.r_[0.3, -0.2, 0.5])
    for outputs, invariant in ((gamma, True), (com_position(BODY["rho"]), False)):
        scene = Scene(full, x0, 3.0, outputs, 1e-7, n_times=61)
        change = output_invariance(scene, lambda x, th: lp.act(x, th))
        assert (change < 1e-14) if invariant else (change > 0.01)
        ch = compare_models(scene, symmetries=("h",), **TIGHT)
        for name in ("Lagrange-Poincare (h)", "Routh (h)"):
            run = ch.level(name)
            assert ("reconstructed" in run.detail) != invariant, run.detail
            assert run.error <= 1e-8, (name, run.error)


def test_routh_level_needs_the_scene_momentum():
    full, lp, _, down = _pendulum()
    scene = Scene(full, _near(lp, down, 0.1), 1.0, gamma, 1e-3)  # at rest: h = 0
    level = ReductionLevel(mechanics.reduce(full, "h", momentum=0.3, breaking_inputs="hold_zero"))
    assert level.kind is LevelKind.ROUTH
    assert "not the level's value 0.3" in level.refusal(scene)
    moving = Scene(full, [scene.states[0], lp.full_state(np.r_[down, 0.0, 0.0, 1.0])], 1.0,
                   gamma, 1e-3)
    names = {lv.name: lv for lv in compare_models(moving, symmetries=("h",), repeats=1,
                                                  raise_on_failure=False).levels}
    assert not names["Routh (h)"].applies and "one value" in names["Routh (h)"].detail


def test_the_choice_is_the_cheapest_level_within_the_tolerance():
    """Loose: the cheapest adequate level; tight (below the linear error): not the linear."""
    full, lp, hanging, down = _pendulum()
    states = _near(lp, down, 2e-3)
    for tol, linear_ok in ((1e-4, True), (1e-7, False)):
        scene = Scene(full, states, 10.0, gamma, tol, n_times=101)
        ch = compare_models(scene, equilibria=[hanging], radius=0.01, **{**TIGHT,
                                                                         "repeats": 3})
        lin = ch.level("linearisation")
        assert lin.meets is linear_ok and (lin.error <= tol) is linear_ok
        adequate = [r for r in ch.levels if r.meets]
        assert ch.choice == min(adequate, key=lambda r: r.cpu_seconds).name
        for r in ch.levels:
            if r.name != ch.choice:
                why = ch.excluded[r.name]
                assert ("costs" in why) if r.meets else ("> tolerance" in why or
                                                         "does not apply" in why)
        assert ch.speedup == pytest.approx(ch.level("full").cpu_seconds / ch.chosen.cpu_seconds)
        assert all(len(r.cpu_repeats) == 3 for r in ch.levels if r.cpu_seconds is not None)


def test_an_unconfirmed_reference_is_reported():
    full, lp, _, down = _pendulum()
    scene = Scene(full, _near(lp, down, 0.3, n=1), 2.0, gamma, 1e-5)
    kw = {"symmetries": (), "repeats": 1, "reference_rtol": 1e-7, "check_rtol": 1e-5}
    ch = compare_models(scene, **kw, raise_on_failure=False)
    assert ch.status is ChoiceStatus.REFERENCE_UNCONFIRMED and ch.choice is None
    assert ch.reference["difference"] > 0.01 * 1e-5
    assert "the reference is unconfirmed" in ch.excluded["full"]  # it meets the tolerance
    with pytest.raises(SolverError, match="REFERENCE_UNCONFIRMED"):
        compare_models(scene, **kw)


def test_bad_scenes_and_knobs_are_refused():
    full, lp, _, down = _pendulum()
    x0 = _near(lp, down, 0.1, n=1)
    with pytest.raises(ParameterError, match="outputs must map full states"):
        Scene(full, x0, 1.0, lambda X: X[0], 1e-3)
    with pytest.raises(ParameterError, match="horizon"):
        Scene(full, x0, -1.0, gamma, 1e-3)
    with pytest.raises(ParameterError, match="tolerance"):
        Scene(full, x0, 1.0, gamma, float("nan"))
    scene = Scene(full, x0, 1.0, gamma, 1e-3)
    with pytest.raises(ParameterError, match="check_rtol must be larger"):
        compare_models(scene, reference_rtol=1e-10, check_rtol=1e-12)
    with pytest.raises(ParameterError, match="include the full model"):
        compare_models(scene, [LinearLevel(full, _pendulum()[2], radius=1.0)])
    with pytest.raises(ParameterError, match="with levels given"):
        compare_models(scene, [FullLevel(full)], equilibria=[_pendulum()[2]])
    with pytest.raises(ParameterError, match="step is RK4's knob"):
        compare_models(scene, step=0.01)
    with pytest.raises(ParameterError, match="'cvodes' or 'rk'"):
        compare_models(scene, method="lgvi")


def test_special_cases_belong_to_the_3d_pendulum():
    with pytest.raises(ModelError, match="models.pendulum3d.full"):
        special_cases(_oscillator())
