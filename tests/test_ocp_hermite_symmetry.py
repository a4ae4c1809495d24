"""Hermite-Simpson collocation, the automatic symmetry gauge, the compiled NLP, bad input.

Mathematics: the Hermite-Simpson step is the 3-stage Lobatto IIIA method (local error
O(h^5) against CVODES with a linear input); its ambient and Lie-group forms agree on the
cost of a local minimum to the order of the method and the Lie form keeps every node on
the manifold; the rotation about the vertical is found where it is a symmetry and refused
where a cost term, a target or the start breaks it; the gauge leaves the optimal cost
unchanged (it only picks one member of a circle of optima); the compiled NLP gives the
same solution as casadi's virtual machine.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from workbench.codegen import CompileError
from workbench.control.ocp import (
    OCP,
    Collocation,
    Compiled,
    Direct,
    Guess,
    HermiteSimpson,
    ManifoldHandling,
    Stepper,
    TargetPoint,
    TargetSet,
    detect_symmetry,
    multistart,
    solve,
    sx_function,
)
from workbench.control.ocp.hermite_simpson import hermite_simpson_interval
from workbench.control.ocp.study import effort_time_ocp
from workbench.core.errors import ParameterError
from workbench.core.manifolds import TS2, ProductManifold, Rn

E1, E3 = np.eye(3)[0], np.eye(3)[2]
X0 = np.r_[0.0, 0.0, 0.0, 0.0, link_state(E3)]
XF = np.r_[0.0, 0.0, 0.0, 0.0, link_state(-E3)]


@pytest.fixture(scope="module")
def cart():
    return effort_time_ocp(chain_cart(1), X0, XF, u_max=10.0, T=(0.5, 3.0), name="hs_cart")


@pytest.fixture(scope="module")
def hs(cart):
    """Hermite-Simpson, N = 20, ambient (its nodes drift off TS^2 by the local error: no
    manifold_tol), one solve from the straight swing about e1."""
    return solve(cart, HermiteSimpson(N=20), guess=Guess.geodesic(cart, T=1.5,
                                                                 axes={"link1": E1}),
                 handling=ManifoldHandling.AMBIENT, strategy=Direct(), manifold_tol=None)


def _hs_step(model, x, u0, u1, h):
    """One ambient Hermite-Simpson step: solve x1 = x_end(x, x1) by Newton's method."""
    f = sx_function(model.function("f"))
    nx = model.manifold.ambient_dim
    F = hermite_simpson_interval(ca.SX, nx, model.n_inputs, model.n_params, f, None, None, {})
    x1 = ca.SX.sym("x1", nx)
    res = x1 - F(x, x1, ca.SX(0, 1), u0, u1, h, model.p)[1]
    G = ca.rootfinder("G", "newton", ca.Function("r", [x1], [res]), {"abstol": 1e-14})
    return np.asarray(G(np.asarray(x, float)), float).ravel()


def test_hermite_simpson_step_has_local_error_of_order_five():
    model = chain_cart(1)
    rng = np.random.default_rng(1)
    x = model.manifold.random_point(rng, scale=0.5)
    u0, rate = np.array([1.0, -0.5]), np.array([-30.0, 40.0])  # a smooth input: u' fixed
    st = Stepper(model, rtol=1e-13, atol=1e-13)
    errs = [np.max(np.abs(_hs_step(model, x, u0, u0 + h * rate, h)
                          - st.step(x, u0, h, u_end=u0 + h * rate))) for h in (0.02, 0.01)]
    order = np.log2(errs[0] / errs[1])
    assert 4.5 < order < 5.5, errs  # Lobatto IIIA(3): local error O(h^5)


def test_linear_input_step_with_equal_ends_is_the_constant_input_step():
    model = chain_cart(1)
    st = Stepper(model, rtol=1e-12, atol=1e-12)
    x = model.manifold.random_point(np.random.default_rng(2), scale=0.5)
    u = np.array([0.7, -0.2])
    assert np.allclose(st.step(x, u, 0.05, u_end=u), st.step(x, u, 0.05), atol=1e-11)


