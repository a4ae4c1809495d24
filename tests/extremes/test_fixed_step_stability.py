"""Fixed-step integration knows when it is unstable.

The hostile pass found ``mechanics_variational``, ``rk`` and ``rkmk4`` returning states of
1e203 and an energy drift of inf as a normal Trajectory when ``h omega`` was beyond the
method's stable range. Here every fixed-step method, beyond its range, raises a
SolverError naming the step and the stable step estimated from the linearised step (which
matches the closed form on a harmonic oscillator: RK4 ``h w < 2 sqrt 2``, the variational
steps ``h w < 2`` like Stormer-Verlet); within its range a long run passes; damped and
forced runs, whose energy legitimately changes by orders of magnitude, pass within the
range and fail beyond it; a NaN controller or field is reported as such, never as a step
to reduce.
"""

from __future__ import annotations

import re

import casadi as ca
import numpy as np
import pytest

from models.spherical import spherical_pendulum
from workbench import mechanics
from workbench.core import Model, ProductManifold, Rn
from workbench.core.errors import ParameterError, SolverError
from workbench.core.manifolds import so3_exp
from workbench.simulation import simulate
from workbench.simulation._stability import DRIFT_LIMIT, RK4_IMAGINARY, StepCheck, probe_for
from workbench.simulation.integrators import integrate, rkmk4
from workbench.simulation.integrators.common import MAX_CHUNK

W = 2.0  # the oscillator's frequency: RK4 is stable for h < sqrt(2), the variational for h < 1
CLOSED_FORM = {"rk": RK4_IMAGINARY / W, "rkmk4": RK4_IMAGINARY / W,
               "mechanics_variational": 2.0 / W}
EXPLICIT = ["rk", "rkmk4", "mechanics_variational"]


def oscillator(damping: float = 0.0) -> Model:
    """``m x'' = -k x - c x' + u`` on R^1 (``k = m W^2``), written with workbench.mechanics."""
    s = mechanics.System("oscillator")
    f = s.rn("x", 1, velocity="v")
    k = s.parameter("k", W**2, "stiffness [N/m]")
    m = s.parameter("m", 1.0, "mass [kg]")
    c = s.parameter("c", damping, "damping [N s/m]")
    s.kinetic(0.5 * m * ca.dot(f.v, f.v))
    s.potential(0.5 * k * ca.dot(f.x, f.x))
    if damping:
        s.dissipation(0.5 * c * ca.dot(f.v, f.v))
    s.force(f, s.input(1, "force [N]"))
    return s.model()


def feedback(gain: float) -> ca.Function:
    """``u = gain * v``: with gain > 0 it feeds energy in (the energy grows like e^(gain t))."""
    x = ca.SX.sym("x", 2)
    return ca.Function("k", [x], [gain * x[1]])


@pytest.fixture(scope="module")
def undamped():
    return oscillator()


@pytest.fixture(scope="module")
def damped():
    return oscillator(damping=0.4)


def x0_of(model):
    return model.state(x=[1.0], v=[0.0])


def estimate(msg: str) -> float:
    found = re.search(r"estimated stable step h < ([0-9.eE+-]+)", msg)
    assert found, msg
    return float(found.group(1))


def outputs(h: float, n: int) -> np.ndarray:
    """``n`` output intervals of one step ``h`` each (the step is exactly ``h``)."""
    return h * np.arange(n + 1)


# ----------------------------------------------------------------------------------------
# beyond the stable range: an error with the step and the estimate; within: a long run


@pytest.mark.parametrize("method", EXPLICIT)
def test_beyond_stability_raises_with_the_step_and_the_closed_form_estimate(undamped, method):
    # before: rk returned |x| = 6e33 and an energy drift of 1e67 at h w = 6, as a result
    for h in (1.5, 3.0):  # h w = 3 and 6
        with pytest.raises(SolverError) as info:
            simulate(undamped, x0_of(undamped), outputs(h, 40), method=method, step=h)
        msg = str(info.value)
        assert info.value.status == "unstable_step"
        assert f"step h = {h:g} is beyond the stable range" in msg
        assert f"h * |lambda|max = {h * W:.3g}" in msg
        assert estimate(msg) == pytest.approx(CLOSED_FORM[method], rel=2e-3)


