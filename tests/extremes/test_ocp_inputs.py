"""OCP inputs are validated when they are constructed, with the argument named.

A path constraint with crossed, NaN or non-numeric bounds, a function that is not callable
or does not return a casadi expression of the right size, a ``guess=`` that is an array,
and sampled guesses with wrong shapes, non-increasing times, NaN or states off the
manifold: each is refused where it is made (never inside casadi or Ipopt, whatever
``raise_on_failure`` says), and its well-formed neighbour is accepted.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from workbench import mechanics
from workbench.control.ocp import OCP, Collocation, Guess, PathConstraint, TargetPoint, solve
from workbench.core.errors import ManifoldError, ModelError, ParameterError


@pytest.fixture(scope="module")
def pendulum():
    """A planar pendulum on S^1 with a torque: small, every check below is cheap."""
    s = mechanics.System("pendulum_s1")
    a = s.s1("theta")
    s.point_mass(1.0, a.p)
    s.gravity(9.81, direction=[1.0, 0.0])  # theta = 0 hangs
    s.moment(a, s.input(1, "torque [N m]"))
    return s.model()


def make_ocp(model, **kw):
    x0 = model.state(theta=0.0, theta_dot=0.0)
    xf = model.state(theta=np.pi, theta_dot=0.0)
    args = {"x0": x0, "target": TargetPoint(model.manifold, xf), "u_lower": -5.0,
            "u_upper": 5.0, "T": 3.0, "running_cost": lambda x, u: ca.dot(u, u)}
    args.update(kw)
    return OCP(model, **args)


# ----------------------------------------------------------------------------------------
# PathConstraint


def speed(x, u):
    return x[2:3]


@pytest.mark.parametrize(("kw", "words"), [
    ({"lower": 1.0, "upper": -1.0}, r"lower must not exceed upper; got lower 1.0 > upper -1.0"),
    ({"lower": [0.0, 2.0], "upper": [1.0, 1.0]}, r"lower must not exceed upper"),
    ({"lower": np.nan}, r"lower \(of path constraint 'c'\) must be real bounds .*never NaN"),
    ({"upper": [1.0, np.nan]}, r"upper \(of path constraint 'c'\) must be real bounds"),
    ({"lower": "0"}, r"lower \(of path constraint 'c'\) must be a real numeric array"),
    ({"upper": True}, r"upper \(of path constraint 'c'\) must be .*booleans"),
    ({"lower": 1j}, r"lower \(of path constraint 'c'\) must be real; got a complex"),
    ({"lower": np.inf}, r"lower must be < inf and upper > -inf"),
    ({"upper": -np.inf}, r"lower must be < inf and upper > -inf"),
    ({"lower": [[0.0]]}, r"lower of path constraint 'c' must be a number or a vector"),
    ({"lower": [0.0, 0.0], "upper": [1.0, 1.0, 1.0]}, r"must have the same length"),
    ({"function": 3.0}, r"function of path constraint 'c' must be a callable"),
    ({"nodes": "middle"}, r"nodes must be 'all', 'first' or 'last'"),
    ({"name": 7}, r"name \(of a path constraint\) must be a str"),
])
def test_a_path_constraint_is_refused_when_made(kw, words):
    args = {"function": speed, "lower": -1.0, "upper": 1.0, "name": "c"}
    args.update(kw)
    with pytest.raises(ParameterError, match=words):
        PathConstraint(**args)


def test_good_path_constraints_keep_their_bounds_as_numbers():
    c = PathConstraint(speed, lower=-1, upper=[2.0], name="c")
    assert c.lower == -1.0 and isinstance(c.lower, float)
    assert c.upper.tolist() == [2.0]
    one_sided = PathConstraint(speed, upper=np.inf, name="free")
    assert one_sided.lower == -np.inf and one_sided.upper == np.inf


@pytest.mark.parametrize(("function", "words"), [
    (lambda x, u: 1.0, r"must return a casadi expression .* got float"),
    (lambda x, u: np.ones(1), r"must return a casadi expression .* got ndarray"),
    (lambda x, u: ca.DM(1.0), r"must return a casadi expression .* got DM"),
    (lambda x, u: x[0:0], r"returned an empty expression"),
    (lambda x, u: x[7], r"calling it with SX symbols raised"),
    (lambda x: x[0], r"calling it with SX symbols raised TypeError"),
    (lambda x, u: ca.vertcat(x[2], u[0]), r"lower of path constraint 'c' must be a number or "
                                          r"have 2 entries .*got 3"),
])
def test_a_path_constraint_function_is_checked_against_the_model(pendulum, function, words):
    c = PathConstraint(function, lower=[-1.0, -1.0, -1.0], upper=1.0, name="c")
    with pytest.raises(ModelError, match=words):
        make_ocp(pendulum, path_constraints=[c])


def test_a_path_constraint_function_must_work_on_mx_symbols_too(pendulum):
    c = PathConstraint(lambda x, u: ca.SX(x.shape[0], 1) + x if isinstance(x, ca.SX)
                       else np.zeros(3), lower=-1.0, upper=1.0, name="sx_only")
    with pytest.raises(ModelError, match=r"\(MX when called with MX symbols\); got ndarray"):
        make_ocp(pendulum, path_constraints=[c])


def test_path_constraints_must_be_a_sequence_of_them(pendulum):
    c = PathConstraint(speed, lower=-1.0, upper=1.0, name="c")
    with pytest.raises(ModelError, match="path_constraints must be a sequence"):
        make_ocp(pendulum, path_constraints=c)
    with pytest.raises(ModelError, match="must hold PathConstraint objects; got dict"):
        make_ocp(pendulum, path_constraints=[{"lower": 0}])
    ocp = make_ocp(pendulum, path_constraints=(c,))
    assert ocp.path_constraints == (c,)


def test_a_valid_path_constraint_binds_in_the_solution(pendulum):
    """|theta-dot| <= 4 on the swing-up: the constrained solution respects it to Ipopt's
    tolerance, and it binds (the free optimum goes faster)."""
    free = solve(make_ocp(pendulum), Collocation(N=30))
    assert np.max(np.abs(free.x[:, 2])) > 4.0
    c = PathConstraint(speed, lower=-4.0, upper=4.0, name="speed")
    held = solve(make_ocp(pendulum, path_constraints=[c]), Collocation(N=30))
    assert np.max(np.abs(held.x[:, 2])) <= 4.0 + 1e-7
    assert held.objective > free.objective


# ----------------------------------------------------------------------------------------
# guesses


def test_a_guess_array_is_refused_before_anything_is_built(pendulum):
    ocp = make_ocp(pendulum)
    for bad in (np.zeros((10, 3)), [0.0, 1.0], "geodesic"):
        for raising in (True, False):
            with pytest.raises(ParameterError, match=r"guess must be a Guess or an OCPSolution; "
                                                     r"got .*Guess.from_samples\(ocp, t, x, u\)"
                                                     r" .* or Guess.geodesic"):
                solve(ocp, Collocation(N=10), guess=bad, raise_on_failure=raising)
    assert not ocp._cache  # noqa: SLF001 - nothing was transcribed (nor cached)


def test_a_guess_of_another_problem_is_refused(pendulum):
    s = mechanics.System("cart")
    x = s.rn("x", 2)
    s.point_mass(1.0, x.x)
    s.force(x, s.input(2, "force [N]"))
    cart = s.model()
    other = OCP(cart, x0=np.zeros(4), target=TargetPoint(cart.manifold, np.r_[1.0, 0, 0, 0]),
                u_lower=-1.0, u_upper=1.0, T=2.0)
    with pytest.raises(ParameterError, match=r"guess is for another problem: its states have "
                                             r"shape \(101, 4\)"):
        solve(make_ocp(pendulum), Collocation(N=10), guess=Guess.geodesic(other))


def samples(ocp, n=11):
    """A sampled guess of ``ocp``: its geodesic guess at ``n`` times, zero control."""
    g = Guess.geodesic(ocp, samples=n)
    return g.s * g.T, g.x.copy(), np.zeros((n - 1, ocp.model.n_inputs))


@pytest.mark.parametrize(("change", "error", "words"), [
    (lambda t, x, u: (t[::-1], x, u), ParameterError, r"t must be strictly increasing; got "
                                                      r"t\[0\] = 3 >= t\[1\]"),
    (lambda t, x, u: (np.r_[t[:5], t[4], t[6:]], x, u), ParameterError,
     r"t must be strictly increasing; got t\[4\]"),
    (lambda t, x, u: (t + 1.0, x, u), ParameterError, r"t must start at 0"),
    (lambda t, x, u: (t[:1], x[:1], u[:0]), ParameterError, r"t must have at least 2"),
    (lambda t, x, u: (np.r_[t[:-1], np.nan], x, u), ParameterError, r"t must be finite"),
    (lambda t, x, u: (t, x[:, :2], u), ParameterError, r"x must have shape \(11, 3\)"),
    (lambda t, x, u: (t, x.T, u), ParameterError, r"x must have shape \(11, 3\)"),
    (lambda t, x, u: (t, np.where(np.arange(3) == 2, np.nan, x), u), ParameterError,
     r"x must be finite"),
    (lambda t, x, u: (t, x, u[:-2]), ParameterError, r"u must have shape \(10, 1\) .* or "
                                                     r"\(11, 1\)"),
    (lambda t, x, u: (t, x, np.r_[u[:-1], [[np.inf]]]), ParameterError, r"u must be finite"),
    (lambda t, x, u: (t, x * 1.01, u), ManifoldError, r"x\[0\] \(the state at t = 0\)"
                                                      r"\['theta'\] is not on S1"),
])
def test_sampled_guesses_are_checked(pendulum, change, error, words):
    ocp = make_ocp(pendulum)
    t, x, u = change(*samples(ocp))
    with pytest.raises(error, match=words):
        Guess.from_samples(ocp, t, x, u)


def test_good_sampled_guesses_pass_and_drift_is_a_stated_tolerance(pendulum):
    ocp = make_ocp(pendulum)
    t, x, u = samples(ocp)
    g = Guess.from_samples(ocp, t, x, u)
    assert g.T == pytest.approx(3.0) and g.s[0] == 0.0 and g.s[-1] == 1.0
    assert Guess.from_samples(ocp, t, x, np.zeros((11, 1))).first_order_hold
    # off the manifold by 1e-4: within the default 1e-3 of a guess, refused at tol=1e-6
    y = x.copy()
    y[3, 0:2] *= 1 + 1e-4
    Guess.from_samples(ocp, t, y, u)
    with pytest.raises(ManifoldError, match=r"x\[3\] \(the state at t = 0.9\)"):
        Guess.from_samples(ocp, t, y, u, tol=1e-6)
    with pytest.raises(ParameterError, match="ocp must be an OCP"):
        Guess.from_samples("ocp", t, x, u)


def test_a_solution_warm_starts_with_its_own_drift(pendulum):
    """A solution's nodes are taken as they are (never projected) for a warm start."""
    ocp = make_ocp(pendulum)
    sol = solve(ocp, Collocation(N=20))
    g = sol.guess()
    assert np.array_equal(g.x, sol.x) and np.array_equal(g.u, sol.u)
    again = solve(ocp, Collocation(N=30), guess=sol)
    assert again.status.ok


