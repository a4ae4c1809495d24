"""Run the problems of a report in parallel processes, each re-used from the cache if unchanged.

Every problem whose cache key (:mod:`~workbench.app.report.cache`) has a stored outcome is
taken from the cache. The others run in forked processes, at most ``jobs`` at a time,
longest first (by the durations of earlier runs), and together only while the peak
memories of their last runs fit a budget. Each child runs its problem, turns the result
into what the report needs (its document section, figures as SVG text, captions,
animations, summary numbers: :class:`Outcome`) and writes it to a file the parent reads;
no live Model or figure crosses the process boundary (the child's side is
:mod:`~workbench.app.report._child`). Each child has its own time limit in CPU seconds,
and three times as much in wall time (its process group is killed when one is exceeded),
and reports its CPU time and peak resident memory. A problem that raises, dies or times
out is recorded as such, cached like a result (``rerun`` runs it again), and the others
go on.

Progress is printed problem by problem with the elapsed time and an estimate of what
remains; a problem still running is mentioned every ``heartbeat`` seconds, with the last
line it gave through :func:`workbench.study.progress` and its own estimate.
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import json
import multiprocessing
import multiprocessing.connection
import os
import pickle
import resource
import signal
import sys
import tempfile
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any, TextIO

from workbench.app.report import cache
from workbench.app.report._child import Outcome, _child, outcome_of  # noqa: F401 - re-exported
from workbench.app.report.collect import Status
from workbench.app.report.errors import ReportInputError
from workbench.app.report.figures import warm_up
from workbench.app.report.progress import (
    Progress,
    RunStats,
    cpu_seconds_of,
    pss_mb,
    rss_mb,
)
from workbench.core.files import write_atomic
from workbench.core.validate import count

__all__ = ["Outcome", "RunStats", "run_all", "DEFAULT_TIMEOUT", "DEFAULT_MEMORY_MB",
           "MAX_JOBS"]

MAX_JOBS = 256
"""Most problems run at the same time (``--jobs``): each is a forked process of the report
(hundreds of MB once it runs); the processes used are also at most the problems to run."""

DEFAULT_TIMEOUT = {True: 600.0, False: 1200.0}
"""Default time limit of one problem [s of CPU time], by quick mode.

