"""Compiled right-hand sides (issue 17): agreement with casadi, the cache, the errors.

Every compilation goes to a temporary cache; states are seeded. Small models keep the
builds short (the chain with two links for the linear-solve replacement).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d
from models.chain_cart import chain_cart
from workbench.codegen import CompileError, Optimization
from workbench.codegen.functions import (
    BatchEvaluator,
    Compilation,
    CompileOptions,
    LinearSolver,
    Parallelization,
    compile_function,
    generable,
)
from workbench.codegen.lanes import lanes_source
from workbench.core import Evaluator
from workbench.core.errors import ModelError
from workbench.simulation._simulate import simulate

N = 500
J = np.array([[3.0, 0.2, 0.1], [0.2, 2.0, 0.0], [0.1, 0.0, 1.0]])


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("fn-cache")


@pytest.fixture(scope="module")
def top():
    return pendulum3d.reduced(J=J, rho=[0.0, 0.1, 0.3], m=2.0, g=9.81)


def _states(model, n, seed):
    rng = np.random.default_rng(seed)
    return np.array([model.manifold.random_point(rng) for _ in range(n)])


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_compiled_batch_equals_casadi_on_seeded_states(top, cache):
    f = top.function("f")
    X, U = _states(top, N, 0), np.random.default_rng(1).normal(size=(N, top.n_inputs))
    ref = BatchEvaluator(f, N, shared=("p",))(X, U, top.p)
    ev = BatchEvaluator(f, N, shared=("p",), compilation=Compilation.C, cache_dir=cache)
    got = ev(X, U, top.p)
    assert got.shape == (N, top.manifold.ambient_dim)
    assert _rel(got, ref) <= 1e-14
    assert ev.compiled is not None and ev.compiled.substitutions == ()
    assert ev.compiled.build_seconds > 0 and ev.compiled.library.is_file()
    # one state through the buffered Evaluator of the compiled library
    one = Evaluator(compile_function(f, cache_dir=cache).function())
    assert_close(one(X[3], U[3], top.p), ref[3], atol=1e-14 * np.max(np.abs(ref[3])),
                 what="single compiled state")


def test_cache_hit_by_content_hash(top, cache):
    f = top.function("f")
    a = compile_function(f, cache_dir=cache)
    b = compile_function(f, cache_dir=cache)
    assert b.cached and b.hash == a.hash and b.directory == a.directory
    assert b.compile_seconds == 0.0
    other = compile_function(top.with_parameters(m=3.0).function("f", frozen=True),
                             cache_dir=cache)
    assert other.hash != a.hash


@pytest.mark.parametrize("solver", [LinearSolver.DENSE_LDL, LinearSolver.QR])
def test_linear_solves_are_replaced_and_reported(solver, cache):
    """The chain's LAPACK LU cannot be generated: replaced, reported, same field."""
    m = chain_cart(2)
    f = m.function("f")
    X, U = _states(m, 200, 2), np.random.default_rng(3).normal(size=(200, 2))
    ref = BatchEvaluator(f, 200, shared=("p",))(X, U, m.p)
    swapped, subs = generable(f, solver)
    assert subs and solver.value in subs[0]
    same_graph = BatchEvaluator(swapped, 200, shared=("p",))(X, U, m.p)
    ev = BatchEvaluator(f, 200, shared=("p",), compilation="c", linear_solver=solver,
                        cache_dir=cache)
    assert ev.compiled.substitutions == subs
    got = ev(X, U, m.p)
    assert _rel(got, same_graph) <= 1e-14          # compiled = casadi on the same graph
    assert _rel(got, ref) <= 1e-12                 # another factorisation of (12)


@pytest.mark.parametrize(("n", "width"), [(7, 2), (7, 4), (8, 4), (5, 1)])
def test_lanes_equal_the_serial_batch_bit_for_bit(n, width, cache):
    """Same operations in the same order: identical to casadi's compiled loop at -O2 (no
    fused multiply-adds), on n states not a multiple of the width too (padded block)."""
    m = chain_cart(2)
    f = m.function("f")
    X, U = _states(m, n, 8), np.random.default_rng(9).normal(size=(n, 2))
    kw = {"shared": ("p",), "compilation": "c", "linear_solver": LinearSolver.DENSE_LDL,
          "cache_dir": cache}
    serial = BatchEvaluator(f, n, **kw)(X, U, m.p)
    ev = BatchEvaluator(f, n, parallelization=Parallelization.LANES, lane_width=width, **kw)
    got = ev(X, U, m.p)
    assert f"lanes{width}x{n}" in ev.compiled.name and ev.compiled.substitutions
    assert np.array_equal(got, serial)
    ref = BatchEvaluator(f, n, shared=("p",))(X, U, m.p)  # LAPACK LU in casadi's VM
    assert _rel(got, ref) <= 1e-12
    # states are independent: the padded lanes never leak into the written ones
    one = BatchEvaluator(f, 1, parallelization="lanes", lane_width=width, **kw)
    assert np.array_equal(one(X[-1:], U[-1:], m.p), got[-1:])