@pytest.mark.parametrize("method", EXPLICIT)
def test_the_estimate_is_the_closed_form_boundary(undamped, method):
    """Just inside the closed-form range 2000 steps pass; just outside they fail."""
    edge = CLOSED_FORM[method]
    inside = simulate(undamped, x0_of(undamped), outputs(0.99 * edge, 2000), method=method,
                      step=0.99 * edge)
    st = inside.diagnostics["stability"]
    assert st["status"] == "stable" and st["step_linearised_at"] >= 1
    assert st["conserved_invariants"] == ["energy"]
    # the numerical amplitude does not grow: |R| <= 1 (the energy norm is x^2 + v^2/W^2)
    norm = np.hypot(inside.x[:, 0], inside.x[:, 1] / W)
    assert norm.max() <= 1.0 + 1e-9
    with pytest.raises(SolverError, match="beyond the stable range"):
        simulate(undamped, x0_of(undamped), outputs(1.01 * edge, 2000), method=method,
                 step=1.01 * edge)


def test_collocation_is_a_stable_and_passes_beyond_the_explicit_ranges(undamped):
    tr = simulate(undamped, x0_of(undamped), outputs(3.0, 200), method="collocation", step=3.0)
    assert tr.diagnostics["stability"]["step_linearised_at"] is None  # no range to exceed
    assert tr.diagnostics["invariant_drift"]["energy"]["max_rel"] < 1e-9  # Gauss: symplectic


@pytest.mark.parametrize("method", EXPLICIT)
def test_backward_integration_beyond_stability_raises(undamped, method):
    t = outputs(1.5, 20)[::-1]
    with pytest.raises(SolverError, match=r"step h = 1.5 is beyond the stable range"):
        simulate(undamped, x0_of(undamped), t, method=method, step=1.5)


def test_lgvi_beyond_stability_names_the_step_and_the_small_oscillation_estimate():
    from models import pendulum3d as p3

    body = p3.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0.0, 0.0, 0.3], m=1.0, g=9.81)
    x0 = body.state(R=so3_exp([0.1, 0.05, 0.0]), omega=[0.0, 0.0, 0.0])  # near hanging
    # small oscillations: omega^2 = m g |rho| / J_xx, the fastest
    w = np.sqrt(9.81 * 0.3 / 0.13)
    ok = simulate(body, x0, np.linspace(0.0, 60.0, 61), method="lgvi", step=0.3)  # h w = 1.4
    assert ok.diagnostics["stability"]["status"] == "stable"
    with pytest.raises(SolverError) as info:
        simulate(body, x0, np.linspace(0.0, 60.0, 21), method="lgvi", step=0.6)  # h w = 2.9
    # its Newton iteration fails first (that stays the status); the message adds the range
    assert info.value.status in ("unstable_step", "newton_not_converged")
    assert "step h = 0.6 is beyond the stable range" in str(info.value)
    assert estimate(str(info.value)) == pytest.approx(2.0 / w, rel=0.03)


def test_s2_variational_beyond_stability_names_the_step_and_the_estimate():
    sph = spherical_pendulum(m=1.0, l=1.0, g=9.81)
    q = np.array([np.sin(0.1), 0.0, np.cos(0.1)])  # near the bottom
    x0 = sph.state(q=np.concatenate([q, np.zeros(3)]))
    ok = simulate(sph, x0, np.linspace(0.0, 60.0, 21), method="s2_variational", step=0.5)
    assert ok.diagnostics["stability"]["conserved_invariants"] == ["energy"]
    with pytest.raises(SolverError) as info:
        simulate(sph, x0, np.linspace(0.0, 60.0, 21), method="s2_variational", step=0.75)
    # its update has no solution a few steps on (that stays the status), the range is named
    assert info.value.status in ("unstable_step", "no_solution")
    assert "step h = 0.75 is beyond the stable range" in str(info.value)
    assert estimate(str(info.value)) == pytest.approx(2.0 / np.sqrt(9.81), rel=0.03)