def test_hermite_simpson_solution_satisfies_its_nlp_and_the_dynamics(cart, hs):
    assert hs.status.ok and hs.u.shape == (21, 2) and hs.first_order_hold
    assert hs.error["constraint_violation"] < 1e-8
    assert np.all(np.abs(hs.u) <= 10.0 + 1e-8)
    assert hs.error["target_residual"] < 1e-8
    assert hs.error["local_defect"] < 0.5  # coarse (h = T/20); its order: the Lie test
    # the trapezoid of u'u over the knots, plus T, is the objective
    h = hs.T / 20
    uu = np.sum(hs.u**2, axis=1)
    assert hs.objective == pytest.approx(h * (uu.sum() - (uu[0] + uu[-1]) / 2) + hs.T,
                                         rel=1e-10)


def test_lie_group_hermite_simpson_agrees_and_stays_on_the_manifold(cart, hs):
    lie = solve(cart, HermiteSimpson(N=20), handling=ManifoldHandling.LIE_GROUP, guess=hs)
    assert lie.error["manifold_residual"] < 1e-12
    assert hs.error["manifold_residual"] > 1e3 * lie.error["manifold_residual"]
    assert lie.objective == pytest.approx(hs.objective, rel=2e-2)  # O(h^4) apart
    fine = solve(cart, HermiteSimpson(N=40), handling=ManifoldHandling.LIE_GROUP, guess=lie)
    assert fine.error["local_defect"] < lie.error["local_defect"] / 4


def test_hermite_simpson_and_legendre_converge_to_the_same_cost(cart, hs):
    a = solve(cart, HermiteSimpson(N=80), guess=hs)
    b = solve(cart, Collocation(N=40), guess=hs)
    assert a.objective == pytest.approx(b.objective, rel=2e-2)


def test_rotation_symmetry_is_found_and_refused_where_broken(cart):
    sym = cart.symmetry
    assert sym is not None and sym.axis == "e3"
    assert set(sym.actions.values()) == {"rotated"}
    model = cart.model
    free = effort_time_ocp(model, X0, XF, u_max=10.0, T=1.0, free=("x",), name="free")
    assert free.symmetry is not None  # the target set (cart anywhere) is invariant
    wall = OCP(model, x0=X0, target=TargetSet(
        map=lambda x: ca.vertcat(x[0], x[2:10]),
        manifold=ProductManifold([("x1", Rn(1)), ("v", Rn(2)), ("link1", TS2())]),
        value=np.r_[0.0, XF[2:]], witness=XF), u_lower=-1, u_upper=1, T=1.0)
    assert wall.symmetry is None  # x_1 = 0 at the end: not invariant
    pushed = OCP(model, x0=X0, target=TargetPoint(model.manifold, XF), u_lower=-1,
                 u_upper=1, T=1.0, running_cost=lambda x, u: ca.dot(u, u) + u[0])
    assert pushed.symmetry is None
    moved = OCP(model, x0=np.r_[0.1, 0.0, 0.0, 0.0, link_state(E3)],
                target=TargetPoint(model.manifold, XF), u_lower=-1, u_upper=1, T=1.0)
    assert moved.symmetry is None
    red = p3.reduced(J=np.diag([0.13, 0.28, 0.17]), rho=[0, 0, 0.3], m=1.0, g=9.81)
    body = OCP(red, x0=np.r_[E3, 0.0, 0.0, 0.0],
               target=TargetPoint(red.manifold, np.r_[-E3, 0.0, 0.0, 0.0]), u_lower=-1,
               u_upper=1, T=3.0)
    assert detect_symmetry(body) is None


def test_symmetry_acts_as_found(cart):
    sym = cart.symmetry
    Gx, Gu = sym.act(0.9)
    rng = np.random.default_rng(3)
    x = cart.model.manifold.random_point(rng)
    u = rng.standard_normal(2)
    f = cart.model.function("f")
    assert np.allclose(np.asarray(f(Gx @ x, Gu @ u, cart.model.p)).ravel(),
                       Gx @ np.asarray(f(x, u, cart.model.p)).ravel(), atol=1e-10)
    assert np.allclose(Gx @ X0, X0) and np.allclose(Gx @ XF, XF)


