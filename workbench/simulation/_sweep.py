"""Sweeps over parameters or initial conditions, run through a concurrent.futures.Executor.

:func:`sweep` calls ``fn(**item)`` for every item of a list of keyword-argument dicts and
returns the outcomes **in the order of the items**, each with its status, value or error
(exception type, message and traceback from the worker), and its wall time. A failing
item never hides the others; by default :func:`sweep` raises a :class:`SweepError`
listing every failure after all items ran (``on_error=OnError.REPORT`` returns them).

Where the items run:

* ``executor=None``: a local process pool of ``workers`` processes (``StartMethod.SPAWN``
  by default: each worker imports its modules afresh, no state is inherited);
* any ``concurrent.futures.Executor`` (a thread pool, :class:`InlineExecutor` to run
  in the calling process, a pool the caller keeps for several sweeps);
* a ``dask.distributed.Client`` (optional extra ``sweep``: ``pip install
  'geometric-pendulum-workbench[sweep]'``); :func:`local_cluster` starts a local one.

``fn`` and the items must be picklable for process pools: a module-level function (not a
lambda or a closure) and plain data. A tqdm progress bar reports completed items.
"""

from __future__ import annotations

import concurrent.futures as cf
import itertools
import multiprocessing
import os
import pickle
import sys
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from workbench.core import validate
from workbench.core.errors import ParameterError, SolverError, WorkbenchError
from workbench.core.status import Record, StatusEnum, StatusResult
from workbench.core.validate import choice, count

__all__ = [
    "ItemStatus",
    "OnError",
    "StartMethod",
    "Outcome",
    "SweepResult",
    "SweepCost",
    "SweepError",
    "MissingDependencyError",
    "InlineExecutor",
    "grid",
    "sweep",
    "local_cluster",
    "MAX_WORKERS",
]

MAX_WORKERS = 1024
"""Largest local pool of :func:`sweep`: each worker is a process (about 100 MB with casadi
loaded); a larger fleet is a cluster's, passed as ``executor``."""


class ItemStatus(StatusEnum):
    """Outcome of one item (and of a sweep: FAILED when any item failed)."""

    OK = "returned a value"
    FAILED = "raised an exception (in fn, in pickling, or the worker died)"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"OK"})


class OnError(Enum):
    """What :func:`sweep` does when items failed (after all items ran)."""

    RAISE = "raise SweepError listing the failures"
    REPORT = "return the result; failures are in SweepResult.failures"


class StartMethod(Enum):
    """How a local process pool starts its workers (``multiprocessing`` contexts)."""

    SPAWN = "spawn"
    FORKSERVER = "forkserver"
    FORK = "fork"


class SweepError(SolverError):
    """Items of a sweep failed; ``result`` holds every outcome (a :class:`SolverError`)."""

    def __init__(self, message: str, *, result: SweepResult) -> None:
        super().__init__(message)
        self.status = ItemStatus.FAILED.code
        self.result = result


class MissingDependencyError(WorkbenchError, ImportError):
    """An optional dependency is not installed (the message says which extra to install)."""


@dataclass
class Outcome(StatusResult):
    """What one item gave.

    Attributes
    ----------
    index : int
        Position of the item in the input list.
    item : dict
        The keyword arguments.
    status : ItemStatus
        OK or FAILED.
    value : Any
        The return value (None on failure).
    error : str
        ``"ExceptionType: message"`` on failure, else ``""``.
    traceback : str
        The worker's formatted traceback on failure.
    seconds : float
        Wall time of the call inside the worker (NaN if it never ran).
    worker : str
        ``host:pid`` of the process that ran it.
    """

    index: int
    item: dict[str, Any]
    status: ItemStatus
    value: Any = None
    error: str = ""
    traceback: str = ""
    seconds: float = float("nan")
    worker: str = ""

    def failure_message(self) -> str:  # noqa: D102
        return f"sweep item {self.index} {self.item!r} failed: {self.error}"


