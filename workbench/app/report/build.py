"""Build a report: run (or re-use) the problems, assemble the document, write HTML and PDF.

Problems run in parallel processes and are re-used from the on-disk cache when nothing
they depend on changed (:mod:`~workbench.app.report.runner`). Output files are written
completely or not at all (a unique temporary name in the target folder, then a rename),
and the output directory is checked before any problem runs. Beside the HTML and the PDF,
every table goes to a CSV file in ``<stem>-tables/`` (:mod:`~workbench.app.report.csvfiles`),
which the HTML links to. The run ends by printing its total wall time and peak memory.
"""

from __future__ import annotations

import os
import resource
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from types import ModuleType
from typing import TextIO

from workbench.app.report import cache as report_cache
from workbench.app.report.collect import Status
from workbench.app.report.csvfiles import check_tables_dir, tables_dir, write_tables
from workbench.app.report.errors import ReportInputError
from workbench.app.report.frontpage import Document, document
from workbench.app.report.progress import RunStats, process_age
from workbench.app.report.runner import Outcome, run_all
from workbench.core import files
from workbench.core.validate import output_path

__all__ = ["Format", "Report", "DEFAULT_OUT", "DEFAULT_CACHE", "build_report", "check_out_dir",
           "rebuild", "write_atomic"]

DEFAULT_OUT = Path(__file__).resolve().parents[3] / "reports" / "out"
"""Default output directory (``reports/out/`` of the repository; git-ignored)."""

DEFAULT_CACHE = DEFAULT_OUT / "cache"
"""Default cache of the problems' outcomes (``reports/out/cache/``; git-ignored)."""


class Format(str, Enum):
    """Output formats of a report."""

    HTML = "html"
    PDF = "pdf"


@dataclass
class Report:
    """A built report.

    Attributes
    ----------
    document : Document
        What was typeset.
    runs : list of Outcome
        The problems' outcomes (status, errors, timings, memory; run or re-used).
    paths : dict of Format to Path
        The files written (HTML, PDF).
    tables : list of Path
        The CSV files written (every table of every problem).
    seconds : dict of str to float
        Wall time of each stage: ``problems``, ``document``, ``html``, ``pdf``, ``total``.
    stats : RunStats or None
        What running the problems cost (processes, re-used, peak memory).
    """

    document: Document
    runs: list[Outcome]
    paths: dict[Format, Path] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    stats: RunStats | None = None
    tables: list[Path] = field(default_factory=list)

    @property
    def failed(self) -> list[str]:
        """Names of the problems that raised, died or timed out."""
        return [r.name for r in self.runs if r.status in (Status.FAILED, Status.TIMED_OUT)]

    @property
    def out_of_tolerance(self) -> list[str]:
        """Names of the problems with a comparison out of tolerance."""
        return [r.name for r in self.runs if r.status is Status.OUT_OF_TOLERANCE]

    @property
    def ok(self) -> bool:
        """Whether every problem ran and every comparison is within tolerance."""
        return all(r.status is Status.OK for r in self.runs)

    def summary_line(self) -> str:
        """Total wall time and peak memory of the whole report, in one line."""
        own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        peak = max(own, self.stats.peak_total_mb if self.stats else 0.0)
        total = self.seconds.get("total", 0.0)
        stages = ", ".join(f"{k} {v:.1f} s" for k, v in self.seconds.items() if k != "total")
        age = process_age()
        since = f", {age:.1f} s since the command started" if age == age else ""
        return (f"report: {len(self.runs)} problems in {total:.1f} s ({stages}{since}); peak "
                f"memory "
                f"{peak:.0f} MB (the report's processes together, sampled), of which the "
                f"report's own process {own:.0f} MB (its peak, rendering included)"
                + (f"; {self.stats.line()}" if self.stats else ""))

    def __str__(self) -> str:
        counts: dict[str, int] = {}
        for r in self.runs:
            counts[r.status.value] = counts.get(r.status.value, 0) + 1
        files = ", ".join(str(p) for p in self.paths.values()) or "nothing written"
        return (f"Report of {len(self.runs)} problems ("
                + ", ".join(f"{n} {k}" for k, n in counts.items()) + f"): {files}")