def test_gauge_only_picks_one_optimum_of_the_circle(cart, hs):
    g = Guess.geodesic(cart, T=1.5, axes={"link1": np.array([1.0, 1.0, 0.0])})
    gauged = solve(cart, Collocation(N=20), guess=g)
    assert "gauged" in gauged.gauge and "gauged" in gauged.message
    assert abs(gauged.error["gauge_multiplier"]) < 1e-6
    ungauged = solve(cart.with_bounds(gauge=False), Collocation(N=20), guess=gauged)
    assert "not gauged" in ungauged.gauge
    assert ungauged.objective == pytest.approx(gauged.objective, rel=1e-7)
    # a rotated optimum is an optimum of the same cost (the circle the gauge cuts)
    Gx, Gu = cart.symmetry.act(0.6)
    rot = Guess.from_samples(cart, gauged.t, gauged.x @ Gx.T, gauged.u @ Gu.T)
    again = solve(cart.with_bounds(gauge=False), Collocation(N=20), guess=rot)
    assert again.objective == pytest.approx(gauged.objective, rel=1e-7)


def test_multistart_in_processes_equals_multistart_here(cart):
    kw = {"seeds": [0, 1], "T_guesses": [1.5], "max_iter": 200,
          "defect_tol": None}  # N = 10 is coarse: this compares the two ways of running
    a, ra = multistart(cart, HermiteSimpson(N=10), **kw)
    b, rb = multistart(cart, HermiteSimpson(N=10), workers=2, **kw)
    assert [r["objective"] for r in ra] == pytest.approx([r["objective"] for r in rb],
                                                         rel=1e-9)
    assert b.objective == pytest.approx(a.objective, rel=1e-9)
    assert sum(r["reached_best"] for r in rb) >= 1


def _pendulum():
    red = p3.reduced(J=np.diag([0.13, 0.28, 0.17]), rho=[0, 0, 0.3], m=1.0, g=9.81)
    return effort_time_ocp(red, np.r_[E3, 0.0, 0.0, 0.0], np.r_[-E3, 0.0, 0.0, 0.0],
                           u_max=3.0, T=(0.5, 3.0), name="compiled_test")


def test_compiled_nlp_gives_the_same_solution(tmp_path):
    ocp = _pendulum()
    # N = 8 is coarse (defect_tol=None): this compares two evaluations of one NLP. From
    # T = 2.5 Ipopt converges in 36 iterations; from T = 1.5 it wanders for 250-350
    # iterations and rounding at 1e-13 decides between Solve_Succeeded and a local
    # infeasibility, which says nothing about the compiled code.
    g = Guess.geodesic(ocp, T=2.5)
    plain = solve(ocp, HermiteSimpson(N=8), guess=g, defect_tol=None)
    comp = solve(ocp, HermiteSimpson(N=8), guess=g, defect_tol=None,
                 compiled=Compiled(cache_dir=str(tmp_path)))
    assert comp.cost["compile"]["cached"] is False
    assert comp.objective == pytest.approx(plain.objective, rel=1e-9)
    assert np.allclose(comp.x, plain.x, atol=1e-7)
    again = solve(ocp.with_bounds(), HermiteSimpson(N=8), guess=g, defect_tol=None,
                  compiled=Compiled(cache_dir=str(tmp_path)))
    assert again.cost["compile"]["hash"] == comp.cost["compile"]["hash"]


def test_missing_compiler_is_a_clear_error_and_the_plain_path_stays(tmp_path):
    ocp = _pendulum()
    with pytest.raises(CompileError, match="no-such-cc"):
        solve(ocp, HermiteSimpson(N=4), defect_tol=None,
              compiled=Compiled(compiler="no-such-cc", cache_dir=str(tmp_path)))
    assert solve(ocp, HermiteSimpson(N=4), defect_tol=None).status.ok


