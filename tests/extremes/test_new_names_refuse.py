"""Bad input to the critical-set search, the model choice and the reduction is refused.

The hostile pass over the public names added with them (``critical_points``,
``find_all_equilibria``, ``ConfigurationFunction``, ``Scene``, ``compare_models``,
``mechanics.reduce``, ``System.s1``) found silent acceptances (a misspelt symmetry reported
as a level that does not apply, a NaN radius, ``raise_on_failure="no"`` read as true,
``p=[True]``), raw errors (a str ``params``, an int ``equilibria``, an overflowing ``p``),
an unbounded run (``repeats=10**9``), an allocation of 7.5 GiB (``n_times=10**9``), a
relative tolerance of 1e300 that reported a third critical point of a function with two,
and NaN placeholders in a result. Each class has its test here; where a bound is checked
before any work, the call would otherwise fail differently (a constant function, a
refused level), which shows the order.
"""

from __future__ import annotations

import json

import casadi as ca
import numpy as np
import pytest

import workbench as wb
from tests.extremes.hostile_entries import S1_MAN, _pendulum_potential, _scene_args, cart_s1
from workbench import mechanics
from workbench.core._evaluator import DenseEvaluator, Evaluator
from workbench.core.errors import ModelError, ParameterError
from workbench.equilibria._critical import LIMITS
from workbench.mechanics._reduction import MAX_CHECK_STATES
from workbench.study._model_choice import MAX_REPEATS
from workbench.study._model_scene import MAX_TIMES

G = 9.81


def _pendulum(**options):
    return wb.critical_points(_pendulum_potential(), manifold=S1_MAN, p=[G], **options)


def _constant() -> ca.Function:
    c = ca.SX.sym("c", 2)
    return ca.Function("flat", [c], [ca.SX(1.0)])


# ----------------------------------------------------------------------------------------
# critical_points, find_all_equilibria, ConfigurationFunction


def test_the_pendulum_height_has_its_two_critical_points_and_no_nan_placeholder():
    """V = -g cos(theta) on S^1: a minimum (-g, index 0) and a maximum (g, index 1)."""
    res = _pendulum()
    assert [s.index for s in res.sets] == [0, 1]
    assert [s.value for s in res.sets] == pytest.approx([-G, G], abs=1e-12)
    assert np.allclose([s.point for s in res.sets], [[1.0, 0.0], [-1.0, 0.0]], atol=1e-12)
    assert all(s.field_residual is None for s in res.sets)  # no model: nothing evaluated
    json.dumps(res.summary(), allow_nan=False)  # strict JSON: no NaN anywhere


@pytest.mark.parametrize("name", ["tol", "hessian_rtol", "symmetry_rtol"])
@pytest.mark.parametrize("value", [1.0, 1e300])
def test_relative_tolerances_of_one_or_more_are_refused(name, value):
    """tol=1e300 accepted every Newton start and reported a third, spurious critical set."""
    with pytest.raises(ParameterError, match=rf"{name} must be a relative tolerance in "
                                             r"\(0, 1\)"):
        _pendulum(**{name: value})


@pytest.mark.parametrize("name", sorted(LIMITS))
def test_counts_are_bounded_before_the_function_is_evaluated(name):
    """A constant function is refused once sampled: the bound's message shows it came first."""
    kw = {name: LIMITS[name] + 1}
    if name == "deflation_starts":
        kw["max_deflation_starts"] = LIMITS["max_deflation_starts"]
    with pytest.raises(ParameterError, match=rf"{name} must be an integer >= \d and <= "
                                             rf"{LIMITS[name]}; got {LIMITS[name] + 1}"):
        wb.critical_points(_constant(), manifold=S1_MAN, **kw)
    with pytest.raises(ParameterError, match="it is constant"):
        wb.critical_points(_constant(), manifold=S1_MAN, **{**kw, name: LIMITS[name]})


def test_the_critical_points_do_not_depend_on_the_scale_within_its_range():
    """V and 1e140 V have the same critical sets; 1e200 V would overflow and is refused."""
    scaled = wb.critical_points(_pendulum_potential(), manifold=S1_MAN, p=[1e140])
    assert np.allclose([s.point for s in scaled.sets], [s.point for s in _pendulum().sets],
                       atol=1e-12)
    with pytest.raises(ParameterError, match=r"outside \[1e-150, 1e\+150\].*rescale it"):
        wb.critical_points(_pendulum_potential(), manifold=S1_MAN, p=[1e200])
    c, k = ca.SX.sym("c", 2), ca.SX.sym("k")
    steep = ca.Function("steep", [c, k], [ca.exp(k * c[0])])  # exp(1000) overflows
    with pytest.raises(ParameterError, match="gradient is not finite"):
        wb.critical_points(steep, manifold=S1_MAN, p=[1000.0])


