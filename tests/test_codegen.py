"""Controllers exported as C: agreement with casadi, closed loops, the export, the errors.

Every compilation goes to a temporary cache (never the user's); states are seeded. The
default run compiles one build per controller (rotating through the bindings) and the
closed loops of papers 001 and 003; the full controller x binding matrix is slow-marked.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_close

from models.chain_cart import link_state
from workbench import codegen
from workbench.app import catalogue as exports
from workbench.app.export_cli import main as cli_main
from workbench.codegen import Binding, Optimization, Through
from workbench.codegen.csource import void_unused_parameters
from workbench.core.errors import ModelError
from workbench.core.manifolds import SO3, so3_exp
from workbench.simulation._simulate import simulate

N_STATES = 10_000
TOL = 1e-12
E3 = np.array([0.0, 0.0, 1.0])
NAMES = ["saturated_velocity_feedback", "s2_pd", "so3_pd", "cart_nonlinear", "chain_lqr_n5"]
DEFAULT_BUILDS = [
    ("saturated_velocity_feedback", Binding.FROZEN),
    ("s2_pd", Binding.PARAMETERS_AND_GAINS),
    ("so3_pd", Binding.PARAMETERS),
    ("cart_nonlinear", Binding.PARAMETERS_AND_GAINS),
    ("chain_lqr_n5", Binding.FROZEN),
]
ALL_BUILDS = [(n, b) for n in NAMES for b in Binding]
# libm functions the generated code may call; anything else undefined (malloc!) is a bug
LIBM = {"sqrt", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "exp", "log",
        "pow", "fabs", "floor", "ceil", "fmin", "fmax", "copysign", "tanh", "sinh", "cosh"}


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("codegen-cache")


_BUILT: dict[str, codegen.ExportableController] = {}


def controller(name: str) -> codegen.ExportableController:
    if name not in _BUILT:
        _BUILT[name] = exports.build(name)
    return _BUILT[name]


# ----------------------------------------------------------------------------------------
# the sampled states really reach the singular and saturated regions


def _near_regions(name: str, X: np.ndarray) -> dict[str, int]:
    """Counts of sampled states in each critical region (each must be well populated)."""
    if name == "saturated_velocity_feedback":
        Pw = X[:, 9:12] @ np.diag([5.0, 10.0, 15.0])
        n = np.linalg.norm(Pw, axis=1)
        return {"|P w| > 1e6": int(np.sum(n > 1e6)), "0 < |P w| < 1e-100":
                int(np.sum((n > 0) & (n < 1e-100))), "w = 0": int(np.sum(n == 0))}
    if name == "s2_pd":
        d = np.linalg.norm(X[:, :3] + E3, axis=1)
        return {"|q + q_d| < 1e-10": int(np.sum(d < 1e-10)), "q = -q_d": int(np.sum(d == 0))}
    if name == "so3_pd":
        saddles = [so3_exp(np.pi * e) for e in np.eye(3)]
        d = np.array([min(np.linalg.norm(SO3.matrix(x[:9]) - S) for S in saddles) for x in X])
        return {"|R - saddle| < 1e-10": int(np.sum(d < 1e-10))}
    if name == "cart_nonlinear":
        s = np.sqrt(2.0 / 14.0)
        return {"|q3 + s| < 1e-8": int(np.sum(np.abs(X[:, 6] + s) < 1e-8)),
                "|q3 - s| < 1e-8": int(np.sum(np.abs(X[:, 6] - s) < 1e-8))}
    q = X[:, 4:].reshape(len(X), -1, 6)[:, :, :3].reshape(-1, 3)
    return {"q_i = -e3": int(np.sum(np.all(q == -E3, axis=1))),
            "|q_i - e3| < 1e-10": int(np.sum(np.linalg.norm(q - E3, axis=1) < 1e-10))}


@pytest.mark.parametrize("name", NAMES)
def test_sampled_states_crowd_the_singular_and_saturated_regions(name):
    c = controller(name)
    X = c.sample_states(N_STATES, seed=0)
    assert X.shape == (N_STATES, c.nx) and np.all(np.isfinite(X))
    counts = _near_regions(name, X)
    assert all(v >= 20 for v in counts.values()), counts
    # all states on the manifold: the law is exercised where it is meant to act
    worst = max(max(c.model.manifold.residual_norms(x).values()) for x in X[:200])
    assert worst < 1e-12


@pytest.mark.parametrize("name", NAMES)
def test_every_binding_evaluates_the_workbench_controller(name):
    """Frozen, parameters and the symbolic-gain law all equal the workbench's controller."""
    c = controller(name)
    X = c.sample_states(N_STATES, seed=1)
    ref = np.asarray(c.function.map(N_STATES)(X.T, c.model.p)).T
    for b in Binding:
        f = c.function_for(b)
        args = [X.T] + ([c.runtime_values(b)] if f.n_in() == 2 else [])
        u = np.asarray(f.map(N_STATES)(*args)).T
        rel = np.max(np.abs(u - ref), axis=1) / np.maximum(np.max(np.abs(ref), axis=1),
                                                           1e-300)
        assert rel.max() <= TOL, f"{name} {b.value}: {rel.max():.3g}"


