"""simulate: methods and their orders, backward time, closed loops, bad input."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from models.spherical import spherical_pendulum
from workbench.core.errors import ModelError, ParameterError
from workbench.simulation._simulate import Method, constraint_residuals, simulate
from workbench.simulation.integrators import integrate, rkmk4


@pytest.fixture
def planar():
    return p3.planar(Jt=0.2, rho_s=0.3)


def test_backward_integration_returns_to_the_start():
    model = p3.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0, 0, 0.3])
    x0 = model.state(R=p3.so3_exp([0.1, 0.2, 0.3]), omega=[0.5, -0.2, 0.4])
    fwd = simulate(model, x0, np.linspace(0, 3, 31), rtol=1e-12, atol=1e-12)
    back = simulate(model, fwd.final, np.linspace(3, 0, 31), rtol=1e-12, atol=1e-12)
    assert_close(back.t, fwd.t[::-1], atol=1e-15, what="times")
    assert_close(back.final, x0, atol=1e-9, what="backward flow inverts forward flow")


@pytest.mark.parametrize(("method", "order", "extra"),
                         [(Method.RK, 4, {}), (Method.COLLOCATION, 4, {"degree": 2}),
                          (Method.COLLOCATION, 6, {"degree": 3})])
def test_fixed_step_methods_reach_their_order(planar, method, order, extra):
    x0 = planar.state(p=[-np.sin(2.0), np.cos(2.0)], omega_y=[0.0])
    T = 2.0
    ref = simulate(planar, x0, [0, T], rtol=1e-13, atol=1e-13).final
    steps = np.array([0.1, 0.05, 0.025])
    errs = [np.linalg.norm(simulate(planar, x0, [0, T], method=method, step=h, **extra).final - ref)
            for h in steps]
    fitted = np.polyfit(np.log(steps), np.log(errs), 1)[0]
    assert abs(fitted - order) < 0.35, f"fitted order {fitted:.2f}, expected {order}"


def test_trajectory_reports_cost_and_diagnostics(planar):
    x0 = planar.state(p=[0, 1.0], omega_y=[1.0])
    tr = simulate(planar, x0, np.linspace(0, 1, 11), method="rk", step=0.01)
    assert tr.cost["steps"] == 100 and tr.cost["rhs_evaluations"] == 400
    assert tr.options["step"] == pytest.approx(0.01)
    assert set(tr.diagnostics["constraint_residual"]) == {"p", "omega_y"}
    assert tr.summary()["method"] == "rk"


def test_closed_loop_input_is_recorded_and_acts():
    model = spherical_pendulum(m=1.0, l=1.0, g=9.81)
    x = ca.SX.sym("x", 6)
    damping = ca.Function("k", [x], [-0.5 * x[3:6]])
    x0 = model.state(q=[0, np.sin(0.5), np.cos(0.5), 0.3, 0, 0])
    tr = simulate(model, x0, np.linspace(0, 5, 51), controller=damping)
    assert_close(tr.u, -0.5 * tr.x[:, 3:6], atol=1e-15, what="recorded input")
    E = tr.invariant_series("energy")
    assert np.all(np.diff(E) < 1e-9), "damping does not add energy"
    assert tr.diagnostics["closed_loop"]


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"t": [0.0]}, "at least two times"),
        ({"t": [0.0, 1.0, 0.5]}, "strictly increasing .* or strictly decreasing"),
        ({"method": "euler"}, "method must be one of"),
        ({"method": "rk"}, "step must be a positive number"),
        ({"method": "rk", "step": -0.1}, "step must be a positive number"),
        ({"method": "rk", "step": 5.0}, "must not exceed the horizon"),
        ({"rtol": 0.0}, "rtol must be a positive finite tolerance; got 0.0"),
        ({"multistep": "gear"}, "multistep must be one of"),
        ({"corrector": "picard"}, r"corrector must be one of \['functional', 'newton'\]"),
        ({"method": "rk", "step": 0.1, "corrector": "newton"}, "does not use it"),
        ({"max_steps": 2.7}, "max_steps must be an integer"),
        ({"max_steps": -5}, "max_steps must be an integer"),
        ({"controller": "pd"}, "controller must be a casadi.Function"),
    ],
)
def test_bad_input(planar, kwargs, pattern):
    x0 = planar.state(p=[0, 1.0], omega_y=[1.0])
    args = {"t": np.linspace(0, 1, 3), **kwargs}
    t = args.pop("t")
    with pytest.raises(ModelError, match=pattern):
        simulate(planar, x0, t, **args)


# ----------------------------------------------------------------------------------------
# moved from test_review_engine.py


def planar_state(model):
    return model.state(p=[0.0, 1.0], omega_y=[1.0])


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


def test_simulate_keeps_its_model_error_for_unknown_choices(planar):
    x0 = planar_state(planar)
    with pytest.raises(ModelError, match=r"method must be one of \['cvodes', .*; got 'rk45'"):
        simulate(planar, x0, [0.0, 1.0], method="rk45")
    with pytest.raises(ModelError, match=r"multistep must be one of \['adams', 'bdf'\]"):
        simulate(planar, x0, [0.0, 1.0], multistep="gear")


@pytest.mark.parametrize(("multistep", "corrector"), [("adams", "newton"), ("bdf", None),
                                                      ("bdf", "functional")])
def test_correctors_agree_to_the_tolerance_and_are_recorded(multistep, corrector):
    """Functional (the Adams default) and Newton iteration solve the same corrector
    equation: the same trajectory to the global error, the choice in ``options``."""
    model = p3.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0, 0, 0.3])
    x0 = model.state(R=p3.so3_exp([0.1, 0.2, 0.3]), omega=[0.5, -0.2, 0.4])
    t = np.linspace(0, 5, 11)
    ref = simulate(model, x0, t, rtol=1e-12, atol=1e-12)
    assert ref.options["corrector"] == "functional" and ref.options["multistep"] == "adams"
    other = simulate(model, x0, t, rtol=1e-12, atol=1e-12, multistep=multistep,
                     corrector=corrector)
    expected = corrector or ("newton" if multistep == "bdf" else "functional")
    assert other.options["corrector"] == expected
    assert_close(other.x, ref.x, atol=1e-9, what=f"{multistep}/{expected} vs adams/functional")


def test_stepper_refuses_bad_cvodes_options():
    """The Stepper's CVODES options are checked like simulate's, the argument named."""
    from workbench.control.ocp.stepper import Stepper

    model = p3.planar(Jt=0.2, rho_s=0.3)
    for kwargs, pattern in (({"max_steps": -5}, "max_steps must be an integer"),
                            ({"max_steps": 2.7}, "max_steps must be an integer"),
                            ({"corrector": "picard"}, "corrector must be one of"),
                            ({"multistep": "gear"}, "multistep must be one of")):
        with pytest.raises(ParameterError, match=pattern):
            Stepper(model, **kwargs)


def _count_residual_builds(monkeypatch, factor):
    calls = []
    real = factor.residual

    def residual(x):
        calls.append(x)
        return real(x)

    monkeypatch.setattr(factor, "residual", residual)
    return calls


def test_constraint_residuals_and_jacobians_build_once_per_factor(monkeypatch, rng):
    model = p3.planar(Jt=0.2, rho_s=0.3)  # a fresh S1 factor
    factor = model.manifold.factor("p")
    calls = _count_residual_builds(monkeypatch, factor)
    X = np.array([model.manifold.random_point(rng) for _ in range(5)])
    X[:, :2] *= np.array([1.0, 1.1, 0.9, 1.0, 2.0])[:, None]  # |p| = 1, 1.1, 0.9, 1, 2
    for _ in range(3):
        res = constraint_residuals(model, X)
        assert_close(res["p"], np.abs(np.sum(X[:, :2] ** 2, axis=1) - 1.0), atol=1e-15,
                     what="|h(p)| = ||p|^2 - 1|")
        assert_close(res["omega_y"], np.zeros(5), atol=0, what="no constraint on R^1")
        J = factor.constraint_jacobian(X[1, :2])
        assert_close(J, 2 * X[1:2, :2], atol=1e-15, what="dh/dp = 2 p^T")
    assert len(calls) == 1


@pytest.mark.parametrize(("kw", "words"), [
    ({"step": 0.1}, ["method 'cvodes' does not use step=0.1", "rtol, atol"]),
    ({"degree": 3}, ["method 'cvodes' does not use degree=3"]),
    ({"method": "rk", "step": 0.1, "degree": 3}, ["method 'rk' does not use degree=3"]),
    ({"jit": True}, ["method 'cvodes' does not use jit=True"]),
    ({"method": "collocation", "step": 0.1, "jit": True},
     ["method 'collocation' does not use jit=True", "'lgvi'"]),
    ({"step": 0.1, "degree": 2}, ["step=0.1", "degree=2"]),
])
def test_simulate_refuses_knobs_its_method_ignores(planar, kw, words):
    with pytest.raises(ModelError) as info:
        simulate(planar, planar_state(planar), [0.0, 1.0], **kw)
    assert all(w in str(info.value) for w in words), str(info.value)


def test_simulate_collocation_degree_defaults_to_four(planar):
    x0 = planar_state(planar)
    a = simulate(planar, x0, [0.0, 1.0], method="collocation", step=0.1)
    b = simulate(planar, x0, [0.0, 1.0], method="collocation", step=0.1, degree=4)
    assert a.options["degree"] == b.options["degree"] == 4
    assert_close(a.final, b.final, atol=0.0, what="same method")


@pytest.mark.parametrize("method", ["collocation", "rk", "cvodes"])
def test_a_field_that_turns_nan_is_an_error_for_every_method(method):
    """casadi's collocation step keeps the last state when the field is NaN, without an
    error: the trajectory 'stopped' and looked like a result. Every method raises now."""
    from workbench.core.errors import SolverError

    model = p3.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0.0, 0.0, 0.3])
    x0 = model.state(R=np.eye(3), omega=[1.0, 0.5, 0.2])
    x = ca.SX.sym("x", 12)
    # real while omega_x > 0.9: NaN once the body has slowed down (t ~ 0.4 s)
    k = ca.Function("k", [x], [ca.vertcat(ca.sqrt(x[9] - 0.9), 0, 0)])
    knobs = {} if method == "cvodes" else {"step": 0.05}
    with pytest.raises(SolverError, match="non-finite|not finite|failed"):
        simulate(model, x0, np.linspace(0.0, 1.0, 11), controller=k, method=method, **knobs)


def test_fixed_step_count_and_collocation_degree_are_bounded():
    model = p3.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0.0, 0.0, 0.3])
    x0 = model.state(R=np.eye(3), omega=[1.0, 0.5, 0.2])
    with pytest.raises(ModelError, match="would take 1e\\+12 fixed steps"):
        simulate(model, x0, np.linspace(0.0, 1.0, 3), method="rk", step=1e-12)
    with pytest.raises(ModelError, match=r"degree must be .*9"):
        simulate(model, x0, np.linspace(0.0, 1.0, 3), method="collocation", step=0.1,
                 degree=10)


def test_cvodes_max_steps_is_bounded_before_anything_runs(planar):
    """``max_steps = 10**18`` over ``t = [0, 1e9]`` ran for hours; it is refused at once,
    with the bound in the message, and the bound itself is accepted."""
    from workbench.simulation._cvodes import MAX_STEPS

    x0 = planar_state(planar)
    with pytest.raises(ModelError, match=rf"max_steps must be .*<= 1e\+08; got {10**18}"):
        simulate(planar, x0, [0.0, 1e9], max_steps=10**18)
    at_bound = simulate(planar, x0, [0.0, 0.5], max_steps=MAX_STEPS)
    default = simulate(planar, x0, [0.0, 0.5])
    assert at_bound.cost["steps"] == default.cost["steps"]  # the knob only caps the steps
    assert np.array_equal(at_bound.x, default.x)


@pytest.mark.parametrize("method", ["rk", "collocation"])
def test_fixed_step_runs_do_not_depend_on_the_chunking_of_their_intervals(planar, method,
                                                                           monkeypatch):
    # the output intervals are integrated in chunks (each starting where the last ended):
    # chunks of 7 with a remainder give the states of one chunk, bit for bit
    from workbench.simulation import _intervals

    x0 = planar.state(p=[np.sin(1.0), np.cos(1.0)], omega_y=[0.5])
    t = np.linspace(0.0, 3.0, 51)
    whole = simulate(planar, x0, t, method=method, step=0.01)
    monkeypatch.setattr(_intervals, "INTERVAL_CHUNK", 7)
    chunked = simulate(planar, x0, t, method=method, step=0.01)
    assert np.array_equal(whole.x, chunked.x)
    assert chunked.cost["steps"] == whole.cost["steps"] == 50 * 6  # 0.06 s per output
