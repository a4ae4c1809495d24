"""The NLP's functions compiled to machine code: an explicit speed-for-build-time knob.

Ipopt calls the objective, the constraints, their Jacobian and the Hessian of the
Lagrangian once or more per iteration; casadi evaluates them in its virtual machine. With
:class:`Compiled`, casadi generates C for all of them (``generate_dependencies`` of a
solver of the same NLP), the system compiler builds a shared library, and Ipopt calls the
library (``nlpsol`` from the library's path). The library lives in the engine's one cache
of compiled artefacts (:func:`workbench.codegen.build.build_cached`): its hash covers the
generated source, the compiler command and the compiler's version, so an identical NLP is
compiled once per machine and loaded in milliseconds afterwards.

What it costs and gains is measured, not assumed: :attr:`Transcription.compile_info`
records the seconds of code generation, of compilation (0 when cached) and of loading,
and ``benchmarks/bench_drake_swingup.py`` prints build and solve times both ways. Only SX
graphs are compiled (an MX graph's numeric linear solves have no C code here); the
uncompiled path is the default and stays available. A missing compiler or a failed
compilation raises :class:`~workbench.codegen.build.CompileError` naming the compiler
command and its exit status.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca

from workbench.core.errors import ParameterError

__all__ = ["Compiled", "compiled_solver"]


@dataclass(frozen=True)
class Compiled:
    """Compile the NLP's functions with the system compiler.

    Parameters
    ----------
    compiler : str
        The C compiler command (on ``PATH`` or a path).
    flags : tuple of str
        Optimisation flags. ``-O1`` compiles the large generated Hessians in a fraction of
        the time of ``-O2``/``-O3`` and runs nearly as fast (measured in the benchmark).
    cache_dir : str, optional
        Cache directory (default: :func:`workbench.codegen.build.cache_root`).
    max_source_mb : float
        Largest generated source accepted for compilation [MB]. Exact Hessians of NLPs
        whose dynamics contain a symbolic linear solve generate C by the hundred megabytes
        (the spherical cart at N = 40: 115 MB), which takes the compiler many minutes and
        gigabytes; above this size the build is refused with the size in the message.
    """

    compiler: str = "gcc"
    flags: tuple[str, ...] = ("-O1",)
    cache_dir: str | None = None
    max_source_mb: float = 20.0

    def __post_init__(self) -> None:
        if not isinstance(self.compiler, str) or not self.compiler.strip():
            raise ParameterError(f"compiler must be a command name; got {self.compiler!r}")
        if isinstance(self.flags, str) or not all(isinstance(f, str) and f.startswith("-")
                                                  for f in self.flags):
            raise ParameterError(
                f"flags must be a tuple of compiler options such as ('-O1',); got "
                f"{self.flags!r}")
        object.__setattr__(self, "flags", tuple(self.flags))
        if not (isinstance(self.max_source_mb, (int, float)) and self.max_source_mb > 0):
            raise ParameterError(f"max_source_mb must be a positive number; got "
                                 f"{self.max_source_mb!r}")

    def describe(self) -> str:
        """E.g. ``"compiled gcc -O1"``."""
        return f"compiled {self.compiler} {' '.join(self.flags)}"


def compiled_solver(name: str, nlp: dict[str, Any], ipopt_opts: dict[str, Any],
                    compiled: Compiled, *, graph_ok: bool = True,
                    derivatives: dict[str, ca.Function] | None = None,
                    ) -> tuple[ca.Function, dict[str, Any]]:
    """An Ipopt solver of ``nlp`` whose functions run from a compiled, cached library.

    Parameters
    ----------
    name : str
        Name of the solver (and prefix of the cache entry).
    nlp : dict
        casadi NLP (``x``, ``p``, ``f``, ``g``) of SX expressions.
    ipopt_opts : dict
        Options of ``nlpsol`` (``ipopt`` sub-dictionary and casadi options).
    compiled : Compiled
        Compiler and flags.
    graph_ok : bool
        Whether the NLP's graph can be generated as C (``Symbolic.SX``).
    derivatives : dict, optional
        ``nlpsol`` derivative options (``jac_g``, ``hess_lag``, ``grad_f``) to generate
        instead of casadi's own (the transcription's per-interval derivatives, see
        :mod:`workbench.control.ocp.derivatives`): the compiled solver then evaluates the
        same functions as the uncompiled one.

    Returns
    -------
    (casadi.Function, dict)
        The solver, and ``generate_seconds``, ``compile_seconds``, ``load_seconds``,
        ``cached``, ``library``, ``hash``.

    Raises
    ------
    ParameterError
        If the NLP's graph cannot be generated (``graph_ok`` false).
    CompileError
        If the compiler is missing or fails (command, exit status and message).
    """
    from workbench.codegen.build import build_cached

    if not graph_ok:
        raise ParameterError("compiled NLPs need graph=Symbolic.SX (an MX graph's numeric "
                             "linear solves are not generated as C here)")
    t0 = time.perf_counter()
    plain = ca.nlpsol(f"{name}_gen", "ipopt", nlp, {"ipopt": {"print_level": 0},
                                                     "print_time": False,
                                                     **(derivatives or {})})
    # the oracle and every function Ipopt calls, user-supplied derivatives included
    # (generate_dependencies would leave those out)
    gen = ca.CodeGenerator(f"{name}.c")
    gen.add(plain.oracle())
    for fn in ("nlp_f", "nlp_g", "nlp_grad", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l"):
        gen.add(plain.get_function(fn))
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        try:
            os.chdir(tmp)
            gen.generate()
        finally:
            os.chdir(cwd)
        source = (Path(tmp) / f"{name}.c").read_text()
    generate = time.perf_counter() - t0
    size_mb = len(source) / 1e6
    if size_mb > compiled.max_source_mb:
        raise ParameterError(
            f"the generated C of {name} is {size_mb:.0f} MB (> max_source_mb = "
            f"{compiled.max_source_mb:g}); compiling it would take {compiled.compiler} "
            f"minutes and gigabytes. Solve uncompiled (compiled=None), use fewer intervals, "
            f"or raise Compiled(max_source_mb=...)")
    digest = hashlib.sha256(source.encode()).hexdigest()
    cmd = [compiled.compiler, *compiled.flags, "-fPIC", "-shared", f"{name}.c", "-o",
           f"lib{name}.so", "-lm"]
    t1 = time.perf_counter()
    final, full, cached = build_cached(
        f"nlp_{name}", {f"{name}.c": source}, [cmd], digest=digest,
        compiler=compiled.compiler, cache_dir=compiled.cache_dir,
        manifest={"kind": "ocp nlp", "casadi_functions": ["nlp_f", "nlp_g", "nlp_grad_f",
                                                           "nlp_jac_g", "nlp_hess_l"]})
    compile_seconds = time.perf_counter() - t1
    t2 = time.perf_counter()
    library = final / f"lib{name}.so"
    solver = ca.nlpsol(name, "ipopt", str(library), ipopt_opts)
    info = {"generate_seconds": generate, "compile_seconds": 0.0 if cached else compile_seconds,
            "load_seconds": time.perf_counter() - t2, "cached": cached,
            "library": str(library), "hash": full, "compiler": compiled.describe(),
            "source_mb": size_mb}
    return solver, info
