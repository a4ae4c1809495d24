"""Progress lines of a report run, and its measured cost (wall time, peak memory)."""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from typing import Any, TextIO

from workbench.core._proc import proc_status_mb

__all__ = ["Progress", "RunStats", "LoadShare", "load_share", "rss_mb", "pss_mb",
           "cpu_seconds_of", "process_age", "clock"]

_TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def rss_mb(pid: int) -> float:
    """Resident memory of a process [MB] from ``/proc`` (0 when it cannot be read)."""
    try:
        return proc_status_mb("VmRSS", pid)
    except OSError:
        return 0.0


def pss_mb(pid: int) -> float:
    """Proportional set size of a process [MB] from ``/proc`` (its share of shared pages).

    Unlike the resident size, the proportional sizes of processes that share pages (a
    parent and its forked children) add up to the memory they use together. Falls back to
    :func:`rss_mb` where ``smaps_rollup`` cannot be read.
    """
    try:
        with open(f"/proc/{pid}/smaps_rollup") as fh:
            for line in fh:
                if line.startswith("Pss:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError, IndexError):
        pass
    return rss_mb(pid)


def cpu_seconds_of(pid: int) -> float:
    """CPU time (user + system) a live process and its ended children have used [s].

    Children count once they have ended and been waited for (a compiler run by the
    problem, say); nan if ``/proc`` cannot be read.
    """
    try:
        with open(f"/proc/{pid}/stat") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()
        return sum(int(f) for f in fields[11:15]) / _TICK
    except (OSError, ValueError, IndexError):
        return float("nan")


def process_age() -> float:
    """Seconds since this process started (nan where ``/proc`` cannot be read).

    Interpreter start-up and imports included: what a user waits for.
    """
    try:
        with open("/proc/self/stat") as fh:
            start = int(fh.read().rsplit(")", 1)[1].split()[19]) / _TICK
        with open("/proc/uptime") as fh:
            return float(fh.read().split()[0]) - start
    except (OSError, ValueError, IndexError):
        return float("nan")


def clock(seconds: float) -> str:
    """``m:ss`` (or ``h:mm:ss``)."""
    s = int(round(max(seconds, 0.0)))
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


@dataclass(frozen=True)
class LoadShare:
    """The share of a core each of the report's processes can expect on a loaded machine.

    Attributes
    ----------
    load : float
        The load average over the last minute before the report started its problems
        (processes running or waiting for a core; nan when unknown).
    cores : int
        The machine's cores.
    processes : int
        The report's problems run at the same time.
    share : float
        ``min(1, cores / (load + processes))``: with ``load`` other processes wanting a
        core and the scheduler sharing the cores evenly, each of the report's processes
        gets this fraction of a core (1 on an idle machine with a core for each); a
        problem then takes its idle time divided by it.
    """

    load: float
    cores: int
    processes: int
    share: float

    def words(self) -> str:
        """How the estimate was scaled, for the printed line."""
        if math.isnan(self.load):
            return "load average unknown: estimate for an idle machine"
        whom = ("the report's process" if self.processes == 1 else
                f"each of the report's {self.processes} processes")
        return (f"load average {self.load:.2f} on {self.cores} cores: about "
                f"{self.share:.0%} of a core for {whom}")


def load_share(processes: int, *, load: float | None = None,
               cores: int | None = None) -> LoadShare:
    """The share of a core each of ``processes`` processes gets, from the machine's load.

    Parameters
    ----------
    processes : int
        Processes the report runs at the same time (at least 1).
    load : float, optional
        Processes already wanting a core (default: the one-minute load average,
        ``os.getloadavg()[0]``, read before the report starts its problems).
    cores : int, optional
        Cores of the machine (default ``os.cpu_count()``).

    Returns
    -------
    LoadShare
        ``share = min(1, cores / (load + processes))``; 1 when the load is unknown.
    """
    if load is None:
        try:
            load = os.getloadavg()[0]
        except (OSError, AttributeError):
            load = math.nan
    cores = max(1, int(cores if cores is not None else (os.cpu_count() or 1)))
    processes = max(1, int(processes))
    load = float(load)
    if math.isnan(load):
        return LoadShare(load, cores, processes, 1.0)
    share = min(1.0, cores / (max(load, 0.0) + processes))
    return LoadShare(load, cores, processes, share)


@dataclass
class RunStats:
    """What running the problems cost.

    Attributes
    ----------
    seconds : float
        Wall time of running (or re-using) every problem.
    jobs : int
        Problems run at the same time.
    reused, ran : int
        Problems taken from the cache, and run.
    peak_total_mb : float
        Largest sum of the proportional set sizes of the report's processes (the parent
        and its running children; pages shared after the fork are split between the
        processes sharing them, so the sum is the memory they use together), sampled
        every 2 s [MB] (:data:`~workbench.app.report.runner.MEMORY_POLL`).
    peak_problem : tuple of (float, str)
        Largest peak resident memory of one problem's process [MB] (``getrusage`` of the
        child), and the problem.
    cpu_seconds : float
        CPU time (user + system) of the problems' processes.
    """

    seconds: float
    jobs: int
    reused: int
    ran: int
    peak_total_mb: float
    peak_problem: tuple[float, str]
    cpu_seconds: float = 0.0

    def line(self) -> str:
        """One line for the terminal."""
        mb, who = self.peak_problem
        largest = f", largest {mb:.0f} MB ({who})" if who and not math.isnan(mb) else ""
        return (f"problems: {self.ran} run, {self.reused} re-used from the cache, "
                f"{self.seconds:.1f} s wall on {self.jobs} processes, {self.cpu_seconds:.1f} s "
                f"CPU{largest}")


class Progress:
    """Problem-by-problem progress with elapsed time and an estimate of what remains.

    The estimate uses each problem's duration in the last run (kept by the runner), or,
    for a problem never timed, the mean duration of the problems finished so far; it is
    the remaining work divided by the number of processes. The durations of the last runs
    are divided by the share of a core each process can expect on this machine now
    (:func:`load_share`, from the load average before the problems start; ``load`` and
    ``cores`` replace the machine's values); the durations measured in this run already
    include the load and are not scaled.
    """

    def __init__(self, total: int, *, stream: TextIO, enabled: bool, jobs: int,
                 load: float | None = None, cores: int | None = None) -> None:
        self.total, self.stream, self.enabled, self.jobs = total, stream, enabled, jobs
        self._load, self._cores = load, cores
        self.load = LoadShare(math.nan, cores or 1, jobs, 1.0)
        self.count = 0
        self.pending: dict[str, float | None] = {}  # expected now: scaled by the load
        self.last: dict[str, float | None] = {}  # the durations of the last runs
        self.running: dict[str, tuple[float, float | None]] = {}
        self.durations: list[float] = []
        self.last_beat: dict[str, float] = {}
        self.steps: dict[str, dict[str, Any]] = {}

    def _print(self, text: str) -> None:
        if self.enabled:
            print(text, file=self.stream, flush=True)

    def plan(self, estimates: dict[str, float | None]) -> None:
        """Announce what will run, with the durations of the last runs where known.

        The durations are scaled by the machine's load (:func:`load_share`) and the line
        says so.
        """
        self.load = load_share(min(self.jobs, max(1, len(estimates))), load=self._load,
                               cores=self._cores)
        share = self.load.share
        self.pending = {k: (None if e is None else e / share) for k, e in estimates.items()}
        self.last = dict(estimates)
        if not estimates:
            return
        known = [e for e in estimates.values() if e is not None]
        guess = ""
        if known:
            # the work spread over the processes, but never less than the longest problem
            idle = max(max(known), sum(known) / self.load.processes)
            guess = f", about {clock(idle / share)} by the last runs"
            guess += (f" ({clock(idle)} on an idle machine; {self.load.words()})"
                      if share < 1 else f" ({self.load.words()})")
        unknown = len(estimates) - len(known)
        more = f" ({unknown} never timed)" if unknown and known else ""
        self._print(f"running {len(estimates)} problem(s) on {self.jobs} processes"
                    f"{guess}{more}")

    def started(self, name: str) -> None:
        """A problem was started."""
        now = time.monotonic()
        self.running[name] = (now, self.pending.pop(name, None))
        self.last_beat[name] = now

    def _inside(self, name: str, now: float) -> tuple[str, float | None]:
        """The problem's last progress message, and its own estimate of the time it has left."""
        step = self.steps.get(name)
        if step is None:
            return "", None
        t0, _ = self.running[name]
        done, total = step.get("done"), step.get("total")
        text = f": {step.get('message', '')}"
        left = None
        if isinstance(done, (int, float)) and isinstance(total, (int, float)) and total > 0:
            text += f" ({done:g}/{total:g})"
            if done > 0:
                left = (step["at"] - t0) * (total - done) / done - (now - step["at"])
                left = max(left, 0.0)
        return text, left

    def step(self, name: str, step: dict[str, Any], *, every: float = 5.0) -> None:
        """A running problem reported progress (printed at most every ``every`` seconds)."""
        if name not in self.running:
            return
        now = time.monotonic()
        first = name not in self.steps
        self.steps[name] = {**step, "at": now}
        if first or now - self.last_beat.get(name, -math.inf) >= every:
            self._beat(name, now)

    def _beat(self, name: str, now: float) -> None:
        self.last_beat[name] = now
        t0, _ = self.running[name]
        exp = self.last.get(name)
        text, left = self._inside(name, now)
        of = f", took {clock(exp)} last time" if exp else ""
        eta = f", about {clock(left)} left in it" if left is not None else ""
        self._print(f"        ... {name} after {clock(now - t0)}{text}{eta}{of}")

    def alive(self, name: str, every: float) -> None:
        """A problem is still running: say so every ``every`` seconds."""
        now = time.monotonic()
        if name in self.running and now - self.last_beat.get(name, now) >= every:
            self._beat(name, now)

    def remaining(self) -> float | None:
        """Estimated seconds of wall time left, or None before anything can be estimated."""
        typical = sum(self.durations) / len(self.durations) if self.durations else None
        now, work = time.monotonic(), 0.0
        for est in self.pending.values():
            if est is None and typical is None:
                return None
            work += est if est is not None else typical  # type: ignore[operator]
        for name, (t0, est) in self.running.items():
            _, own = self._inside(name, now)
            ref = est if est is not None else typical
            if own is not None:  # the problem's own estimate first
                work += own
            elif ref is None:
                return None
            else:
                work += max(ref - (now - t0), 0.0)
        return work / self.jobs

    def finished(self, out: Any, elapsed: float) -> None:
        """A problem is done (or re-used)."""
        self.count += 1
        self.running.pop(out.name, None)
        self.last_beat.pop(out.name, None)
        self.steps.pop(out.name, None)
        if not out.cached:
            self.durations.append(out.seconds)
        how = "re-used" if out.cached else f"{out.seconds:6.1f} s"
        cpu = getattr(out, "cpu_seconds", math.nan)
        if not out.cached and not math.isnan(cpu):
            how += f" ({cpu:.1f} s CPU)"
        mem = "" if out.cached or math.isnan(out.peak_mb) else f", peak {out.peak_mb:.0f} MB"
        left = self.remaining()
        eta = "" if left is None or self.count == self.total else f", about {clock(left)} left"
        why = f" -- {out.error}" if out.error else ""
        if out.cached and out.error:
            why += f" (re-used; 'workbench report --rerun {out.name}' runs it again)"
        count = f"[{self.count}/{self.total}]"
        self._print(f"{count:>7} {out.name:<36} {out.status.value:<16} "
                    f"{how}{mem} | elapsed {clock(elapsed)}{eta}{why}")