# ----------------------------------------------------------------------------------------
# damping and forcing: legitimate energy change is never flagged


@pytest.mark.parametrize("method", [*EXPLICIT, "collocation"])
def test_a_damped_run_within_stability_passes_and_beyond_fails(damped, method):
    tr = simulate(damped, x0_of(damped), outputs(0.5, 400), method=method, step=0.5)
    E = tr.invariant_series("energy")
    assert E[-1] < 1e-10 * E[0]  # the energy is dissipated by ten orders of magnitude
    assert tr.diagnostics["stability"]["conserved_invariants"] == []  # so it is not checked
    if method == "collocation":
        return
    with pytest.raises(SolverError, match="beyond the stable range"):
        simulate(damped, x0_of(damped), outputs(1.5, 40), method=method, step=1.5)


@pytest.mark.parametrize("method", EXPLICIT)
def test_a_forced_run_within_stability_passes_and_beyond_fails(undamped, method):
    k = feedback(0.2)  # eigenvalues 0.1 +- 2i: the exact energy grows like e^(0.2 t)
    tr = simulate(undamped, x0_of(undamped), outputs(0.25, 400), controller=k, method=method,
                  step=0.25)
    E = tr.invariant_series("energy")
    assert E[-1] > 100 * DRIFT_LIMIT * E[0]  # far beyond what a conserved energy may drift
    # and it is the right growth: the energy's mean rate is 2 Re(lambda) = 0.2
    assert np.log(E[-1] / E[0]) / tr.t[-1] == pytest.approx(0.2, rel=0.01)
    assert tr.diagnostics["stability"]["conserved_invariants"] == []
    with pytest.raises(SolverError, match="beyond the stable range") as info:
        simulate(undamped, x0_of(undamped), outputs(1.5, 40), controller=k, method=method,
                 step=1.5)
    assert estimate(str(info.value)) < 1.5


# ----------------------------------------------------------------------------------------
# the invariant check: a conserved invariant that jumps is refused, a dissipated one is not


def exact_orbit(n: int, blow_up_at: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 10.0, n)
    x = np.column_stack([np.cos(W * t), -W * np.sin(W * t)])
    x[blow_up_at:] *= 10.0  # energy x 100 from there on
    return t, x


def test_a_conserved_invariant_that_jumps_is_refused_with_its_time(undamped):
    t, x = exact_orbit(50, 30)
    check = StepCheck(undamped, probe_for(undamped, None), "collocation", None, False, 0.1)
    with pytest.raises(SolverError) as info:
        check.run(t, x)
    assert info.value.status == "invariant_drift"
    assert f"by t = {t[30]:.6g}" in str(info.value) and "'energy'" in str(info.value)
    t, x = exact_orbit(50, 50)  # the unchanged orbit passes
    assert check.run(t, x)["stability"]["conserved_invariants"] == ["energy"]


def test_a_dissipated_invariant_may_fall_but_not_rise_and_a_forced_one_is_not_checked(
        damped, undamped):
    """The damped energy can only fall along the flow: a fall of any size passes, a rise
    by more than DRIFT_LIMIT times its scale is refused; a fed energy may do either."""
    t, x = exact_orbit(50, 30)  # the energy x 100 from t[30] on
    check = StepCheck(damped, probe_for(damped, None), "collocation", None, False, 0.1)
    with pytest.raises(SolverError) as info:
        check.run(t, x)
    assert info.value.status == "invariant_drift"
    assert f"rose from 2 to 200 by t = {t[30]:.6g}" in str(info.value)
    assert "does not increase" in str(info.value)
    fallen = x.copy()
    fallen[30:] *= 1e-5  # the energy / 1e10: what damping may do
    st = check.run(t, fallen)["stability"]
    assert st["conserved_invariants"] == [] and st["non_increasing_invariants"] == ["energy"]
    forced = StepCheck(undamped, probe_for(undamped, feedback(0.2)), "collocation", None,
                       False, 0.1)
    st = forced.run(t, x)["stability"]
    assert st["conserved_invariants"] == [] and st["non_increasing_invariants"] == []


