"""Every size knob is bounded before anything is allocated, generated, compiled or run.

Hostile sizes (``export-c --verify 10**11``, ``report --jobs 100000``, ``lane_width=1024``,
a batch of 10**9 states, ``bench_c(calls=10**12)``) end in one clear error naming the
bound, never in an allocation traceback, a compiler running for minutes or a report
claiming 100000 processes. The bounds are checked where they bite (the largest accepted
size passes) and before any work (a compiler that cannot run, or an output folder, shows
nothing was started). ``BatchEvaluator`` also refuses what it would read wrongly: complex
data, matrix and sparse inputs or outputs.
"""

from __future__ import annotations

import io
import types

import casadi as ca
import numpy as np
import pytest

from workbench.codegen import BatchEvaluator, batch_function
from workbench.codegen.lanes import (
    LANE_BUDGET,
    MAX_BATCH_ENTRIES,
    MAX_LANE_WIDTH,
    STACK_BUDGET,
    _check_states,
    check_lane_width,
    lanes_source,
    max_lane_width,
    max_states,
)
from workbench.core.errors import ModelError

NO_COMPILER = "/nonexistent/bin/cc"
"""A compiler that cannot run: reaching it would raise CompileError, not ModelError."""


def _double(n: int = 2) -> ca.Function:
    x = ca.SX.sym("x", n)
    return ca.Function("double", [x], [2 * x], ["x"], ["y"])


def _sin_chain(k: int) -> ca.Function:
    """x -> sin(sin(...sin(x)...)), k times: an SX function of about k instructions."""
    x = ca.SX.sym("x")
    y = x
    for _ in range(k):
        y = ca.sin(y)
    return ca.Function("chain", [x], [y], ["x"], ["y"])


# ----------------------------------------------------------------------------------------
# BatchEvaluator: what it would read wrongly


@pytest.mark.parametrize("data", [np.array([[1 + 2j, 3.0], [4.0, 5.0]]),
                                  np.array([[1 + 0j, 3], [4, 5]]),   # imaginary part zero
                                  [[1j, 0.0], [0.0, 0.0]]])
def test_complex_input_is_refused_not_truncated(data):
    ev = BatchEvaluator(_double(), 2)
    with pytest.raises(ModelError, match=r"input 'x' is complex.*imaginary part"):
        ev(data)
    # the real data of the same shape give the closed form
    real = np.real(np.asarray(data, dtype=complex))
    np.testing.assert_array_equal(ev(real), 2 * real)


def test_complex_shared_input_is_refused():
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    ev = BatchEvaluator(ca.Function("f", [x, p], [x * p], ["x", "p"], ["y"]), 3,
                        shared=("p",))
    X = np.arange(6.0).reshape(3, 2)
    with pytest.raises(ModelError, match=r"input 'p' is complex"):
        ev(X, np.array([1.0, 2.0 + 1e-3j]))
    np.testing.assert_array_equal(ev(X, [1.0, 2.0]), X * [1.0, 2.0])


def test_a_matrix_input_or_output_is_refused_with_the_layout_named():
    M = ca.SX.sym("M", 2, 3)
    with pytest.raises(ModelError, match=r"input 'M' is a 2x3 matrix.*column-major.*vec"):
        BatchEvaluator(ca.Function("m", [M], [ca.sum1(M).T], ["M"], ["s"]), 4)
    x = ca.SX.sym("x", 3)
    with pytest.raises(ModelError, match=r"output 'P' is a 3x3 matrix"):
        BatchEvaluator(ca.Function("outer", [x], [x @ x.T], ["x"], ["P"]), 4)


def test_a_sparse_vector_is_refused():
    x = ca.SX.sym("x", 2)
    f = ca.Function("g", [x], [ca.vertcat(x[0], ca.SX(1, 1), x[1])], ["x"], ["y"])
    with pytest.raises(ModelError, match=r"output 'y' is a sparse vector \(2 of 3 entries"):
        BatchEvaluator(f, 2)
    fine = ca.Function("g", [x], [ca.densify(f(x))], ["x"], ["y"])
    X = np.array([[1.0, 2.0], [3.0, 4.0]])
    np.testing.assert_array_equal(BatchEvaluator(fine, 2)(X), [[1, 0, 2], [3, 0, 4]])


