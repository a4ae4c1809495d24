"""Compile generated controllers into a hash-addressed cache, load them back, time them.

:func:`compile_sources` compiles a :class:`~workbench.codegen.csource.CSources` with the
warning flags of :data:`~workbench.codegen.csource.CFLAGS_WARN` (warnings are errors) and
an explicit :class:`Optimization` into ``<cache>/<name>-<hash>/``: the shared library
(for :func:`casadi.external`), the example and the benchmark. The hash covers the sources,
the compiler command and the compiler's version, so a cached build is reused only for the
same function, flags and compiler. Every compiler exit status is checked; a failure raises
:class:`CompileError` with the compiler's own message. Builds happen in a temporary
directory that is renamed into place when complete, so the cache never holds a partial
build.

:func:`export` writes the sources to a user directory the same way (all files are written
to a temporary directory first, then moved), after checking that they compile; it lives in
:mod:`~workbench.codegen._export` and is re-exported here.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import re
import shutil
import subprocess
import tempfile
import time
import warnings
from dataclasses import dataclass
from enum import Enum
from functools import lru_cache
from pathlib import Path

import casadi as ca
import numpy as np

from workbench.codegen._export import (  # noqa: F401 - MANIFEST and the checks re-exported
    MANIFEST,
    ExportError,
    _temp_dir,
    _writable_target,
    export,
)
from workbench.codegen.csource import CFLAGS_WARN, CSources
from workbench.core.errors import ModelError, WorkbenchError
from workbench.core.files import apply_umask
from workbench.core.validate import choice, count

__all__ = [
    "CACHE_ENV",
    "BenchResult",
    "CompileError",
    "CompiledController",
    "ExportError",
    "Optimization",
    "bench_c",
    "build_cached",
    "cache_root",
    "compile_sources",
    "export",
]

CACHE_ENV = "WORKBENCH_CODEGEN_CACHE"
"""Environment variable naming the cache directory (default
``$XDG_CACHE_HOME/workbench/codegen`` or ``~/.cache/workbench/codegen``)."""


class CompileError(WorkbenchError, RuntimeError):
    """The C compiler (or a compiled program) failed; the message carries its output.

    Attributes
    ----------
    command : list of str
        The command that failed.
    returncode : int or None
        Its exit status (``None`` if it could not be started).
    stderr : str
        What it printed on stderr.
    """

    def __init__(self, message: str, *, command: list[str], returncode: int | None,
                 stderr: str) -> None:
        super().__init__(message)
        self.command, self.returncode, self.stderr = command, returncode, stderr


class Optimization(str, Enum):
    """Optimisation flags of the compilation (always with the warning flags).

    Attributes
    ----------
    O2
        ``-O2``: the default; portable code, results bit-identical to casadi's virtual
        machine in the measured cases.
    O3
        ``-O3``.
    NATIVE
        ``-O3 -march=native``: for the machine it is built on only; may contract
        ``a*b + c`` into fused multiply-adds (last-bit differences).
    """

    O2 = "O2"
    O3 = "O3"
    NATIVE = "O3-native"

    @classmethod
    def _missing_(cls, value: object) -> Optimization:
        raise ModelError(f"optimization must be one of {[o.value for o in cls]} (or an "
                         f"Optimization); got {value!r}")

    @property
    def flags(self) -> tuple[str, ...]:
        """The compiler flags."""
        return {"O2": ("-O2",), "O3": ("-O3",), "O3-native": ("-O3", "-march=native")}[
            self.value]


def cache_root(cache_dir: str | os.PathLike | None = None) -> Path:
    """The cache directory of compiled controllers.

    ``cache_dir`` if given, else ``$WORKBENCH_CODEGEN_CACHE``, else the user cache
    (``$XDG_CACHE_HOME/workbench/codegen`` or ``~/.cache/workbench/codegen``).
    """
    if cache_dir is not None:
        return Path(cache_dir)
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "workbench" / "codegen"


def _run(command: list[str], *, cwd: Path, what: str) -> subprocess.CompletedProcess:
    try:
        proc = subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False)
    except OSError as exc:
        raise CompileError(f"{what}: cannot run {command[0]!r} ({exc.strerror}); is it "
                           f"installed and on PATH?", command=command, returncode=None,
                           stderr=str(exc)) from exc
    if proc.returncode != 0:
        raise CompileError(
            f"{what} failed (exit status {proc.returncode}) running "
            f"{' '.join(command)}:\n{proc.stderr.strip() or proc.stdout.strip()}",
            command=command, returncode=proc.returncode, stderr=proc.stderr)
    return proc


@lru_cache(maxsize=8)
def _compiler_version(compiler: str) -> str:
    proc = _run([compiler, "--version"], cwd=Path.cwd(), what="compiler version query")
    return proc.stdout.splitlines()[0] if proc.stdout else compiler


@dataclass(frozen=True)
class CompiledController:
    """A compiled controller in the cache.

    Attributes
    ----------
    sources : CSources
        What was compiled.
    optimization : Optimization
        The optimisation flags.
    directory : Path
        ``<cache>/<name>-<hash>``: sources, ``lib<name>.so``, ``example``, ``bench``.
    hash : str
        SHA-256 of the sources, the compiler command and the compiler version.
    cached : bool
        Whether the build was found in the cache (nothing compiled).
    """

    sources: CSources
    optimization: Optimization
    directory: Path
    hash: str
    cached: bool

    def __str__(self) -> str:
        """Name, binding, flags and where the library is; never the sources."""
        how = "found in the cache" if self.cached else "compiled"
        return (f"CompiledController {self.sources.name} ({self.sources.binding.value}, "
                f"{self.optimization.value}): {how}, {self.library}")

    __repr__ = __str__

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"

    @property
    def library(self) -> Path:
        """The shared library."""
        return self.directory / f"lib{self.sources.name}.so"

    def function(self) -> ca.Function:
        """The compiled function loaded back through :func:`casadi.external`."""
        return ca.external(self.sources.name, str(self.library))

    def step(self, states: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Call the C function ``NAME_step`` (through ctypes) on every row of ``states``.

        Parameters
        ----------
        states : ndarray, shape=(n, nx)
            States.
        p : ndarray, shape=(n_p,)
            The run-time vector of the binding (empty for ``FROZEN``).

        Returns
        -------
        ndarray, shape=(n, nu)

        Raises
        ------
        CompileError
            ``NAME_step`` returned a non-zero status.
        """
        src = self.sources
        X = np.ascontiguousarray(states, dtype=float)
        pv = np.ascontiguousarray(np.ravel(p), dtype=float)
        if X.ndim != 2 or X.shape[1] != src.nx or pv.size != src.n_p:
            raise ModelError(f"{src.name}_step needs states of shape (n, {src.nx}) and p of "
                             f"size {src.n_p}; got {X.shape} and {pv.size}")
        fn = ctypes.CDLL(str(self.library))[f"{src.name}_step"]
        dp = ctypes.POINTER(ctypes.c_double)
        fn.argtypes, fn.restype = [dp, dp, dp], ctypes.c_int
        U = np.empty((X.shape[0], src.nu))
        pbuf = np.zeros(max(1, pv.size))
        pbuf[:pv.size] = pv
        pp = pbuf.ctypes.data_as(dp)
        for i in range(X.shape[0]):
            status = fn(X[i].ctypes.data_as(dp), pp, U[i].ctypes.data_as(dp))
            if status != 0:
                raise CompileError(f"{src.name}_step returned status {status} at state {i}",
                                   command=[], returncode=status, stderr="")
        return U

    def run_example(self) -> list[float]:
        """Run the example program; return the ``u`` it prints."""
        out = _run([str(self.directory / "example")], cwd=self.directory,
                   what=f"example of {self.sources.name}").stdout
        return [float(v) for v in re.findall(r"^u\[\d+\] = (\S+)$", out, re.M)]