def test_a_state_exploding_beyond_the_flow_is_refused_whatever_the_method(damped, undamped):
    """The growth check: a dissipated run (no invariant to watch) whose state jumps by
    1e8 is refused; the same growth at the rate the forced flow has passes."""
    t = np.linspace(0.0, 10.0, 51)
    x = np.column_stack([np.cos(W * t), -W * np.sin(W * t)])
    blown = x.copy()
    blown[40:] *= 1e8
    check = StepCheck(damped, probe_for(damped, None), "collocation", None, False, 0.1)
    with pytest.raises(SolverError) as info:
        check.run(t, blown)
    assert info.value.status == "unstable_step"
    assert f"by t = {t[40]:.6g}" in str(info.value) and "grew to" in str(info.value)
    assert check.run(t, x)["stability"]["status"] == "stable"
    # forced: alpha = 0.1 at x0, the flow allows e^(0.1 t); e^(0.1 t) growth is fine
    forced = StepCheck(undamped, probe_for(undamped, feedback(0.2)), "collocation", None,
                       False, 0.1)
    grown = x * np.exp(0.1 * t)[:, None]
    assert forced.run(t, grown)["stability"]["status"] == "stable"


# ----------------------------------------------------------------------------------------
# NaN is a defect of the field or controller, not a step to reduce


def nan_controller() -> ca.Function:
    x = ca.SX.sym("x", 2)
    return ca.Function("k", [x], [ca.sqrt(-1.0 - x[0])])  # NaN for x > -1


@pytest.mark.parametrize("method", [*EXPLICIT, "collocation"])
def test_a_nan_controller_is_named_with_its_state_and_time(undamped, method):
    with pytest.raises(SolverError) as info:
        simulate(undamped, x0_of(undamped), outputs(0.1, 20), controller=nan_controller(),
                 method=method, step=0.1)
    msg = str(info.value)
    assert "controller" in msg and "t = 0" in msg and "[1. 0.]" in msg, msg
    assert "Reduce step" not in msg and "reduce step" not in msg


def test_a_nan_field_is_named_with_its_state_and_time():
    man = ProductManifold([("x", Rn(1))])
    model = Model(name="sqrt_field", manifold=man, n_inputs=0, parameters=(), values={},
                  vector_field=lambda ctx: ca.sqrt(ctx["x"]))
    for method in ("rk", "rkmk4"):
        with pytest.raises(SolverError) as info:
            simulate(model, np.array([-1.0]), outputs(0.1, 10), method=method, step=0.1)
        msg = str(info.value)
        assert info.value.status == "non_finite_field" and "field" in msg, msg
        assert "x = [-1.]" in msg and "Reduce step" not in msg


# ----------------------------------------------------------------------------------------
# sizes unrolled into a graph or allocated are bounded before anything is built


def test_newton_max_iter_and_chunk_are_bounded_with_the_bound_in_the_message(undamped):
    with pytest.raises(ParameterError, match=r"newton_max_iter must be .*<= 50.*unrolled"):
        simulate(undamped, x0_of(undamped), outputs(0.1, 5), method="mechanics_variational",
                 step=0.1, newton_max_iter=10**7)
    with pytest.raises(ParameterError, match=rf"chunk must be .*<= {MAX_CHUNK}"):
        integrate(undamped, rkmk4(undamped), x0_of(undamped), outputs(0.1, 5), step=0.1,
                  chunk=10**9)


def test_sample_repeat_halving_and_worker_counts_are_bounded_before_any_work(undamped):
    from workbench.simulation import sweep
    from workbench.simulation._simulate import MAX_POINTS
    from workbench.simulation._sweep import MAX_WORKERS
    from workbench.simulation.accuracy import AccuracySweep, default_reference, work_precision
    from workbench.simulation.accuracy.work_precision import MAX_HALVINGS, MAX_REPEATS

    sweeps = [AccuracySweep("rk", (0.1,))]
    with pytest.raises(ParameterError, match=rf"n_samples must be .*<= {MAX_POINTS}"):
        work_precision(undamped, x0_of(undamped), 1.0, sweeps, n_samples=10**12)
    with pytest.raises(ParameterError, match=rf"repeats must be .*<= {MAX_REPEATS}"):
        work_precision(undamped, x0_of(undamped), 1.0, sweeps, repeats=10**9)
    with pytest.raises(ParameterError, match=rf"halvings must be .*<= {MAX_HALVINGS}"):
        default_reference(1.0, halvings=60)
    with pytest.raises(ParameterError, match=rf"workers must be .*<= {MAX_WORKERS}"):
        sweep(abs, [{"x": 1}], workers=10**6)


