"""Compiled casadi Functions: speed for build time, as an explicit, measured knob.

:func:`compile_function` writes any casadi Function (a model's right-hand side, a closed
loop, a batch of either) as C with casadi's ``CodeGenerator``, compiles it with the system
compiler into the hash-addressed cache of :func:`workbench.codegen.build.build_cached` (the
cache of the C export) and returns a :class:`CompiledFunction` that loads back through
:func:`casadi.external` and says what the build cost (generation and compiler seconds,
0 when found in the cache). :class:`BatchEvaluator` evaluates many states per call, through
casadi's virtual machine (:attr:`Compilation.NONE`) or compiled C (:attr:`Compilation.C`);
a single state is ``Evaluator(compile_function(f).function())``.

Linear solves whose casadi plugin cannot be generated as C (``lapacklu``, ``lapackqr``)
are replaced by the explicit ``linear_solver`` (:class:`LinearSolver`) and the
replacement is reported in :attr:`CompiledFunction.substitutions`; nothing else in the
graph changes. A compiler that is missing or fails raises
:class:`~workbench.codegen.build.CompileError` naming the compiler and its exit status;
the uncompiled function is never touched, so the uncompiled path stays available.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import casadi as ca
import numpy as np

from workbench.codegen._solves import LinearSolver, generable
from workbench.codegen.build import Optimization, build_cached
from workbench.codegen.lanes import (
    _check_states,
    _width_value,
    check_lane_width,
    lanes_source,
    max_lane_width,
)
from workbench.core._evaluator import Evaluator
from workbench.core.errors import ModelError
from workbench.core.types import ArrayLike
from workbench.core.validate import choice

__all__ = [
    "BatchEvaluator",
    "Compilation",
    "CompileOptions",
    "CompiledFunction",
    "LinearSolver",
    "Parallelization",
    "batch_function",
    "compile_function",
    "generable",
]


class Compilation(str, Enum):
    """How a function is evaluated.

    Attributes
    ----------
    NONE
        casadi's virtual machine (no build cost).
    C
        Generated C compiled by the system compiler, loaded with :func:`casadi.external`
        (a build cost once per content hash, then cached on disk).
    """

    NONE = "none"
    C = "c"

    @classmethod
    def _missing_(cls, value: object) -> Compilation:
        raise ModelError(f"compilation must be one of {[c.value for c in cls]} (or a "
                         f"Compilation); got {value!r}")


class Parallelization(str, Enum):
    """How a batch loops over its states (casadi ``Function.map``).

    Attributes
    ----------
    SERIAL
        One loop (in C when compiled).
    LANES
        Compiled C only: the straight-line (SX) code of one state run on several states
        per instruction, each work variable a vector (SIMD registers; see
        :mod:`workbench.codegen.lanes`); same operations in the same order as casadi's.
        Needs a compiler with the GCC/clang ``vector_size`` extension.

    casadi's ``"openmp"`` map compiles (``-fopenmp``) and agrees, but a library loaded
    with OpenMP threads crashed the interpreter at exit (libgomp unloaded under its
    threads), so it is not offered; for many cores, split the states over processes
    (:mod:`workbench.simulation` sweeps).
    """

    SERIAL = "serial"
    LANES = "lanes"

    @classmethod
    def _missing_(cls, value: object) -> Parallelization:
        raise ModelError(f"parallelization must be one of {[p.value for p in cls]}; got "
                         f"{value!r}")


@dataclass(frozen=True)
class CompileOptions:
    """How :func:`compile_function` builds, for callers that compile on the user's behalf.

    For example ``simulate(..., compilation="c", compile_options=CompileOptions(...))``.

    Attributes
    ----------
    optimization : Optimization or str
        Compiler optimisation (default ``-O2``).
    compiler : str
        The C compiler command.
    cache_dir : path-like or None
        Cache directory (default ``$WORKBENCH_CODEGEN_CACHE`` or the user cache).
    linear_solver : LinearSolver or str
        Replacement for linear solves casadi cannot generate.
    """

    optimization: Optimization | str = Optimization.O2
    compiler: str = "gcc"
    cache_dir: str | os.PathLike | None = None
    linear_solver: LinearSolver | str = LinearSolver.QR

    def keywords(self) -> dict:
        """The keyword arguments of :func:`compile_function`."""
        return {"optimization": self.optimization, "compiler": self.compiler,
                "cache_dir": self.cache_dir, "linear_solver": self.linear_solver}


@dataclass(frozen=True)
class CompiledFunction:
    """A casadi Function compiled to a shared library in the cache.

    Attributes
    ----------
    name : str
        Name of the function (and of its C entry point).
    directory : Path
        ``<cache>/<name>-<hash>``: the C source, the library, ``manifest.json``.
    hash : str
        SHA-256 of the C source, the compiler command and the compiler's version.
    cached : bool
        Whether the library was found in the cache (nothing compiled).
    generate_seconds : float
        Wall time of casadi's code generation (and of any solver substitution).
    compile_seconds : float
        Wall time of the compiler (0 when cached).
    optimization : Optimization
        Optimisation flags.
    substitutions : tuple of str
        Linear solves replaced to make the function generable (empty if none).
    with_jacobian : bool
        Whether ``jac_NAME`` is in the library (needed inside implicit integrators).
    """

    name: str
    directory: Path
    hash: str
    cached: bool
    generate_seconds: float
    compile_seconds: float
    optimization: Optimization
    substitutions: tuple[str, ...]
    with_jacobian: bool

    @property
    def library(self) -> Path:
        """The shared library."""
        return self.directory / f"lib{self.name}.so"

    @property
    def build_seconds(self) -> float:
        """Generation plus compilation [s]: the price of the speed."""
        return self.generate_seconds + self.compile_seconds

    def function(self) -> ca.Function:
        """The compiled function, loaded with :func:`casadi.external`."""
        return ca.external(self.name, str(self.library))

    def __str__(self) -> str:
        """Name, flags, build cost and where the library is."""
        how = "found in the cache" if self.cached else \
            f"compiled in {self.compile_seconds:.2f} s"
        subs = f"; {', '.join(self.substitutions)}" if self.substitutions else ""
        return (f"CompiledFunction {self.name} ({self.optimization.value}): generated in "
                f"{self.generate_seconds:.2f} s, {how}{subs}; {self.library}")

    __repr__ = __str__


def batch_function(fn: ca.Function, n: int, *, shared: Sequence[str] = (),
                   parallelization: Parallelization | str = Parallelization.SERIAL
                   ) -> ca.Function:
    """``fn`` evaluated on ``n`` states per call (casadi ``Function.map``).

    Inputs named in ``shared`` (e.g. the parameters ``"p"``) are given once; every other
    input and every output gets ``n`` columns, one per state.

    Parameters
    ----------
    fn : casadi.Function
        The function of one state.
    n : int
        States per call: at most :func:`workbench.codegen.lanes.max_states` (the inputs and
        outputs of one call hold at most ``MAX_BATCH_ENTRIES`` doubles, 128 MiB).
    shared : sequence of str
        Names of the inputs common to all states.
    parallelization : Parallelization or str
        The loop (see :class:`Parallelization`).

    Returns
    -------
    casadi.Function
        Named ``<name>_batch<n>``.

    Raises
    ------
    ModelError
        ``n`` is not a whole number in range, or ``shared`` names no input.
    """
    par = choice(Parallelization, parallelization, "parallelization", error=ModelError)
    reduce_in = _shared_inputs(fn, shared)
    n = _check_states(fn, n, shared)
    return fn.map(f"{fn.name()}_batch{n}", par.value, n, reduce_in, [])


def _shared_inputs(fn: ca.Function, shared: Sequence[str]) -> list[int]:
    """The indices of the inputs named in ``shared`` (each must be an input of ``fn``)."""
    names = fn.name_in()
    if isinstance(shared, str) or not isinstance(shared, (list, tuple)) or \
            not all(isinstance(s, str) for s in shared):
        raise ModelError(f"shared must be a sequence of input names (e.g. ('p',)); got "
                         f"{shared!r}")
    unknown = [s for s in shared if s not in names]
    if unknown:
        raise ModelError(f"shared inputs {unknown} are not inputs of {fn.name()} "
                         f"(inputs {names})")
    return [names.index(s) for s in shared]


def _vector_layout(fn: ca.Function) -> None:
    """Refuse inputs and outputs a batch's rows cannot hold without a layout convention.

    A batch's data have one row per state. A dense vector (column or row) is that row; a
    matrix would be read in casadi's column-major order from the row-major rows, and a
    sparse vector would take only its structural nonzeros, so both are refused.
    """
    for kind, total, sp, names in (("input", fn.n_in(), fn.sparsity_in, fn.name_in),
                                   ("output", fn.n_out(), fn.sparsity_out, fn.name_out)):
        for i in range(total):
            s = sp(i)
            rows, cols = s.size()
            if rows > 1 and cols > 1:
                raise ModelError(
                    f"{fn.name()}: {kind} {names(i)!r} is a {rows}x{cols} matrix; a batch "
                    "takes one row of data per state, so every input and output must be a "
                    "vector (a matrix would be read in casadi's column-major order): pass "
                    f"casadi.vec of it (column-major) and reshape inside {fn.name()}")
            if not s.is_dense():
                raise ModelError(
                    f"{fn.name()}: {kind} {names(i)!r} is a sparse vector ({s.nnz()} of "
                    f"{s.numel()} entries structurally nonzero); a batch takes dense vectors "
                    "(casadi.densify it)")


def _generate(fn: ca.Function, with_jacobian: bool) -> str:
    with tempfile.TemporaryDirectory(prefix="workbench-fn-") as tmp:
        cg = ca.CodeGenerator(f"{fn.name()}.c", {"casadi_real": "double",
                                                  "casadi_int": "long long int"})
        cg.add(fn)
        if with_jacobian:
            cg.add(fn.jacobian())
        cg.generate(tmp + "/")
        return Path(tmp, f"{fn.name()}.c").read_text()


def _errors(code: str) -> list[str]:
    return [line.strip()[len("#error"):].strip() for line in code.splitlines()
            if line.strip().startswith("#error")]


def _generable_code(fn: ca.Function, linear_solver: LinearSolver | str, with_jacobian: bool
                    ) -> tuple[ca.Function, tuple[str, ...], str]:
    """``fn`` with its solves replaced only if casadi cannot generate them.

    Returns the function, the replacements and the C code; raises ModelError naming what
    casadi cannot generate.
    """
    code, subs = _generate(fn, with_jacobian), ()
    if _errors(code):
        fn, subs = generable(fn, linear_solver)
        code = _generate(fn, with_jacobian) if subs else code
    if _errors(code):
        raise ModelError(f"casadi cannot generate C for {fn.name()}: "
                         f"{'; '.join(_errors(code))}")
    return fn, subs, code


def compile_function(
    fn: ca.Function,
    *,
    optimization: Optimization | str = Optimization.O2,
    compiler: str = "gcc",
    cache_dir: str | os.PathLike | None = None,
    with_jacobian: bool = False,
    linear_solver: LinearSolver | str = LinearSolver.QR,
    substitutions: tuple[str, ...] = (),
    extra_seconds: float = 0.0,
) -> CompiledFunction:
    """Generate C for ``fn``, compile it (or find it in the cache) and report the cost.

    Parameters
    ----------
    fn : casadi.Function
        Any casadi Function (SX or MX; a :func:`batch_function` for many states).
    optimization : Optimization or str
        Compiler optimisation (``-O2`` default: the same arithmetic as casadi's virtual
        machine in the measured cases; ``O3-native`` may fuse multiply-adds).
    compiler : str
        The C compiler command (its ``--version`` enters the hash).
    cache_dir : path-like, optional
        Cache directory (default ``$WORKBENCH_CODEGEN_CACHE`` or the user cache).
    with_jacobian : bool
        Also compile ``jac_NAME`` (CVODES and other implicit integrators differentiate
        their right-hand side).
    linear_solver : LinearSolver or str
        Replacement for linear solves casadi cannot generate (used only when needed).
    substitutions : tuple of str
        Replacements already made by the caller (reported with the build).
    extra_seconds : float
        Generation time already spent by the caller (added to the reported cost).

    Returns
    -------
    CompiledFunction

    Raises
    ------
    ModelError
        ``fn`` is not a casadi Function, or contains an operation casadi cannot write as C
        even after the solver replacement (casadi's message quoted).
    CompileError
        The compiler is missing or failed: its name, exit status and message.
    """
    if not isinstance(fn, ca.Function):
        raise ModelError(f"fn must be a casadi.Function; got {type(fn).__name__}")
    opt = choice(Optimization, optimization, "optimization", error=ModelError)
    t0 = time.perf_counter()
    fn, subs, code = _generable_code(fn, linear_solver, bool(with_jacobian))
    subs = (*substitutions, *subs)
    generate_seconds = time.perf_counter() - t0 + float(extra_seconds)
    return _build(fn.name(), code, opt, compiler, cache_dir, subs, bool(with_jacobian),
                  generate_seconds)


def _build(name: str, code: str, opt: Optimization, compiler: str,
           cache_dir: str | os.PathLike | None, subs: tuple[str, ...], with_jacobian: bool,
           generate_seconds: float) -> CompiledFunction:
    """Compile C source ``code`` defining ``name`` into the cache; its build cost."""
    flags = [*opt.flags, "-fPIC", "-shared"]
    commands = [[compiler, *flags, f"{name}.c", "-o", f"lib{name}.so", "-lm"]]
    digest = hashlib.sha256(code.encode()).hexdigest()
    t1 = time.perf_counter()
    directory, full, cached = build_cached(
        name, {f"{name}.c": code}, commands, digest=digest, compiler=compiler,
        cache_dir=cache_dir,
        manifest={"kind": "function", "source_digest": digest,
                  "substitutions": list(subs), "with_jacobian": with_jacobian})
    compile_seconds = 0.0 if cached else time.perf_counter() - t1
    return CompiledFunction(name, directory, full, cached, generate_seconds, compile_seconds,
                            opt, tuple(subs), with_jacobian)


def _compile_lanes(one: ca.Function, n: int, shared: tuple[str, ...], width: int | None,
                   opt: Optimization, compiler: str,
                   cache_dir: str | os.PathLike | None, subs: tuple[str, ...],
                   t0: float) -> CompiledFunction:
    """The lane-vectorised batch of ``one`` compiled (see :mod:`workbench.codegen.lanes`)."""
    if one.is_a("MXFunction"):
        try:
            one = one.expand()
        except RuntimeError as exc:
            raise ModelError(f"parallelization 'lanes' needs {one.name()} as straight-line "
                             f"SX code; casadi cannot expand it: {exc}") from None
    if width is None:  # the default: one register, or the widest the bounds allow
        width = min(4 if opt is Optimization.NATIVE else 2, max(max_lane_width(one), 1))
    width = _lane_width(one, width)  # the function's size is known only once expanded
    name = f"{one.name()}_lanes{width}x{n}"
    code = lanes_source(one, n, name=name, shared=shared, width=width)
    return _build(name, code, opt, compiler, cache_dir, subs, False,
                  time.perf_counter() - t0)


def _lane_width(fn: ca.Function, width: int) -> int:
    """``lane_width`` checked against ``fn``'s size and the stack (named as the argument)."""
    try:
        return check_lane_width(fn, width)
    except ModelError as exc:
        raise ModelError(f"lane_width: {exc}") from None


class BatchEvaluator:
    """Evaluate a function on many states per call, interpreted or compiled.

    Each call takes, for every input not in ``shared``, a real array of shape
    ``(n, size)`` (one row per state) and, for the shared inputs, one vector; it returns
    one array of shape ``(n, size)`` per output (a tuple if there are several). Complex
    data are refused (the imaginary part would be lost), as are functions with a matrix
    or sparse input or output (a row of data per state has no layout for them: pass
    ``casadi.vec`` of a matrix and reshape inside the function).

    Parameters
    ----------
    fn : casadi.Function
        The function of one state, dense vector (column or row) inputs and outputs.
    n : int
        States per call: at most :func:`workbench.codegen.lanes.max_states` (the inputs
        and outputs of one call hold at most ``MAX_BATCH_ENTRIES`` doubles, 128 MiB).
    shared : sequence of str
        Inputs common to all states (e.g. ``("p",)``).
    compilation : Compilation or str
        :attr:`Compilation.NONE` (casadi's virtual machine) or :attr:`Compilation.C`.
    parallelization : Parallelization or str
        The loop over states.
    optimization, compiler, cache_dir, linear_solver
        As in :func:`compile_function` (for :attr:`Compilation.C`).
    lane_width : int, optional
        States per instruction of :attr:`Parallelization.LANES` only (default: 4 with
        ``O3-native``, one AVX2 register of doubles; 2 otherwise, one SSE2 register of
        the x86-64 baseline; or the widest the bounds allow for the function, if
        narrower): a power of two up to ``MAX_LANE_WIDTH`` (8) whose product
        with the function's instructions and whose stack frame are within
        ``LANE_BUDGET`` and ``STACK_BUDGET``
        (:func:`~workbench.codegen.lanes.check_lane_width`; checked before anything is
        compiled). The function must expand to SX (straight-line code).

    Raises
    ------
    ModelError
        A bad option, a matrix or sparse input or output, ``n`` or ``lane_width`` out of
        its bounds (the message names the bound).

    Attributes
    ----------
    batched : casadi.Function
        The function evaluated (the batch, or its compiled library).
    compiled : CompiledFunction or None
        The build, with its cost, for :attr:`Compilation.C`.

    Examples
    --------
    >>> ev = BatchEvaluator(model.function("f"), 1000, shared=("p",),  # doctest: +SKIP
    ...                     compilation="c")
    >>> xdot = ev(X, U, model.p)       # X shape (1000, nx), U (1000, nu) # doctest: +SKIP
    """

    def __init__(self, fn: ca.Function, n: int, *, shared: Sequence[str] = (),
                 compilation: Compilation | str = Compilation.NONE,
                 parallelization: Parallelization | str = Parallelization.SERIAL,
                 optimization: Optimization | str = Optimization.O2, compiler: str = "gcc",
                 cache_dir: str | os.PathLike | None = None,
                 linear_solver: LinearSolver | str = LinearSolver.QR,
                 lane_width: int | None = None) -> None:
        if not isinstance(fn, ca.Function):
            raise ModelError(f"fn must be a casadi.Function; got {type(fn).__name__}")
        how = choice(Compilation, compilation, "compilation", error=ModelError)
        par = choice(Parallelization, parallelization, "parallelization", error=ModelError)
        _shared_inputs(fn, shared)
        _vector_layout(fn)
        self.fn, self.shared = fn, tuple(shared)
        self.n = _check_states(fn, n, self.shared)
        self.compiled: CompiledFunction | None = None
        if par is Parallelization.LANES and how is not Compilation.C:
            raise ModelError("parallelization 'lanes' is compiled C: it needs "
                             "compilation='c'")
        if lane_width is not None and par is not Parallelization.LANES:
            raise ModelError(f"lane_width applies to parallelization='lanes' only; got "
                             f"lane_width={lane_width!r} with parallelization={par.value!r}")
        if par is Parallelization.LANES and lane_width is not None:  # before any work
            try:
                lane_width = _width_value(lane_width)
            except ModelError as exc:
                raise ModelError(f"lane_width: {exc}") from None
            if fn.is_a("SXFunction"):
                _lane_width(fn, lane_width)
        if how is Compilation.C:
            t0 = time.perf_counter()
            one, subs, _ = _generable_code(fn, linear_solver, False)
            if par is Parallelization.LANES:
                opt = choice(Optimization, optimization, "optimization", error=ModelError)
                self.compiled = _compile_lanes(one, self.n, self.shared, lane_width,
                                               opt, compiler, cache_dir, subs, t0)
            else:
                batched = batch_function(one, self.n, shared=self.shared,
                                         parallelization=par)
                self.compiled = compile_function(
                    batched, optimization=optimization, compiler=compiler,
                    cache_dir=cache_dir, linear_solver=linear_solver,
                    substitutions=subs, extra_seconds=time.perf_counter() - t0)
            batched = self.compiled.function()
        else:
            batched = batch_function(fn, self.n, shared=self.shared, parallelization=par)
        self.batched = batched
        self._ev = Evaluator(batched)
        self._sizes = [fn.nnz_in(i) for i in range(fn.n_in())]
        self._out = [fn.nnz_out(i) for i in range(fn.n_out())]

    def __call__(self, *args: ArrayLike) -> np.ndarray | tuple[np.ndarray, ...]:
        """Evaluate on ``n`` states; see the class docstring for the shapes.

        Raises
        ------
        ModelError
            A wrong number of arguments, or an argument of the wrong shape, complex or
            not numeric (naming it).
        """
        if len(args) != len(self._sizes):
            raise ModelError(f"{self.fn.name()} takes {len(self._sizes)} inputs "
                             f"{self.fn.name_in()}; got {len(args)} arguments")
        for i, a in enumerate(args):
            name = self.fn.name_in(i)
            if np.iscomplexobj(a):  # numpy would cast to float and drop the imaginary part
                raise ModelError(f"{self.fn.name()}: input {name!r} is complex (dtype "
                                 f"{np.asarray(a).dtype}); a batch evaluates real numbers "
                                 "and would drop the imaginary part: pass real data "
                                 "(np.real(a), if the imaginary part is meant to be zero)")
            want = (self._sizes[i],) if name in self.shared else (self.n, self._sizes[i])
            if np.size(a) != int(np.prod(want)) or (
                    name not in self.shared and np.shape(a) != want):
                raise ModelError(f"{self.fn.name()}: input {name!r} must have shape {want} "
                                 f"({'shared' if name in self.shared else 'one row per state'})"
                                 f"; got shape {np.shape(a)}")
        out = self._ev(*args)
        outs = out if isinstance(out, tuple) else (out,)
        res = tuple(o.reshape(self.n, k) for o, k in zip(outs, self._out))
        return res[0] if len(res) == 1 else res