@dataclass(frozen=True)
class SweepCost(Record):
    """What a sweep cost.

    Attributes
    ----------
    wall_seconds : float
        Submission to last result.
    item_seconds : float
        Sum over the items of their wall time inside the workers.
    backend : str
        The executor's kind.
    workers : int
        Distinct worker processes seen.
    speedup : float
        ``item_seconds / wall_seconds``.
    n_items, n_failed : int
        Items run, items failed.
    """

    wall_seconds: float
    item_seconds: float
    backend: str
    workers: int
    speedup: float
    n_items: int
    n_failed: int


@dataclass
class SweepResult(StatusResult):
    """Outcomes in item order, and what the sweep cost.

    Attributes
    ----------
    outcomes : list of Outcome
        One per item, in input order.
    cost : SweepCost
        ``wall_seconds`` (submission to last result), ``item_seconds`` (sum over items),
        ``workers`` (distinct worker processes seen), ``backend``, ``speedup``
        (``item_seconds / wall_seconds``), ``n_items``, ``n_failed`` (a typed record that
        also reads as a mapping).
    """

    outcomes: list[Outcome]
    cost: SweepCost | dict[str, Any] = field(default_factory=dict)

    @property
    def status(self) -> ItemStatus:
        """OK when every item returned a value, else FAILED."""
        return ItemStatus.OK if all(o.ok for o in self.outcomes) else ItemStatus.FAILED

    def raise_for_status(self) -> SweepResult:
        """Return ``self`` when every item succeeded; otherwise raise :class:`SweepError`."""
        if not self.ok:
            raise SweepError(_failure_message(self), result=self)
        return self

    @property
    def failures(self) -> list[Outcome]:
        """The failed outcomes."""
        return [o for o in self.outcomes if not o.ok]

    def values(self) -> list[Any]:
        """Return values in item order; raises :class:`SweepError` if any item failed."""
        if not self.ok:
            raise SweepError(_failure_message(self), result=self)
        return [o.value for o in self.outcomes]

    def __len__(self) -> int:
        return len(self.outcomes)

    def __iter__(self) -> Iterator[Outcome]:
        return iter(self.outcomes)


def _failure_message(result: SweepResult) -> str:
    fails = result.failures
    lines = [f"{len(fails)} of {len(result.outcomes)} sweep items failed:"]
    for o in fails[:10]:
        lines.append(f"  item {o.index} {o.item!r}: {o.error}")
    if len(fails) > 10:
        lines.append(f"  ... and {len(fails) - 10} more (SweepError.result.failures)")
    return "\n".join(lines)


class InlineExecutor(cf.Executor):
    """An executor that runs each call at submission, in the calling process.

    For debugging (tracebacks and breakpoints in the caller's process) and for sweeps too
    small to pay for worker start-up.
    """

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> cf.Future:
        """Run ``fn(*args, **kwargs)`` now; return a completed future."""
        fut: cf.Future = cf.Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - delivered through the future
            fut.set_exception(exc)
        return fut


def grid(**axes: Sequence[Any]) -> list[dict[str, Any]]:
    """The Cartesian product of named value lists, as a list of keyword dicts.

    Examples
    --------
    >>> grid(c=[1, 2], mu=[0.0])
    [{'c': 1, 'mu': 0.0}, {'c': 2, 'mu': 0.0}]
    """
    for name, values in axes.items():
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
            raise ParameterError(f"grid axis {name!r} must be a sequence of values; got "
                                 f"{values!r}")
    names = list(axes)
    return [dict(zip(names, combo)) for combo in itertools.product(*axes.values())]


