"""CVODES runs are checked after the fact, and its step can be bounded.

The hostile review found a point mass flying at a narrow potential wall (height 5, kinetic
energy 2: it must bounce) passing through it under CVODES: in free flight the force
underflows to exactly 0, the error estimate is 0 and the step grows until it jumps the
wall. Here: with ``max_step`` below the wall's width the bounce matches its closed form
(by quadrature); with the default unbounded step and 51 outputs the run is refused (its
energy moves by 2.5e7 times what the tolerances allow); ``rtol`` is a relative tolerance
in ``(0, 1e-3]`` (1e3 returned a unit vector of length 4e17); an exploded state, a state
off its manifold and a non-smooth invariant that the field really moves are told apart;
damped and forced runs, whose energy legitimately changes, pass and balance their power.
"""

from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import quad, simpson

from models.spherical import spherical_pendulum
from tests.conftest import assert_close
from workbench import mechanics
from workbench.core.errors import ModelError, SolverError
from workbench.simulation import simulate
from workbench.simulation._cvodes import RTOL_MAX, RunCheck, cvodes_options
from workbench.simulation._invariant_check import TOLERANCE_SAFETY, classify
from workbench.simulation._probe import probe_for
from workbench.simulation._stability import GROWTH_LIMIT

HEIGHT, CENTRE, WIDTH = 5.0, 2.0, 0.1  # V = HEIGHT exp(-((x - CENTRE) / WIDTH)^2)
X0, V0, HORIZON = -3.0, 2.0, 5.0  # E = V0^2 / 2 = 2 < HEIGHT: it must bounce


@pytest.fixture(scope="module")
def wall():
    s = mechanics.System("wall")
    x = s.rn("x", 1, velocity="v")
    s.point_mass(1.0, ca.vertcat(x.x, 0, 0))
    s.potential(HEIGHT * ca.exp(-(((x.x[0] - CENTRE) / WIDTH) ** 2)))
    return s.model()


def bounce_closed_form() -> float:
    """x(HORIZON) of the bounce, by quadrature of ``dt = dx / v(x)``.

    ``v(x) = sqrt(2 (E - V(x)))`` up to the turning point ``x* = CENTRE - WIDTH sqrt(ln(
    HEIGHT / E))``; with ``x = x* - s^2`` the integrand ``2 s / v`` is smooth at ``s = 0``.
    The motion is symmetric about the turn, then free at speed V0 (V(X0) = 5 e^-2500 = 0).
    """
    energy = 0.5 * V0**2
    turn = CENTRE - WIDTH * math.sqrt(math.log(HEIGHT / energy))

    def potential(x: float) -> float:
        return HEIGHT * math.exp(-(((x - CENTRE) / WIDTH) ** 2))

    def integrand(s: float) -> float:
        if s == 0.0:  # the limit 2 / sqrt(2 V'(x*))
            return 2.0 / math.sqrt(2.0 * 2.0 * (CENTRE - turn) / WIDTH**2 * potential(turn))
        return 2.0 * s / math.sqrt(2.0 * (energy - potential(turn - s * s)))

    t_turn, err = quad(integrand, 0.0, math.sqrt(turn - X0), epsabs=1e-13, epsrel=1e-13,
                       limit=200)
    assert err < 1e-10
    return X0 - V0 * (HORIZON - 2.0 * t_turn)


def test_a_wall_jumped_between_51_outputs_is_refused_with_the_time_and_the_remedy(wall):
    x0 = wall.state(x=[X0], v=[V0])
    with pytest.raises(SolverError) as info:
        simulate(wall, x0, np.linspace(0.0, HORIZON, 51))
    msg = str(info.value)
    assert info.value.status == "invariant_drift"
    assert "'energy'" in msg
    # named: the first output where the run ignored the wall, between the start of its
    # tail (V = 5 e^-36 at x = CENTRE - 6 WIDTH, below the tolerance) and its top
    t_bad = float(re.search(r"by t = ([0-9.]+)", msg).group(1))
    assert (CENTRE - 6 * WIDTH - X0) / V0 <= t_bad <= (CENTRE - X0) / V0
    assert "times what the tolerances allow" in msg and "max_step" in msg
    assert "not detectable at the outputs" in msg  # the honest limit: equal energy both sides
    # backward in time, from the mirror image: the same wall, the same refusal
    with pytest.raises(SolverError, match="invariant 'energy'"):
        simulate(wall, wall.state(x=[X0], v=[-V0]), np.linspace(0.0, -HORIZON, 51))