@pytest.mark.parametrize("flag", ["no", 0, None, np.ones(2)])
def test_raise_on_failure_must_be_a_bool(flag):
    with pytest.raises(ParameterError, match="raise_on_failure must be True or False"):
        _pendulum(raise_on_failure=flag)
    with pytest.raises(ParameterError, match="raise_on_failure must be True or False"):
        wb.find_all_equilibria(cart_s1(), raise_on_failure=flag)


@pytest.mark.parametrize("params", ["g", 3, np.zeros(3), object()])
def test_find_all_equilibria_params_must_be_a_dict(params):
    with pytest.raises(ParameterError, match="params must be a dict"):
        wb.find_all_equilibria(cart_s1(), params=params)


def test_find_all_equilibria_of_the_rail_pendulum_with_params():
    """Hanging (index 0) and inverted (index 1), each a point times the rail's R^1."""
    res = wb.find_all_equilibria(cart_s1(), params={"g": 2.0})
    assert [s.index for s in res.sets] == [0, 1]
    m, length = 0.2, 0.5
    assert [s.value for s in res.sets] == pytest.approx([-m * 2.0 * length,
                                                         m * 2.0 * length], abs=1e-12)
    assert max(s.field_residual for s in res.sets) <= 1e-12


@pytest.mark.parametrize("p, what", [([9.81 + 1j], "complex"), ([9.81 + 0j], "complex"),
                                     ([True], "booleans"), (["9.81"], "<U4")])
def test_configuration_function_p_must_be_real_numbers(p, what):
    with pytest.raises(ModelError, match=rf"^p must be .*{what}"):
        wb.ConfigurationFunction(S1_MAN, _pendulum_potential(), p=p)


def test_configuration_function_names_and_functions_are_checked():
    with pytest.raises(ModelError, match="name must be a str; got int"):
        wb.ConfigurationFunction(S1_MAN, _pendulum_potential(), p=[G], name=3)
    x, p = ca.SX.sym("x", 5), ca.SX.sym("p", 4)
    energy = ca.Function("E", [x, p], [x[2]])
    with pytest.raises(ModelError, match="function must be a casadi.Function"):
        wb.ConfigurationFunction.from_state(cart_s1(), "E")
    with pytest.raises(ModelError, match="configuration must be a sequence of factor names"):
        wb.ConfigurationFunction.from_state(cart_s1(), energy, configuration="th")
    with pytest.raises(ModelError, match="configuration must be a sequence of factor names"):
        wb.ConfigurationFunction.from_state(cart_s1(), energy, configuration=3)
    fn = wb.ConfigurationFunction.from_state(cart_s1(), energy, configuration=["th"])
    assert fn.value([0.6, 0.8]) == 0.6  # cos(theta) read from the state at rest


# ----------------------------------------------------------------------------------------
# Scene and compare_models


def test_scene_n_times_is_bounded_before_allocation_and_its_name_is_text():
    with pytest.raises(ParameterError, match=rf"n_times must be an integer >= 2 and <= "
                                             rf"{MAX_TIMES}; got 1000000000"):
        wb.Scene(**{**_scene_args(), "n_times": 10**9})  # was 7.45 GiB for the times
    assert wb.Scene(**{**_scene_args(), "n_times": MAX_TIMES}).times.shape == (MAX_TIMES,)
    for name in (3, None, b"swing"):
        with pytest.raises(ParameterError, match="name must be a str"):
            wb.Scene(**{**_scene_args(), "name": name})


def _scene() -> wb.Scene:
    return wb.Scene(**_scene_args())


@pytest.mark.parametrize("outputs, match", [
    (lambda X: X[:, 2:4] + 1e-3j, r"outputs must be real; got a complex array .*never "
                                  r"truncated to their real part"),
    (lambda X: X[:, 2:4] + 0j, "outputs must be real; got a complex array"),
    (lambda X: X[:, []], r"with n_outputs >= 1; for n = 1 it gave shape \(1, 0\)"),
    (lambda X: X[:, 2], r"shape \(n, n_outputs\) with n_outputs >= 1; for n = 1 it gave "
                        r"shape \(1,\)"),
    (lambda X: X[:, 2:4] > 0, "outputs must be a real numeric array; got booleans"),
    (lambda X: X[:, 2:4] * np.nan, "outputs must be finite"),
])
def test_scene_refuses_complex_empty_and_non_numeric_outputs(outputs, match):
    """Complex outputs were cut to their real part (a ComplexWarning only, and a model
    chosen as usual); zero outputs ended in a raw "zero-size array" error of numpy."""
    with pytest.raises(ParameterError, match=match):
        wb.Scene(**{**_scene_args(), "outputs": outputs})