# ----------------------------------------------------------------------------------------
# an instability between outputs: a stiff wall hit and left within one output interval


def wall(damping: float) -> Model:
    """``V = x^2 / 2 + x^12``: soft near 0, stiff for ``|x| > 1`` (``V'' = 1 + 132 x^10``)."""
    s = mechanics.System("wall")
    f = s.rn("x", 1, velocity="v")
    s.kinetic(0.5 * ca.dot(f.v, f.v))
    s.potential(0.5 * f.x[0] ** 2 + f.x[0] ** 12)
    if damping:
        s.dissipation(0.5 * damping * f.v[0] ** 2)
    return s.model()


@pytest.mark.parametrize(("method", "v0", "horizon", "h"), [
    ("rk", 6.0, 1.7, 0.0763536),                     # energy 18 -> 1.9e8, was "stable"
    ("mechanics_variational", 4.0, 1.0, 0.0873806),  # energy 8 -> 4.2e9, was "stable"
])
def test_a_damped_wall_exploding_between_outputs_is_refused_and_the_estimate_holds(
        method, v0, horizon, h):
    """Two outputs, the blow-up between them: the linearised step at the outputs (soft
    region) sees nothing, but the damped energy, which the flow can only lower, rose by
    orders of magnitude. The interval is stepped again: the error names the state at the
    wall where the step is unstable, and the step estimated there runs, its energy never
    rising and ending within 10 % of CVODES'."""
    model = wall(0.02)
    x0 = model.state(x=[0.0], v=[v0])
    t = np.array([0.0, horizon])
    with pytest.raises(SolverError) as info:
        simulate(model, x0, t, method=method, step=h)
    msg = str(info.value)
    assert info.value.status == "unstable_step" and "between outputs" in msg, msg
    state = re.search(r"\(x = \[\s*([-0-9.e+]+)", msg)
    assert state and abs(float(state.group(1))) > 1.0  # at the wall, where V'' > 133
    est = estimate(msg)
    assert est < h
    ok = simulate(model, x0, t, method=method, step=est)
    ref = simulate(model, x0, t, rtol=1e-12, atol=1e-12)
    E, E_ref = ok.invariant_series("energy"), ref.invariant_series("energy")
    # stable, if coarse: the energy never rises by more than 5 % (it rose 1e7-fold at h),
    # and ends within 15 % of CVODES' (RK4 loses 11 % more, the variational step gains 4 %)
    assert np.max(E - E[0]) <= 0.05 * E[0]
    assert E[-1] == pytest.approx(E_ref[-1], rel=0.15)
    assert ok.diagnostics["stability"]["non_increasing_invariants"] == ["energy"]


def test_a_conservative_wall_whose_energy_grows_elevenfold_is_refused():
    """Undamped, RK4 at h = 0.1: the energy went 8 -> 89 between the outputs (it was
    accepted within the former 10 times its scale); the conserved energy may move by
    DRIFT_LIMIT = 1 times its scale (2 E0 here: E is a quadratic form near 0) at most."""
    model = wall(0.0)
    with pytest.raises(SolverError, match="changed from 8 to 88.9") as info:
        simulate(model, model.state(x=[0.0], v=[4.0]), np.array([0.0, 1.0]), method="rk",
                 step=0.1)
    assert info.value.status == "unstable_step"