@pytest.mark.parametrize("n_times", [6, 51])
def test_with_max_step_below_the_width_the_bounce_matches_its_closed_form(wall, n_times):
    x0 = wall.state(x=[X0], v=[V0])
    tr = simulate(wall, x0, np.linspace(0.0, HORIZON, n_times), max_step=WIDTH / 10)
    assert tr.options["max_step"] == WIDTH / 10
    assert_close(tr.x[-1, 0], bounce_closed_form(), atol=1e-6, what="x(5) of the bounce")
    assert_close(tr.x[-1, 1], -V0, atol=1e-8, what="the speed after the bounce")
    # energy conserved to the tolerance's level (1e-10 per step, about 700 steps)
    assert tr.diagnostics["invariant_drift"]["energy"]["max_rel"] < 1e-7
    checks = tr.diagnostics["checks"]
    assert checks["status"] == "passed" and checks["conserved_invariants"] == ["energy"]
    allowance = checks["drift_allowance"]["energy"]
    assert tr.diagnostics["invariant_drift"]["energy"]["max_abs"] < allowance / TOLERANCE_SAFETY


@pytest.mark.parametrize("rtol", [1.0, 1e3, 2e-3, 1 + 1e-12])
def test_rtol_is_a_relative_tolerance_up_to_the_bound(wall, rtol):
    x0 = wall.state(x=[X0], v=[V0])
    with pytest.raises(ModelError, match=rf"rtol must be a relative tolerance in \(0, "
                                         rf"{RTOL_MAX:g}\]; got {rtol!r}"):
        simulate(wall, x0, np.linspace(0.0, 1.0, 3), rtol=rtol)
    with pytest.raises(ModelError, match="rtol must be a relative tolerance"):
        cvodes_options(rtol=rtol, atol=1e-8)  # every CVODES user gets the bound


def test_rtol_at_the_bound_runs(wall):
    tr = simulate(wall, wall.state(x=[X0], v=[V0]), np.linspace(0.0, 1.0, 3), rtol=RTOL_MAX)
    assert tr.options["rtol"] == RTOL_MAX


@pytest.mark.parametrize(("kwargs", "pattern"), [
    ({"max_step": 0.0}, "max_step must be a positive number; got 0.0"),
    ({"max_step": -1}, "max_step must be a positive number; got -1"),
    ({"max_step": float("nan")}, "max_step must be a positive number; got nan"),
    ({"max_step": float("inf")}, "max_step must be a positive finite number; got inf"),
    ({"max_step": "0.1"}, "max_step must be a positive number"),
    ({"max_step": 1e-7, "max_steps": 1000},
     r"max_step = 1e-07 needs at least 5e\+06 steps .* more than max_steps = 1000"),
    ({"max_step": 0.1, "method": "rk", "step": 0.1}, "method 'rk' does not use max_step"),
])
def test_max_step_is_checked_before_anything_runs(wall, kwargs, pattern):
    with pytest.raises(ModelError, match=pattern):
        simulate(wall, wall.state(x=[X0], v=[V0]), np.linspace(0.0, 1.0, 3), **kwargs)


def test_max_step_bounds_the_whole_run_before_anything_runs(wall):
    """1e5 steps per output interval fit max_steps, but 1e9 over the horizon do not."""
    t = np.linspace(0.0, 1000.0, 10001)
    with pytest.raises(ModelError, match=r"max_step = 1e-06 needs at least 1e\+09 steps over "
                                         r"the horizon \(1000\), more than 1e\+08"):
        simulate(wall, wall.state(x=[X0], v=[V0]), t, max_step=1e-6, max_steps=10**6)


