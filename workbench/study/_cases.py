"""Tables of cases: run a call at an extreme, classify what it did, tabulate it.

A *case* is a call of a public entry point under a name. It either returns a
:class:`Check` (what the workbench did, an error estimate, what the error measures and
the tolerance it is held to) or raises. :class:`Cases` runs cases and keeps one table
(list of rows) per group; the outcome of a row is

* :data:`CORRECT` -- a finite error at or below its tolerance;
* :data:`CLEAR` -- a documented :class:`~workbench.core.errors.WorkbenchError` with its
  message (a clear failure);
* :data:`DEFECT` -- anything else: an undocumented exception, an error above its tolerance
  or not finite, or a result where a clear failure was expected.

:func:`run_isolated` runs a function in another process, spawned (one BLAS thread) or
forked, for cases whose memory is measured per case.
"""

from __future__ import annotations

import math
import os
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass
from multiprocessing import get_context
from typing import Any

from workbench.core._proc import proc_status_mb, reset_peak_rss
from workbench.core.errors import ParameterError, SolverError, WorkbenchError

__all__ = ["CLEAR", "CORRECT", "DEFECT", "Cases", "Check", "run_isolated", "reset_peak_memory",
           "peak_memory_mb"]

CORRECT, CLEAR, DEFECT = "correct", "clear failure", "DEFECT"


@dataclass
class Check:
    """What a case returns when the workbench produced a result.

    Attributes
    ----------
    did : str
        What the workbench did and found, in words.
    error : float
        The error estimate.
    measure : str
        What the error is (against what).
    tolerance : float
        Largest error for which the case counts as correct.
    extra : dict
        Further columns (peak memory, stage times).
    """

    did: str
    error: float
    measure: str
    tolerance: float
    extra: dict[str, Any] | None = None


class Cases:
    """Runs case functions and collects one table (list of rows) per group.

    Attributes
    ----------
    groups : dict of str to list of dict
        The rows of each group, in the order the cases ran; every row has ``case``,
        ``did``, ``outcome``, ``error``, ``measure``, ``tolerance`` and ``cost [s]``.
    """

    def __init__(self) -> None:
        self.groups: dict[str, list[dict[str, Any]]] = {}

    def run(self, group: str, case: str, fn: Callable[[], Check], *,
            expect_failure: bool = False) -> Check | None:
        """Run ``fn`` and tabulate its outcome.

        Parameters
        ----------
        group : str
            The table the row goes to.
        case : str
            The row's name.
        fn : callable
            Runs the case: returns a :class:`Check` or raises.
        expect_failure : bool
            The case must fail clearly; a result is then a defect.

        Returns
        -------
        Check or None
            What ``fn`` returned (None if it raised).
        """
        t0 = time.perf_counter()
        out: Check | None = None
        row: dict[str, Any] = {"case": case}
        try:
            out = fn()
        except WorkbenchError as exc:
            row.update(did=f"{type(exc).__name__}: {exc}", outcome=CLEAR, error=None,
                       measure="", tolerance=None)
        except Exception as exc:  # noqa: BLE001 - anything else is the defect we look for
            row.update(did=f"{type(exc).__name__}: {exc} | "
                           f"{traceback.format_exc(limit=2).splitlines()[-3]}",
                       outcome=DEFECT, error=None, measure="undocumented exception",
                       tolerance=None)
        else:
            ok = math.isfinite(out.error) and out.error <= out.tolerance
            row.update(did=out.did, outcome=CORRECT if ok else DEFECT, error=out.error,
                       measure=out.measure if ok else f"ABOVE TOLERANCE: {out.measure}",
                       tolerance=out.tolerance)
            row.update(out.extra or {})
        if expect_failure and row["outcome"] == CORRECT:
            row.update(outcome=DEFECT, measure="expected a clear failure, got a result")
        row["cost [s]"] = time.perf_counter() - t0
        self.groups.setdefault(group, []).append(row)
        return out

    def outcomes(self) -> dict[str, int]:
        """How many rows have each outcome, over every group."""
        counts: dict[str, int] = {}
        for rows in self.groups.values():
            for r in rows:
                counts[r["outcome"]] = counts.get(r["outcome"], 0) + 1
        return counts


_ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


@contextmanager
def _environment(values: dict[str, str]) -> Iterator[None]:
    old = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _child(conn: Any, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
    try:
        conn.send((True, fn(*args)))
    except BaseException as exc:  # noqa: BLE001 - handed to the parent, which re-raises it
        conn.send((False, exc))
    finally:
        conn.close()


def reset_peak_memory() -> float:
    """Reset this process's peak resident memory to its current one; return that [MB].

    With :func:`peak_memory_mb` at the end, the memory a piece of work adds beyond what
    the process had loaded. Linux only (``/proc``). It changes the process's own peak
    from then on: call it in a process of its own, such as ``run_isolated(fresh=False)``.

    Raises
    ------
    OSError
        Where ``/proc`` cannot do it.
    """
    return reset_peak_rss()


def peak_memory_mb() -> float:
    """Peak resident memory (``VmHWM``) of this process [MB], since its last reset if any.

    Raises
    ------
    OSError
        Where ``/proc`` cannot be read.
    """
    return proc_status_mb("VmHWM")


def run_isolated(fn: Callable[..., Any], *args: Any, timeout: float = 3600.0,
                 fresh: bool = True) -> Any:
    """Call ``fn(*args)`` in another process; return its value.

    A fresh (spawned) process starts from nothing, so its peak resident memory (read
    inside ``fn``) is that of this call and of the imports it needs. A forked one
    (``fresh=False``) inherits this process's modules and memory and starts in
    milliseconds instead of the 2-3 s of imports a spawned one pays (the extremes'
    20-link chain: 3.1-3.8 s CPU spawned, 0.6-0.7 s forked); what ``fn`` itself adds to
    the memory is then measured inside it, against its start. A spawned
    process runs one BLAS thread; a forked one keeps this process's BLAS set-up.

    Parameters
    ----------
    fn : callable
        A module-level function (it is pickled by reference); its arguments and return
        value must pickle.
    *args
        Its arguments.
    timeout : float
        Seconds to wait for the result; the process is then terminated.
    fresh : bool
        Spawn a fresh process (default) or fork this one.

    Returns
    -------
    Any
        What ``fn`` returned.

    Raises
    ------
    ParameterError
        If ``fresh`` is not a bool.
    SolverError
        If the process dies without a result or times out; an exception raised by ``fn``
        itself is raised again here.
    """
    if not isinstance(fresh, bool):
        raise ParameterError(f"fresh must be True (spawn) or False (fork); got {fresh!r}")
    ctx = get_context("spawn" if fresh else "fork")
    receive, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, fn, args), daemon=True)
    # the variables reach a spawned process's BLAS; a forked one has its BLAS loaded
    with _environment(_ONE_THREAD) if fresh else nullcontext():
        proc.start()
    send.close()
    try:
        if not receive.poll(timeout):
            proc.terminate()
            raise SolverError(f"{fn.__name__}{args}: no result within {timeout:g} s; the "
                              "process was terminated", status="timeout")
        try:
            ok, value = receive.recv()
        except EOFError:
            proc.join()
            raise SolverError(f"{fn.__name__}{args}: the process ended (exit code "
                              f"{proc.exitcode}) without a result", status="process died"
                              ) from None
    finally:
        receive.close()
        proc.join()
    if not ok:
        raise value
    return value
