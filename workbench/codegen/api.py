"""One-call entry points: build, compile, verify and export a controller of the workbench."""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import casadi as ca
import numpy as np

from workbench.codegen.build import (
    CompiledController,
    Optimization,
    compile_sources,
    export,
)
from workbench.codegen.csource import generate
from workbench.codegen.spec import Binding, ExportableController
from workbench.core.errors import ModelError
from workbench.core.validate import choice

__all__ = ["ExportResult", "Through", "agreement", "compile_controller", "export_c"]


def _controller(controller: ExportableController) -> ExportableController:
    if not isinstance(controller, ExportableController):
        got = f"{type(controller).__name__} {controller!r}" if isinstance(controller, str) \
            else type(controller).__name__
        raise ModelError(f"controller must be an ExportableController (the papers' "
                         f"controllers are built by name with "
                         f"workbench.app.catalogue.build(name)); got {got}")
    return controller


def compile_controller(
    controller: ExportableController,
    *,
    binding: Binding,
    optimization: Optimization = Optimization.O2,
    with_jacobian: bool = False,
    compiler: str = "gcc",
    cache_dir: str | os.PathLike | None = None,
) -> CompiledController:
    """Generate and compile a controller (cached by the hash of its sources and flags).

    Parameters
    ----------
    controller : ExportableController
        The controller (e.g. from :func:`workbench.app.catalogue.build`).
    binding : Binding
        What is frozen into the code and what is a run-time input.
    optimization : Optimization
        Optimisation flags; ``-std=c99 -Wall -Wextra -Werror`` are always on.
    with_jacobian : bool
        Include ``jac_NAME`` (for use inside CVODES and other implicit integrators).
    compiler : str
        The C compiler command.
    cache_dir : path-like, optional
        Cache directory (default ``$WORKBENCH_CODEGEN_CACHE`` or the user cache).

    Returns
    -------
    CompiledController
    """
    c = _controller(controller)
    return compile_sources(generate(c, binding=Binding(binding), with_jacobian=with_jacobian),
                           optimization=optimization, compiler=compiler, cache_dir=cache_dir)


class Through(str, Enum):
    """How the compiled code is called when checked.

    Attributes
    ----------
    STEP
        The wrapper ``NAME_step`` (what a C user calls), through ctypes.
    EXTERNAL
        casadi's entry point ``NAME``, through :func:`casadi.external` (what
        :func:`workbench.simulation._simulate.simulate` calls).
    """

    STEP = "step"
    EXTERNAL = "external"

    @classmethod
    def _missing_(cls, value: object) -> Through:
        raise ModelError(f"through must be one of {[t.value for t in cls]}; got {value!r}")


def agreement(controller: ExportableController, compiled: CompiledController,
              states: np.ndarray, *, binding: Binding, through: Through = Through.STEP,
              reference: ca.Function | None = None) -> np.ndarray:
    """Per-state relative deviation of the compiled controller from casadi's evaluation.

    ``|u_c - u_ref|_inf / |u_ref|_inf`` (0 where both agree exactly, including 0 = 0), with
    ``u_ref`` from ``reference`` (default: the exported casadi function of the binding)
    evaluated by casadi's virtual machine, both on the binding's default run-time vector.

    Parameters
    ----------
    controller : ExportableController
        The controller.
    compiled : CompiledController
        Its build, with the same binding.
    states : ndarray, shape=(n, nx)
        States.
    binding : Binding
        The binding the library was compiled with.
    through : Through
        Which compiled entry point to call.
    reference : casadi.Function, optional
        Another reference with the binding's inputs, e.g. the workbench's controller for
        ``PARAMETERS``.

    Returns
    -------
    ndarray, shape=(n,)
    """
    binding = choice(Binding, binding, "binding")
    through = choice(Through, through, "through")
    if compiled.sources.binding is not binding:
        raise ModelError(f"compiled was built with binding {compiled.sources.binding.value}; "
                         f"got binding={binding.value}")
    ref = controller.function_for(binding) if reference is None else reference
    X = np.asarray(states, dtype=float)
    if X.ndim != 2 or X.shape[1] != controller.nx:
        raise ModelError(f"states must have shape (n, {controller.nx}); got {X.shape}")
    p = controller.runtime_values(binding)

    def run(f: ca.Function) -> np.ndarray:
        args = [X.T] + ([p] if f.n_in() == 2 else [])
        return np.asarray(f.map(X.shape[0])(*args)).T

    u_c = compiled.step(X, p) if through is Through.STEP else run(compiled.function())
    u_r = run(ref)
    num = np.max(np.abs(u_c - u_r), axis=1)
    den = np.max(np.abs(u_r), axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(num == 0, 0.0, num / den)


@dataclass(frozen=True)
class ExportResult:
    """What :func:`export_c` wrote.

    Attributes
    ----------
    controller : ExportableController
        The exported controller.
    compiled : CompiledController
        The checked build of the same sources (in the cache).
    files : list of Path
        The files written to the output directory.
    """

    controller: ExportableController
    compiled: CompiledController
    files: list[Path]


    def __str__(self) -> str:
        """What was written where, and the checked build; never the sources."""
        files = ", ".join(p.name for p in self.files)
        folder = self.files[0].parent if self.files else "-"
        return (f"Exported {self.controller.name} to {folder}: {files}; checked build: "
                f"{self.compiled}")

    __repr__ = __str__

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"


def export_c(
    controller: ExportableController,
    out_dir: str | os.PathLike,
    *,
    binding: Binding,
    optimization: Optimization = Optimization.O2,
    compiler: str = "gcc",
    cache_dir: str | os.PathLike | None = None,
) -> ExportResult:
    """Export a controller as C99 sources, after checking that they compile warning-free.

    Writes ``NAME.c``, ``NAME.h``, ``main.c``, ``bench.c`` and a ``Makefile`` to
    ``out_dir`` (created if missing). The sources are first compiled in the cache with
    ``-std=c99 -Wall -Wextra -Werror``; nothing is written if that fails.

    Parameters
    ----------
    controller : ExportableController
        The controller (e.g. from :func:`workbench.app.catalogue.build`).
    out_dir : path-like
        Output directory.
    binding : Binding
        What is frozen into the code and what is a run-time input.
    optimization : Optimization
        Optimisation flags of the check build (the Makefile defaults to ``-O2``).
    compiler : str
        The C compiler command for the check build.
    cache_dir : path-like, optional
        Cache directory.

    Returns
    -------
    ExportResult

    Raises
    ------
    ModelError
        ``controller`` is not an :class:`ExportableController`.
    ExportError
        ``out_dir`` is not a writable directory.
    CompileError
        The check build failed (the compiler's message is included).
    """
    from workbench.codegen.build import _temp_dir, _writable_target

    c = _controller(controller)
    out = Path(out_dir)
    # probe the output directory before compiling: a bad --out fails fast
    shutil.rmtree(_temp_dir(_writable_target(out), ".probe-", out))
    sources = generate(c, binding=Binding(binding))
    compiled = compile_sources(sources, optimization=optimization, compiler=compiler,
                               cache_dir=cache_dir)
    return ExportResult(c, compiled, export(sources, out_dir))