def _commands(name: str, compiler: str, opt: Optimization) -> list[list[str]]:
    flags = [*CFLAGS_WARN, *opt.flags]
    return [
        [compiler, *flags, "-fPIC", "-shared", f"{name}.c", "-o", f"lib{name}.so", "-lm"],
        [compiler, *flags, "-c", f"{name}.c", "-o", f"{name}.o"],
        [compiler, *flags, "main.c", f"{name}.o", "-o", "example", "-lm"],
        [compiler, *flags, "bench.c", f"{name}.o", "-o", "bench", "-lm"],
    ]


def _digests(directory: Path) -> dict[str, str]:
    """SHA-256 of every file of a build directory (sources and artefacts), by name."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(directory.iterdir()) if p.is_file() and p.name != "manifest.json"}


def _verify_entry(entry: Path, full: str) -> str | None:
    """None if a cache entry is intact (manifest, hash, every file's content hash), else why.

    Checked on every cache hit: a truncated library, an edited source or a missing
    artefact is found by content, not by the presence of the manifest.
    """
    try:
        manifest = json.loads((entry / "manifest.json").read_text())
    except (OSError, ValueError) as exc:
        return f"manifest unreadable: {exc}"
    if not isinstance(manifest, dict) or manifest.get("hash") != full:
        return "manifest hash differs from the requested build"
    recorded = manifest.get("files")
    if not isinstance(recorded, dict) or not recorded:
        return "manifest lists no content hashes"
    try:
        actual = _digests(entry)
    except OSError as exc:
        return f"files unreadable: {exc}"
    changed = sorted(n for n in set(recorded) | set(actual) if recorded.get(n) != actual.get(n))
    return f"content hash differs for {changed}" if changed else None


def _discard(entry: Path) -> None:
    """Move a corrupt cache entry aside (atomically), then remove it.

    A concurrent process may have moved it already; then there is nothing to do.
    """
    aside = entry.with_name(f".{entry.name}.corrupt-{os.getpid()}-{time.monotonic_ns()}")
    try:
        os.rename(entry, aside)
    except OSError:
        return
    shutil.rmtree(aside, ignore_errors=True)


def compile_sources(sources: CSources, *, optimization: Optimization,
                    compiler: str = "gcc", cache_dir: str | os.PathLike | None = None
                    ) -> CompiledController:
    """Compile the sources into the cache (or reuse an identical cached build).

    Parameters
    ----------
    sources : CSources
        From :func:`workbench.codegen.csource.generate`.
    optimization : Optimization
        Optimisation flags (the warning flags ``-std=c99 -Wall -Wextra -Werror`` are
        always on).
    compiler : str
        The C compiler command.
    cache_dir : path-like, optional
        Cache directory (see :func:`cache_root`).

    Returns
    -------
    CompiledController

    Raises
    ------
    CompileError
        The compiler is missing or failed (its message included).
    """
    opt = choice(Optimization, optimization, "optimization")
    commands = _commands(sources.name, compiler, opt)
    final, digest, cached = build_cached(
        sources.name, sources.files, commands, digest=sources.digest, compiler=compiler,
        cache_dir=cache_dir,
        manifest={"binding": sources.binding.value, "source_digest": sources.digest,
                  "nx": sources.nx, "np": sources.n_p, "nu": sources.nu,
                  "work": sources.work, "with_jacobian": sources.with_jacobian})
    return CompiledController(sources, opt, final, digest, cached=cached)


def build_cached(name: str, files: dict[str, str], commands: list[list[str]], *,
                 digest: str, compiler: str, cache_dir: str | os.PathLike | None,
                 manifest: dict) -> tuple[Path, str, bool]:
    """Run ``commands`` on ``files`` in ``<cache>/<name>-<hash>/`` unless already built.

    The one cache of every compiled artefact (controllers, compiled right-hand sides):
    the hash covers ``digest`` (of the sources), the commands and the compiler's version;
    the build happens in a temporary directory renamed into place when complete.

    Parameters
    ----------
    name : str
        Prefix of the cache directory.
    files : dict of str to str
        File name -> text, written before the commands run.
    commands : list of list of str
        Compiler commands, run in order in the build directory; every exit status checked.
    digest : str
        Hash of the sources.
    compiler : str
        The compiler command (its ``--version`` enters the hash).
    cache_dir : path-like or None
        Cache directory (see :func:`cache_root`).
    manifest : dict
        Extra JSON entries of ``manifest.json``.

    Returns
    -------
    tuple of (Path, str, bool)
        The build directory, the full hash, whether it was found in the cache.

    Raises
    ------
    CompileError
        The compiler is missing or failed (its name, exit status and message included).
    ExportError
        The cache directory is not writable.
    """
    h = hashlib.sha256()
    h.update(digest.encode())
    h.update(json.dumps(commands).encode())
    h.update(_compiler_version(compiler).encode())
    full = h.hexdigest()
    root = cache_root(cache_dir)
    final = root / f"{name}-{full[:20]}"
    if final.exists():
        problem = _verify_entry(final, full)
        if problem is None:
            return final, full, True
        warnings.warn(f"compile cache entry {str(final)!r} is corrupt ({problem}); it is "
                      f"rebuilt", RuntimeWarning, stacklevel=2)
        _discard(final)
    try:
        root.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{name}-", dir=root))
    except OSError as exc:
        raise ExportError(f"cache directory {str(root)!r} is not writable ({exc.strerror}); "
                          f"set {CACHE_ENV} or pass cache_dir=") from exc
    try:
        for fname, text in files.items():
            (tmp / fname).write_text(text)
        for cmd in commands:
            _run(cmd, cwd=tmp, what=f"compiling {name}")
        (tmp / "manifest.json").write_text(json.dumps({
            "name": name, "hash": full, "commands": commands, "files": _digests(tmp),
            "compiler": _compiler_version(compiler), "casadi": ca.__version__, **manifest},
            indent=2))
        apply_umask(tmp, directory=True)
        try:
            os.rename(tmp, final)
        except OSError:
            if _verify_entry(final, full) is not None:  # not a concurrent identical build
                raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return final, full, False


@dataclass(frozen=True)
class BenchResult:
    """Nanoseconds per call of a compiled step function, measured in C.

    Attributes
    ----------
    name : str
        Controller.
    median_ns, min_ns, max_ns : float
        Median, minimum and maximum over batches of the mean time per call.
    calls, batches : int
        Calls per batch and number of batches.
    """

    name: str
    median_ns: float
    min_ns: float
    max_ns: float
    calls: int
    batches: int


    def __str__(self) -> str:
        """Median time per call, with its spread."""
        return (f"{self.name}: median {self.median_ns:.1f} ns per call (min {self.min_ns:.1f},"
                f" max {self.max_ns:.1f}; {self.batches} batches of {self.calls} calls)")

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"


BENCH_CALLS = 10 ** 8
"""Most calls of one :func:`bench_c` in all its batches (10 s at 100 ns per call)."""


def bench_c(compiled: CompiledController, *, calls: int = 20_000, batches: int = 501
            ) -> BenchResult:
    """Run the compiled benchmark program.

    Parameters
    ----------
    compiled : CompiledController
        A compiled controller.
    calls : int
        Calls per batch. Short batches (the default lasts well under a millisecond) let
        the median over batches discard the ones a busy machine preempted; ``calls *
        batches <= BENCH_CALLS``.
    batches : int
        Number of batches (1 to 1001); the median over batches is reported.

    Returns
    -------
    BenchResult

    Raises
    ------
    ModelError
        ``calls`` or ``batches`` out of range (checked before the program runs).
    """
    batches = count("batches", batches, maximum=1001, error=ModelError)
    try:
        calls = count("calls", calls, maximum=BENCH_CALLS // batches, error=ModelError)
    except ModelError as exc:
        raise ModelError(f"{exc} (calls per batch: at most BENCH_CALLS = {BENCH_CALLS} calls "
                         f"in all over the {batches} batches)") from None
    out = _run([str(compiled.directory / "bench"), str(int(calls)), str(int(batches))],
               cwd=compiled.directory, what=f"benchmark of {compiled.sources.name}").stdout
    vals = dict(re.findall(r"(\w+)=(\S+)", out))
    return BenchResult(compiled.sources.name, float(vals["median_ns"]),
                       float(vals["min_ns"]), float(vals["max_ns"]), int(vals["calls"]),
                       int(vals["batches"]))
