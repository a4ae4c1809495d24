"""The OCP's defaults: projected handling, structured guesses, the Auto strategy, diagnoses.

Mathematics checked: the projection lands on the manifold and fixes it; the kinematics read
off the field reproduce it; the structured guesses' velocities satisfy the kinematics and
their energy-pumping start is a trajectory of the model under admissible controls; the
controllable great circle of the rail pendulum is the one the force drives (closed form:
the force along e1 swings the bob about e2); the default strategy solves a weak-motor
swing-up nobody tuned, on the manifold to 1e-10, deterministically; failures name their
worst constraint.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import furuta, rail_pendulum
from models.chain_cart import chain_cart, link_state
from workbench.control.ocp import (
    OCP,
    Auto,
    Collocation,
    Direct,
    HermiteSimpson,
    ManifoldHandling,
    OCPStatus,
    TargetPoint,
    solve,
)
from workbench.control.ocp.initial import (
    controllable_axes,
    pumping,
    structure,
    structured_guesses,
)
from workbench.control.ocp.projection import projection_function
from workbench.control.ocp.pumping import energy_pumping
from workbench.control.ocp.stepper import Stepper
from workbench.core.errors import ParameterError
from workbench.core.manifolds import S1, S2, SO3, TS2, ProductManifold, Rn

E1, E2, E3 = np.eye(3)


def _effort_time(model, x0, xf, u_max, T):
    return OCP(model, x0=x0, target=TargetPoint(model.manifold, xf), u_lower=-u_max,
               u_upper=u_max, T=T, running_cost=lambda x, u: ca.dot(u, u),
               terminal_cost=lambda x, T: T)


@pytest.fixture(scope="module")
def weak_furuta():
    model = furuta.furuta()
    return _effort_time(model, furuta.hanging(model), furuta.upright(model), 0.01, (0.5, 4.0))


@pytest.fixture(scope="module")
def rail():
    model = rail_pendulum.rail_pendulum()
    return OCP(model, x0=rail_pendulum.hanging(model),
               target=TargetPoint(model.manifold, rail_pendulum.inverted(model)),
               u_lower=-10.0, u_upper=10.0, T=3.0, running_cost=lambda x, u: ca.dot(u, u))


# --- the projection ----------------------------------------------------------------------


def test_projection_lands_on_the_manifold_and_fixes_it():
    man = ProductManifold([("x", Rn(2)), ("a", S1()), ("q", S2()), ("w", TS2()),
                           ("R", SO3())])
    P = projection_function(man)
    rng = np.random.default_rng(0)
    for _ in range(20):
        x = man.random_point(rng)
        assert np.allclose(np.asarray(P(x)).ravel(), x, rtol=0, atol=1e-15)  # fixed points
        near = x + 1e-2 * rng.standard_normal(x.size)
        y = np.asarray(P(near)).ravel()
        assert max(man.residual_norms(y).values()) < 1e-14  # on the manifold
        assert np.abs(y - near).max() < 0.1  # and near the point projected
        assert np.allclose(np.asarray(P(y)).ravel(), y, atol=1e-14)  # idempotent
        R = SO3.matrix(y[man.slices["R"]])
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)


def test_projected_hermite_simpson_keeps_its_nodes_where_ambient_drifts():
    model = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    x0, xf = np.r_[0, 0, 0, 0, link_state(E3)], np.r_[0, 0, 0, 0, link_state(-E3)]
    ocp = _effort_time(model, x0, xf, 10.0, (0.5, 3.0))
    one = {"strategy": Direct(), "defect_tol": None}
    amb = solve(ocp, HermiteSimpson(N=20), handling=ManifoldHandling.AMBIENT,
                manifold_tol=None, **one)
    proj = solve(ocp, HermiteSimpson(N=20), guess=amb, **one)  # the default handling
    assert proj.handling is ManifoldHandling.PROJECTED
    assert amb.error["manifold_residual"] > 1e-5  # Lobatto IIIA drifts off TS^2 ...
    assert proj.error["manifold_residual"] <= 1e-10  # ... the projected nodes do not
    assert proj.objective == pytest.approx(amb.objective, rel=2e-2)  # O(h^4) apart
    # the ambient nodes are refused by the default manifold_tol
    again = solve(ocp, HermiteSimpson(N=20), handling=ManifoldHandling.AMBIENT, guess=amb,
                  raise_on_failure=False, **one)
    assert again.status is OCPStatus.OFF_MANIFOLD and not again.status.ok


# --- the structure read off the field --------------------------------------------------------


@pytest.mark.parametrize("make", [lambda: chain_cart(2), furuta.furuta,
                                  rail_pendulum.rail_pendulum], ids=["chain", "furuta", "rail"])
def test_kinematics_read_off_the_field_reproduce_it(make):
    model = make()
    st = structure(model)
    assert st is not None
    f = model.function("f")
    rng = np.random.default_rng(1)
    for _ in range(5):
        x = model.manifold.random_point(rng)
        u = rng.standard_normal(model.n_inputs)
        fx = np.asarray(f(x, u, model.p)).ravel()
        K = np.asarray(st.kinematics(x, model.p))
        # the configuration rates are K v, whatever the input
        assert np.allclose(K @ x[st.velocity], fx[st.config], rtol=0, atol=1e-12)
        fv0, Bv = (np.asarray(a) for a in st.drift(x, model.p))
        assert np.allclose(fv0.ravel() + Bv @ u, fx[st.velocity], rtol=1e-10, atol=1e-10)


def test_the_controllable_great_circle_is_the_one_the_force_drives(rail):
    axes, where = controllable_axes(rail)
    assert where == "x0"
    # the force along e1 swings the bob in the e1-e3 plane: about e2 (closed form)
    assert np.abs(np.abs(axes["q"] @ E2) - 1.0) < 1e-9


def test_structured_paths_satisfy_the_kinematics(rail):
    g = pumping(rail, half_swings=2)
    st = structure(rail.model)
    man = rail.model.manifold
    guess = g.guess
    assert max(max(man.residual_norms(x).values()) for x in guess.x) < 1e-12
    f = rail.model.function("f")
    dt = guess.T * (guess.s[1] - guess.s[0])  # equal samples
    c = guess.x[:, st.config]
    for i in range(5, len(guess.s) - 5, 20):  # fourth-order central differences
        rate = (8 * (c[i + 1] - c[i - 1]) - (c[i + 2] - c[i - 2])) / (12 * dt)
        fx = np.asarray(f(guess.x[i], guess._at(guess.s[i:i + 1])[0], rail.model.p)).ravel()
        assert np.abs(fx[st.config] - rate).max() < 1e-5 * max(1.0, np.abs(rate).max())


def test_energy_pumping_start_is_a_trajectory_under_admissible_controls(weak_furuta):
    g = energy_pumping(weak_furuta)
    assert g is not None
    guess = g.guess
    assert np.all(np.abs(guess.u) <= 0.01 + 1e-15)
    stepper = Stepper(weak_furuta.model, rtol=1e-8, atol=1e-8)
    h = guess.T / (len(guess.s) - 1)
    for k in range(0, len(guess.u), 37):  # each held sample steps node k to node k+1
        nxt = stepper.step(guess.x[k], guess.u[k], h)
        assert np.abs(nxt - guess.x[k + 1]).max() < 1e-6
    # the free final time ends where the link comes closest to upright
    alpha = guess.x[-1][weak_furuta.model.manifold.slices["alpha"]]
    assert alpha[0] < -0.99  # cos(alpha) ~ -1: upright


def test_structured_guesses_are_deterministic(rail):
    a = [g.description for g in structured_guesses(rail)]
    b = [g.description for g in structured_guesses(rail)]
    assert a == b and len(a) >= 2


# --- the default strategy -------------------------------------------------------------------


def test_default_strategy_swings_up_a_weak_motor_nobody_tuned(weak_furuta):
    sol = solve(weak_furuta, Collocation(N=60))
    assert sol.status.ok
    assert sol.error["manifold_residual"] <= 1e-10
    assert sol.error["target_residual"] < 1e-8
    assert np.abs(sol.u).max() <= 0.01 + 1e-8
    assert any(a["guess"].startswith("energy pumping") for a in sol.attempts)
    assert sol.attempts[-1]["status"] == "SUCCESS"
    assert sol.cost["strategy_attempts"] == len(sol.attempts)
    # deterministic: the same problem, the same attempts
    again = solve(weak_furuta, Collocation(N=60))
    assert [(a["what"], a["guess"], a["iterations"]) for a in again.attempts] == \
        [(a["what"], a["guess"], a["iterations"]) for a in sol.attempts]


def test_a_guess_given_is_relaxed_then_polished(rail):
    first = solve(rail, Collocation(N=30), strategy=Direct(),
                  handling=ManifoldHandling.LIE_GROUP)
    sol = solve(rail, Collocation(N=30), guess=first)
    assert sol.status.ok and sol.attempts[0]["guess"].startswith("given")
    assert sol.objective == pytest.approx(first.objective, rel=1e-3)


def test_an_impossible_problem_fails_with_its_attempts_and_a_diagnosis(rail):
    short = rail.with_bounds(u_lower=-0.5, u_upper=0.5, T=0.3)  # cannot invert in 0.3 s
    sol = solve(short, Collocation(N=15), raise_on_failure=False,
                strategy=Auto(swings=1, bound_factors=(), terminal_slacks=(),
                              coarse_factor=0))
    assert not sol.status.ok
    assert len(sol.attempts) >= 2
    d = sol.diagnosis
    assert d is not None and d["worst_constraint"]["kind"] is not None
    assert d["primal_infeasibility"] > 1e-6
    assert "Try next" in sol.message and d["advice"]


def test_strategy_knobs_are_checked():
    with pytest.raises(ParameterError, match="bound_factors"):
        Auto(bound_factors=(2.0, 4.0))
    with pytest.raises(ParameterError, match="bound_factors"):
        Auto(bound_factors=(0.5,))
    with pytest.raises(ParameterError, match="terminal_slacks"):
        Auto(terminal_slacks=(0.0,))
    with pytest.raises(ParameterError, match="swings"):
        Auto(swings=-1)
    with pytest.raises(ParameterError, match="relax"):
        Auto(relax="yes")


def test_strategy_and_handling_must_be_of_their_kinds(rail):
    with pytest.raises(ParameterError, match="strategy"):
        solve(rail, Collocation(N=10), strategy="auto")
    with pytest.raises(ParameterError, match="handling"):
        solve(rail, Collocation(N=10), handling="projected")
    with pytest.raises(ParameterError, match="manifold_tol"):
        solve(rail, Collocation(N=10), manifold_tol=-1.0)


# --- multistart over the structured starts, here and on a dask cluster ------------------------


def rail_problem(u_max: float = 10.0):
    """A module-level builder (picklable): the rail swing-up of the fixture, T free."""
    model = rail_pendulum.rail_pendulum()
    return OCP(model, x0=rail_pendulum.hanging(model),
               target=TargetPoint(model.manifold, rail_pendulum.inverted(model)),
               u_lower=-u_max, u_upper=u_max, T=(1.0, 3.0),
               running_cost=lambda x, u: ca.dot(u, u), terminal_cost=lambda x, T: T,
               name="rail")


def test_structured_multistart_keeps_the_cheapest_of_the_deterministic_starts():
    from workbench.control.ocp import multistart

    ocp = rail_problem()
    best, records = multistart(ocp, Collocation(N=20), starts="structured", max_iter=150,
                               defect_tol=None)
    names = [g.name for g in structured_guesses(ocp)]
    assert [r["seed"] for r in records] == names  # one record per structured start
    ok = [r["objective"] for r in records if r["status"] in ("SUCCESS", "ACCEPTABLE")]
    assert ok and best.objective == pytest.approx(min(ok), rel=1e-9)
    assert best.error["manifold_residual"] <= 1e-10


def test_multistart_on_a_dask_cluster_equals_multistart_here():
    import functools

    from workbench.control.ocp import multistart
    from workbench.simulation import local_cluster

    dask = pytest.importorskip("dask")
    pytest.importorskip("dask.distributed")
    ocp = rail_problem()
    options = {"starts": "structured", "max_iter": 150, "defect_tol": None}
    here, rec_here = multistart(ocp, Collocation(N=20), **options)
    # dask's nanny sets OMP/BLAS threads to 1 in its workers; the linear algebra's sums then
    # run in another order, and a start of 120 iterations ends elsewhere. The same solves
    # in the same numerical environment are compared: the worker inherits this process's.
    with dask.config.set({"distributed.nanny.pre-spawn-environ": {}}), \
            local_cluster(workers=1) as client:  # a worker process: the OCP is rebuilt
        there, rec_there = multistart(ocp, Collocation(N=20), executor=client,
                                      build=functools.partial(rail_problem, 10.0), **options)
    assert [r["status"] for r in rec_there] == [r["status"] for r in rec_here]
    for a, b in zip(rec_here, rec_there):  # the same deterministic solves, elsewhere
        assert a["objective"] == pytest.approx(b["objective"], rel=1e-8)
        assert a["iterations"] == b["iterations"]
    assert there.objective == pytest.approx(here.objective, rel=1e-8)


def test_multistart_on_an_executor_needs_a_picklable_build_of_the_same_problem():
    from concurrent.futures import ThreadPoolExecutor

    from workbench.control.ocp import multistart

    ocp = rail_problem()
    with ThreadPoolExecutor(1) as pool:
        with pytest.raises(ParameterError, match="build must be"):
            multistart(ocp, Collocation(N=10), executor=pool)
        with pytest.raises(ParameterError, match="picklable"):
            multistart(ocp, Collocation(N=10), executor=pool, build=lambda: ocp)
        with pytest.raises(ParameterError, match="same problem"):
            import functools
            multistart(ocp, Collocation(N=10), executor=pool,
                       build=functools.partial(rail_problem, 5.0))
    with pytest.raises(ParameterError, match="starts must be"):
        multistart(ocp, Collocation(N=10), starts="random")