def test_row_and_column_vectors_both_take_one_row_per_state():
    """A row-vector input is read as a column-vector one: y = A x on seeded states."""
    A = np.array([[1.0, -2.0, 0.5], [0.0, 3.0, 1.0]])
    col, row = ca.SX.sym("x", 3), ca.SX.sym("x", 1, 3)
    f_col = ca.Function("fc", [col], [ca.DM(A) @ col], ["x"], ["y"])
    f_row = ca.Function("fr", [row], [(ca.DM(A) @ row.T).T], ["x"], ["y"])
    X = np.random.default_rng(0).normal(size=(5, 3))
    for f in (f_col, f_row):
        np.testing.assert_allclose(BatchEvaluator(f, 5)(X), X @ A.T, rtol=0, atol=1e-15)


# ----------------------------------------------------------------------------------------
# states per call


def test_states_per_call_are_bounded_by_the_doubles_of_one_call():
    x, p = ca.SX.sym("x", 2 ** 10), ca.SX.sym("p", 3)
    f = ca.Function("big", [x, p], [x * p[0]], ["x", "p"], ["y"])
    limit = max_states(f, ("p",))
    assert limit == (MAX_BATCH_ENTRIES - 3) // 2 ** 11 == 8191
    assert _check_states(f, limit, ("p",)) == limit  # the largest accepted (casadi's map
    # of it takes a minute to build: the bound is about what one call may cost)
    for call in (lambda: batch_function(f, limit + 1, shared=("p",)),
                 lambda: BatchEvaluator(f, limit + 1, shared=("p",)),
                 lambda: lanes_source(f, limit + 1, name="big_lanes", shared=("p",),
                                      width=1)):
        with pytest.raises(ModelError, match=rf"n must be an integer >= 1 and <= {limit}; "
                                             rf"got {limit + 1}.*{MAX_BATCH_ENTRIES}"):
            call()
    with pytest.raises(ModelError, match=r"n must be an integer >= 1 and <= 4194304; got "
                                         r"1000000000"):
        BatchEvaluator(_double(), 10 ** 9, compilation="c", compiler=NO_COMPILER)


@pytest.mark.parametrize("bad", [0, -1, 2.0, True, "3", None])
def test_states_per_call_must_be_a_whole_number(bad):
    with pytest.raises(ModelError, match="n must be an integer"):
        BatchEvaluator(_double(), bad)


def test_shared_must_name_inputs():
    for bad in ("x", 3, None, [1], ("x", None)):
        with pytest.raises(ModelError, match="shared must be a sequence of input names"):
            BatchEvaluator(_double(), 2, shared=bad)
    with pytest.raises(ModelError, match=r"shared inputs \['q'\] are not inputs"):
        BatchEvaluator(_double(), 2, compilation="c", parallelization="lanes", shared=("q",),
                       compiler=NO_COMPILER)


# ----------------------------------------------------------------------------------------
# lane_width


@pytest.mark.parametrize("width", [16, 1024, 2 ** 40, 3, 0, -2, 2.0, True, "4"])
def test_lane_width_beyond_the_widest_register_or_not_a_power_of_two(width):
    """Refused before casadi generates or gcc compiles anything (the compiler cannot run)."""
    with pytest.raises(ModelError, match=rf"lane_width: width must be a power of two \(1, 2, "
                                         rf"4 or {MAX_LANE_WIDTH}.*got"):
        BatchEvaluator(_double(), 4, compilation="c", parallelization="lanes",
                       lane_width=width, compiler=NO_COMPILER)