def _not_a_file(option: str, out_dir: str | Path) -> Path:
    path = output_path(option, out_dir, error=ReportInputError)
    if path.exists() and not path.is_dir():
        raise ReportInputError(f"{option}: {str(path)!r} exists and is not a directory")
    return path


def check_out_dir(out_dir: str | Path, *, option: str = "--out") -> Path:
    """Create ``out_dir`` if needed and check that files can be written in it.

    Parameters
    ----------
    out_dir : path-like
        The directory.
    option : str
        The option that named it, for the messages (``--out``, ``--cache``).

    Raises
    ------
    ReportInputError
        If it is a file, cannot be created, or is not writable.
    """
    path = _not_a_file(option, out_dir)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ReportInputError(
            f"{option}: cannot create directory {str(path)!r} ({exc.strerror})") from exc
    try:
        fd, probe = tempfile.mkstemp(prefix=".write-probe-", dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ReportInputError(
            f"{option}: cannot write to directory {str(path)!r} ({exc.strerror})") from exc
    return path


def write_atomic(path: Path, data: bytes | str) -> Path:
    """Write a whole file under a unique temporary name beside it, then rename it into place.

    The engine's one writer, :func:`workbench.core.files.write_atomic` (umask respected;
    nothing left behind on failure or interrupt; OutputError with one line on a full disk).
    """
    return files.write_atomic(path, data, name="--out")


def _catalogue() -> ModuleType:
    from workbench.app import registry

    return registry


def _check_outputs(out: Path, stem: str, formats: Sequence[Format]) -> None:
    """Refuse, before anything runs or is written, an HTML or PDF file that cannot be replaced."""
    for fmt, suffix in ((Format.HTML, "html"), (Format.PDF, "pdf")):
        if fmt in formats:
            files.writable_file(out / f"{stem}.{suffix}", name="--out")


def _write(doc: Document, out: Path, stem: str, formats: Sequence[Format],
           seconds: dict[str, float]) -> tuple[dict[Format, Path], list[Path]]:
    """Write the CSV tables (first: the HTML links to them), then the HTML and the PDF."""
    paths: dict[Format, Path] = {}
    t0 = time.perf_counter()
    folder = tables_dir(out, stem)
    tables = write_tables(doc.problems, folder)
    doc.tables_dir = folder.name
    seconds["tables"] = time.perf_counter() - t0
    if Format.HTML in formats:
        from workbench.app.report.html import render_html

        t0 = time.perf_counter()
        paths[Format.HTML] = write_atomic(out / f"{stem}.html", render_html(doc))
        seconds["html"] = time.perf_counter() - t0
    if Format.PDF in formats:
        from workbench.app.report.pdf import render_pdf

        t0 = time.perf_counter()
        paths[Format.PDF] = write_atomic(out / f"{stem}.pdf", render_pdf(doc))
        seconds["pdf"] = time.perf_counter() - t0
    return paths, tables


def build_report(
    names: Sequence[str] | None = None,
    *,
    quick: bool = False,
    formats: Sequence[Format] = (Format.HTML, Format.PDF),
    out_dir: str | Path = DEFAULT_OUT,
    stem: str | None = None,
    catalogue: ModuleType | None = None,
    progress: bool = True,
    stream: TextIO | None = None,
    jobs: int | None = None,
    timeout: float | None = None,
    cache_dir: str | Path | None = DEFAULT_CACHE,
    rerun: Sequence[str] | str | None = None,
    memory_mb: float | None = None,
) -> Report:
    """Run (or re-use) problems and write their report.

    Parameters
    ----------
    names : sequence of str, optional
        Problems to include (default: every problem in the catalogue, in its order).
    quick : bool
        Run the problems in quick mode.
    formats : sequence of Format
        What to write.
    out_dir : path
        Output directory (created if needed).
    stem : str, optional
        File name without suffix (default ``"report"``, or ``"report-quick"``).
    catalogue : module, optional
        The problem catalogue (``names()``, ``load(name)``); default the problem registry.
    progress : bool
        Print per-problem progress and the final cost on ``stream``.
    stream : file, optional
        Where progress goes (default ``sys.stderr``).
    jobs : int, optional
        Problems run at the same time (default: the number of cores).
    timeout : float, optional
        Time limit of one problem [s of CPU time] (default 600 quick, 1200 full; a problem
        is also stopped after three times as long in wall time).
    cache_dir : path or None
        Cache of the problems' outcomes; None runs every problem and caches nothing.
        Failures and time-outs are cached too (and shown as such when re-used).
    rerun : str or sequence of str, optional
        Problems to run even if their outcome is cached: names, ``"failed"`` (every
        cached failure or time-out) or ``"all"``.
    memory_mb : float, optional
        Budget of the peak memories (of their last runs) of the problems run at the same
        time [MB] (default 1300); a problem that alone needs more runs by itself.

    Returns
    -------
    Report

    Raises
    ------
    ReportInputError
        For an unknown problem, a bad knob or an unusable output directory (before
        anything runs).
    """
    t_start = time.perf_counter()
    catalogue = catalogue or _catalogue()
    known = list(catalogue.names())
    names = list(known if not names else names)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ReportInputError(
            f"unknown problem(s) {', '.join(map(repr, unknown))}; run 'workbench list' "
            f"(known: {', '.join(known)})")
    try:
        formats = [Format(f) for f in formats]
    except ValueError as exc:
        raise ReportInputError(f"formats must be among {[f.value for f in Format]}; got "
                               f"{list(formats)!r}") from exc
    if not formats:
        raise ReportInputError("no output format chosen (HTML, PDF or both)")
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
        raise ReportInputError(f"--jobs must be a whole number >= 1; got {jobs!r}")
    if timeout is not None and not (isinstance(timeout, (int, float)) and timeout > 0
                                    and timeout < float("inf")):
        raise ReportInputError(f"--timeout must be a positive number of seconds; got "
                               f"{timeout!r}")
    if memory_mb is not None and not (isinstance(memory_mb, (int, float))
                                      and not isinstance(memory_mb, bool)
                                      and 0 < memory_mb < float("inf")):
        raise ReportInputError(f"--memory must be a positive number of MB; got {memory_mb!r}")
    stem = stem or ("report-quick" if quick else "report")
    check_tables_dir(tables_dir(_not_a_file("--out", out_dir), stem))  # before any is created
    if cache_dir is not None:
        report_cache.check_foreign(_not_a_file("--cache", cache_dir), default=DEFAULT_CACHE)
    out = check_out_dir(out_dir)
    _check_outputs(out, stem, formats)  # a read-only report.html stops it before any run
    cache = None
    if cache_dir is not None:
        cache = check_out_dir(cache_dir, option="--cache")
        report_cache.claim(cache)
    stream = stream or sys.stderr
    seconds: dict[str, float] = {}

    t0 = time.perf_counter()
    outcomes, stats = run_all(names, quick=quick, catalogue=catalogue, jobs=jobs,
                              timeout=timeout, cache_dir=cache, stream=stream,
                              progress=progress, rerun=rerun, memory_mb=memory_mb)
    seconds["problems"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    modules = {n: catalogue.load(n) for n in names}
    doc = document(outcomes, quick=quick, seconds=seconds["problems"], modules=modules,
                   run_note=stats.line())
    seconds["document"] = time.perf_counter() - t0
    report = Report(doc, outcomes, seconds=seconds, stats=stats)
    report.paths, report.tables = _write(doc, out, stem, formats, seconds)
    seconds["total"] = time.perf_counter() - t_start
    if progress:
        print(report.summary_line(), file=stream, flush=True)
    return report


def rebuild(doc: Document, *, formats: Sequence[Format], out_dir: str | Path,
            stem: str) -> dict[Format, Path]:
    """Write an already assembled document (no problem is run), and its CSV tables."""
    out = check_out_dir(out_dir)
    check_tables_dir(tables_dir(out, stem))
    _check_outputs(out, stem, [Format(f) for f in formats])
    return _write(doc, out, stem, [Format(f) for f in formats], {})[0]
