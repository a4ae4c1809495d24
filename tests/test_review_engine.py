"""Fixes from the engine review: validation helpers, branch switching, evaluators, caches."""

from __future__ import annotations

import gc
import importlib
import json
import sys
import weakref
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from models import relative_families
from models.relative_equilibria import static_equilibria
from models.relative_families import trace_relative_equilibria
from workbench.codegen import agreement, compile_sources, generate
from workbench.control._attraction import check_convergence
from workbench.control._lyapunov import Lyapunov, SublevelSet
from workbench.core import validate as _validate
from workbench.core._evaluator import DenseEvaluator, Evaluator
from workbench.core._model import Model, Parameter, Symbolic
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import ProductManifold, Rn
from workbench.equilibria._branch import PointKind, StepControl
from workbench.equilibria._continuation import continue_branch, switch_branch
from workbench.equilibria._roots import RootStatus, ZeroProblem, check_count, check_positive
from workbench.linear._controllability import second_order_form
from workbench.linear._eigen import eigenstructure
from workbench.linear._linearize import linearize, linearize_ambient
from workbench.linear._lqr import geometric_feedback, lqr
from workbench.simulation._simulate import Method, constraint_residuals, simulate
from workbench.simulation.accuracy import AccuracySweep, WorkPrecision
from workbench.simulation.integrators import integrate, rkmk4


@pytest.fixture(scope="module")
def planar():
    return p3.planar(Jt=0.2, rho_s=0.3)


def planar_state(model):
    return model.state(p=[0.0, 1.0], omega_y=[1.0])


# ----------------------------------------------------------------------------------------
# one implementation of positive numbers, counts and steps


def test_roots_validators_are_the_shared_ones():
    assert check_positive is _validate.positive
    assert check_count is _validate.count
    with pytest.raises(ParameterError, match="tol must be a positive number; got -1"):
        check_positive("tol", -1)
    with pytest.raises(ParameterError, match="n must be an integer >= 2; got True"):
        check_count("n", True, minimum=2)


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


# ----------------------------------------------------------------------------------------
# unknown enum values name the argument and the choices


def _distance():
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 4)
    return ca.Function("d", [x, p], [ca.norm_2(x)])


@pytest.mark.parametrize(("call", "name", "choices", "got"), [
    (lambda m, x0: check_convergence(m, None, [x0], distance=_distance(), horizon=1.0,
                                     tolerance=0.1, multistep="gear"),
     "multistep", "['adams', 'bdf']", "'gear'"),
    (lambda m, x0: WorkPrecision("m", 1.0, None, [], {}).fastest(1e-3, cost="speed"),
     "cost", "['wall_seconds', 'evaluations']", "'speed'"),
    (lambda m, x0: WorkPrecision("m", 1.0, None, [], {}).winners([1e-3], cost="speed"),
     "cost", "['wall_seconds', 'evaluations']", "'speed'"),
    (lambda m, x0: eigenstructure(linearize(m, m.state(p=[0.0, -1.0], omega_y=[0.0])))
     .subspace("middle"), "which", "['stable', 'unstable', 'centre']", "'middle'"),
    (lambda m, x0: lqr(np.zeros((1, 1)), [[1.0]], [[1.0]], B=[[1.0]], require="stable"),
     "require", "['controllable', 'stabilizable']", "'stable'"),
    (lambda m, x0: AccuracySweep("rk45", [0.1]), "AccuracySweep.method", "['cvodes', 'rk', ",
     "'rk45'"),
    (lambda m, x0: generate(None, binding="baked"), "binding", "['", "'baked'"),
    (lambda m, x0: compile_sources(None, optimization="O9"), "optimization", "['", "'O9'"),
    (lambda m, x0: agreement(None, None, np.zeros((1, 3)), binding="frozen", through="air"),
     "through", "['", "'air'"),
])
def test_an_unknown_choice_is_a_parameter_error_listing_the_choices(planar, call, name,
                                                                    choices, got):
    with pytest.raises(ParameterError) as info:
        call(planar, planar_state(planar))
    msg = str(info.value)
    assert msg.startswith(f"{name} must be one of [") and choices in msg and got in msg, msg