# ----------------------------------------------------------------------------------------
# the compiled code agrees with casadi


def _check_build(name: str, binding: Binding, cache: Path) -> None:
    c = controller(name)
    lib = codegen.compile_controller(c, binding=binding, optimization=Optimization.O2,
                                     cache_dir=cache)
    X = c.sample_states(N_STATES, seed=2)
    for via in Through:
        rel = codegen.agreement(c, lib, X, binding=binding, through=via)
        assert rel.max() <= TOL, f"{name} {binding.value} via {via.value}: {rel.max():.3g}"
    if binding is Binding.PARAMETERS:  # the workbench's own function as the reference
        rel = codegen.agreement(c, lib, X, binding=binding, reference=c.function)
        assert rel.max() <= TOL
    # the example program prints u at the paper's initial state, to the last bit
    f = c.function_for(binding)
    args = [c.example_state] + ([c.runtime_values(binding)] if f.n_in() == 2 else [])
    assert lib.run_example() == np.asarray(f(*args)).ravel().tolist()
    # no heap allocation anywhere in the compiled controller: only libm is called
    undefined = subprocess.run(["nm", "-u", str(lib.directory / f"{c.name}.o")],
                               capture_output=True, text=True, check=True).stdout.split()
    called = {s for s in undefined if s != "U"}
    assert called <= LIBM, called - LIBM
    text = lib.sources.files[f"{c.name}.c"]
    assert not any(w in text for w in ("malloc", "calloc", "realloc", "free("))


@pytest.mark.parametrize(("name", "binding"), DEFAULT_BUILDS,
                         ids=[f"{n}-{b.value}" for n, b in DEFAULT_BUILDS])
def test_compiled_agrees_with_casadi_on_seeded_states(name, binding, cache):
    _check_build(name, binding, cache)


def test_saturated_law_is_branch_free_with_one_division():
    """Issue 17: (34) as C without an ``if`` on a zero norm and with a single division,
    equal to ``-k P w / (1 + |P w|)`` at the ulp level on the seeded states."""
    c = controller("saturated_velocity_feedback")
    code = codegen.generate(c, binding=Binding.FROZEN).files[f"{c.name}.c"]
    body = code[code.index("static int casadi_f0"):]
    body = body[:body.index("\n}\n")]
    assert "?" not in body.replace("arg[0]?", "") and body.count("/") == 1, body
    X = c.sample_states(N_STATES, seed=2)
    Pw = X[:, 9:12] @ np.diag([5.0, 10.0, 15.0])
    ref = -10.0 * Pw / (1 + np.linalg.norm(Pw, axis=1))[:, None]
    u = np.asarray(c.function_for(Binding.FROZEN).map(N_STATES)(X.T)).T
    scale = np.maximum(np.max(np.abs(ref), axis=1), 1e-300)
    assert np.max(np.max(np.abs(u - ref), axis=1) / scale) <= 4e-16


@pytest.mark.slow
@pytest.mark.parametrize(("name", "binding"),
                         [nb for nb in ALL_BUILDS if nb not in DEFAULT_BUILDS]
                         + [("chain_lqr_n1", Binding.FROZEN), ("chain_lqr_n2", Binding.PARAMETERS),
                            ("chain_lqr_n10", Binding.PARAMETERS_AND_GAINS)],
                         ids=lambda v: v.value if isinstance(v, Binding) else v)
def test_compiled_agrees_with_casadi_full_matrix(name, binding, cache):
    _check_build(name, binding, cache)