def test_lanes_write_every_elementary_operation_as_casadi_does(cache):
    """The lane-by-lane operations (libm, comparisons, branches as selects) and the vector
    ones agree with casadi's virtual machine on seeded points, shared inputs broadcast."""
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    a, b, c = x[0], x[1], x[2]
    outs = [ca.sin(a) * p[0], ca.cos(b) / p[1], ca.sqrt(ca.fabs(c)), ca.atan2(a, b),
            ca.fmin(a, b), ca.fmax(b, c), ca.if_else(a < b, c, -c), ca.exp(-a * a),
            ca.log(1 + b * b), ca.tanh(c), ca.sign(a), ca.floor(3 * b), ca.power(p[0], c),
            ca.logic_and(a > 0, b <= 0), ca.logic_not(c == 0), 2 * a, 1 / (1 + c * c),
            ca.copysign(a, c), ca.erf(b), ca.asin(ca.tanh(a)), ca.fmod(3 * a, 0.7)]
    f = ca.Function("ops", [x, p], [ca.vertcat(*outs)], ["x", "p"], ["y"])
    n = 9
    X = np.random.default_rng(10).normal(size=(n, 3))
    X[0, 1] = X[0, 0]  # ties of the comparisons
    P = np.array([1.3, -0.4])
    ref = BatchEvaluator(f, n, shared=("p",))(X, P)
    for opt in (Optimization.O2, Optimization.NATIVE):
        got = BatchEvaluator(f, n, shared=("p",), compilation="c", parallelization="lanes",
                             optimization=opt, cache_dir=cache)(X, P)
        assert _rel(got, ref) <= 1e-14, opt


def test_lanes_write_infinite_and_nan_constants_as_c99(cache):
    """inf, -inf and nan constants become INFINITY, -INFINITY, NAN (repr gave 'inf': the
    C did not compile); the compiled lanes equal casadi's VM, non-finite entries included."""
    x = ca.SX.sym("x", 3)
    a, b, c = x[0], x[1], x[2]
    f = ca.Function("nonfinite", [x], [ca.vertcat(ca.if_else(a > 0, b, ca.inf),
                                                  ca.if_else(b > 0, -ca.inf, c),
                                                  ca.if_else(c > 0, np.nan, a))])
    X = np.random.default_rng(11).normal(size=(7, 3))
    ref = np.asarray(BatchEvaluator(f, 7)(X))
    got = np.asarray(BatchEvaluator(f, 7, compilation="c", parallelization="lanes",
                                    cache_dir=cache)(X))
    assert np.isinf(ref).any() and np.isnan(ref).any()
    np.testing.assert_array_equal(got, ref)  # equal, inf to inf and nan to nan


def test_lanes_are_refused_where_they_cannot_apply(top):
    f = top.function("f")
    with pytest.raises(ModelError, match="needs compilation='c'"):
        BatchEvaluator(f, 4, parallelization="lanes")
    for width in (3, 16):
        with pytest.raises(ModelError, match=r"width must be a power of two \(1, 2, 4 or 8"):
            BatchEvaluator(f, 4, shared=("p",), compilation="c", parallelization="lanes",
                           lane_width=width)
    x = ca.SX.sym("x", 2, 2)
    with pytest.raises(ModelError, match="dense column vectors; input 0 has shape"):
        lanes_source(ca.Function("g", [x], [ca.trace(x)]), 4, name="g_lanes")
    y = ca.MX.sym("y")
    with pytest.raises(ModelError, match="needs an SX function"):
        lanes_source(ca.Function("h", [y], [y * 2]), 4, name="h_lanes")


@pytest.mark.parametrize("par", list(Parallelization))
def test_compiled_batches_take_real_rows_only(par, cache):
    """Compiled serial and lanes batches give the closed form on real rows, and refuse
    complex rows (which numpy would cast, dropping the imaginary part) and a matrix input
    (which would be read column-major from the rows)."""
    x = ca.SX.sym("x", 2)
    f = ca.Function("real_rows", [x], [ca.vertcat(3 * x[0], x[0] * x[1])], ["x"], ["y"])
    X = np.random.default_rng(12).normal(size=(5, 2))
    ev = BatchEvaluator(f, 5, compilation="c", parallelization=par, cache_dir=cache)
    np.testing.assert_array_equal(ev(X), np.column_stack([3 * X[:, 0], X[:, 0] * X[:, 1]]))
    with pytest.raises(ModelError, match="input 'x' is complex"):
        ev(X + 1e-9j)
    M = ca.SX.sym("M", 2, 2)
    with pytest.raises(ModelError, match=r"input 'M' is a 2x2 matrix"):
        BatchEvaluator(ca.Function("tr", [M], [ca.trace(M)], ["M"], ["t"]), 5,
                       compilation="c", parallelization=par, cache_dir=cache)