# --- found by an independent hostile pass ---------------------------------------------------


def _rail_ocp(**kw):
    import casadi as ca

    from models import rail_pendulum
    from workbench.control.ocp import OCP, TargetPoint

    model = rail_pendulum.rail_pendulum()
    args = dict(u_lower=-10.0, u_upper=10.0, T=3.0, running_cost=lambda x, u: ca.dot(u, u))
    args.update(kw)
    return OCP(model, x0=rail_pendulum.hanging(model),
               target=TargetPoint(model.manifold, rail_pendulum.inverted(model)), **args)


def test_unrolled_and_allocated_sizes_are_bounded_before_anything_is_built():
    from workbench.control.ocp import Collocation, Direct, MultipleShooting, solve
    from workbench.control.ocp.transcription import MAX_NLP_VARIABLES, MAX_STEPS

    with pytest.raises(ParameterError, match=rf"steps must be an integer in \[1, {MAX_STEPS}\]"):
        MultipleShooting(N=5, steps=10**7)
    with pytest.raises(ParameterError, match=rf"at most {MAX_NLP_VARIABLES}"):
        solve(_rail_ocp(), Collocation(N=100_000, degree=9), strategy=Direct())


def test_guess_builders_check_their_counts():
    from workbench.control.ocp import energy_pumping, structured_guesses
    from workbench.control.ocp.initial import pumping

    ocp = _rail_ocp()
    for bad in (0, -1, True, 2.5, 10**7):
        with pytest.raises(ParameterError, match="samples"):
            energy_pumping(ocp, samples=bad)
    for bad in (-1, 10**6, 1.5):
        with pytest.raises(ParameterError, match="swings"):
            structured_guesses(ocp, swings=bad)
    with pytest.raises(ParameterError, match="wrap"):
        pumping(ocp, half_swings=1, wrap=0.5)