def _run_item(fn: Callable[..., Any], index: int, item: Mapping[str, Any]) -> tuple:
    """Worker side: call, time, and catch; never raises for errors of ``fn``."""
    worker = f"{os.uname().nodename}:{os.getpid()}"
    t0 = time.perf_counter()
    try:
        value = fn(**item)
    except Exception as exc:  # noqa: BLE001 - reported per item
        return (index, False, None, f"{type(exc).__name__}: {exc}", traceback.format_exc(),
                time.perf_counter() - t0, worker)
    return index, True, value, "", "", time.perf_counter() - t0, worker


def _is_dask_client(obj: Any) -> bool:
    return type(obj).__module__.startswith("distributed") and hasattr(obj, "get_executor")


def _check_items(items: Any) -> list[dict[str, Any]]:
    if isinstance(items, Mapping) or not isinstance(items, Sequence):
        raise ParameterError(
            f"items must be a sequence of keyword-argument dicts (e.g. from grid(...)); got "
            f"{type(items).__name__}"
        )
    out = []
    for k, it in enumerate(items):
        if not isinstance(it, Mapping) or not all(isinstance(key, str) for key in it):
            raise ParameterError(f"items[{k}] must be a dict of keyword arguments; got {it!r}")
        out.append(dict(it))
    return out


def _progress_bar(total: int, desc: str, progress: bool | None) -> Any:
    show = progress if progress is not None else (total > 1 and sys.stderr.isatty())
    if not show:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="item", file=sys.stderr)


@validate.arguments(desc=validate.text)
def sweep(
    fn: Callable[..., Any],
    items: Sequence[Mapping[str, Any]],
    *,
    executor: cf.Executor | Any | None = None,
    workers: int | None = None,
    start_method: StartMethod = StartMethod.SPAWN,
    on_error: OnError = OnError.RAISE,
    progress: bool | None = None,
    desc: str = "sweep",
) -> SweepResult:
    """Run ``fn(**item)`` for every item, concurrently, and collect the outcomes in order.

    Parameters
    ----------
    fn : callable
        A module-level function (picklable by reference) taking keyword arguments.
    items : sequence of dict
        Keyword arguments of each call (see :func:`grid`).
    executor : concurrent.futures.Executor or dask.distributed.Client, optional
        Where to run; ``None`` starts (and shuts down) a local process pool.
    workers : int, optional
        Size of the local pool (``os.cpu_count()`` when omitted; at most
        :data:`MAX_WORKERS`); only with ``executor=None``.
    start_method : StartMethod
        How the local pool starts processes; only with ``executor=None``.
    on_error : OnError
        Raise :class:`SweepError` after all items ran if any failed (default), or report.
    progress : bool, optional
        Show a tqdm bar; by default when stderr is a terminal and there are several items.
    desc : str
        Label of the progress bar.

    Returns
    -------
    SweepResult

    Raises
    ------
    ParameterError
        If ``fn`` or the items cannot be sent to worker processes, or bad options.
    SweepError
        If items failed and ``on_error`` is ``OnError.RAISE``.
    """
    if not callable(fn):
        raise ParameterError(f"fn must be callable; got {type(fn).__name__}")
    item_list = _check_items(items)
    on_error = choice(OnError, on_error, "on_error")
    start_method = choice(StartMethod, start_method, "start_method")
    if workers is not None:  # processes are started for them: bounded before any is
        count("workers", workers, maximum=MAX_WORKERS)
    if executor is not None and workers is not None:
        raise ParameterError("workers applies only to the local pool (executor=None); size "
                             "the executor you pass yourself")
    backend: str
    own_pool = None
    dask = _is_dask_client(executor)
    if executor is None:
        n = workers or os.cpu_count() or 1
        _check_picklable(fn, item_list)
        own_pool = cf.ProcessPoolExecutor(
            max_workers=n, mp_context=multiprocessing.get_context(start_method.value))
        pool: cf.Executor = own_pool
        backend = f"process pool ({n} workers, {start_method.value})"
    elif dask:
        pool = executor.get_executor()
        backend = f"dask.distributed ({executor.scheduler.address})"
    elif isinstance(executor, cf.Executor):
        if isinstance(executor, cf.ProcessPoolExecutor):
            _check_picklable(fn, item_list)
        pool = executor
        backend = type(executor).__name__
    else:
        raise ParameterError(
            f"executor must be a concurrent.futures.Executor or a dask.distributed.Client; "
            f"got {type(executor).__name__}"
        )

    outcomes: list[Outcome | None] = [None] * len(item_list)
    bar = _progress_bar(len(item_list), desc, progress)
    t0 = time.perf_counter()
    try:
        futures = {pool.submit(_run_item, fn, k, it): k for k, it in enumerate(item_list)}
        for fut in cf.as_completed(futures):
            k = futures[fut]
            try:
                idx, ok, value, err, tb, secs, worker = fut.result()
                outcomes[k] = Outcome(idx, item_list[k],
                                      ItemStatus.OK if ok else ItemStatus.FAILED,
                                      value, err, tb, secs, worker)
            except Exception as exc:  # noqa: BLE001 - worker died, or result unpicklable
                outcomes[k] = Outcome(k, item_list[k], ItemStatus.FAILED,
                                      error=f"{type(exc).__name__}: {exc}",
                                      traceback=traceback.format_exc())
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        if own_pool is not None:
            own_pool.shutdown(wait=True, cancel_futures=True)
    wall = time.perf_counter() - t0
    done = [o for o in outcomes if o is not None]
    item_seconds = sum(o.seconds for o in done if o.seconds == o.seconds)
    result = SweepResult(done, SweepCost(
        wall_seconds=wall, item_seconds=item_seconds, backend=backend,
        workers=len({o.worker for o in done if o.worker}),
        speedup=item_seconds / wall if wall > 0 else float("nan"),
        n_items=len(done), n_failed=sum(not o.ok for o in done),
    ))
    if on_error is OnError.RAISE and not result.ok:
        raise SweepError(_failure_message(result), result=result)
    return result