def test_simulate_keeps_its_model_error_for_unknown_choices(planar):
    x0 = planar_state(planar)
    with pytest.raises(ModelError, match=r"method must be one of \['cvodes', .*; got 'rk45'"):
        simulate(planar, x0, [0.0, 1.0], method="rk45")
    with pytest.raises(ModelError, match=r"multistep must be one of \['adams', 'bdf'\]"):
        simulate(planar, x0, [0.0, 1.0], multistep="gear")


def test_choice_accepts_members_and_values():
    assert _validate.choice(Method, "rk", "method") is Method.RK
    assert _validate.choice(Method, Method.RK, "method") is Method.RK
    with pytest.raises(ModelError, match=r"method must be one of .*; got \[1\]"):
        _validate.choice(Method, [1], "method", error=ModelError)


# ----------------------------------------------------------------------------------------
# switching branches: a side that fails is reported, not dropped


def plane_problem(expr_of) -> ZeroProblem:
    y = ca.SX.sym("y", 2)
    F = expr_of(y)
    fn = ca.Function("F", [y, ca.SX.sym("u", 0), ca.SX.sym("p", 0)], [F, ca.jacobian(F, y)])
    return ZeroProblem(name="plane", manifold=ProductManifold([("y", Rn(2))]), function=fn,
                       u=[], p=[])


@pytest.fixture(scope="module")
def line_and_circle():
    """y ((x - 1)^2 + y^2 - 1) = 0: the x-axis crosses the unit circle about (1, 0) at 0."""
    prob = plane_problem(lambda y: y[1] * ((y[0] - 1) ** 2 + y[1] ** 2 - 1))
    b = continue_branch(prob, [-1.0, 0.0], direction=[1.0, 0.0], max_arclength=1.5,
                        control=StepControl(step=0.07, max_step=0.1))
    (bp,) = b.specials(PointKind.BRANCH_POINT)
    return prob, bp


def test_switch_branch_returns_both_sides(line_and_circle):
    prob, bp = line_and_circle
    sw = switch_branch(prob, bp, step=0.1)
    assert len(sw) == 2 and not sw.failed and sw.describe_failures() == ""
    assert [r.status for r in sw.sides] == [RootStatus.CONVERGED] * 2
    for (y, d), r in zip(sw, sw.sides):
        assert y is r.x
        assert_close(abs(y[1]), 0.1, atol=1e-12, what="Keller distance along the y-axis")
        assert_close((y[0] - 1) ** 2 + y[1] ** 2, 1.0, atol=1e-12, what="on the circle")
        assert_close(abs(d[1]), 1.0, atol=1e-9, what="leaves vertically")


def test_switch_branch_raises_with_the_statuses_when_no_side_converges(line_and_circle):
    """At distance 1.5 from the origin the circle (|y| <= 1) has no point: both sides fail."""
    prob, bp = line_and_circle
    with pytest.raises(SolverError, match="neither side") as info:
        switch_branch(prob, bp, step=1.5)
    statuses = info.value.status.split("/")
    assert len(statuses) == 2 and "converged" not in statuses
    sw = switch_branch(prob, bp, step=1.5, raise_on_failure=False)
    assert len(sw) == 0 and list(sw) == [] and len(sw.failed) == 2
    assert all(not r.ok and r.message for r in sw.sides)
    assert "side +" in sw.describe_failures() and "side -" in sw.describe_failures()


def test_trace_notes_a_branch_point_whose_other_branch_was_not_picked_up(monkeypatch):
    """A corrector that cannot converge (tol below rounding) leaves a note per branch point."""
    model = p3.reduced(J=np.diag([0.4486, 0.3943, 0.0772]), rho=[0.0, 0.1044, 0.4989])
    real = relative_families.switch_branch

    def failing(problem, sp, *, step, control, raise_on_failure):
        hopeless = replace(control, tol=1e-300, max_corrector_iterations=1)
        return real(problem, sp, step=step, control=hopeless,
                    raise_on_failure=raise_on_failure)

    monkeypatch.setattr(relative_families, "switch_branch", failing)
    atlas = trace_relative_equilibria(model, control=StepControl(max_step=2.0),
                                      with_stability=False)
    bps = [sp for b in atlas.branches for sp in b.specials(PointKind.BRANCH_POINT)]
    notes = [n for n in atlas.notes if "was not picked up" in n]
    assert bps and len(notes) == len(bps)
    assert all("2 of 2 sides" in n and "max_iterations" in n for n in notes)
    assert not any(o.startswith("branch point") for o in atlas.origins)
    assert atlas.summary()["notes"] == atlas.notes


