"""Fast numeric evaluation of casadi Functions through their buffer interface.

:class:`Evaluator` binds numpy arrays to a function's inputs and outputs once, so a call
costs about a microsecond on top of the function's own work (a plain casadi call converts
every argument, tens of microseconds); :class:`DenseEvaluator` also scatters sparse outputs
(Jacobians) into dense matrices. Both check every call: the number of arguments and each
argument's size against the function's inputs, so no input is broadcast or silently keeps
a value from an earlier call, and only real numbers are accepted: complex input is refused,
never truncated to its real part (numpy's cast would drop the imaginary part with only a
warning), as are booleans, strings and objects.

Output layout of :class:`DenseEvaluator`: an output whose casadi shape is a column
``(n, 1)`` comes back 1-D, shape ``(n,)``, whatever ``n`` (casadi has no vectors: a 1 x 1
matrix output such as the Hessian of a function of one variable is a column too, so it
comes back with shape ``(1,)``; reshape it where a matrix is meant); every other output
comes back 2-D with its casadi shape, empty ones included.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import casadi as ca
import numpy as np

from workbench.core.errors import ModelError
from workbench.core.types import ArrayLike

__all__ = ["Evaluator", "DenseEvaluator", "cached_evaluator", "evaluate_rows"]


class Evaluator:
    """Low-overhead numeric evaluation of a casadi.Function through its buffer interface.

    Calling a casadi.Function from Python converts every argument (tens of microseconds);
    an evaluator binds numpy arrays once and then costs about a microsecond per call on
    top of the function's own work. Use it in Python-level loops and benchmarks. Every
    call must give every input, each with the function's number of entries (any shape);
    nothing is broadcast and no input keeps a value from an earlier call.

    Parameters
    ----------
    fn : casadi.Function
        A function with dense vector inputs and outputs.

    Examples
    --------
    >>> ev = Evaluator(model.function("f"))          # doctest: +SKIP
    >>> xdot = ev(x, u, model.p)                     # doctest: +SKIP
    """

    def __init__(self, fn: ca.Function) -> None:
        if not isinstance(fn, ca.Function):
            raise ModelError(f"fn must be a casadi.Function; got {type(fn).__name__}")
        self.fn = fn
        self._buf, self._eval = fn.buffer()
        self._args = [np.zeros(fn.nnz_in(i)) for i in range(fn.n_in())]
        self._res = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
        for i, a in enumerate(self._args):
            self._buf.set_arg(i, memoryview(a))
        for i, r in enumerate(self._res):
            self._buf.set_res(i, memoryview(r))

    def _inputs(self) -> str:
        return ", ".join(f"{self.fn.name_in(i)} ({a.size})" for i, a in enumerate(self._args))

    def _fill(self, args: tuple[ArrayLike, ...]) -> None:
        """Copy the arguments into the bound input buffers, checking count and sizes."""
        if len(args) != len(self._args):
            raise ModelError(
                f"{self.fn.name()} takes {len(self._args)} inputs [{self._inputs()}]; got "
                f"{len(args)} arguments"
            )
        for i, (dst, src) in enumerate(zip(self._args, args)):
            try:
                v = np.ravel(src)
            except (TypeError, ValueError) as exc:  # ragged nested sequences
                raise ModelError(f"{self.fn.name()}: input {self.fn.name_in(i)!r} must be an "
                                 f"array of real numbers; got {src!r:.80}") from exc
            if v.dtype.kind not in "iuf":
                raise ModelError(self._not_real(i, src, v))
            if v.size != dst.size:
                raise ModelError(
                    f"{self.fn.name()}: input {self.fn.name_in(i)!r} must have {dst.size} "
                    f"entries; got shape {np.shape(src)}"
                )
            try:
                dst[:] = v
            except (TypeError, ValueError) as exc:
                raise ModelError(
                    f"{self.fn.name()}: input {self.fn.name_in(i)!r} must be numeric; got "
                    f"{src!r}"
                ) from exc

    def _not_real(self, i: int, src: ArrayLike, v: np.ndarray) -> str:
        name = f"{self.fn.name()}: input {self.fn.name_in(i)!r}"
        if v.dtype.kind == "c":
            return (f"{name} is complex (dtype {v.dtype}); the evaluator computes with real "
                    "numbers and would drop the imaginary part: pass real data (np.real(a), "
                    "if the imaginary part is meant to be zero)")
        return f"{name} must be numeric (real numbers); got dtype {v.dtype}: {src!r:.80}"

    def _outputs(self) -> np.ndarray | tuple[np.ndarray, ...]:
        if len(self._res) == 1:
            return self._res[0].copy()
        return tuple(r.copy() for r in self._res)

    def __call__(self, *args: ArrayLike) -> np.ndarray | tuple[np.ndarray, ...]:
        """Evaluate; returns copies of the outputs (one array, or a tuple).

        Raises
        ------
        ModelError
            A wrong number of arguments, or an argument of the wrong size, complex or not
            numeric (naming the input).
        """
        self._fill(args)
        self._eval()
        return self._outputs()


class DenseEvaluator(Evaluator):
    """Fast numeric calls of a casadi.Function with dense numpy outputs.

    A :class:`workbench.core._model.Evaluator` (buffer interface, about a microsecond of
    overhead, inputs checked for count, size and real dtype) whose sparse outputs
    (Jacobians) are scattered into dense matrices, and which always returns a tuple.
    Column outputs (casadi shape ``(n, 1)``, a 1 x 1 matrix included) come back 1-D,
    shape ``(n,)``; every other output 2-D with its casadi shape (module docstring).

    Parameters
    ----------
    fn : casadi.Function
        Dense vector inputs; any outputs.
    """

    def __init__(self, fn: ca.Function) -> None:
        super().__init__(fn)
        self._scatter = []
        for i in range(fn.n_out()):
            sp = fn.sparsity_out(i)
            shape = (sp.size1(), sp.size2())
            if sp.is_dense():
                self._scatter.append((shape, None))
            else:
                rows, cols = sp.get_triplet()  # empty lists for an all-zero sparsity
                self._scatter.append((shape, (np.asarray(rows, dtype=np.intp),
                                              np.asarray(cols, dtype=np.intp))))

    def _outputs(self) -> tuple[np.ndarray, ...]:
        """One dense array per output (columns 1-D, a 1 x 1 one too; others 2-D)."""
        out = []
        for r, (shape, idx) in zip(self._res, self._scatter):
            if idx is None:
                a = r.copy()
                out.append(a if shape[1] == 1 else a.reshape(shape, order="F"))
            else:
                d = np.zeros(shape)
                d[idx[0], idx[1]] = r
                out.append(d[:, 0] if shape[1] == 1 else d)
        return tuple(out)

    def __call__(self, *args: ArrayLike) -> tuple[np.ndarray, ...]:
        """Evaluate; one dense array per output (columns 1-D, a 1 x 1 one too; others 2-D)."""
        return super().__call__(*args)  # type: ignore[return-value]


ROWS_CHUNK = 1024
"""Largest number of rows :func:`evaluate_rows` evaluates in one call of a mapped function."""

_ROWS = threading.local()  # per thread: an evaluator's bound buffers are not shared
_ROWS_MAX = 256


def cached_evaluator(cache: dict[tuple[int, int], tuple[ca.Function, Evaluator]],
                     fn: ca.Function, k: int, build: Callable[[], ca.Function],
                     maximum: int) -> Evaluator:
    """The evaluator of ``build()``, cached in ``cache`` under ``fn`` and ``k``.

    At most ``maximum`` entries are kept (the oldest is dropped first); each entry holds
    ``fn`` itself, so its ``id`` cannot be reused by another function while it is cached.
    """
    key = (id(fn), k)
    hit = cache.get(key)
    if hit is not None and hit[0] is fn:
        return hit[1]
    if len(cache) >= maximum:
        cache.pop(next(iter(cache)))
    ev = Evaluator(build())
    cache[key] = (fn, ev)
    return ev


def _rows_evaluator(fn: ca.Function, k: int) -> Evaluator:
    """A cached evaluator of ``fn`` mapped over ``k`` rows, the other inputs shared."""
    cache = getattr(_ROWS, "cache", None)
    if cache is None:
        cache = _ROWS.cache = {}

    def build() -> ca.Function:
        ins = [ca.MX.sym(fn.name_in(i), fn.sparsity_in(i)) for i in range(fn.n_in())]
        dense = ca.Function(f"{fn.name()}_dense", ins, [ca.densify(o) for o in fn.call(ins)])
        return dense.map(f"{fn.name()}_rows{k}", "serial", k, list(range(1, fn.n_in())), [])

    return cached_evaluator(cache, fn, k, build, _ROWS_MAX)


def evaluate_rows(fn: ca.Function, X: ArrayLike, *fixed: ArrayLike) -> tuple[np.ndarray, ...]:
    """``fn`` at every row of ``X``, its other inputs fixed: each output as ``(n, numel)``.

    The same numbers as ``fn.map(n)(X.T, *fixed)``, without its cost on long series: that
    builds a map of ``n`` calls and converts every argument and result through casadi's
    ``DM`` (about 0.8 s for 2e5 states of the 3D pendulum's energy); here a map of at most
    :data:`ROWS_CHUNK` calls, built once per function and chunk size, is evaluated through
    its buffer interface chunk by chunk (about 0.04 s). The last chunk is padded with
    copies of the last row, whose results are dropped.

    Parameters
    ----------
    fn : casadi.Function
        Its first input is one row of ``X`` (its nonzeros); outputs are made dense (a
        structural zero comes back as 0.0).
    X : array-like, shape=(n, fn.nnz_in(0))
        The rows (real numbers).
    *fixed : array-like
        The other inputs of ``fn``, the same at every row, each with its number of entries.

    Returns
    -------
    tuple of ndarray
        Output ``i`` at row ``j`` is ``out[i][j]``, of ``fn.numel_out(i)`` entries (each
        output's entries in casadi's column-major order).

    Raises
    ------
    ModelError
        ``X`` is not 2-D with ``fn.nnz_in(0)`` columns, or a fixed input has the wrong
        number of entries, or is not real.
    """
    rows = np.asarray(X)
    if rows.ndim != 2 or rows.shape[1] != fn.nnz_in(0):
        raise ModelError(f"{fn.name()}: X must have shape (n, {fn.nnz_in(0)}) (a row per "
                         f"evaluation); got shape {rows.shape}")
    if len(fixed) != fn.n_in() - 1:
        raise ModelError(f"{fn.name()} takes {fn.n_in() - 1} fixed inputs after the rows; got "
                         f"{len(fixed)}")
    n = len(rows)
    outs = tuple(np.empty((n, fn.numel_out(i))) for i in range(fn.n_out()))
    if n == 0:
        return outs
    k = min(ROWS_CHUNK, 1 << (n - 1).bit_length())  # a power of two: few cached sizes
    ev = _rows_evaluator(fn, k)
    for start in range(0, n, k):
        block = rows[start: start + k]
        m = len(block)
        if m < k:
            block = np.concatenate([block, np.repeat(block[-1:], k - m, axis=0)])
        res = ev(np.ascontiguousarray(block).ravel(), *fixed)
        for out, r in zip(outs, res if isinstance(res, tuple) else (res,)):
            out[start: start + m] = r.reshape(k, -1)[:m]
    return outs