@pytest.mark.parametrize("make, match", [
    (lambda: HermiteSimpson(N=0), "N must be"),
    (lambda: HermiteSimpson(N=True), "N must be"),
    (lambda: HermiteSimpson(N=2.5), "N must be"),
    (lambda: Compiled(compiler=""), "compiler"),
    (lambda: Compiled(flags="-O2"), "flags"),
    (lambda: Compiled(flags=("O2",)), "flags"),
    (lambda: Compiled(max_source_mb=0), "max_source_mb"),
])
def test_bad_new_options_are_rejected(make, match):
    with pytest.raises(ParameterError, match=match):
        make()


def test_bad_gauge_workers_free_and_guess_shapes_are_rejected(cart):
    model = cart.model
    with pytest.raises(ParameterError, match="gauge"):
        OCP(model, x0=X0, target=TargetPoint(model.manifold, XF), u_lower=-1, u_upper=1,
            T=1.0, gauge="yes")
    with pytest.raises(ParameterError, match="workers"):
        multistart(cart, HermiteSimpson(N=4), seeds=[0], workers=0)
    with pytest.raises(ParameterError, match="free"):
        effort_time_ocp(model, X0, XF, u_max=1.0, T=1.0, free=("cart",), name="bad")
    from workbench.control.ocp import transcribe

    tr, _ = transcribe(cart, HermiteSimpson(N=4))
    with pytest.raises(ParameterError, match="rows"):
        tr.pack(lambda s: X0, np.zeros((4, 2)), 1.0)


def test_multistart_refining_only_the_best_coarse_start_agrees_with_refining_all(cart):
    # refine_best=1: the coarse starts all run, only the cheapest is refined (here, in
    # the parent, also after forked workers); its refined cost is that start's own
    # refined cost when every start is refined
    kw = {"seeds": [0, 1, 2], "T_guesses": [1.5, 2.0], "max_iter": 200,
          "refine_with": [HermiteSimpson(N=20)], "defect_tol": None}
    every, r_all = multistart(cart, HermiteSimpson(N=10), **kw)
    for workers in (1, 2):
        one, r_one = multistart(cart, HermiteSimpson(N=10), refine_best=1, workers=workers,
                                **kw)
        coarse = [r["coarse_objective"] for r in r_one]
        assert coarse == pytest.approx([r["coarse_objective"] for r in r_all], rel=1e-9)
        refined = [i for i, r in enumerate(r_one) if r["refined"]]
        ok = [i for i, r in enumerate(r_one) if r["status"] in ("SUCCESS", "ACCEPTABLE")]
        assert len(refined) == 1 and refined[0] == min(ok, key=lambda i: coarse[i])
        i = refined[0]
        assert len(r_one[i]["iterations"]) == 2  # coarse, then N = 20
        assert one.method.N == 20
        assert one.objective == pytest.approx(r_all[i]["objective"], rel=1e-6)
        assert one.objective >= every.objective - 1e-9  # refining fewer never finds more
        assert [r["reached_best"] for r in r_one] == [j == i for j in range(3)]
        for j in set(range(3)) - {i}:  # an unrefined start keeps its coarse record
            assert r_one[j]["objective"] == pytest.approx(coarse[j], rel=1e-12)


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "1"])
def test_multistart_refuses_a_refine_best_that_is_not_a_positive_integer(cart, bad):
    with pytest.raises(ParameterError, match=r"refine_best must be None or an integer >= 1"):
        multistart(cart, HermiteSimpson(N=4), seeds=[0], refine_best=bad)


def test_multistart_names_the_refined_starts_failure_not_a_coarse_success(cart):
    # the coarse starts converge (their own iteration limit), the one refined start
    # cannot (2 iterations): the error is about the refinement, with its status
    from workbench.core.errors import SolverError

    with pytest.raises(SolverError, match="none of the 1 refined starts") as err:
        multistart(cart, HermiteSimpson(N=10), seeds=[0, 1], T_guesses=[1.5], max_iter=2,
                   ipopt_variants=({"max_iter": 200},), refine_with=[HermiteSimpson(N=20)],
                   refine_best=1, defect_tol=None)
    assert err.value.status not in ("SUCCESS", "ACCEPTABLE")


def test_multistart_refuses_refine_best_without_refine_with(cart):
    with pytest.raises(ParameterError, match="got refine_best without refine_with"):
        multistart(cart, HermiteSimpson(N=4), seeds=[0], refine_best=1)