# ----------------------------------------------------------------------------------------
# evaluators check their arguments


@pytest.fixture(scope="module")
def f_and_state(planar):
    return planar.function("f"), planar_state(planar)


@pytest.mark.parametrize("cls", [Evaluator, DenseEvaluator])
def test_evaluators_refuse_missing_and_extra_arguments(f_and_state, planar, cls):
    f, x = f_and_state
    ev = cls(f)
    first = ev(x, np.zeros(0), planar.p)
    with pytest.raises(ModelError, match=r"f takes 3 inputs \[x \(3\), u \(0\), p \(4\)\]; "
                                         r"got 2 arguments"):
        ev(2 * x, np.zeros(0))  # p would have kept its value from the first call
    with pytest.raises(ModelError, match="got 4 arguments"):
        ev(x, np.zeros(0), planar.p, planar.p)
    again = ev(x, np.zeros(0), planar.p)
    assert_close(np.ravel(again[0] if isinstance(again, tuple) else again),
                 np.ravel(first[0] if isinstance(first, tuple) else first), atol=0.0,
                 what="refused calls leave nothing behind")


@pytest.mark.parametrize("cls", [Evaluator, DenseEvaluator])
def test_evaluators_refuse_wrong_sizes_instead_of_broadcasting(f_and_state, planar, cls):
    f, x = f_and_state
    ev = cls(f)
    with pytest.raises(ModelError, match=r"f: input 'p' must have 4 entries; got shape \(\)"):
        ev(x, np.zeros(0), 1.0)  # numpy would broadcast the scalar
    with pytest.raises(ModelError, match=r"input 'x' must have 3 entries; got shape \(2,\)"):
        ev(x[:2], np.zeros(0), planar.p)
    with pytest.raises(ModelError, match="input 'x' must be numeric"):
        ev(["a", "b", "c"], np.zeros(0), planar.p)
    # any shape with the right number of entries is accepted (column, row, matrix)
    ev(x.reshape(3, 1), np.zeros((0, 1)), planar.p.reshape(2, 2))


def test_dense_evaluator_is_an_evaluator_with_dense_outputs(planar):
    fx = planar.function("f_x")
    ev = DenseEvaluator(fx)
    assert isinstance(ev, Evaluator)
    (J,) = ev(planar_state(planar), np.zeros(0), planar.p)
    assert_close(J, np.asarray(fx(planar_state(planar), np.zeros(0), planar.p)), atol=0.0,
                 what="dense Jacobian")


# ----------------------------------------------------------------------------------------
# hot paths build their casadi Functions once


class _CountingDomain:
    """A domain b(x, p) that counts how often it is mapped over a batch."""

    def __init__(self, fn):
        self.fn, self.maps = fn, 0

    def map(self, n):
        self.maps += 1
        return self.fn.map(n)


def test_sublevel_set_maps_its_domain_once_per_batch_size(rng):
    model = p3.reduced(J=np.diag([3.0, 2.0, 1.0]), rho=[0.1, -0.05, 0.2])
    V = Lyapunov(model, lambda ctx: ca.dot(ctx["omega"], ctx["omega"]), name="kinetic")
    xs, ps = ca.SX.sym("x", 6), ca.SX.sym("p", model.n_params)
    domain = _CountingDomain(ca.Function("b", [xs, ps], [-xs[2]]))  # Gamma_3 > 0
    cap = SublevelSet(V, 1.0, domain=domain)
    X = np.array([model.manifold.random_point(rng) for _ in range(40)])
    first = cap.contains(X)
    assert_close(first, (np.sum(X[:, 3:] ** 2, axis=1) <= 1.0) & (X[:, 2] > 0), atol=0,
                 what="membership")
    for _ in range(3):
        assert_close(cap.contains(X), first, atol=0, what="same answer from the cache")
    cap.contains(X[:7])
    assert domain.maps == 2  # one map per batch size, not one per call


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