def pendulum(*, damping: float = 0.0, forced: bool = False):
    """A point mass on a unit circle under gravity, with Rayleigh damping or a torque."""
    s = mechanics.System("pendulum")
    th = s.s1("th", velocity="w")
    s.point_mass(1.0, ca.vertcat(th.sin, 0, th.cos))
    s.gravity(9.81)
    if damping:
        s.dissipation(0.5 * damping * th.rate**2)
    if forced:
        s.moment(th, s.input(1, "torque [N m]"))
    return s.model()


def test_a_state_off_its_manifold_is_refused_with_the_time():
    m = pendulum()
    with pytest.raises(SolverError) as info:  # atol = 1: no error control on |p| = 1
        simulate(m, m.state(th=1.0, w=[0.0]), np.linspace(0.0, 20.0, 201), rtol=1e-3, atol=1.0)
    assert info.value.status == "left_manifold"
    assert "constraint residual of factor 'th'" in str(info.value) and "at t = " in str(info.value)


def test_an_exploded_state_is_refused_with_the_time():
    """The growth check on a run with no invariant to watch (damped), as CVODES gives it."""
    m = pendulum(damping=0.3)
    t = np.linspace(0.0, 10.0, 51)
    x = simulate(m, m.state(th=1.0, w=[0.0]), t).x
    check = RunCheck(m, probe_for(m, None), cvodes_options(rtol=1e-10, atol=1e-10), 500, True)
    assert check.run(t, x)["checks"]["status"] == "passed"
    blown = x.copy()
    blown[40:] *= 1e8
    with pytest.raises(SolverError) as info:
        check.run(t, blown)
    assert info.value.status == "exploded" and f"by t = {t[40]:.6g}" in str(info.value)
    # the bounded rerun of the interval from the last state within the allowance does
    # not reproduce the blown one
    assert f"integrating again from t = {t[39]:.6g}" in str(info.value)


def test_a_damped_pendulum_passes_and_its_energy_falls_by_the_dissipated_power():
    c = 0.3
    m = pendulum(damping=c)
    t = np.linspace(0.0, 10.0, 2001)
    for rtol in (RTOL_MAX, 1e-10):
        tr = simulate(m, m.state(th=1.0, w=[0.0]), t, rtol=rtol, atol=rtol)
        assert tr.diagnostics["checks"]["non_increasing_invariants"] == ["energy"]
    energy, w = tr.invariant_series("energy"), tr.x[:, 2]
    # dE/dt = -c w^2: the energy lost is the dissipated work (Simpson, h^4 ~ 1e-11)
    assert_close(energy[-1] - energy[0], -c * simpson(w**2, x=t), atol=1e-7,
                 what="energy balance of the damped pendulum")
    assert energy[-1] < energy[0] - 1.0  # it really fell, far beyond any tolerance allowance


def test_a_forced_pendulum_passes_and_its_energy_rises_by_the_input_power():
    gain = 0.3
    m = pendulum(forced=True)
    xs = ca.SX.sym("x", m.manifold.ambient_dim)
    pump = ca.Function("pump", [xs], [gain * xs[2]])  # u = gain w: power gain w^2 >= 0
    t = np.linspace(0.0, 10.0, 2001)
    tr = simulate(m, m.state(th=1.0, w=[0.0]), t, controller=pump)
    checks = tr.diagnostics["checks"]
    assert checks["conserved_invariants"] == [] and checks["non_increasing_invariants"] == []
    energy, w = tr.invariant_series("energy"), tr.x[:, 2]
    assert_close(energy[-1] - energy[0], gain * simpson(w**2, x=t), atol=1e-6,
                 what="energy balance of the forced pendulum")
    assert energy[-1] - energy[0] > 1.0  # it rose far beyond any tolerance allowance


