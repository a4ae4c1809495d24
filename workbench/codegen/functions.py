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

from workbench.codegen.build import Optimization, build_cached
from workbench.codegen.lanes import lanes_source
from workbench.core._evaluator import Evaluator
from workbench.core._solve import solve_spd
from workbench.core.errors import ModelError
from workbench.core.types import ArrayLike
from workbench.core.validate import choice, count

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


class LinearSolver(str, Enum):
    """Replacement of the linear solves casadi cannot write as C.

    Attributes
    ----------
    QR
        casadi's sparse QR (``"qr"``): any nonsingular matrix.
    LDL
        casadi's sparse LDL^T (``"ldl"``): symmetric matrices only (mass matrices).
    DENSE_LDL
        A dense LDL^T without pivoting written as scalar (SX) operations, so that the
        whole function becomes straight-line C: the fastest, for symmetric positive
        definite matrices only (mass matrices); the matrix is never checked.
    """

    QR = "qr"
    LDL = "ldl"
    DENSE_LDL = "dense_ldl"

    @classmethod
    def _missing_(cls, value: object) -> LinearSolver:
        raise ModelError(f"linear_solver must be one of {[s.value for s in cls]} (or a "
                         f"LinearSolver); got {value!r}")


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


_HELPER = "wb_generable_solve_"
"""Prefix of the functions that hold the replacement solves (never inlined again)."""


def _targets(outputs: list[ca.MX]) -> tuple[list[ca.MX], list[ca.MX]]:
    """The linear-solve nodes and the outputs of calls to MX functions in a graph."""
    seen: set[int] = set()
    stack, solves, calls = list(outputs), [], []
    while stack:
        e = stack.pop()
        key = e.__hash__()
        if key in seen:
            continue
        seen.add(key)
        if e.is_op(ca.OP_SOLVE):
            solves.append(e)
        elif e.is_output() and e.dep(0).is_op(ca.OP_CALL):
            g = e.dep(0).which_function()
            if g.is_a("MXFunction") and not g.name().startswith(_HELPER):
                calls.append(e)
        stack.extend(e.dep(i) for i in range(e.n_dep()))
    return solves, calls


def _dense_ldl_solve(n: int, m: int) -> ca.Function:
    """``(A, B) -> A^{-1} B`` by L D L^T without pivoting, in scalar operations (SX).

    The symbolic solve is :func:`workbench.core.solve_spd`, the one the SX replay of a
    model with symmetric positive definite solves writes (``sx_function(spd=True)``).
    """
    A, B = ca.SX.sym("A", n, n), ca.SX.sym("B", n, m)
    return ca.Function(f"dense_ldl_solve_{n}x{m}", [A, B], [solve_spd(A, B)])


def _replacement(solver: LinearSolver, n: int, m: int) -> ca.Function:
    """``(A, B) -> A^{-1} B`` with the replacement solver, as a named function."""
    if solver is LinearSolver.DENSE_LDL:
        return _dense_ldl_solve(n, m)
    A, B = ca.MX.sym("A", n, n), ca.MX.sym("B", n, m)
    return ca.Function(f"{_HELPER}{solver.value}_{n}x{m}", [A, B],
                       [ca.solve(A, B, solver.value)])