def test_lane_width_is_bounded_by_the_functions_size():
    """instructions x width <= LANE_BUDGET: the widest allowed follows the closed form."""
    f = _sin_chain(30_000)
    k = f.n_instructions()
    widest = max(w for w in (1, 2, 4, 8) if k * w <= LANE_BUDGET)
    assert max_lane_width(f) == widest == 4  # 30 003 instructions: 4 fits, 8 does not
    assert check_lane_width(f, widest) == widest
    with pytest.raises(ModelError, match=rf"lane_width: width 8 is too wide .*: {k} "
                                         rf"instructions x 8 lanes = {8 * k} > LANE_BUDGET = "
                                         rf"{LANE_BUDGET}.*widest allowed for it is 4"):
        BatchEvaluator(f, 4, compilation="c", parallelization="lanes", lane_width=8,
                       compiler=NO_COMPILER)
    huge = _sin_chain(LANE_BUDGET)
    assert max_lane_width(huge) == 0
    with pytest.raises(ModelError, match="no width fits: use parallelization='serial'"):
        lanes_source(huge, 4, name="huge_lanes", width=1)


def test_lane_width_is_bounded_by_the_stack():
    """A block's vectors (work, inputs, outputs) live on the stack: at most STACK_BUDGET."""
    n_in = 100_000  # one entry used: few instructions, a large frame
    x = ca.SX.sym("x", n_in)
    f = ca.Function("first", [x], [x[0]], ["x"], ["y"])
    vectors = f.sz_w() + n_in + 1 + 2
    assert 8 * vectors <= STACK_BUDGET < 8 * 2 * vectors
    assert max_lane_width(f) == 1
    with pytest.raises(ModelError, match=rf"frame of {vectors} vectors of 2 doubles is "
                                         rf"{16 * vectors} bytes > STACK_BUDGET = "
                                         rf"{STACK_BUDGET}.*widest allowed for it is 1"):
        BatchEvaluator(f, 4, compilation="c", parallelization="lanes", lane_width=2,
                       compiler=NO_COMPILER)


def test_the_default_lane_width_narrows_to_the_bounds_and_says_so(tmp_path):
    """Given no lane_width, a function too large for the default 2 gets the widest allowed
    (1 here, by the stack), named in the compiled function; given 2, it is refused."""
    x = ca.SX.sym("x", 100_000)
    f = ca.Function("first", [x], [x[0] - x[-1]], ["x"], ["y"])
    assert max_lane_width(f) == 1
    X = np.random.default_rng(1).normal(size=(3, 100_000))
    ev = BatchEvaluator(f, 3, compilation="c", parallelization="lanes", cache_dir=tmp_path)
    assert ev.compiled.name == "first_lanes1x3"
    np.testing.assert_array_equal(ev(X)[:, 0], X[:, 0] - X[:, -1])
    with pytest.raises(ModelError, match="widest allowed for it is 1"):
        BatchEvaluator(f, 3, compilation="c", parallelization="lanes", lane_width=2,
                       cache_dir=tmp_path)


def test_lane_width_only_with_lanes():
    with pytest.raises(ModelError, match="lane_width applies to parallelization='lanes' only"):
        BatchEvaluator(_double(), 4, compilation="c", lane_width=4, compiler=NO_COMPILER)


def test_the_default_widths_fit_the_benchmarked_chains():
    """The chain on a cart with 5 and 10 links (benchmarks/bench_compiled.py) at the
    default widths 2 and 4 stays within the bounds."""
    from models.chain_cart import chain_cart
    from workbench.codegen.functions import LinearSolver, generable

    f, _ = generable(chain_cart(10).function("f"), LinearSolver.DENSE_LDL)
    assert max_lane_width(f.expand()) >= 4


# ----------------------------------------------------------------------------------------
# sample counts, --verify, bench_c


def test_sample_states_is_bounded():
    from workbench.app.catalogue import build
    from workbench.codegen.spec import MAX_SAMPLES

    c = build("s2_pd")
    assert c.sample_states(3, seed=0).shape == (3, c.nx)
    for n in (MAX_SAMPLES + 1, 10 ** 12):
        with pytest.raises(ModelError, match=rf"n must be an integer >= 1 and <= "
                                             rf"{MAX_SAMPLES}"):
            c.sample_states(n, seed=0)
    for n in (0, -5, 2.5, True):
        with pytest.raises(ModelError, match="n must be an integer >= 1"):
            c.sample_states(n, seed=0)
    with pytest.raises(ModelError, match="seed must be an integer >= 0"):
        c.sample_states(3, seed=-1)


