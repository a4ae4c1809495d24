"""Build a report: run the problems, assemble the document, write HTML and/or PDF.

Output files are written completely or not at all (a temporary name, then a rename), and
the output directory is checked before any problem runs.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from types import ModuleType
from typing import TextIO

from workbench.app.report.collect import ProblemRun, Status, run_problems
from workbench.app.report.document import Document, document
from workbench.app.report.errors import ReportInputError

__all__ = ["Format", "Report", "DEFAULT_OUT", "build_report", "check_out_dir", "rebuild",
           "write_atomic"]

DEFAULT_OUT = Path(__file__).resolve().parents[3] / "reports" / "out"
"""Default output directory (``reports/out/`` of the repository; git-ignored)."""


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
    runs : list of ProblemRun
        The problems' runs (results, errors, timings).
    paths : dict of Format to Path
        The files written.
    seconds : dict of str to float
        Wall time of each stage: ``problems``, ``document``, ``html``, ``pdf``.
    """

    document: Document
    runs: list[ProblemRun]
    paths: dict[Format, Path] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def failed(self) -> list[str]:
        """Names of the problems that raised."""
        return [r.name for r in self.runs if r.status is Status.FAILED]

    @property
    def out_of_tolerance(self) -> list[str]:
        """Names of the problems with a comparison out of tolerance."""
        return [r.name for r in self.runs if r.status is Status.OUT_OF_TOLERANCE]

    @property
    def ok(self) -> bool:
        """Whether every problem ran and every comparison is within tolerance."""
        return all(r.status is Status.OK for r in self.runs)


def check_out_dir(out_dir: str | Path) -> Path:
    """Create ``out_dir`` if needed and check that files can be written in it.

    Raises
    ------
    ReportInputError
        If it is a file, cannot be created, or is not writable.
    """
    path = Path(out_dir)
    if path.exists() and not path.is_dir():
        raise ReportInputError(f"--out: {str(path)!r} exists and is not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ReportInputError(
            f"--out: cannot create directory {str(path)!r} ({exc.strerror})") from exc
    probe = path / f".write-probe-{os.getpid()}"
    try:
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise ReportInputError(
            f"--out: cannot write to directory {str(path)!r} ({exc.strerror})") from exc
    return path


def write_atomic(path: Path, data: bytes | str) -> Path:
    """Write a whole file under a temporary name, then rename it into place."""
    tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
    try:
        if isinstance(data, str):
            tmp.write_text(data, encoding="utf-8")
        else:
            tmp.write_bytes(data)
        tmp.replace(path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _catalogue() -> ModuleType:
    from workbench.app import registry as problems

    return problems


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
) -> Report:
    """Run problems and write their report.

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
        The problem catalogue (``names()``, ``load(name)``); default the ``problems``
        package.
    progress : bool
        Show per-problem progress on ``stream``.
    stream : file, optional
        Where progress goes (default ``sys.stderr``).

    Returns
    -------
    Report

    Raises
    ------
    ReportInputError
        For an unknown problem or an unusable output directory (before anything runs).
    """
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
    out = check_out_dir(out_dir)
    stem = stem or ("report-quick" if quick else "report")
    stream = stream or sys.stderr
    seconds: dict[str, float] = {}

    t0 = time.perf_counter()
    runs = run_problems(names, quick=quick, catalogue=catalogue, progress=progress,
                        stream=stream)
    seconds["problems"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    doc = document(runs, quick=quick, seconds=seconds["problems"])
    seconds["document"] = time.perf_counter() - t0
    report = Report(doc, runs, seconds=seconds)
    if Format.HTML in formats:
        from workbench.app.report.html import render_html

        t0 = time.perf_counter()
        report.paths[Format.HTML] = write_atomic(out / f"{stem}.html", render_html(doc))
        seconds["html"] = time.perf_counter() - t0
    if Format.PDF in formats:
        from workbench.app.report.pdf import render_pdf

        t0 = time.perf_counter()
        report.paths[Format.PDF] = write_atomic(out / f"{stem}.pdf", render_pdf(doc))
        seconds["pdf"] = time.perf_counter() - t0
    return report


def rebuild(doc: Document, *, formats: Sequence[Format], out_dir: str | Path,
            stem: str) -> dict[Format, Path]:
    """Write an already assembled document (no problem is run)."""
    out = check_out_dir(out_dir)
    paths: dict[Format, Path] = {}
    if Format.HTML in formats:
        from workbench.app.report.html import render_html

        paths[Format.HTML] = write_atomic(out / f"{stem}.html", render_html(doc))
    if Format.PDF in formats:
        from workbench.app.report.pdf import render_pdf

        paths[Format.PDF] = write_atomic(out / f"{stem}.pdf", render_pdf(doc))
    return paths