def generable(fn: ca.Function, linear_solver: LinearSolver | str = LinearSolver.QR
              ) -> tuple[ca.Function, tuple[str, ...]]:
    """``fn`` with every linear solve of its graph replaced by ``linear_solver``.

    Only needed for MX functions whose solves use a plugin casadi cannot write as C; SX
    functions and functions without solves are returned unchanged. Calls of nested MX
    functions are inlined (their values are kept; a custom Jacobian attached to one is
    replaced by automatic differentiation of its inlined graph). With
    :attr:`LinearSolver.DENSE_LDL` the result is expanded to one SX function (straight-line
    code) when the rest of the graph allows it.

    Parameters
    ----------
    fn : casadi.Function
        The function.
    linear_solver : LinearSolver or str
        The replacement (see :class:`LinearSolver`).

    Returns
    -------
    tuple of (casadi.Function, tuple of str)
        The function (same name, inputs and outputs) and a description of each
        replacement.
    """
    solver = choice(LinearSolver, linear_solver, "linear_solver", error=ModelError)
    if not fn.is_a("MXFunction"):
        return fn, ()
    args = fn.mx_in()
    outs = fn.call(args, True, False)
    replaced = []
    for _ in range(100):  # each round inlines one level of nested MX functions
        solves, calls = _targets(outs)
        if not solves and not calls:
            break
        new = [c.dep(0).which_function().call(
            [c.dep(0).dep(k) for k in range(c.dep(0).n_dep())], True, False)[c.which_output()]
            for c in calls]
        for s in solves:
            A = s.dep(1).T if s.info().get("tr", False) else s.dep(1)
            b = s.dep(0)
            replaced.append(f"{A.shape[0]}x{A.shape[1]}")
            new.append(_replacement(solver, A.shape[0], b.shape[1])(A, b))
        outs = ca.graph_substitute(outs, calls + solves, new)
    if not replaced:
        return fn, ()
    out = ca.Function(fn.name(), args, outs, fn.name_in(), fn.name_out())
    if solver is LinearSolver.DENSE_LDL:
        try:
            out = out.expand()
        except RuntimeError:
            pass  # a node that cannot be expanded: keep the MX graph
    return out, (f"{len(replaced)} linear solve(s) ({', '.join(replaced)}) -> "
                 f"{solver.value}",)


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
        States per call.
    shared : sequence of str
        Names of the inputs common to all states.
    parallelization : Parallelization or str
        The loop (see :class:`Parallelization`).

    Returns
    -------
    casadi.Function
        Named ``<name>_batch<n>``.
    """
    n = count("n", n, error=ModelError)
    par = choice(Parallelization, parallelization, "parallelization", error=ModelError)
    names = fn.name_in()
    unknown = [s for s in shared if s not in names]
    if unknown:
        raise ModelError(f"shared inputs {unknown} are not inputs of {fn.name()} "
                         f"(inputs {names})")
    reduce_in = [names.index(s) for s in shared]
    return fn.map(f"{fn.name()}_batch{n}", par.value, n, reduce_in, [])


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
                   optimization: Optimization | str, compiler: str,
                   cache_dir: str | os.PathLike | None, subs: tuple[str, ...],
                   t0: float) -> CompiledFunction:
    """The lane-vectorised batch of ``one`` compiled (see :mod:`workbench.codegen.lanes`)."""
    opt = choice(Optimization, optimization, "optimization", error=ModelError)
    if width is None:
        width = 4 if opt is Optimization.NATIVE else 2
    if one.is_a("MXFunction"):
        try:
            one = one.expand()
        except RuntimeError as exc:
            raise ModelError(f"parallelization 'lanes' needs {one.name()} as straight-line "
                             f"SX code; casadi cannot expand it: {exc}") from None
    name = f"{one.name()}_lanes{width}x{n}"
    code = lanes_source(one, n, name=name, shared=shared, width=width)
    return _build(name, code, opt, compiler, cache_dir, subs, False,
                  time.perf_counter() - t0)


class BatchEvaluator:
    """Evaluate a function on many states per call, interpreted or compiled.

    Each call takes, for every input not in ``shared``, an array of shape
    ``(n, size)`` (one row per state) and, for the shared inputs, one vector; it returns
    one array of shape ``(n, size)`` per output (a tuple if there are several).

    Parameters
    ----------
    fn : casadi.Function
        The function of one state, dense vector inputs and outputs.
    n : int
        States per call.
    shared : sequence of str
        Inputs common to all states (e.g. ``("p",)``).
    compilation : Compilation or str
        :attr:`Compilation.NONE` (casadi's virtual machine) or :attr:`Compilation.C`.
    parallelization : Parallelization or str
        The loop over states.
    optimization, compiler, cache_dir, linear_solver
        As in :func:`compile_function` (for :attr:`Compilation.C`).
    lane_width : int, optional
        States per instruction of :attr:`Parallelization.LANES` (default: 4 with
        ``O3-native``, one AVX2 register of doubles; 2 otherwise, one SSE2 register of
        the x86-64 baseline). The function must expand to SX (straight-line code).

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
        self.fn, self.n, self.shared = fn, count("n", n, error=ModelError), tuple(shared)
        self.compiled: CompiledFunction | None = None
        if par is Parallelization.LANES and how is not Compilation.C:
            raise ModelError("parallelization 'lanes' is compiled C: it needs "
                             "compilation='c'")
        if how is Compilation.C:
            t0 = time.perf_counter()
            one, subs, _ = _generable_code(fn, linear_solver, False)
            if par is Parallelization.LANES:
                self.compiled = _compile_lanes(one, self.n, self.shared, lane_width,
                                               optimization, compiler, cache_dir, subs, t0)
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
            A wrong number of arguments, or an argument of the wrong shape (naming it).
        """
        if len(args) != len(self._sizes):
            raise ModelError(f"{self.fn.name()} takes {len(self._sizes)} inputs "
                             f"{self.fn.name_in()}; got {len(args)} arguments")
        for i, a in enumerate(args):
            name = self.fn.name_in(i)
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
