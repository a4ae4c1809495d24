"""Findings of a second hostile review of the optimal-control layer, each checked in numbers.

A problem cannot change under its cached transcriptions (a change is a new, validated
problem whose solve follows it); a converged status is held to ``solve``'s ``tol`` whatever
Ipopt's own tolerances say; a solution of another problem as ``guess=`` is refused by
name; the work of one shooting evaluation and of a re-simulation is bounded before
anything runs; flags and axes are what they say.
"""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from tests.conftest import assert_close, ulps
from workbench import mechanics
from workbench.control.ocp import (
    OCP,
    Auto,
    Collocation,
    Direct,
    Guess,
    MultipleShooting,
    OCPStatus,
    PathConstraint,
    TargetPoint,
    TargetSet,
    solve,
)
from workbench.control.ocp.solution import MAX_RESIM_SAMPLES
from workbench.control.ocp.transcription import MAX_SHOOTING_STEPS, Integrator
from workbench.core.errors import ManifoldError, ParameterError, SolverError
from workbench.core.manifolds import ProductManifold, Rn

C = Collocation(N=20)
U_MAX = 5.0


@pytest.fixture(scope="module")
def pendulum():
    """A planar pendulum on S^1 with a torque (theta = 0 hangs)."""
    s = mechanics.System("pendulum_s1")
    a = s.s1("theta")
    s.point_mass(1.0, a.p)
    s.gravity(9.81, direction=[1.0, 0.0])
    s.moment(a, s.input(1, "torque [N m]"))
    return s.model()


def make_ocp(model, **kw):
    """theta 0 -> 2 rad at rest in 2 s, |u| <= 5 (the bound is active at the optimum)."""
    args = {"x0": model.state(theta=0.0, theta_dot=0.0),
            "target": TargetPoint(model.manifold, model.state(theta=2.0, theta_dot=0.0)),
            "u_lower": -U_MAX, "u_upper": U_MAX, "T": 2.0,
            "running_cost": lambda x, u: ca.dot(u, u), "name": "swing"}
    args.update(kw)
    return OCP(model, **args)


@pytest.fixture(scope="module")
def swing(pendulum):
    ocp = make_ocp(pendulum)
    return ocp, solve(ocp, C, strategy=Direct())


# --- a made problem is immutable; dataclasses.replace makes the changed one ---------------


def test_every_assignment_is_refused_naming_the_field_and_the_fix(pendulum):
    ocp = make_ocp(pendulum)
    xf = pendulum.state(theta=1.0, theta_dot=0.0)
    for name, value in (("T", 3.0), ("running_cost", lambda x, u: 10 * ca.dot(u, u)),
                        ("path_constraints", [PathConstraint(lambda x, u: u, -1.0, 1.0)]),
                        ("target", TargetPoint(pendulum.manifold, xf)),
                        ("x0", np.array([3.0, 0.0, 0.0])), ("u_upper", 1.0), ("tol", 1e-6)):
        with pytest.raises(dataclasses.FrozenInstanceError,
                           match=rf"assignment to '{name}'.*dataclasses\.replace\(ocp, {name}="):
            setattr(ocp, name, value)
    with pytest.raises(AttributeError, match="'horizon' is none of its fields"):
        ocp.horizon = 3.0  # type: ignore[attr-defined]
    with pytest.raises(AttributeError, match="deletion of 'T'"):
        del ocp.T
    assert ocp.T == 2.0 and ocp.T_range == (2.0, 2.0)  # nothing changed
    for arr in (ocp.x0, ocp.u_lower, ocp.u_upper, ocp.target.point):
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 0.5
    assert isinstance(ocp.path_constraints, tuple)


def test_the_problem_copies_the_callers_arrays_and_leaves_them_writable(pendulum):
    x0 = pendulum.state(theta=0.0, theta_dot=0.0)
    bound = np.array([U_MAX])
    ocp = make_ocp(pendulum, x0=x0, u_upper=bound)
    x0[2], bound[0] = 7.0, 1.0  # the caller's arrays: still theirs
    assert ocp.x0[2] == 0.0 and ocp.u_upper[0] == U_MAX