@pytest.mark.slow
@pytest.mark.parametrize("opt", [Optimization.O3, Optimization.NATIVE])
def test_other_optimisation_levels_agree(opt, cache):
    c = controller("so3_pd")
    lib = codegen.compile_controller(c, binding=Binding.FROZEN, optimization=opt,
                                     cache_dir=cache)
    rel = codegen.agreement(c, lib, c.sample_states(N_STATES, seed=3), binding=Binding.FROZEN)
    assert rel.max() <= TOL


# ----------------------------------------------------------------------------------------
# closed loops with the compiled controller inside the integrator


def _closed_loops(name, x0, t, binding, cache, *, rtol):
    """Python and compiled closed loops, and the integrator's own error at ``rtol``.

    The error is measured against a run at ``rtol / 10``: the compiled closed loop must
    agree with the Python one within ``max(10 rtol, 10 x that error)``. Both runs carry the
    integrator's error independently, and one comparison with ``rtol / 10`` estimates it only
    to its order of magnitude (on the cart of Fig. 5 the derived model's loop differs from the
    compiled one by 4.8e-8 against an estimate of 6.4e-9; the printed model's by 2.1e-9
    against 5.6e-9).
    """
    c = controller(name)
    lib = codegen.compile_controller(c, binding=binding, with_jacobian=True, cache_dir=cache)
    py = simulate(c.model, x0, t, controller=c.function, rtol=rtol, atol=rtol)
    fine = simulate(c.model, x0, t, controller=c.function, rtol=rtol / 10, atol=rtol / 10)
    cc = simulate(c.model, x0, t, controller=lib.function(), rtol=rtol, atol=rtol)
    tol = max(10 * rtol, 10 * float(np.max(np.abs(py.x - fine.x))))
    assert_close(cc.x, py.x, atol=tol, what="states, compiled vs Python closed loop")
    return c, py, cc, tol


def test_closed_loop_paper001_section7_compiled_reproduces_python(cache):
    """Saturated feedback (34) from R(0) of Section 7: same trajectory to the tolerance."""
    rtol = 1e-10
    x0 = controller("saturated_velocity_feedback").example_state
    c, py, cc, tol = _closed_loops("saturated_velocity_feedback", x0,
                                   np.linspace(0.0, 30.0, 301), Binding.PARAMETERS, cache,
                                   rtol=rtol)
    assert_close(cc.u, py.u, atol=10 * tol * 10.0, what="inputs (|dk/dx| < 10 k)")
    theta = np.degrees(np.arccos(np.clip([SO3.matrix(x[:9])[2, 2] for x in py.x], -1, 1)))
    assert abs(theta[0] - 179.2) < 0.05           # the paper's Theta(0) = 179.2 deg
    assert theta[-1] < 5.0 and theta[-1] < theta[150]   # on its way to the hanging manifold
    assert np.max(np.linalg.norm(py.u, axis=1)) <= 10.0 + 1e-12   # |u| <= k = 10 N m


def test_closed_loop_paper003_fig3_chain_compiled_reproduces_python(cache):
    """LQR feedback (19) of the five-link chain from (27): same trajectory to the tolerance."""
    c = controller("chain_lqr_n5")
    links = {f"link{i + 1}": link_state((-1.0) ** (i + 1) * E3) for i in range(4)}
    links["link5"] = link_state([np.sin(np.radians(1)), 0.0, -np.cos(np.radians(1))])
    x0 = c.model.state(x=[0.2, 0.1], v=[0.0, -0.1], **links)
    rtol = 1e-10
    _, py, cc, _ = _closed_loops("chain_lqr_n5", x0, np.linspace(0.0, 6.0, 13),
                                 Binding.FROZEN, cache, rtol=rtol)
    e_q = sum(np.linalg.norm(py.x[-1, 4 + 6 * i:7 + 6 * i] - E3) for i in range(5))
    assert e_q < 0.1                               # Fig. 3: approaching the hanging state


def test_closed_loop_paper003_fig5_cart_compiled_reproduces_python(cache):
    rtol = 1e-10
    _, py, _, _ = _closed_loops("cart_nonlinear", controller("cart_nonlinear").example_state,
                                np.linspace(0.0, 10.0, 101), Binding.FROZEN, cache, rtol=rtol)
    assert py.x[-1, 6] < -0.99                     # Fig. 5: inverted (q1 . e3 -> -1)


# ----------------------------------------------------------------------------------------
# the export, the cache, the benchmark