def test_linearize_ambient_evaluates_the_jacobians_once(monkeypatch):
    model = p3.reduced(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.3])
    x_e = model.state(Gamma=[0.0, 0.0, 1.0], omega=[0.0, 0.0, 0.0])
    module = sys.modules[linearize_ambient.__module__]
    real, calls = module._jacobians, []

    def counting(model, controller):
        fn = real(model, controller)

        def call(*args):
            calls.append(args)
            return fn(*args)

        return call

    monkeypatch.setattr(module, "_jacobians", counting)
    amb = linearize_ambient(model, x_e)
    assert len(calls) == 1
    lin = linearize(model, x_e)
    assert_close(amb.A @ lin.basis, lin.basis @ lin.A, atol=1e-12,
                 what="df/dx N = N A at an equilibrium")
    assert_close(amb.C @ amb.basis, np.zeros((1, 5)), atol=1e-15, what="basis in ker C")


# ----------------------------------------------------------------------------------------
# linearize.py split by concept; the old imports keep working


def test_linearize_reexports_the_ambient_form_and_stays_small():
    amb = importlib.import_module("workbench.linear._ambient")
    lin_mod = importlib.import_module("workbench.linear._linearize")  # the package binds the function

    for name in ("AmbientLinearization", "linearize_ambient", "closed_loop_jacobians",
                 "EQUILIBRIUM_TOL"):
        assert getattr(lin_mod, name) is getattr(amb, name) and name in lin_mod.__all__
    for module in (lin_mod, amb):
        with open(module.__file__, encoding="utf-8") as fh:
            assert sum(1 for _ in fh) <= 600, f"{module.__name__} is past ~600 lines"


# ----------------------------------------------------------------------------------------
# the symbol class is an enum (strings still accepted and still equal)


def _decay(symbolic):
    return Model(name="decay", manifold=ProductManifold([("x", Rn(2))]), n_inputs=0,
                 parameters=[Parameter("a", (), "rate [1/s]")], values={"a": 2.0},
                 vector_field=lambda ctx: -ctx["a"] * ctx["x"], symbolic=symbolic)


@pytest.mark.parametrize(("given", "member", "cls", "kind"), [
    (Symbolic.SX, Symbolic.SX, ca.SX, "SXFunction"), ("SX", Symbolic.SX, ca.SX, "SXFunction"),
    (Symbolic.MX, Symbolic.MX, ca.MX, "MXFunction"), ("MX", Symbolic.MX, ca.MX, "MXFunction"),
])
def test_model_symbolic_is_a_str_enum(given, member, cls, kind):
    model = _decay(given)
    assert model.symbolic is member and model.symbolic == member.value and model.sym is cls
    f = model.function("f")
    assert f.is_a(kind) and model.function("f", frozen=True).is_a(kind)
    assert_close(model.rhs([1.0, -3.0]), [-2.0, 6.0], atol=0, what="f = -a x")
    record = model.build_log.as_list()[0]
    assert json.loads(json.dumps(record))["symbolic"] == member.value
    assert f"{model.symbolic}" == member.value


def test_model_refuses_an_unknown_symbol_class():
    with pytest.raises(ModelError, match=r"symbolic must be one of \['SX', 'MX'\]; got 'QX'"):
        _decay("QX")


# ----------------------------------------------------------------------------------------
# static_equilibria names the model's own offset parameter


class _RenamedOffset:
    """A builder context that reads the offset 'rho' from a parameter called 'c'."""

    def __init__(self, ctx):
        self._ctx, self.x, self.u, self.p, self.model = ctx, ctx.x, ctx.u, ctx.p, ctx.model

    def __getitem__(self, name):
        return self._ctx["c" if name == "rho" else name]


def _balanced_body_with_offset_called_c():
    red = p3.reduced(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.0])
    params = [replace(p, name="c") if p.name == "rho" else p for p in red.parameters]
    values = {("c" if k == "rho" else k): v for k, v in red.values.items()}
    return Model(
        name="renamed", manifold=red.manifold, n_inputs=red.n_inputs, parameters=params,
        values=values, vector_field=lambda ctx: red._vector_field(_RenamedOffset(ctx)),
        invariants={k: (lambda ctx, b=b: b(_RenamedOffset(ctx)))
                    for k, b in red._invariants.items()})