def test_a_replaced_horizon_is_the_solved_one(swing):
    ocp, _ = swing
    longer = dataclasses.replace(ocp, T=3.0)
    sol = solve(longer, C, strategy=Direct())
    assert sol.status is OCPStatus.SUCCESS and not sol.cost["transcription_cached"]
    assert sol.T == 3.0 and longer.T_range == (3.0, 3.0)
    assert_close(sol.t, np.linspace(0.0, 3.0, C.N + 1), atol=ulps(8, 3.0), what="node times")
    assert ocp.T == 2.0 and ocp.T_range == (2.0, 2.0)  # the original is untouched


def test_a_replaced_target_is_reached_not_the_cached_one(swing, pendulum):
    ocp, first = swing
    xf = pendulum.state(theta=1.0, theta_dot=0.0)
    moved = dataclasses.replace(ocp, target=TargetPoint(pendulum.manifold, xf))
    sol = solve(moved, C, strategy=Direct())
    assert sol.status is OCPStatus.SUCCESS
    assert_close(sol.x[-1], xf, atol=1e-8, what="final node at the new target")
    assert sol.error["target_residual"] <= 1e-8
    assert np.max(np.abs(first.x[-1] - xf)) > 0.5  # the old final node is far from it


def test_a_scaled_cost_has_the_same_minimiser_and_a_scaled_minimum(swing):
    ocp, first = swing
    tenfold = dataclasses.replace(ocp, running_cost=lambda x, u: 10.0 * ca.dot(u, u))
    sol = solve(tenfold, C, strategy=Direct(), guess=first)
    assert sol.status is OCPStatus.SUCCESS
    # argmin of 10 J is argmin of J: the same local minimum, ten times its value
    assert_close(sol.objective, 10.0 * first.objective, atol=0.0, rtol=1e-7, what="10 J*")
    assert_close(sol.u, first.u, atol=1e-5 * U_MAX, what="minimiser")


def test_a_replaced_path_constraint_binds_and_costs_more(swing):
    ocp, first = swing
    assert np.max(np.abs(first.u)) > 4.9  # the optimum without it uses the bound 5
    capped = dataclasses.replace(ocp, path_constraints=[
        PathConstraint(lambda x, u: u, -4.5, 4.5, name="|u| <= 4.5")])
    sol = solve(capped, C, strategy=Direct())
    assert sol.status is OCPStatus.SUCCESS
    assert np.max(np.abs(sol.u)) <= 4.5 + sol.error["constraint_limit"]
    assert np.max(np.abs(sol.u)) > 4.5 - 1e-6  # it binds
    assert sol.objective > first.objective  # a smaller admissible set: no cheaper minimum


def test_replace_validates_the_new_problem(swing):
    ocp, _ = swing
    with pytest.raises(ManifoldError, match="x0"):
        dataclasses.replace(ocp, x0=[3.0, 0.0, 0.0])  # |c|^2 - 1 = 8: off S^1
    with pytest.raises(ParameterError, match="T must satisfy"):
        dataclasses.replace(ocp, T=-1.0)


# --- a converged status is held to solve's tol --------------------------------------------


LOOSE = {"tol": 1e300, "constr_viol_tol": 1e300, "dual_inf_tol": 1e300, "compl_inf_tol": 1e300}


def _rest(ocp):
    """Hanging at rest for T: a trajectory of the model that ends where it starts."""
    return Guess.from_samples(ocp, [0.0, 2.0], np.array([ocp.x0, ocp.x0]), np.zeros((1, 1)))


def test_loose_ipopt_tolerances_cannot_make_a_point_off_the_target_a_success(swing):
    ocp, _ = swing
    with pytest.raises(SolverError, match="CONSTRAINTS_VIOLATED") as info:
        solve(ocp, C, strategy=Direct(), guess=_rest(ocp), ipopt_options=LOOSE)
    sol = info.value.solution
    d = ocp.target.distance(ocp.x0)  # the rest trajectory never left x0
    assert d > 0.5 and sol.ipopt_status == "Solve_Succeeded"
    assert sol.status is OCPStatus.CONSTRAINTS_VIOLATED and not sol.status.ok
    assert_close(sol.error["target_residual"], d, atol=ulps(4, d), what="target residual")
    assert sol.error["constraint_violation"] >= d  # the terminal rows are constraints
    assert f"constraint violation {sol.error['constraint_violation']:.3g}" in str(info.value)
    assert f"target residual {d:.3g}" in str(info.value)
    assert sol.diagnosis["worst_constraint"]["kind"] == "terminal"