def test_outputs_that_turn_complex_during_the_comparison_are_refused():
    """Real for the initial states (one row), complex for a level's trajectory: refused by
    the comparison too, not truncated."""
    scene = wb.Scene(**{**_scene_args(),
                        "outputs": lambda X: X[:, 2:4] + (1e-3j if len(X) > 1 else 0.0)})
    with pytest.raises(ParameterError, match="outputs must be real; got a complex array"):
        wb.compare_models(scene, repeats=1)


def test_integer_outputs_are_read_as_their_real_values():
    """Whole-number outputs are real: the scene gives them as floats, exactly."""
    scene = wb.Scene(**{**_scene_args(), "outputs": lambda X: np.rint(X[:, 2:4] * 1e3)
                        .astype(np.int64)})
    Y = scene.output(scene.states)
    assert Y.dtype == float and np.array_equal(Y, np.rint(scene.states[:, 2:4] * 1e3))


def test_compare_models_bounds_repeats():
    with pytest.raises(ParameterError, match=rf"repeats must be an integer >= 1 and <= "
                                             rf"{MAX_REPEATS}; got 1000000000"):
        wb.compare_models(_scene(), repeats=10**9)  # was an unbounded run


def test_a_misspelt_symmetry_is_refused_not_reported_as_a_level_that_does_not_apply():
    with pytest.raises(ParameterError, match=r"symmetries must name momenta of 'cart_s1'; "
                                             r"\['pz'\] are not among \['px'\]"):
        wb.compare_models(_scene(), symmetries=["pz"], repeats=1)
    with pytest.raises(ParameterError, match="symmetries must be a sequence"):
        wb.compare_models(_scene(), symmetries="px", repeats=1)  # not the letters 'p', 'x'


@pytest.mark.parametrize("kw, name", [({"radius": float("nan")}, "radius"),
                                      ({"radius": "0.1"}, "radius"),
                                      ({"seed": -1}, "seed"),
                                      ({"equilibria": 3}, "equilibria"),
                                      ({"equilibria": None}, "equilibria"),
                                      ({"special_cases": "abc"}, "special_cases"),
                                      ({"special_cases": [3]}, "special_cases"),
                                      ({"levels": 3}, "levels")])
def test_compare_models_checks_every_argument_even_when_unused(kw, name):
    """A NaN radius without equilibria, a bad seed caught as an unavailable level: refused."""
    with pytest.raises(ParameterError, match=rf"^{name} must be"):
        wb.compare_models(_scene(), repeats=1, **kw)


def test_the_rail_pendulum_levels_agree_on_the_scene():
    """Full, Lagrange-Poincare and Routh by the rail's translation: the same outputs."""
    ch = wb.compare_models(_scene(), repeats=1, rtol=1e-10, atol=1e-10)
    for name in ("full", "Lagrange-Poincare (px)", "Routh (px)"):
        assert ch.level(name).error <= 1e-8, name
    assert ch.choice is not None


# ----------------------------------------------------------------------------------------
# mechanics: reduce and the S^1 factor


def test_reduce_bounds_its_checks_and_its_relative_tolerance():
    kw = {"momentum": 0.3, "breaking_inputs": "hold_zero"}
    with pytest.raises(ModelError, match=rf"n_states must be an integer >= 1 and <= "
                                         rf"{MAX_CHECK_STATES}"):
        mechanics.reduce(cart_s1(), "px", n_states=10**9, **kw)
    for rtol in (1.0, 1e300):
        with pytest.raises(ModelError, match=r"rtol must be a relative tolerance in \(0, 1\)"):
            mechanics.reduce(cart_s1(), "px", rtol=rtol, **kw)


@pytest.mark.parametrize("velocity", ["a b", "", 3, b"v"])
def test_a_bad_velocity_name_is_named_as_the_velocity(velocity):
    s = mechanics.System("named")
    with pytest.raises(ModelError, match=r"^velocity \(the storage name of factor 'th'"):
        s.s1("th", velocity=velocity)
    with pytest.raises(ModelError, match=r"^velocity \(the storage name of factor 'x'"):
        s.rn("x", 1, velocity=velocity)
    with pytest.raises(ModelError, match=r"^velocity \(the storage name of factor 'R'"):
        s.so3("R", velocity=velocity)
    assert s.factors == []  # nothing was added


# ----------------------------------------------------------------------------------------
# the evaluators: no truncation of complex input


@pytest.mark.parametrize("cls", [Evaluator, DenseEvaluator])
def test_evaluators_refuse_complex_input(cls):
    model = cart_s1()
    x = model.state(x=[0.0], v=[0.0], th=0.3, th_dot=[0.0])
    ev = cls(model.function("f"))
    with pytest.raises(ModelError, match=r"input 'x' is complex.*drop the imaginary part"):
        ev(x.astype(complex), np.zeros(1), model.p)