def test_the_drift_limit_admits_the_variational_energy_error_of_stable_steps(undamped):
    """The variational step on x'' = -W^2 x conserves v^2 + W^2 (1 - c) x^2, c = (h W / 2)^2,
    so from x = 0 the energy peaks at exactly E0 / (1 - c): a rise of c / (2 (1 - c)) times
    the scale 2 E0, within DRIFT_LIMIT = 1 up to c = 2/3 (h W = 1.633); beyond it refused
    (the steps are stable but the energy error exceeds the energy)."""
    x0 = undamped.state(x=[0.0], v=[1.0])
    for hw in (1.3, 1.5, 1.62):  # rotation angles incommensurate with pi: the peak is met
        h = hw / W
        tr = simulate(undamped, x0, h * np.arange(401), method="mechanics_variational",
                      step=h)
        E = tr.invariant_series("energy")
        assert E.max() / E[0] == pytest.approx(1.0 / (1.0 - (hw / 2) ** 2), rel=1e-4)
    with pytest.raises(SolverError) as info:
        simulate(undamped, x0, 0.85 * np.arange(401), method="mechanics_variational",
                 step=0.85)
    assert info.value.status == "invariant_drift"  # h W = 1.7: c / (2 (1 - c)) = 1.30


def test_a_forced_run_is_never_flagged_for_its_energy_rise(undamped):
    """The loop feeds the energy (grad E . f > 0 at the samples): its rise by e^(0.2 t) over
    100 s, a factor 5e8, is legitimate, within the stable range."""
    tr = simulate(undamped, x0_of(undamped), outputs(0.25, 400), controller=feedback(0.2),
                  method="rk", step=0.25)
    st = tr.diagnostics["stability"]
    assert st["non_increasing_invariants"] == [] and st["conserved_invariants"] == []


# ----------------------------------------------------------------------------------------
# a run that meets a singular kinetic energy says so, with the state and the time


def coupled() -> Model:
    """``T = (v1^2 + v2^2) / 2 + q1 v1 v2``: ``M = [[1, q1], [q1, 1]]``, singular on
    ``|q1| = 1`` and indefinite beyond; ``V = -2 q1`` pulls ``q1`` from 0.5 towards 1."""
    s = mechanics.System("coupled")
    q = s.rn("q", 2, velocity="v")
    s.kinetic(0.5 * (q.v[0] ** 2 + q.v[1] ** 2) + q.x[0] * q.v[0] * q.v[1])
    s.potential(-2.0 * q.x[0])
    return s.model()


@pytest.mark.parametrize("method", ["rk", "rkmk4"])
def test_a_fixed_step_run_past_a_singular_kinetic_energy_names_the_first_bad_state(method):
    model = coupled()
    x0 = model.state(q=[0.5, 0.0], v=[0.0, 0.0])
    with pytest.raises(SolverError) as info:
        simulate(model, x0, np.linspace(0.0, 3.0, 31), method=method, step=0.05)
    msg = str(info.value)
    assert info.value.status == "kinetic_energy_not_definite", msg
    assert "not positive definite" in msg and "Reduce step" not in msg
    when = float(re.search(r"at t = ([0-9.e+-]+) \(state", msg).group(1))
    q1 = float(re.search(r"at the state x = \[\s*([-0-9.e+]+)", msg).group(1))
    assert abs(q1) > 1.0  # M's eigenvalues are 1 +- q1: indefinite there
    assert when > 0.5  # after the exact motion reaches q1 = 1 (CVODES stalls at t = 0.5002)


def test_cvodes_stalling_at_a_singular_kinetic_energy_says_so_and_not_raise_max_steps():
    model = coupled()
    x0 = model.state(q=[0.5, 0.0], v=[0.0, 0.0])
    with pytest.raises(SolverError) as info:
        simulate(model, x0, np.array([0.0, 3.0]), max_steps=20_000)
    msg = str(info.value)
    reached = float(re.search(r"no further than t = ([0-9.e+-]+), x = \[\s*([-0-9.e+]+)",
                              msg).group(1))
    q1 = float(re.search(r"no further than t = [0-9.e+-]+, x = \[\s*([-0-9.e+]+)",
                         msg).group(1))
    assert reached == pytest.approx(0.5002, abs=1e-3) and q1 == pytest.approx(1.0, abs=1e-3)
    assert "singularity of the equations" in msg and "raise max_steps" not in msg