def test_an_invariant_the_field_moves_at_a_jump_is_not_refused():
    """A step in the potential with no force (``if_else``): the energy jumps by 0.1 where x
    crosses 1 though the field is free flight everywhere. The rates at the outputs call it
    conserved; the interval integrated again with the step bounded moves it too, so the
    field moves it and the exact free flight is returned."""
    s = mechanics.System("step")
    x = s.rn("x", 1, velocity="v")
    s.point_mass(1.0, ca.vertcat(x.x, 0, 0))
    s.potential(ca.if_else(x.x[0] < 1.0, 0.0, 0.1))
    m = s.model()
    t = np.linspace(0.0, 2.0, 11)
    tr = simulate(m, m.state(x=[0.0], v=[1.0]), t)
    assert_close(tr.x[:, 0], t, atol=1e-12, what="free flight")
    assert tr.diagnostics["invariant_drift"]["energy"]["max_abs"] == pytest.approx(0.1)
    assert tr.diagnostics["checks"]["conserved_invariants"] == []  # no longer watched


def test_a_loose_run_off_its_manifold_keeps_its_energy_watched():
    """At rtol = 1e-3 the spherical pendulum's states drift off TS^2, where the ambient
    field does not conserve the energy: classified at the raw states it would not be
    watched at all; at their projections to the manifold it is."""
    m = spherical_pendulum()
    q = np.array([math.sin(1.0), 0.0, -math.cos(1.0)])
    w = np.cross(q, [0.0, 1.5, 0.0])
    t = np.linspace(0.0, 50.0, 501)
    tr = simulate(m, np.r_[q, w], t, rtol=RTOL_MAX, atol=RTOL_MAX)
    assert tr.diagnostics["constraint_residual"]["q"] > 1e-3  # well off the manifold
    raw = classify(probe_for(m, None), m, tr.x, [0])
    assert raw.conserved == []
    assert tr.diagnostics["checks"]["conserved_invariants"] == ["energy"]


def line(potential, *, forced: bool = False):
    """A unit mass on a line with the potential ``potential(x)`` (and a force input)."""
    s = mechanics.System("line")
    x = s.rn("x", 1, velocity="v")
    s.point_mass(1.0, ca.vertcat(x.x, 0, 0))
    s.potential(potential(x.x[0]))
    if forced:
        s.force(x, s.input(1, "force [N]"))
    return s.model()


def hill_ramp(x):
    """``(x - 5)_+`` smoothed over 0.1: ``~0`` (5e-4 at x = 0) for x < 5, ``~x - 5`` beyond."""
    d = x - 5.0
    return 0.5 * (d + (d * d + 0.01) ** 0.5)


def test_a_run_that_rolls_off_a_hill_flat_at_x0_is_accepted_and_matches_its_quadrature():
    """``V = -(x - 5)_+^2 / 2``: free flight at v = 1 until x = 5, then ``x'' ~ x - 5``, so
    ``x ~ e^t``: 1.6e6 at t = 20, 8e4 times the growth allowed by the linearisation at x0
    (alpha ~ 2e-4 there), beyond the refusal's bound GROWTH_LIMIT = 1e4. Every output
    interval that leaves that allowance is reproduced by a bounded-step rerun, and the
    state is the flow's: the output times agree with the time to reach each output's x,
    ``t(x) = int_0^x dy / v(y)``, ``v(y) = sqrt(1 + ramp(y)^2 - ramp(0)^2)``
    (energy conservation)."""
    m = line(lambda x: -0.5 * hill_ramp(x) ** 2)
    t = np.linspace(0.0, 20.0, 101)
    tr = simulate(m, m.state(x=[0.0], v=[1.0]), t)
    assert tr.diagnostics["checks"]["status"] == "passed"
    check = RunCheck(m, probe_for(m, None), cvodes_options(rtol=1e-10, atol=1e-10), 1, True)
    allowed, _ = check._growth_allowance(t, tr.x, None)
    assert np.max(np.abs(tr.x[-1])) > GROWTH_LIMIT * allowed[-1]  # refused from x0 alone

    r0 = hill_ramp(0.0)

    def speed(y: float) -> float:
        return math.sqrt(1.0 + hill_ramp(y) ** 2 - r0**2)

    assert_close(tr.x[:, 1] / [speed(y) for y in tr.x[:, 0]], np.ones_like(t), atol=1e-7,
                 what="v / v(x) from the conserved energy")
    edges = np.r_[0.0, 4.0, 6.0, np.geomspace(10.0, 2e6, 12)]  # the integrand ~ 1 / y late
    pieces = np.cumsum([0.0, *(quad(lambda y: 1.0 / speed(y), a, b, epsabs=1e-13,
                                    epsrel=1e-13, limit=200)[0]
                               for a, b in zip(edges[:-1], edges[1:]))])
    for tk, xk in zip(t[1:], tr.x[1:, 0]):
        i = int(np.searchsorted(edges, xk)) - 1
        t_of_x = pieces[i] + quad(lambda y: 1.0 / speed(y), edges[i], xk, epsabs=1e-13,
                                  epsrel=1e-13, limit=200)[0]
        assert abs(t_of_x - tk) < 1e-6, (tk, xk, t_of_x)