def test_export_writes_a_self_contained_project_that_builds(tmp_path, cache):
    out = tmp_path / "s2"
    res = codegen.export_c(controller("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
    names = sorted(p.name for p in res.files)
    assert names == sorted(["s2_pd.c", "s2_pd.h", "main.c", "bench.c", "Makefile",
                            ".workbench-export.json"])
    assert sorted(os.listdir(tmp_path)) == ["s2"]   # no temporary left behind
    header = (out / "s2_pd.h").read_text()
    for needle in ("S2_PD_NX 6", "S2_PD_NP 0", "S2_PD_NU 3", "[N m]", "[rad/s]",
                   "s2_pd_SZ_W", "s2_pd_workspace", "heap", "Singular"):
        assert needle in header
    if shutil.which("make"):
        subprocess.run(["make", "-s"], cwd=out, check=True, capture_output=True)
        printed = subprocess.run(["./example"], cwd=out, check=True, capture_output=True,
                                 text=True).stdout
        c = controller("s2_pd")
        u = np.asarray(c.function(c.example_state, c.model.p)).ravel()
        assert [float(line.split("=")[1]) for line in printed.split("\n") if line] \
            == u.tolist()
    # exporting again into the existing directory replaces the files
    again = codegen.export_c(controller("s2_pd"), out, binding=Binding.PARAMETERS, cache_dir=cache)
    assert "S2_PD_NP 3" in (out / "s2_pd.h").read_text() and len(again.files) == 6


def test_cache_is_reused_and_keyed_by_flags(cache):
    c = controller("s2_pd")
    a = codegen.compile_controller(c, binding=Binding.FROZEN, cache_dir=cache)
    b = codegen.compile_controller(c, binding=Binding.FROZEN, cache_dir=cache)
    assert b.cached and b.directory == a.directory
    o3 = codegen.compile_controller(c, binding=Binding.FROZEN, optimization=Optimization.O3,
                                    cache_dir=cache)
    assert o3.hash != a.hash and o3.directory != a.directory


def test_bench_runs_and_reports_positive_times(cache):
    lib = codegen.compile_controller(controller("s2_pd"), binding=Binding.FROZEN,
                                     cache_dir=cache)
    r = codegen.bench_c(lib, calls=1000, batches=3)
    assert r.calls == 1000 and r.batches == 3
    assert 0 < r.min_ns <= r.median_ns <= r.max_ns < float("inf")


# ----------------------------------------------------------------------------------------
# bad input and failures


def test_unknown_controllers_are_refused_with_the_known_names():
    with pytest.raises(ModelError, match="not an exportable controller.*s2_pd"):
        exports.build("lqr_tracker")
    with pytest.raises(ModelError, match="chain_lqr_n<N>"):
        exports.build("chain_lqr")
    with pytest.raises(ModelError, match="1 <= N"):
        exports.build("chain_lqr_n0")
    with pytest.raises(ModelError, match="C identifier"):
        exports.build("s2-pd")
    with pytest.raises(ModelError, match="ExportableController.*workbench.app.catalogue.build"):
        codegen.export_c(controller("s2_pd").function, "/tmp", binding=Binding.FROZEN)
    with pytest.raises(ModelError, match="ExportableController.*got str 's2_pd'"):
        codegen.export_c("s2_pd", "/tmp", binding=Binding.FROZEN)  # names live in models
    with pytest.raises(ModelError, match="binding must be one of"):
        codegen.Binding("runtime")
    with pytest.raises(ModelError, match="optimization must be one of"):
        codegen.Optimization("-Ofast")


def test_bad_output_directories_are_refused_and_nothing_is_written(tmp_path, cache):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    cases = [(a_file, "not a directory"), (tmp_path / "missing" / "out", "parent"),
             (Path("/proc/workbench-export"), "not writable")]
    for out, msg in cases:
        with pytest.raises(codegen.ExportError, match=msg):
            codegen.export_c(controller("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
    assert sorted(os.listdir(tmp_path)) == ["file"]


def test_a_compiler_failure_shows_the_compilers_message(tmp_path):
    c = controller("s2_pd")
    src = codegen.generate(c, binding=Binding.FROZEN)
    broken = dict(src.files)
    broken["s2_pd.c"] += "\nint s2_pd_broken(void) { return undeclared_symbol; }\n"
    bad = dataclasses.replace(src, files=broken, digest="broken")
    with pytest.raises(codegen.CompileError, match="undeclared_symbol") as err:
        codegen.compile_sources(bad, optimization=Optimization.O2, cache_dir=tmp_path)
    assert err.value.returncode not in (0, None) and "error" in err.value.stderr
    # a warning is an error too (-Werror)
    warned = dict(src.files)
    warned["s2_pd.c"] += "\nint s2_pd_warn(int unused_arg);\nint s2_pd_warn(int unused_arg) {" \
                         " return 0; }\n"
    with pytest.raises(codegen.CompileError, match="unused"):
        codegen.compile_sources(dataclasses.replace(src, files=warned, digest="warned"),
                                optimization=Optimization.O2, cache_dir=tmp_path)
    # no partial build is left in the cache
    assert os.listdir(tmp_path) == []
    with pytest.raises(codegen.CompileError, match="cannot run"):
        codegen.compile_sources(src, optimization=Optimization.O2,
                                compiler="no-such-compiler-xyz", cache_dir=tmp_path)
    out = tmp_path / "never"
    with pytest.raises(codegen.CompileError):
        codegen.export_c(c, out, binding=Binding.FROZEN, compiler="no-such-compiler-xyz",
                         cache_dir=tmp_path)
    assert not out.exists()


def test_void_unused_parameters_casts_every_parameter_of_a_definition():
    code = ("static int f(const double** arg, double* w, int mem) {\n  return 0;\n}\n"
            "void g(void) {\n}\n#define X(a) (a)\n")
    out = void_unused_parameters(code)
    assert "  (void)arg; (void)w; (void)mem;" in out
    assert "void g(void) {\n}\n" in out and out.count("(void)") == 4


# ----------------------------------------------------------------------------------------
# the export-c subcommand


def test_the_engine_imports_no_concrete_model():
    """workbench.codegen receives ExportableController entries; models/ builds them."""
    code = ("import sys, workbench, workbench.codegen, workbench.app.export_cli, "
            "workbench.app.cli; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('models', 'problems')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=Path(__file__).resolve().parents[1])
    assert out.stdout.strip() == "[]", out.stdout


def test_cli_lists_exports_and_reports_errors(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv(codegen.CACHE_ENV, str(tmp_path / "cache"))
    assert cli_main(["export-c", "--list"]) == 0
    listed = capsys.readouterr().out
    for name in ("saturated_velocity_feedback", "s2_pd", "so3_pd", "chain_lqr_n<N>",
                 "cart_nonlinear", "swingup_tvlqr_cart"):
        assert name in listed
    assert cli_main(["export-c", "nope", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: 'nope' is not an exportable controller") and \
        err.count("\n") == 1
    assert cli_main(["export-c", "s2_pd", "--out", "/proc/workbench-x"]) == 2
    assert "not writable" in capsys.readouterr().err
    assert cli_main(["export-c", "s2_pd"]) == 2
    assert "--out" in capsys.readouterr().err
    assert cli_main(["export-c", "s2_pd", "--out", str(tmp_path / "o"), "--verify", "500",
                     "--binding", "parameters"]) == 0
    out = capsys.readouterr().out
    assert "verified on 500 seeded states" in out and "(ok" in out
    assert (tmp_path / "o" / "s2_pd.h").is_file()
    # the same subcommand through the 'workbench' command
    from workbench.app.cli import main as workbench_main

    assert workbench_main(["export-c", "--list"]) == 0
    assert capsys.readouterr().out == listed


# ----------------------------------------------------------------------------------------
# the time-varying LQR tracker of the swing-up: a table lookup (x, t) -> u


def _table_reference(tg, X, U, G, C, lo, hi, x, t):
    """The law of workbench/tvlqr.py on a table: sample k held on [t_k, t_k+1)."""
    k = int(np.clip(np.searchsorted(tg, t, side="right") - 1, 0, len(tg) - 1))
    return np.clip(U[k] - G[k] @ (C[k] @ (x - X[k])), lo, hi)


def test_tvlqr_table_law_on_a_synthetic_table():
    rng = np.random.default_rng(3)
    K, nx, nu, d = 5, 4, 2, 3
    tg = np.arange(K + 1) * 0.1  # t_K = 0.5 holds the equilibrium row
    X, U = rng.normal(size=(K + 1, nx)), rng.normal(size=(K + 1, nu))
    G, C = rng.normal(size=(K + 1, nu, d)), rng.normal(size=(K + 1, d, nx))
    f = exports.tvlqr_table_law(tg, X, U, G, C, u_lower=-2.0, u_upper=2.0)
    ts = np.concatenate([tg, np.nextafter(tg, -np.inf), np.nextafter(tg, np.inf),
                         [-1.0, -1e-300, 0.25, 10.0, 1e300]])
    xs = rng.normal(size=(ts.size, nx)) * 2
    u = np.asarray(f.map(ts.size)(xs.T, ts[None, :])).T
    ref = np.array([_table_reference(tg, X, U, G, C, -2, 2, x, t) for x, t in zip(xs, ts)])
    assert np.max(np.abs(u - ref) / np.maximum(np.abs(ref).max(axis=1, keepdims=True),
                                               1e-300)) <= TOL
    assert np.any(np.abs(ref) == 2.0)  # the saturation is exercised
    # before t_0: the first sample; from t_K on: the equilibrium row; on t_k: sample k
    x0 = np.zeros(nx)
    for t, k in ((-1.0, 0), (tg[2], 2), (np.nextafter(tg[2], 0), 1), (tg[-1], K), (9.0, K)):
        assert_close(np.asarray(f(x0, t)).ravel(), np.clip(U[k] + G[k] @ (C[k] @ X[k]), -2, 2),
                     atol=1e-14, what=f"t = {t!r}")
    with pytest.raises(ModelError):
        exports.tvlqr_table_law(tg, X[:-1], U, G, C)


@pytest.mark.slow
def test_swingup_tvlqr_compiled_agrees_with_casadi_and_workbench_tvlqr(cache):
    c = controller("swingup_tvlqr_cart")
    Z = c.sample_states(N_STATES, seed=0)
    # the sampler puts t on the grid, one ulp around it, before t_0 and after the horizon
    assert np.sum(Z[:, -1] < 0) >= 500
    compiled = codegen.compile_controller(c, binding=Binding.FROZEN, cache_dir=cache)
    for through in Through:
        dev = codegen.agreement(c, compiled, Z, binding=Binding.FROZEN, through=through)
        assert dev.max() <= TOL, f"{through.value}: {dev.max():.3g}"
    u = np.asarray(c.function_for(Binding.FROZEN).map(N_STATES)(Z.T)).T
    ref = np.array([c.reference(z[:-1], z[-1]) for z in Z])
    rel = np.max(np.abs(u - ref), axis=1) / np.max(np.abs(ref), axis=1)
    assert rel.max() <= TOL, rel.max()
    assert np.all(np.isfinite(compiled.run_example()))
    with pytest.raises(ModelError):
        c.function_for(Binding.PARAMETERS)


def test_export_never_replaces_files_it_did_not_write(tmp_path, cache):
    """A user's Makefile or main.c (or a file its Makefile's clean would remove) stops the
    export before anything is written; a re-export replaces its own unedited files."""
    from workbench.codegen.build import MANIFEST, ExportError

    out = tmp_path / "proj"
    out.mkdir()
    (out / "Makefile").write_text("all:\n\techo mine\n")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(ExportError, match=r"holds files this export did not write.*Makefile"):
        codegen.export_c(controller("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
    assert sorted(os.listdir(out)) == ["Makefile", "notes.txt"]  # nothing written
    assert (out / "Makefile").read_text() == "all:\n\techo mine\n"
    (out / "Makefile").unlink()
    (out / "bench").write_text("a user's file that 'make clean' would remove")
    with pytest.raises(ExportError, match=r"\['bench'\]"):
        codegen.export_c(controller("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
    (out / "bench").unlink()
    first = codegen.export_c(controller("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
    assert (out / MANIFEST).exists() and (out / "notes.txt").read_text() == "mine"
    (out / "bench").write_text("built by the export's Makefile")  # a product: replaceable
    again = codegen.export_c(controller("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
    assert [p.name for p in again.files] == [p.name for p in first.files]
    (out / "main.c").write_text("/* edited by the user */")
    with pytest.raises(ExportError, match=r"edited since.*main\.c"):
        codegen.export_c(controller("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
    assert (out / "main.c").read_text() == "/* edited by the user */"
    (out / "main.c").unlink()
    (out / "main.c").mkdir()
    with pytest.raises(ExportError, match=r"main\.c \(a directory\)"):
        codegen.export_c(controller("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
