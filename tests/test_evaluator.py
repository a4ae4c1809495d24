"""Evaluators of casadi Functions (workbench/core/_evaluator.py) check their arguments."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from workbench.core._evaluator import DenseEvaluator, Evaluator, evaluate_rows
from workbench.core.errors import ModelError


@pytest.fixture(scope="module")
def planar():
    return p3.planar(Jt=0.2, rho_s=0.3)


def planar_state(model):
    return model.state(p=[0.0, 1.0], omega_y=[1.0])


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


@pytest.mark.parametrize("cls", [Evaluator, DenseEvaluator])
@pytest.mark.parametrize("imag", [1e-3, 0.0])
def test_evaluators_refuse_complex_input_instead_of_dropping_its_imaginary_part(
        f_and_state, planar, cls, imag):
    """numpy's cast to the float buffer would keep the real part with only a warning."""
    f, x = f_and_state
    ev = cls(f)
    with pytest.raises(ModelError, match=r"f: input 'x' is complex \(dtype complex128\)"):
        ev(x + 1j * imag, np.zeros(0), planar.p)
    with pytest.raises(ModelError, match=r"input 'p' is complex"):
        ev(x, np.zeros(0), [complex(v, imag) for v in planar.p])


@pytest.mark.parametrize("bad, dtype", [(["0.0", "1.0", "1.0"], "<U3"),
                                        ([False, True, True], "bool")])
def test_evaluators_refuse_numeric_strings_and_booleans(f_and_state, planar, bad, dtype):
    f, _ = f_and_state
    with pytest.raises(ModelError, match=rf"input 'x' must be numeric \(real numbers\); got "
                                         rf"dtype {dtype}"):
        Evaluator(f)(bad, np.zeros(0), planar.p)  # numpy would parse the strings, cast bools


def test_evaluators_accept_integer_input_exactly(f_and_state, planar):
    f, x = f_and_state
    ev = Evaluator(f)
    whole = np.array([0, 1, 2])
    assert_close(ev(whole, np.zeros(0, dtype=int), planar.p),
                 ev(whole.astype(float), np.zeros(0), planar.p), atol=0.0, what="int input")


def _layout_function() -> ca.Function:
    """Outputs of every layout: all-zero sparse, sparse row, 1 x 1, column, dense matrix."""
    x = ca.SX.sym("x", 3)
    return ca.Function("layouts", [x], [
        ca.SX(3, 3),                                  # no structural nonzero at all
        ca.jacobian(ca.sin(x[0]) * x[2], x),         # a sparse 1 x 3 row
        ca.hessian(x[0] ** 3, x[0])[0],              # a 1 x 1 matrix: d2/dx0^2 = 6 x0
        ca.vertcat(x[1], ca.SX(1, 1), x[0] * x[2]),  # a column with a structural zero
        ca.jacobian(ca.vertcat(x[0] * x[1], x[2]), x)])  # a sparse 2 x 3 matrix


def test_dense_evaluator_scatters_every_output_layout_as_casadi_does():
    """An all-zero sparsity (empty triplets) used to fail with float indices."""
    fn = _layout_function()
    x = np.array([0.3, -1.2, 2.5])
    out = DenseEvaluator(fn)(x)
    exact = [np.asarray(v) for v in fn(x)]
    shapes = [(3, 3), (1, 3), (1,), (3,), (2, 3)]
    for k, (got, want, shape) in enumerate(zip(out, exact, shapes, strict=True)):
        assert got.shape == shape, f"output {k}"
        assert_close(got.reshape(want.shape), want, atol=0.0, what=f"output {k}")
    # the closed forms: 6 x0 for the 1 x 1 Hessian, (cos(x0) x2, 0, sin(x0)) for the row
    assert_close(out[2], [6 * x[0]], atol=1e-15, what="1 x 1 Hessian")
    assert_close(out[1], [[np.cos(x[0]) * x[2], 0.0, np.sin(x[0])]], atol=1e-15,
                 what="row Jacobian")
    assert not out[0].any()


def test_dense_evaluator_returns_columns_1d_including_a_1x1_matrix():
    """The documented layout: casadi has no vectors, so a 1 x 1 output is a column."""
    fn = _layout_function()
    _, _, hess, col, _ = DenseEvaluator(fn)(np.array([1.0, 2.0, 3.0]))
    assert hess.ndim == 1 and col.ndim == 1
    assert_close(hess.reshape(1, 1), [[6.0]], atol=0.0, what="1 x 1 read as a matrix")
    assert_close(col, [2.0, 0.0, 3.0], atol=0.0, what="column")


@pytest.mark.parametrize("n", [1, 2, 3, 1023, 1024, 1025, 2 * 1024 + 7])
def test_evaluate_rows_gives_casadis_map_bit_for_bit_across_chunk_boundaries(n):
    # the padded last chunk and every chunk size (powers of two up to ROWS_CHUNK) give the
    # numbers of one map over all n rows; two outputs of different sizes
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    fn = ca.Function("g", [x, p], [ca.sin(x[0]) * p[0] + x[1] * x[2], ca.vertcat(
        x * p[1], ca.exp(x[2]))])
    X = np.random.default_rng(n).standard_normal((n, 3))
    P = np.array([0.7, -1.3])
    got = evaluate_rows(fn, X, P)
    want = [np.asarray(o).reshape(-1, n).T for o in fn.map(n)(X.T, P)]
    assert [g.shape for g in got] == [(n, 1), (n, 4)]
    for g, w in zip(got, want):
        assert np.array_equal(g, w)


def test_evaluate_rows_refuses_wrong_shapes_and_missing_inputs():
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    fn = ca.Function("g", [x, p], [x * p[0]])
    with pytest.raises(ModelError, match=r"X must have shape \(n, 3\).*got shape \(5, 2\)"):
        evaluate_rows(fn, np.zeros((5, 2)), [1.0, 2.0])
    with pytest.raises(ModelError, match="X must have shape"):
        evaluate_rows(fn, np.zeros(3), [1.0, 2.0])  # one state is not a row of a series
    with pytest.raises(ModelError, match="takes 1 fixed inputs after the rows; got 0"):
        evaluate_rows(fn, np.zeros((5, 3)))
    with pytest.raises(ModelError, match="must have 2 entries"):
        evaluate_rows(fn, np.zeros((5, 3)), [1.0, 2.0, 3.0])
    with pytest.raises(ModelError, match="complex"):
        evaluate_rows(fn, np.zeros((5, 3)) + 1j, [1.0, 2.0])
    assert [o.shape for o in evaluate_rows(fn, np.zeros((0, 3)), [1.0, 2.0])] == [(0, 3)]


def test_evaluate_rows_returns_structural_zeros_as_dense_entries():
    # a field with a structurally zero row, and an input that is a structural zero: the
    # outputs keep their full size (a map's DM has the same numbers, densified)
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 1)
    fn = ca.Function("h", [x, p], [ca.vertcat(x[1] * p, ca.SX(1, 1)), ca.SX(2, 1)])
    assert fn.nnz_out(0) == 1 and fn.nnz_out(1) == 0
    X = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, -6.0]])
    rates, zeros = evaluate_rows(fn, X, [0.5])
    assert np.array_equal(rates, [[1.0, 0.0], [2.0, 0.0], [-3.0, 0.0]])
    assert np.array_equal(zeros, np.zeros((3, 2)))
