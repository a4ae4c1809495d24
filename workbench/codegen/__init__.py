"""Controllers of the workbench exported as self-contained C99 code, verified and timed.

Typical use: your own feedback in one call (the papers' controllers are exported by name
from the application layer, ``workbench export-c NAME --out DIR``; the engine only receives
:class:`ExportableController` entries)::

    from workbench import codegen, linearize, lqr
    k = lqr(linearize(model, x_eq), Q=Q, R=R).feedback(name="my_lqr")
    res = codegen.export_feedback(model, k, "out/", name="my_lqr", title="...",
                                  example_state=x_eq)
    res.compiled.function()                           # casadi.external, usable in simulate

Any casadi Function (a model's right-hand side, a closed loop, a batch of states) compiles
the same way, as an explicit speed-for-build-time knob::

    from workbench.codegen import BatchEvaluator, compile_function
    ev = BatchEvaluator(model.function("f"), 1000, shared=("p",), compilation="c")
    xdot = ev(X, U, model.p)                          # X: (1000, nx), U: (1000, nu)
    ev.compiled.build_seconds                         # what the speed cost, once per hash

Modules: :mod:`~workbench.codegen.spec` (what an exportable controller is, bindings),
:mod:`~workbench.codegen.csource` (C sources), :mod:`~workbench.codegen.build` (compiler,
cache, benchmark, export), :mod:`~workbench.codegen.api` and
:mod:`~workbench.codegen.functions` (compiled functions and batch evaluation).
"""

from workbench.codegen.api import (
    ExportResult,
    Through,
    agreement,
    compile_controller,
    export_c,
)
from workbench.codegen.build import (
    CACHE_ENV,
    BenchResult,
    CompiledController,
    CompileError,
    ExportError,
    Optimization,
    bench_c,
    cache_root,
    compile_sources,
)
from workbench.codegen.csource import CSources, generate
from workbench.codegen.feedback import export_feedback, feedback_controller
from workbench.codegen.functions import (
    BatchEvaluator,
    Compilation,
    CompiledFunction,
    CompileOptions,
    LinearSolver,
    Parallelization,
    batch_function,
    compile_function,
)
from workbench.codegen.spec import Binding, Entry, ExportableController

__all__ = [
    "CACHE_ENV",
    "BatchEvaluator",
    "BenchResult",
    "Binding",
    "CSources",
    "Compilation",
    "CompileError",
    "CompileOptions",
    "CompiledController",
    "CompiledFunction",
    "Entry",
    "ExportError",
    "ExportResult",
    "ExportableController",
    "LinearSolver",
    "Optimization",
    "Parallelization",
    "Through",
    "agreement",
    "batch_function",
    "bench_c",
    "cache_root",
    "compile_controller",
    "compile_function",
    "compile_sources",
    "export_c",
    "export_feedback",
    "feedback_controller",
    "generate",
]