def _check_picklable(fn: Callable[..., Any], items: list[dict[str, Any]]) -> None:
    try:
        pickle.dumps(fn)
    except Exception as exc:  # noqa: BLE001
        raise ParameterError(
            f"fn must be picklable to run in worker processes (a module-level function, not "
            f"a lambda, closure or local function); got {fn!r} ({exc})"
        ) from exc
    for k, it in enumerate(items):
        try:
            pickle.dumps(it)
        except Exception as exc:  # noqa: BLE001
            raise ParameterError(f"items[{k}] must be picklable plain data; got {it!r} "
                                 f"({exc})") from exc


def local_cluster(*, workers: int = 2, threads_per_worker: int = 1) -> Any:
    """Start a local dask.distributed cluster and return a connected Client.

    Close it with ``client.close(); client.cluster.close()`` (or use it as a context
    manager: ``with local_cluster() as client: ...``).

    Parameters
    ----------
    workers : int
        Worker processes (1 to :data:`MAX_WORKERS`).
    threads_per_worker : int
        Threads per worker (1 for CPU-bound numerics holding the GIL; at most
        :data:`MAX_WORKERS`).

    Returns
    -------
    dask.distributed.Client

    Raises
    ------
    ParameterError
        ``workers`` or ``threads_per_worker`` not an integer in ``[1, MAX_WORKERS]``
        (checked before anything is started).
    MissingDependencyError
        If dask.distributed is not installed.
    """
    count("workers", workers, maximum=MAX_WORKERS)
    count("threads_per_worker", threads_per_worker, maximum=MAX_WORKERS)
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:
        raise MissingDependencyError(
            "dask.distributed is not installed; install the optional extra: "
            "pip install 'geometric-pendulum-workbench[sweep]' (or 'dask[distributed]')"
        ) from exc
    cluster = LocalCluster(n_workers=workers, threads_per_worker=threads_per_worker,
                           processes=True, dashboard_address=None)
    return Client(cluster)
