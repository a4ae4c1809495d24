"""Controllers of the workbench exported as self-contained C99 code, verified and timed.

Typical use::

    from workbench import codegen
    codegen.names()                                   # what can be exported
    res = codegen.export_c("saturated_velocity_feedback", "out/",
                           binding=codegen.Binding.FROZEN)
    lib = codegen.compile_controller("chain_lqr_n5", binding=codegen.Binding.PARAMETERS)
    k = lib.function()                                # casadi.external, usable in simulate
    codegen.bench_c(lib).median_ns                    # nanoseconds per call, measured in C

Modules: :mod:`~workbench.codegen.spec` (what an exportable controller is, bindings),
:mod:`~workbench.codegen.catalogue` and :mod:`~workbench.codegen.registry` (the papers'
controllers), :mod:`~workbench.codegen.csource` (C sources), :mod:`~workbench.codegen.build`
(compiler, cache, benchmark, export) and :mod:`~workbench.codegen.api`.
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
from workbench.codegen.registry import build, describe, names
from workbench.codegen.spec import Binding, Entry, ExportableController

__all__ = [
    "CACHE_ENV",
    "BenchResult",
    "Binding",
    "CSources",
    "CompileError",
    "CompiledController",
    "Entry",
    "ExportError",
    "ExportResult",
    "ExportableController",
    "Optimization",
    "Through",
    "agreement",
    "bench_c",
    "build",
    "cache_root",
    "compile_controller",
    "compile_sources",
    "describe",
    "export_c",
    "generate",
    "names",
]