The limit is on CPU time (the problem's process and its ended children), so that a busy
machine does not stop a problem that would finish in time on a quiet one: a cached
time-out says the problem needs more than that much computing. A process that stays
alive :data:`WALL_FACTOR` times as long in wall time is stopped too (waiting, hung)."""

WALL_FACTOR = 3.0
"""A problem is also stopped after this many times its time limit in wall time."""

DEFAULT_MEMORY_MB = 1300.0
"""Default budget of the peak memories of the problems run at the same time [MB] (with the
report's own process, about 200 MB, under the report's 1.5 GB target for its peak)."""

SMALL_MB = 300.0
"""Problems whose last peak was at most this [MB] run beside any other (most of the report's
problems peak at 170-270 MB, most of it pages shared with the report's process)."""

POLL = 0.2
"""Seconds between checks of the running children."""

MEMORY_POLL = 2.0
"""Seconds between samples of the memory of all the report's processes together (reading a
process's proportional set size walks its page tables: about 15 ms for a 400 MB process)."""

PRELOAD = ("control", "scipy.stats", "PIL.Image", "sympy.tensor.tensor",
           "sympy.physics.mechanics", "workbench.mechanics")
"""Modules the problems import lazily (python-control for LQR, scipy.stats for the
attraction estimates, PIL for figures with images, sympy.physics.mechanics for the Kane
references, workbench.mechanics for the derived models; sympy imports sympy.tensor.tensor
at its first sum of certain terms, which every model sheet makes): imported once here,
after the first problem started and before the others, so that they inherit them. Each
child imported its own copy: python-control took 0.8 s CPU in each of the 4 quick problems
that design an LQR, scipy.stats 0.6 s in 7, sympy.physics.mechanics 0.44 s in 3 (and
part of it in a fourth)."""


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime




@dataclass
class _Job:
    name: str
    key: str | None
    title: str
    process: Any = None
    started: float = 0.0
    peak_sampled: float = 0.0
    cpu_sampled: float = float("nan")
    path: Path | None = None
    read_at: int = 0


def _kill_group(process: Any) -> None:
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        process.kill()
    process.join(5)


EXPECTED_TIMINGS = Path(__file__).with_name("expected_timings.json")
"""Seconds and peak memory of every problem, quick and full, measured in a cold report on
2 cores (shipped with the code): a first run, with no timings in its cache yet, still
starts the longest problems first, packs by memory and estimates what remains. Timings
measured in the cache directory take precedence."""


def _read_timings(cache_dir: Path | None, *, path: Path | None = None) -> dict[str, float]:
    if cache_dir is None and path is None:
        return {}
    try:
        data = json.loads((path or Path(cache_dir) / "timings.json").read_text())
        return {str(k): float(v) for k, v in data.items()}
    except (OSError, ValueError, AttributeError):
        return {}


def _write_timings(cache_dir: Path | None, timings: dict[str, float]) -> None:
    if cache_dir is None:
        return
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    # atomic, umask respected, nothing left behind and one clear line if it cannot be written
    write_atomic(cache_dir / "timings.json", json.dumps(timings, indent=1, sort_keys=True),
                 name="--cache timings.json", error=ReportInputError)


def _over(job: _Job, timeout: float) -> str:
    """``"cpu"`` or ``"wall"`` when a running problem is past its limit, else ``""``."""
    if job.cpu_sampled > timeout:
        return "cpu"
    if time.monotonic() - job.started > WALL_FACTOR * timeout:
        return "wall"
    return ""


def _finished(job: _Job, path: Path, *, timed_out: str, timeout: float) -> Outcome:
    """The outcome of a child that has exited, or was stopped at its limit (``timed_out``)."""
    if path.is_file():
        with path.open("rb") as fh:
            out: Outcome = pickle.load(fh)
        out.limit = timeout
        return out
    seconds = time.monotonic() - job.started
    if timed_out:
        used = job.cpu_sampled
        why = (f"{timeout:.0f} s of CPU time ({seconds:.0f} s wall)" if timed_out == "cpu" else
               f"{seconds:.0f} s wall, {WALL_FACTOR:g} times the limit, having used only "
               f"{used:.0f} s of CPU time (waiting for something, or the machine very busy)")
        return Outcome(job.name, job.title, Status.TIMED_OUT, seconds, peak_mb=job.peak_sampled,
                       error=f"timed out: stopped after {why}; the time limit of one problem is "
                             f"{timeout:.0f} s of CPU time (workbench report --timeout SECONDS)",
                       ran_at=time.time(), cpu_seconds=used, limit=timeout)
    return Outcome(job.name, job.title, Status.FAILED, seconds, peak_mb=job.peak_sampled,
                   error=f"the process running the problem died (exit code "
                         f"{job.process.exitcode}; a negative code is the signal)",
                   ran_at=time.time(), cpu_seconds=job.cpu_sampled, limit=timeout)


FAILURES = (Status.FAILED, Status.TIMED_OUT)


def _reusable(hit: Outcome | None, name: str, rerun: frozenset[str],
              timeout: float) -> bool:
    """Whether a cached outcome is re-used (not asked to re-run, not stopped too early)."""
    if hit is None or "all" in rerun or name in rerun:
        return False
    if hit.status in FAILURES and "failed" in rerun:
        return False
    # a problem stopped at a shorter limit than today's may finish now: run it again
    return not (hit.status is Status.TIMED_OUT and not hit.limit >= timeout)


def _lookup(names: Sequence[str], *, quick: bool, catalogue: ModuleType,
            cache_dir: Path | None, rerun: frozenset[str], timeout: float,
            ) -> tuple[dict[str, Outcome], list[_Job]]:
    """Split ``names`` into outcomes re-used from the cache and jobs to run."""
    done: dict[str, Outcome] = {}
    todo: list[_Job] = []
    engine = cache.engine_digest() if cache_dir else None
    for name in names:
        module = catalogue.load(name)
        key = (cache.problem_key(cache.module_file(module), quick=quick, engine=engine)
               if cache_dir else None)
        title = str(getattr(module, "TITLE", name))
        hit = cache.load(cache_dir, name, quick=quick, key=key) if cache_dir and key else None
        if _reusable(hit, name, rerun, timeout):
            hit.cached = True
            done[name] = hit
        else:
            todo.append(_Job(name, key, title))
    return done, todo


def _read_progress(job: _Job) -> list[dict[str, Any]]:
    """New progress lines of a running problem (see :func:`workbench.study.progress`)."""
    if job.path is None:
        return []
    try:
        with open(f"{job.path}.progress", "rb") as fh:
            fh.seek(job.read_at)
            data = fh.read()
    except OSError:
        return []
    complete = data[: data.rfind(b"\n") + 1]
    job.read_at += len(complete)
    out = []
    for line in complete.splitlines():
        try:
            out.append(json.loads(line))
        except ValueError:
            continue
    return out


def _next_job(todo: list[_Job], running: list[_Job], peaks: dict[str, float],
              budget: float) -> int | None:
    """Index of the next problem to start: the first (longest) whose last peak memory fits.

    Problems run together only while the sum of their peak memories in the last run stays
    within ``budget`` [MB]; a problem never measured counts as 0, one that alone exceeds
    the budget runs when nothing else does, and a small one (last peak at most
    :data:`SMALL_MB`, most problems) always fits, so that a memory-heavy problem does not
    leave the other cores idle. None: wait for a running one to end.
    """
    if not running:
        return 0 if todo else None
    used = sum(peaks.get(j.name, 0.0) for j in running)
    for i, job in enumerate(todo):
        peak = peaks.get(job.name, 0.0)
        if peak <= SMALL_MB or used + peak <= budget:
            return i
    return None


def _warm_up_for_children() -> None:
    """Load matplotlib's fonts and parser and :data:`PRELOAD` here, for the children."""
    warm_up()
    for module in PRELOAD:
        with contextlib.suppress(Exception):  # a problem needing it reports the error
            importlib.import_module(module)


def _check_rerun(rerun: Collection[str] | str | None, names: Sequence[str]) -> frozenset[str]:
    if rerun is None:
        return frozenset()
    items = frozenset([rerun] if isinstance(rerun, str) else rerun)
    unknown = sorted(items - set(names) - {"all", "failed"})
    if unknown:
        raise ReportInputError(
            f"--rerun: {', '.join(map(repr, unknown))} is not a problem of this report; "
            f"expected problem names, 'failed' or 'all' (problems: {', '.join(names)})")
    return items


def run_all(
    names: Sequence[str],
    *,
    quick: bool,
    catalogue: ModuleType,
    jobs: int | None = None,
    timeout: float | None = None,
    cache_dir: Path | None = None,
    stream: TextIO | None = None,
    progress: bool = True,
    heartbeat: float = 30.0,
    on_done: Callable[[Outcome], None] | None = None,
    rerun: Collection[str] | str | None = None,
    memory_mb: float | None = None,
) -> tuple[list[Outcome], RunStats]:
    """Run (or re-use) every problem; return the outcomes in the order of ``names``.

    Every outcome is cached, a failure or a time-out too (shown as such, with the error,
    when re-used), so that a second report with nothing changed runs nothing; ``rerun``
    forces problems to run again. A time-out is run again by itself when ``timeout`` is
    larger than the limit it was stopped at.

    Parameters
    ----------
    names : sequence of str
        Problems of ``catalogue``.
    quick : bool
        Quick mode.
    catalogue : module
        ``load(name)`` gives a problem module with ``TITLE`` and ``solve``.
    jobs : int, optional
        Problems run at the same time, 1 to :data:`MAX_JOBS` (default: the number of
        cores). The processes used are at most the problems to run (the rest are
        re-used from the cache); when that is fewer than asked, the progress says so, and
        ``RunStats.jobs`` is the number used.
    timeout : float, optional
        Time limit of one problem [s of CPU time] (default :data:`DEFAULT_TIMEOUT`; also
        stopped after :data:`WALL_FACTOR` times as long in wall time).
    cache_dir : Path, optional
        Where outcomes are cached; None runs everything and caches nothing.
    stream : file, optional
        Progress output (default ``sys.stderr``).
    progress : bool
        Print progress.
    heartbeat : float
        Seconds between "still running" lines for a long problem.
    on_done : callable, optional
        Called with every outcome as it becomes available.
    rerun : str or collection of str, optional
        Problems to run even if cached: names, ``"failed"`` (every cached failure and
        time-out) or ``"all"``.
    memory_mb : float, optional
        Problems run at the same time only while the sum of their peak memories in the
        last run is at most this [MB] (default :data:`DEFAULT_MEMORY_MB`); a problem that
        alone needs more runs by itself.

    Returns
    -------
    outcomes : list of Outcome
    stats : RunStats
        Wall time, counts and peak memory.

    Raises
    ------
    ReportInputError
        If ``rerun`` names something that is not a problem of ``names``, or ``jobs`` is
        not a whole number from 1 to :data:`MAX_JOBS`.
    """
    asked = jobs
    if jobs is not None:
        jobs = count("--jobs", jobs, maximum=MAX_JOBS, error=ReportInputError)
    jobs = jobs or min(os.cpu_count() or 1, MAX_JOBS)
    timeout = float(timeout or DEFAULT_TIMEOUT[bool(quick)])
    forced = _check_rerun(rerun, names)
    stream = stream or sys.stderr
    t0 = time.monotonic()
    cpu0 = _children_cpu()
    mode = "quick" if quick else "full"
    measured = _read_timings(cache_dir)
    timings = {**_read_timings(None, path=EXPECTED_TIMINGS), **measured}
    show = Progress(len(names), stream=stream, enabled=progress, jobs=jobs)
    done, todo = _lookup(names, quick=quick, catalogue=catalogue, cache_dir=cache_dir,
                         rerun=forced, timeout=timeout)
    # no more processes than problems to run: the number used is the one reported
    jobs = show.jobs = min(jobs, max(1, len(todo)))
    if asked is not None and jobs < asked and progress:
        print(f"--jobs {asked}: {jobs} process(es) used, one per problem to run "
              f"({len(todo)} to run, {len(done)} re-used from the cache)", file=stream)
    for hit in done.values():
        show.finished(hit, time.monotonic() - t0)
        if on_done:
            on_done(hit)
    todo.sort(key=lambda j: -timings.get(f"{mode}/{j.name}", 0.0))
    peaks = {j.name: timings.get(f"{mode}/{j.name}/peak_mb", 0.0) for j in todo}
    memory_mb = float(DEFAULT_MEMORY_MB if memory_mb is None else memory_mb)
    show.plan({j.name: timings.get(f"{mode}/{j.name}") for j in todo})
    ctx = multiprocessing.get_context("fork")
    # cores of each problem's own pools: the cores over the problems that run at once
    share = max(1, (os.cpu_count() or 1) // jobs)
    # the forked children inherit matplotlib's loaded fonts and parser, and the modules
    # they would each import (one problem alone: its own). The first (longest) problem
    # starts before: it loads what it needs itself while this process loads them for the
    # others, instead of both cores waiting for these 1.2 s (the double cart, first in
    # either mode, needs none of PRELOAD)
    warm = len(todo) > 1
    running: list[_Job] = []
    peak_total = pss_mb(os.getpid())
    sampled_at = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="workbench-report-runs-") as tmp:
        try:
            while todo or running:
                while todo and len(running) < jobs:
                    pick = _next_job(todo, running, peaks, memory_mb)
                    if pick is None:
                        break
                    job = todo.pop(pick)
                    job.path = Path(tmp) / f"{job.name}.pkl"
                    job.process = ctx.Process(
                        target=_child, name=f"report:{job.name}",
                        args=(job.name, quick, catalogue, str(job.path), share))
                    # what the child inherits (modules, fonts: ~170k objects) lives as
                    # long as the child: frozen, its collector does not walk it. Unfrozen,
                    # one full collection cost a child 0.12-0.4 s CPU and copied every
                    # page it touched (benchmarks/bench_report_fork.py: the 13 small
                    # problems' processes 5% less CPU with this and PRELOAD)
                    gc.freeze()
                    job.process.start()
                    job.started = time.monotonic()
                    running.append(job)
                    show.started(job.name)
                    if warm:
                        warm = False
                        _warm_up_for_children()
                # wake when a child ends (its slot is refilled at once) or after POLL
                # to sample memory and progress; a fixed sleep left each core idle for
                # half a POLL on average per problem (26 problems: ~1.3 s of the report)
                if running:
                    multiprocessing.connection.wait([j.process.sentinel for j in running],
                                                    timeout=POLL)
                else:
                    time.sleep(POLL)
                sample = time.monotonic() - sampled_at >= MEMORY_POLL
                if sample:
                    sampled_at = time.monotonic()
                    peak_total = max(peak_total, sum(
                        pss_mb(pid) for pid in [os.getpid(), *(j.process.pid for j in running)]))
                for job in list(running):
                    job.peak_sampled = max(job.peak_sampled, rss_mb(job.process.pid))
                    cpu = cpu_seconds_of(job.process.pid)
                    job.cpu_sampled = cpu if cpu == cpu else job.cpu_sampled
                    for step in _read_progress(job):
                        show.step(job.name, step)
                    over = _over(job, timeout)
                    if job.process.is_alive() and not over:
                        show.alive(job.name, heartbeat)
                        continue
                    timed_out = over if job.process.is_alive() else ""
                    if timed_out:
                        _kill_group(job.process)
                    job.process.join()
                    out = _finished(job, job.path, timed_out=timed_out, timeout=timeout)
                    running.remove(job)
                    done[job.name] = out
                    measured[f"{mode}/{job.name}"] = out.seconds
                    if out.peak_mb == out.peak_mb:
                        measured[f"{mode}/{job.name}/peak_mb"] = out.peak_mb
                    if cache_dir and job.key:  # failures and time-outs are cached too
                        cache.store(cache_dir, job.name, out, quick=quick, key=job.key)
                    show.finished(out, time.monotonic() - t0)
                    if on_done:
                        on_done(out)
        finally:
            for job in running:
                _kill_group(job.process)
            gc.unfreeze()  # this process's own objects are collected again
    try:
        _write_timings(cache_dir, measured)
    except ReportInputError as exc:  # only the next run's estimates: the results stand
        print(f"warning: the problems' timings were not saved: {exc}", file=stream)
    outcomes = [done[n] for n in names]
    stats = RunStats(
        seconds=time.monotonic() - t0, jobs=jobs,
        reused=sum(o.cached for o in outcomes), ran=sum(not o.cached for o in outcomes),
        peak_total_mb=peak_total,
        peak_problem=max(((o.peak_mb, o.name) for o in outcomes if not o.cached
                          and o.peak_mb == o.peak_mb), default=(float("nan"), "")),
        cpu_seconds=_children_cpu() - cpu0,
    )
    return outcomes, stats