@pytest.mark.parametrize("verify", ["1000001", "100000000000", "-1"])
def test_export_c_verify_is_bounded_before_anything_is_built(tmp_path, capsys, verify):
    from workbench.app import cli
    from workbench.codegen.spec import MAX_SAMPLES

    out = tmp_path / "out"
    code = cli.main(["export-c", "s2_pd", "--out", str(out), "--verify", verify])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err
    assert f"--verify must be an integer >= 0 and <= {MAX_SAMPLES}; got {verify}" in err
    assert not out.exists()


def test_bench_c_is_bounded_before_the_program_runs():
    from workbench.codegen import bench_c
    from workbench.codegen.build import BENCH_CALLS

    not_built = types.SimpleNamespace()  # never reached: the counts are checked first
    with pytest.raises(ModelError, match=rf"calls must be an integer >= 1 and <= "
                                         rf"{BENCH_CALLS // 501}; got 1000000000000"):
        bench_c(not_built, calls=10 ** 12)
    for batches in (0, 1002, 10 ** 9):
        with pytest.raises(ModelError, match=r"batches must be an integer >= 1 and <= 1001"):
            bench_c(not_built, batches=batches)


# ----------------------------------------------------------------------------------------
# the report's --jobs


def _catalogue(folder, names):
    """Problems as real module files (the runner hashes their sources)."""
    import importlib.util

    folder.mkdir(exist_ok=True)
    mods = {}
    for name in names:
        path = folder / f"{name}.py"
        path.write_text(f'from workbench.study import Result\nTITLE = "synthetic {name}"\n'
                        f'def solve(*, quick=False):\n'
                        f'    return Result("{name}", TITLE, quick=quick).finish()\n')
        spec = importlib.util.spec_from_file_location(f"size_bounds_{name}", path)
        mods[name] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mods[name])
    return types.SimpleNamespace(names=lambda: sorted(mods), load=lambda n: mods[n],
                                 title=lambda n: mods[n].TITLE)


def test_report_jobs_is_bounded_and_reports_the_processes_used(tmp_path):
    from workbench.app.report import ReportInputError
    from workbench.app.report.runner import MAX_JOBS, run_all

    names = ["one", "two"]
    cat = _catalogue(tmp_path / "problems", names)
    for jobs in (MAX_JOBS + 1, 100_000, 0, 2.0, True):
        bound = "" if isinstance(jobs, (bool, float)) else rf" and <= {MAX_JOBS}"
        with pytest.raises(ReportInputError, match=rf"--jobs must be an integer >= 1{bound}; "
                                                   rf"got {jobs}"):
            run_all(names, quick=True, catalogue=cat, jobs=jobs, progress=False)
    stream = io.StringIO()
    outcomes, stats = run_all(names, quick=True, catalogue=cat, jobs=MAX_JOBS, stream=stream,
                              timeout=120)
    assert [o.status.value for o in outcomes] == ["ok", "ok"], [o.error for o in outcomes]
    assert stats.jobs == 2 and "on 2 processes" in stats.line()
    text = stream.getvalue()
    assert f"--jobs {MAX_JOBS}: 2 process(es) used, one per problem to run" in text
    assert "on 2 processes" in text and f"on {MAX_JOBS} processes" not in text


def test_cli_report_jobs_is_bounded_before_any_work(tmp_path, capsys):
    from workbench.app import cli
    from workbench.app.report.runner import MAX_JOBS

    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        cli.main(["report", "--jobs", "100000", "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert info.value.code == 2 and len(err.splitlines()) == 1
    assert f"expected a whole number from 1 to {MAX_JOBS}" in err and "100000" in err
    assert not out.exists()
    with pytest.raises(SystemExit):
        cli.main(["report", "--help"])
    assert f"and {MAX_JOBS})" in " ".join(capsys.readouterr().out.split())

