"""One problem in a process of its own: what the report's runner forks for each problem.

:func:`outcome_of` runs a problem and reduces it to an :class:`Outcome` (its document
section, figures as SVG text, captions, animations, summary numbers, cost): plain data,
picklable, what the cache stores. :func:`_child` is the body of the forked process the
runner (:mod:`~workbench.app.report.runner`) starts: its own process group, killed with
the report's process, its progress lines and cores passed through the environment, the
outcome written to a file the parent reads; anything it raises is reported as a failed
outcome, never lost.
"""

from __future__ import annotations

import os
import pickle
import resource
import signal
import time
import traceback
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

from workbench.app.report.collect import Status, run_problem
from workbench.app.report.document import ProblemSection, problem_section
from workbench.app.report.figures import report_style
from workbench.app.report.tables import telling_order
from workbench.study._result import CORES_ENV, PROGRESS_ENV

__all__ = ["Outcome", "outcome_of"]


@dataclass
class Outcome:
    """One problem as the report needs it: plain data, picklable, cached.

    Attributes
    ----------
    name, title : str
        The problem's name and one-line title.
    status : Status
    seconds : float
        Wall time of the problem's run (of the original run when re-used).
    peak_mb : float
        Peak resident memory of the process that ran it [MB] (nan if unknown).
    section : ProblemSection or None
        Its document section (None when it failed before producing a result).
    summary : dict
        ``comparisons`` and ``comparisons_ok`` (counts), ``functions_built``, ``models``
        (names), ``headline`` (every comparison as a plain row, most telling first:
        :func:`~workbench.app.report.tables.telling_order`), ``notes``.
    error, traceback : str
        Why it failed or timed out.
    cached : bool
        Whether this outcome was re-used from the cache in this report.
    ran_at : float
        When it ran (seconds since the epoch).
    cpu_seconds : float
        CPU time (user + system) of the process that ran it and of its own children [s]
        (sampled from ``/proc`` for a process that was killed or died; nan if unknown).
    solve_seconds : float
        Wall time of the problem's ``solve`` alone [s]; the rest of ``seconds`` is turning
        its result into the report's section (figures as SVG, tables, animations).
    limit : float
        The time limit in force when it ran [s] (a cached time-out is run again when the
        limit is raised above it).
    """

    name: str
    title: str
    status: Status
    seconds: float
    peak_mb: float = float("nan")
    section: ProblemSection | None = None
    summary: dict[str, Any] = field(default_factory=dict)
    error: str = ""
    traceback: str = ""
    cached: bool = False
    ran_at: float = 0.0
    cpu_seconds: float = float("nan")
    solve_seconds: float = float("nan")
    limit: float = float("nan")


def _summary(run: Any) -> dict[str, Any]:
    res = run.result
    if res is None:
        return {"comparisons": 0, "comparisons_ok": 0, "functions_built": 0, "models": []}
    comps = list(res.comparisons)
    return {
        "comparisons": len(comps),
        "comparisons_ok": sum(bool(c.ok) for c in comps),
        "functions_built": len(res.build_log),
        "models": list(dict.fromkeys(m.name for m in run.models)),
        "headline": [[c.quantity, c.reference, c.workbench, c.deviation, c.tolerance,
                      bool(c.ok), c.source, c.headline] for c in telling_order(comps)],
    }


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _own_cpu() -> float:
    """CPU time of this process and of its waited-for children [s]."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def outcome_of(name: str, *, quick: bool, catalogue: ModuleType) -> Outcome:
    """Run one problem in this process and reduce it to an :class:`Outcome`."""
    from workbench.app.report.animate import animations_of

    t0 = time.perf_counter()
    cpu0 = _own_cpu()
    with report_style():
        run = run_problem(name, quick=quick, catalogue=catalogue)
    out = Outcome(run.name, run.title, run.status, run.seconds, ran_at=time.time(),
                  error=run.error, traceback=run.traceback, summary=_summary(run),
                  solve_seconds=run.seconds)
    if run.result is not None:
        try:
            out.section = problem_section(run, quick=quick)
            out.section.animations = animations_of(run)
        except Exception as exc:  # noqa: BLE001 - a section that fails is shown as failed
            out.status, out.error = Status.FAILED, f"report section: {type(exc).__name__}: {exc}"
            out.traceback = traceback.format_exc()
    out.peak_mb = _peak_mb()
    out.seconds = time.perf_counter() - t0
    out.cpu_seconds = _own_cpu() - cpu0
    return out


def _die_with_parent() -> None:
    """Ask Linux to kill this process when the report's process ends, however it ends.

    The child has its own process group (so its time limit can kill everything it
    started), hence a terminal's Ctrl-C does not reach it; when the parent is killed
    without running its clean-up (SIGTERM, SIGKILL), ``PR_SET_PDEATHSIG`` still stops the
    child. Elsewhere this does nothing.
    """
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG = 1
    except (OSError, AttributeError):
        pass
    if os.getppid() == 1:  # the parent died before the request took effect
        os._exit(1)


def _child(name: str, quick: bool, catalogue: ModuleType, path: str, cores: int) -> None:
    """Body of a forked child: own process group, run, write the outcome, exit.

    The problem's progress lines (:func:`workbench.study.progress`) go to ``path``
    with the suffix ``.progress``, which the parent reads while it runs; its own pools
    may use ``cores`` cores (:func:`workbench.study.cores`).
    """
    os.setpgrp()
    _die_with_parent()
    os.environ[PROGRESS_ENV] = f"{path}.progress"
    os.environ[CORES_ENV] = str(cores)
    try:
        out = outcome_of(name, quick=quick, catalogue=catalogue)
    except BaseException as exc:  # noqa: BLE001 - anything is reported to the parent
        out = Outcome(name, name, Status.FAILED, 0.0, error=f"{type(exc).__name__}: {exc}",
                      traceback=traceback.format_exc(), peak_mb=_peak_mb(), ran_at=time.time(),
                      cpu_seconds=_own_cpu())
    tmp = f"{path}.partial"
    with open(tmp, "wb") as fh:
        pickle.dump(out, fh, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(tmp, path)