def test_multistart_seeds_are_checked():
    from workbench.control.ocp import Collocation, multistart

    for bad in ([], [-1], ["a"], [1.5], [True]):
        with pytest.raises(ParameterError, match="seeds must be"):
            multistart(_rail_ocp(), Collocation(N=10), seeds=bad)


def test_a_cost_that_is_not_finite_is_refused_when_the_ocp_is_made():
    import casadi as ca

    with pytest.raises(ModelError, match="running_cost must be finite"):
        _rail_ocp(running_cost=lambda x, u: ca.sqrt(-1.0 - ca.dot(u, u)))
    with pytest.raises(ModelError, match="terminal_cost must be finite"):
        _rail_ocp(terminal_cost=lambda x, T: ca.log(T - 5.0))


def test_a_manifold_tolerance_below_rounding_is_refused():
    from workbench.control.ocp import Collocation, solve

    with pytest.raises(ParameterError, match="manifold_tol must be at least"):
        solve(_rail_ocp(), Collocation(N=10), manifold_tol=1e-17)


def test_a_tiny_pumping_axis_is_an_axis_not_a_parallel_one():
    from workbench.control.ocp.study import pumping_guess

    ocp = _rail_ocp()
    g = pumping_guess(ocp, half_swings=1, axes={"q": [0.0, 1e-300, 0.0]})
    big = pumping_guess(ocp, half_swings=1, axes={"q": [0.0, 1.0, 0.0]})
    assert np.allclose(g.x, big.x)  # only the direction of the axis counts
    with pytest.raises(ParameterError, match="parallel"):
        pumping_guess(ocp, half_swings=1, axes={"q": [0.0, 0.0, 1e-300]})