@pytest.mark.parametrize("x0", [1.0, 1e-6])
def test_the_inverted_oscillator_over_30_s_is_accepted_and_matches_cosh(x0):
    """``x'' = x`` from rest: ``x = x0 cosh t`` grows to 5e12 x0. Its energy ``(v^2 -
    x^2) / 2 = -x0^2 / 2`` is the difference of two terms of size ``x^2 / 2``, known only
    to round-off in them (at t = 30 a unit of ``eps`` in each is 1e9 x0^2): the round-off
    allowance follows the terms at each state, not their size at x0. ``atol`` is that of
    a state of size 1 (1e-10) scaled to x0, so that the error is rtol's, not atol's."""
    m = line(lambda x: -0.5 * x**2)
    t = np.linspace(0.0, 30.0, 31)
    tr = simulate(m, m.state(x=[x0], v=[0.0]), t, atol=1e-10 * x0)
    assert tr.diagnostics["checks"]["conserved_invariants"] == ["energy"]
    assert_close(tr.x[:, 0] / (x0 * np.cosh(t)), np.ones_like(t), atol=1e-6,
                 what="x / (x0 cosh t)")
    assert_close(tr.x[1:, 1] / (x0 * np.sinh(t[1:])), np.ones(len(t) - 1), atol=1e-6,
                 what="v / (x0 sinh t)")


def test_a_run_through_the_wall_is_refused_with_a_controller_that_does_no_work(wall):
    """The wall's model with a force input: the controller ``u = 0`` conserves the energy
    and ``u = -c v`` does not increase it (closed-loop rates), so both are watched and the
    tunnelling run is refused as without a controller; with max_step below the width the
    zero-controller run bounces and matches the closed form."""
    m = line(lambda x: HEIGHT * ca.exp(-(((x - CENTRE) / WIDTH) ** 2)), forced=True)
    x0 = m.state(x=[X0], v=[V0])
    t = np.linspace(0.0, HORIZON, 51)
    xs = ca.SX.sym("x", m.manifold.ambient_dim)
    zero = ca.Function("zero", [xs], [ca.SX.zeros(1)])
    damp = ca.Function("damp", [xs], [-1e-3 * xs[1]])
    for controller, kind in ((zero, "conserves"), (damp, "does not increase")):
        with pytest.raises(SolverError) as info:
            simulate(m, x0, t, controller=controller)
        assert info.value.status == "invariant_drift"
        assert f"which the closed-loop field {kind}" in str(info.value)
    tr = simulate(m, x0, t, controller=zero, max_step=WIDTH / 10)
    assert tr.diagnostics["checks"]["conserved_invariants"] == ["energy"]
    assert_close(tr.x[-1, 0], bounce_closed_form(), atol=1e-6, what="x(5) of the bounce")