def test_static_equilibria_quotes_the_offset_parameter_the_model_has():
    model = _balanced_body_with_offset_called_c()
    with pytest.raises(ParameterError, match="the body is balanced") as info:
        static_equilibria(model)
    assert "'rho'" not in str(info.value)  # the model has no parameter 'rho'
    with pytest.raises(ParameterError, match=r"parameter 'c' = \[0.0, 0.0, 0.0\] makes the "
                                             r"body balanced"):
        static_equilibria(model, offset="c")
    with pytest.raises(ModelError, match=r"offset must name .* \['J', 'c', 'm', 'g'\].*'rho'"):
        static_equilibria(model, offset="rho")
    with pytest.raises(ParameterError, match=r"parameter 'rho' = \[0.0, 0.0, 0.0\] makes"):
        static_equilibria(p3.reduced(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.0]))


# ----------------------------------------------------------------------------------------
# lqr takes its matrices through the same checks as pbh


def test_lqr_checks_its_system_like_pbh(planar):
    lin = linearize(planar, planar.state(p=[0.0, -1.0], omega_y=[0.0]))
    A = np.array([[0.0, 1.0], [2.0, 0.0]])
    for call, match in [
        (lambda: lqr(lin, np.eye(2), np.eye(0), B=np.ones((2, 1))), "pass B only"),
        (lambda: lqr(A, np.eye(2), np.eye(1)), "B is required when A is given as a matrix"),
        (lambda: lqr(A, np.eye(2), np.eye(1), B=np.ones((3, 1))), r"A \(2, 2\) and B \(3, 1\)"),
        (lambda: lqr(A, np.eye(2), np.eye(1), B=[[np.nan], [1.0]]), "must be finite"),
    ]:
        with pytest.raises(ModelError, match=match):
            call()
    res = lqr(A, np.eye(2), np.eye(1), B=[1.0, 1.0])  # a 1-D B is one input column
    assert np.all(res.closed_loop_eigenvalues.real < 0)
    assert res.riccati_residual < 1e-12


# ----------------------------------------------------------------------------------------
# geometric_feedback fails clearly, with the original error chained


class _UncallableController:
    """Stands for a controller that no symbol class can call."""

    def n_in(self):
        return 1

    def name(self):
        return "stub"

    def __call__(self, x):
        raise RuntimeError(f"no {type(x).__name__} evaluation")


def test_geometric_feedback_keeps_the_original_error(planar):
    lin = linearize(planar, planar.state(p=[0.0, -1.0], omega_y=[0.0]))
    broken = replace(lin, controller=_UncallableController())
    with pytest.raises(ModelError, match="could not compose the controller 'stub'") as info:
        geometric_feedback(broken, np.zeros((0, 2)))
    msg = str(info.value)
    assert "on SX symbols with RuntimeError: no SX evaluation" in msg
    assert "on MX symbols with RuntimeError: no MX evaluation" in msg
    assert isinstance(info.value.__cause__, RuntimeError)
    law = geometric_feedback(lin, np.zeros((0, 2)))  # no controller: SX, nothing to retry
    assert law.is_a("SXFunction") and law.nnz_out(0) == 0


# ----------------------------------------------------------------------------------------
# simulate refuses knobs its method would ignore


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


# ----------------------------------------------------------------------------------------
# the energy Hessian lives with the model's graphs (no unbounded module cache)


def test_energy_hessian_is_cached_with_the_model_and_released_with_it(monkeypatch):
    amb = importlib.import_module("workbench.linear._ambient")
    monkeypatch.setattr(amb, "_JAC_CACHE", {})  # linearize's bounded cache, emptied below
    model = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.5])
    x_e = model.state(R=np.diag([1.0, -1.0, -1.0]), omega=np.zeros(3))  # hanging
    forms = [second_order_form(model, x_e, pairs={"R": "omega"}),
             second_order_form(model.with_parameters(m=2.0), x_e, pairs={"R": "omega"})]
    assert_close(forms[1].G, 2.0 * forms[0].G, atol=1e-12, what="G scales with m")
    assert model.build_log.names().count(f"{model.name}.energy_hessian") == 1
    graphs = weakref.ref(model._graphs)
    amb._JAC_CACHE.clear()
    del model, forms
    gc.collect()
    assert graphs() is None, "a module-level cache keeps the model's graphs alive"