def test_a_solve_with_its_own_tolerances_succeeds_within_the_limit(swing):
    _, sol = swing
    assert sol.status is OCPStatus.SUCCESS
    assert sol.error["constraint_violation"] <= sol.error["constraint_limit"]
    assert sol.error["target_residual"] <= 1e-8
    # from the rest start, solve's own tolerances are not fooled: Ipopt reports the
    # stationary point of the constraint violation it is (no SUCCESS either way)
    ocp, _ = swing
    rest = solve(ocp, C, strategy=Direct(), guess=_rest(ocp), raise_on_failure=False)
    assert not rest.status.ok


@pytest.mark.parametrize("tol", [1e-8, 1e-10])
def test_a_bound_relaxed_by_ipopt_is_allowed_and_reported(swing, tol):
    """At the bound the control exceeds it by Ipopt's bound_relax_factor (1e-8 relative)."""
    ocp, _ = swing
    sol = solve(ocp, C, strategy=Direct(), tol=tol)
    assert sol.status is OCPStatus.SUCCESS  # a tighter tol than the relaxation: no flip
    over = float(np.max(np.abs(sol.u))) - U_MAX
    assert_close(sol.error["bound_violation"], max(over, 0.0), atol=ulps(4, U_MAX),
                 what="bound violation = max|u| - u_max")
    assert sol.error["bound_violation"] <= (1e-8 + tol) * U_MAX


@pytest.mark.parametrize("options, key", [
    ({"tol": float("nan")}, "tol"), ({"constr_viol_tol": float("nan")}, "constr_viol_tol"),
    ({"acceptable_tol": float("inf")}, "acceptable_tol"), ({"dual_inf_tol": -1.0},
                                                           "dual_inf_tol"),
    ({"compl_inf_tol": 0.0}, "compl_inf_tol"),
    ({"acceptable_constr_viol_tol": float("nan")}, "acceptable_constr_viol_tol"),
    ({"bound_relax_factor": float("nan")}, "bound_relax_factor"),
])
def test_ipopt_tolerances_must_be_positive_finite_and_no_option_nan(swing, options, key):
    ocp, _ = swing
    with pytest.raises(ParameterError, match=rf"ipopt_options\['{key}'\] must be"):
        solve(ocp, C, strategy=Direct(), ipopt_options=options)


# --- a solution of another problem as guess= ----------------------------------------------


@pytest.mark.parametrize("strategy", [Direct(), Auto()])
def test_a_solution_of_another_problem_is_refused_as_a_guess(swing, strategy):
    from models import rail_pendulum

    _, sol = swing
    rail = rail_pendulum.rail_pendulum()
    other = OCP(rail, x0=rail_pendulum.hanging(rail),
                target=TargetPoint(rail.manifold, rail_pendulum.inverted(rail)),
                u_lower=-10.0, u_upper=10.0, T=3.0, name="rail")
    with pytest.raises(ParameterError, match=r"guess \(a solution of problem 'swing', model "
                       r"'pendulum_s1'\) is for another problem: its states have shape "
                       r"\(21, 3\).*'rail'.* has 8 state entries and 1 inputs"):
        solve(other, C, strategy=strategy, guess=sol)


# --- the work of one evaluation is bounded before anything runs ---------------------------