def test_uncompiled_path_needs_no_compiler(top):
    f = top.function("f")
    ev = BatchEvaluator(f, 3, shared=("p",))
    assert ev.compiled is None and ev(_states(top, 3, 4), np.zeros((3, 3)), top.p).shape \
        == (3, 6)


@pytest.mark.parametrize(("compiler", "match", "status"),
                         [("/nonexistent/bin/cc", "cannot run '/nonexistent/bin/cc'", None),
                          ("false", r"exit status 1.*false --version", 1)])
def test_missing_or_failing_compiler_is_a_clear_error(top, tmp_path, compiler, match, status):
    f = top.function("f")
    with pytest.raises(CompileError, match=match) as err:
        compile_function(f, compiler=compiler, cache_dir=tmp_path)
    assert err.value.returncode == status
    for par in Parallelization:
        with pytest.raises(CompileError, match=match):
            BatchEvaluator(f, 4, shared=("p",), compilation="c", compiler=compiler,
                           cache_dir=tmp_path, parallelization=par)
    x0 = _states(top, 1, 5)[0]
    with pytest.raises(CompileError, match=match):
        simulate(top, x0, [0.0, 0.1], compilation="c",
                 compile_options=CompileOptions(compiler=compiler, cache_dir=tmp_path))
    # the uncompiled paths stay available
    assert simulate(top, x0, [0.0, 0.1]).x.shape == (2, 6)
    assert BatchEvaluator(f, 4, shared=("p",))(_states(top, 4, 6), np.zeros((4, 3)),
                                               top.p).shape == (4, 6)


def test_simulate_with_the_compiled_rhs(top, cache):
    x0 = _states(top, 1, 7)[0]
    t = np.linspace(0.0, 1.0, 11)
    opts = CompileOptions(cache_dir=cache)
    rk = simulate(top, x0, t, method="rk", step=1e-3)
    rk_c = simulate(top, x0, t, method="rk", step=1e-3, compilation="c", compile_options=opts)
    assert_close(rk_c.x, rk.x, atol=1e-13, what="rk, compiled vs casadi")
    assert rk_c.options["compilation"] == "c" and "compile" in rk_c.cost
    rtol = 1e-10
    cv = simulate(top, x0, t, rtol=rtol, atol=rtol)
    fine = simulate(top, x0, t, rtol=rtol / 10, atol=rtol / 10)
    cv_c = simulate(top, x0, t, rtol=rtol, atol=rtol, compilation=Compilation.C,
                    compile_options=opts)
    tol = max(10 * rtol, float(np.max(np.abs(cv.x - fine.x))))
    assert_close(cv_c.x, cv.x, atol=tol, what="cvodes, compiled vs casadi")
    again = simulate(top, x0, t, rtol=rtol, atol=rtol, compilation="c", compile_options=opts)
    assert again.cost["compile"]["cached"] and again.cost["compile"]["compile_seconds"] == 0


def test_bad_options_are_refused(top):
    f = top.function("f")
    with pytest.raises(ModelError, match="compilation must be one of"):
        BatchEvaluator(f, 2, compilation="gpu")
    with pytest.raises(ModelError, match="parallelization must be one of"):
        BatchEvaluator(f, 2, parallelization="openmp")
    with pytest.raises(ModelError, match="linear_solver must be one of"):
        generable(chain_cart(1).function("f"), "lapacklu")
    with pytest.raises(ModelError, match=r"shared inputs \['q'\]"):
        BatchEvaluator(f, 2, shared=("q",))
    with pytest.raises(ModelError, match="n must"):
        BatchEvaluator(f, 0)
    ev = BatchEvaluator(f, 2, shared=("p",))
    with pytest.raises(ModelError, match=r"input 'x' must have shape \(2, 6\)"):
        ev(np.zeros((3, 6)), np.zeros((2, 3)), top.p)
    with pytest.raises(ModelError, match="takes 3 inputs"):
        ev(np.zeros((2, 6)), top.p)
    with pytest.raises(ModelError, match="casadi.Function"):
        compile_function("f")
    x0 = _states(top, 1, 8)[0]
    with pytest.raises(ModelError, match="does not use compilation"):
        simulate(top, x0, [0.0, 0.1], method="rkmk4", step=0.01, compilation="c")
    with pytest.raises(ModelError, match="compile_options must be a CompileOptions"):
        simulate(top, x0, [0.0, 0.1], compilation="c", compile_options={"compiler": "gcc"})