def test_shooting_bounds_the_rk4_steps_of_one_evaluation():
    ok = MultipleShooting(N=MAX_SHOOTING_STEPS // 2, steps=2)  # a fine grid, default steps
    assert ok.N * ok.steps == MAX_SHOOTING_STEPS
    with pytest.raises(ParameterError, match=rf"N \* steps must be at most {MAX_SHOOTING_STEPS}"
                       rf".*N = 50001 x steps = 2 = 100002"):
        MultipleShooting(N=MAX_SHOOTING_STEPS // 2 + 1, steps=2)
    with pytest.raises(ParameterError, match="99999000"):
        MultipleShooting(N=99_999, steps=1000)  # ~40 min per Ipopt iteration on a pendulum
    # CVODES takes its own steps: ``steps`` is not unrolled there
    assert MultipleShooting(N=1000, steps=1000, integrator=Integrator.CVODES).N == 1000


def test_resimulate_bounds_its_samples_and_its_tolerances_before_integrating(swing):
    _, sol = swing
    n = len(sol.u)
    sol.error.pop("resim_end_error", None)
    with pytest.raises(ParameterError, match=rf"{n * (MAX_RESIM_SAMPLES // n + 1)} samples; "
                       rf"at most {MAX_RESIM_SAMPLES}"):
        sol.resimulate(substeps=MAX_RESIM_SAMPLES // n + 1)
    for kw, words in (({"rtol": 10.0}, r"rtol must be a relative tolerance in \(0, 1\)"),
                      ({"rtol": 1.0}, r"rtol must be a relative tolerance in \(0, 1\)"),
                      ({"rtol": float("nan")}, "rtol must be a positive finite"),
                      ({"atol": 0.0}, "atol must be a positive finite"),
                      ({"atol": float("inf")}, "atol must be a positive finite")):
        with pytest.raises(ParameterError, match=words):
            sol.resimulate(**kw)
    assert "resim_end_error" not in sol.error  # nothing was integrated


# --- flags and axes -----------------------------------------------------------------------


@pytest.mark.parametrize("kw, words", [
    ({"raise_on_failure": "no"}, "raise_on_failure must be True or False; got 'no'"),
    ({"raise_on_failure": 0}, "raise_on_failure must be True or False; got 0"),
    ({"print_level": True}, r"print_level must be an integer in \[0, 12\]; got True"),
])
def test_flags_are_booleans_and_levels_integers(swing, kw, words):
    ocp, _ = swing
    with pytest.raises(ParameterError, match=words):
        solve(ocp, C, strategy=Direct(), **kw)


def test_geodesic_axes_are_refused_where_they_mean_nothing(swing):
    ocp, _ = swing
    for axis in ([0.0, 0.0], [np.nan, 0.0], [1.0, 0.0, 0.0]):
        with pytest.raises(ParameterError, match=r"axes\['theta'\]: factor 'theta' is S1"):
            Guess.geodesic(ocp, axes={"theta": axis})


def test_a_geodesic_axis_of_an_antipodal_sphere_turns_about_it():
    from models import rail_pendulum

    rail = rail_pendulum.rail_pendulum()
    ocp = OCP(rail, x0=rail_pendulum.hanging(rail),
              target=TargetPoint(rail.manifold, rail_pendulum.inverted(rail)),
              u_lower=-10.0, u_upper=10.0, T=3.0)
    for bad, words in (([0.0, 0.0, 0.0], "non-zero 3-vector"), ([np.nan, 1.0, 0.0], "finite"),
                       ([1.0, 0.0], "shape")):
        with pytest.raises(ParameterError, match=rf"axes\['q'\].*{words}"):
            Guess.geodesic(ocp, axes={"q": bad})
    q = rail.manifold.slices["q"]
    e1, e3 = np.eye(3)[0], np.eye(3)[2]
    assert_close(ocp.x0[q][:3], e3, atol=0.0)
    g = Guess.geodesic(ocp, axes={"q": 2.0 * e1}, samples=101)  # only the direction counts
    # q(s) = cos(pi s) q0 + sin(pi s) (a x q0): at s = 1/2 the axis crossed with the start
    assert_close(g.state(0.5)[q][:3], np.cross(e1, e3), atol=1e-12, what="midpoint")
    assert_close(g.state(1.0)[q][:3], -e3, atol=1e-12, what="end point")


# --- no array of a problem can be made writable again; copies are made again ---------------


def _u(x, u):
    """``c(x, u) = u`` (a module-level function: a constraint holding it can be pickled)."""
    return u


def _arrays(ocp):
    """Every array a problem holds, directly or through its target and path constraints."""
    out = {"x0": ocp.x0, "u_lower": ocp.u_lower, "u_upper": ocp.u_upper,
           "target.value": ocp.target.value, "target.witness": ocp.target.witness}
    for i, c in enumerate(ocp.path_constraints):
        out.update({f"path_constraints[{i}].lower": c.lower,
                    f"path_constraints[{i}].upper": c.upper})
    return out


def _assert_unwritable(name, arr):
    """Writing, and every way of making the array (or a view, or its bases) writable, fail."""
    assert isinstance(arr, np.ndarray) and arr.ndim == 1, name
    with pytest.raises(ValueError, match="read-only"):
        arr[0] = 0.25
    chain, a = [arr, arr.view(), arr[::-1], arr.reshape(-1, 1)], arr.base
    while isinstance(a, np.ndarray):  # the bases down to the owner of the memory
        chain.append(a)
        a = a.base
    assert isinstance(a, bytes), f"{name}: its memory must be immutable bytes"
    for v in chain:
        with pytest.raises(ValueError, match="WRITEABLE"):
            v.setflags(write=True)


@pytest.fixture(scope="module")
def capped(pendulum):
    """|u| <= 4 as a path constraint with array bounds, T = 3 s (the constraint is slack)."""
    pc = PathConstraint(_u, lower=np.array([-4.0]), upper=np.array([4.0]), name="|u| <= 4")
    return make_ocp(pendulum, T=3.0, path_constraints=[pc])


def test_no_array_of_a_problem_or_its_parts_can_be_made_writable(capped, pendulum):
    arrays = _arrays(capped)
    assert len(arrays) == 7
    for name, arr in arrays.items():
        before = arr.copy()
        _assert_unwritable(name, arr)
        assert np.array_equal(arr, before), name  # nothing changed
    pc = capped.path_constraints[0]
    for name, value in (("upper", 2.5), ("lower", -2.5), ("function", lambda x, u: 2 * u),
                        ("nodes", "last")):
        with pytest.raises(dataclasses.FrozenInstanceError, match=name):
            setattr(pc, name, value)
    down = TargetSet(lambda x: x[2], ProductManifold([("w", Rn(1))]), [0.0],
                     pendulum.state(theta=2.0, theta_dot=0.0), "at rest")
    for name in ("value", "witness"):
        _assert_unwritable(f"TargetSet.{name}", getattr(down, name))
        with pytest.raises(dataclasses.FrozenInstanceError, match=name):
            setattr(down, name, np.zeros(3))


def test_a_tighter_path_bound_is_a_replaced_problem_and_binds(capped):
    first = solve(capped, C, strategy=Direct())
    assert first.status is OCPStatus.SUCCESS
    slack = float(np.max(np.abs(first.u)))
    assert 3.5 < slack < 4.0  # the optimum uses more than 3.5 and less than the cap
    pc = capped.path_constraints[0]
    tight = dataclasses.replace(pc, lower=np.array([-3.5]), upper=np.array([3.5]))
    assert pc.upper[0] == 4.0 and tight.upper[0] == 3.5
    _assert_unwritable("replaced upper", tight.upper)
    ocp = dataclasses.replace(capped, path_constraints=[tight])
    sol = solve(ocp, C, strategy=Direct(), guess=first)  # the slack optimum as the start
    assert sol.status is OCPStatus.SUCCESS and not sol.cost["transcription_cached"]
    assert np.max(np.abs(sol.u)) <= 3.5 + sol.error["constraint_limit"]
    assert np.max(np.abs(sol.u)) > 3.5 - 1e-6  # it binds
    assert sol.objective > first.objective  # a smaller admissible set: no cheaper minimum
    with pytest.raises(ParameterError, match="lower must not exceed upper"):
        dataclasses.replace(pc, lower=np.array([5.0]))  # replace validates again


def test_copies_and_pickles_are_made_again_with_frozen_data_and_no_cache(capped):
    import copy
    import pickle

    solve(capped, C, strategy=Direct())  # a transcription cached on the original
    for twin in (copy.copy(capped), copy.deepcopy(capped)):
        assert twin is not capped and twin.T == capped.T
        for name, arr in _arrays(twin).items():
            assert np.array_equal(arr, _arrays(capped)[name]), name
            _assert_unwritable(f"copy's {name}", arr)
        with pytest.raises(dataclasses.FrozenInstanceError, match="'T'"):
            twin.T = 2.0
        sol = solve(twin, C, strategy=Direct())
        assert not sol.cost["transcription_cached"]  # its own (empty) cache
    pc, target = capped.path_constraints[0], capped.target
    for obj, names in ((pc, ("lower", "upper")), (target, ("point",))):
        back = pickle.loads(pickle.dumps(obj))
        for name in names:
            assert np.array_equal(getattr(back, name), getattr(obj, name))
            _assert_unwritable(f"unpickled {name}", getattr(back, name))
