"""The whole document: the first page in plain words, then one section per problem.

:func:`document` assembles a :class:`Document` from the problems' outcomes (run now or
re-used from the cache): a figure for the first page (:func:`cover_figure`), the status
of every problem, the most telling comparison of each
(:func:`~workbench.app.report.tables.telling_key`), the errata of the papers the
workbench confirms and what it found beyond them (each shown as confirmed only when the
problem that checks it met all its comparisons in this report), the problems'
plain-language summaries and the figures' captions (:mod:`~workbench.app.report.texts`,
or a problem's own ``SUMMARY``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

from workbench.app.report.collect import Status
from workbench.app.report.document import ProblemSection
from workbench.app.report.environment import environment
from workbench.app.report.figures import FigureData
from workbench.app.report.tables import Table, fmt, telling_key
from workbench.app.report.texts import CAPTIONS, COVER, ERRATA, FINDINGS, INTRO, SUMMARIES

__all__ = ["Claim", "Cover", "Document", "document", "summary_of", "cover_figure"]


@dataclass
class Claim:
    """An erratum or a finding, and whether this report confirms it.

    Attributes
    ----------
    text : str
        The claim, in words.
    paper : str
        The paper it is about ("" for a finding).
    problem : str
        The problem whose run checks it.
    confirmed : bool
        Whether that problem ran and met all its comparisons in this report.
    status : str
        That problem's status ("not in this report" when it was not run).
    """

    text: str
    paper: str
    problem: str
    confirmed: bool
    status: str


@dataclass
class Cover:
    """The figure of the first page: one of a problem's figures.

    Attributes
    ----------
    problem : str
        The problem it comes from.
    figure : FigureData
        The figure (its caption is the problem's).
    """

    problem: str
    figure: FigureData


def cover_figure(sections: list[ProblemSection]) -> Cover | None:
    """The first page's figure.

    The first of :data:`~workbench.app.report.texts.COVER` whose problem is in the report
    and ok, else the first figure of the first problem that is ok and has one, else of any
    problem; None when no problem has a figure.
    """
    figs = {(s.name, f.name): (s, f) for s in sections for f in s.figures}
    for key in COVER:
        if key in figs and figs[key][0].status is Status.OK:
            return Cover(key[0], figs[key][1])
    for want_ok in (True, False):
        for s in sections:
            if s.figures and (s.status is Status.OK or not want_ok):
                return Cover(s.name, s.figures[0])
    return None


@dataclass
class Document:
    """The whole report.

    ``cover`` is the first page's figure; ``tables_dir`` the folder of the CSV files,
    relative to the HTML file ("" when none was written).
    """

    title: str
    quick: bool
    problems: list[ProblemSection]
    summary: Table
    environment: list[tuple[str, str]]
    seconds: float
    intro: str = ""
    headlines: Table | None = None
    errata: list[Claim] = field(default_factory=list)
    findings: list[Claim] = field(default_factory=list)
    run_note: str = ""
    cover: Cover | None = None
    tables_dir: str = ""

    @property
    def created(self) -> str:
        """The date line of the environment."""
        return dict(self.environment).get("date", "")

    @property
    def counts(self) -> dict[str, int]:
        """Problems by status value."""
        out: dict[str, int] = {}
        for p in self.problems:
            out[p.status.value] = out.get(p.status.value, 0) + 1
        return out


def _first_paragraph(doc: str | None) -> str:
    if not doc:
        return ""
    para = doc.strip().split("\n\n")[0]
    return " ".join(para.split())


def summary_of(name: str, module: ModuleType | None) -> str:
    """A problem's plain-language paragraph: its ``SUMMARY``, the report's, or its docstring."""
    own = getattr(module, "SUMMARY", None) if module is not None else None
    if isinstance(own, str) and own.strip():
        return " ".join(own.split())
    if name in SUMMARIES:
        return SUMMARIES[name]
    return _first_paragraph(getattr(module, "__doc__", None))


def _section(out: Any, quick: bool, module: ModuleType | None) -> ProblemSection:
    sec = out.section or ProblemSection(out.name, out.title, out.status, out.seconds, quick)
    sec.status, sec.seconds = out.status, out.seconds
    sec.error, sec.traceback = out.error, out.traceback
    if out.cached and out.status in (Status.FAILED, Status.TIMED_OUT):
        when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(out.ran_at)) if out.ran_at else "?"
        sec.error += (f" [re-used from the cache: this failure is that of the run of {when}, "
                      f"and nothing it depends on changed since; 'workbench report --rerun "
                      f"{out.name}' runs it again]")
    sec.cached, sec.peak_mb = out.cached, out.peak_mb
    sec.summary = summary_of(out.name, module)
    for fig in sec.figures:  # the problem's own caption first, then the report's words
        if not getattr(fig, "own", False):
            fig.caption = CAPTIONS.get((out.name, fig.name), fig.caption)
    return sec


def _claims(items: list[tuple[str, ...]], status: dict[str, Status]) -> list[Claim]:
    out = []
    for item in items:
        paper, text, problem = (item if len(item) == 3 else ("", *item))
        st = status.get(problem)
        out.append(Claim(text, paper, problem, st is Status.OK,
                         st.value if st is not None else "not in this report"))
    return out


def _telling(row: list[Any]) -> tuple[int, float]:
    """:func:`telling_key` of a summary row.

    The row is ``[quantity, reference, workbench, deviation, tolerance, ok, source,
    headline]`` (rows cached before the headline flag have no 8th item).
    """
    _q, ref, _got, dev, tol, ok, src, *flag = row
    return telling_key(ok=bool(ok), reference=ref, deviation=dev, tolerance=tol, source=src,
                       headline=bool(flag and flag[0]))


def _headlines(outcomes: list[Any]) -> Table | None:
    rows, status = [], []
    for o in outcomes:
        head = o.summary.get("headline") or []
        if not head:
            continue
        q, ref, got, dev, tol, ok, src, *_ = min(head, key=_telling)  # first of the best
        rows.append([o.name, q, src, fmt(ref, digits=8), fmt(got, digits=8),
                     f"{dev:.1e}", f"{tol:.0e}", "ok" if ok else "OUT"])
        status.append("ok" if ok else "bad")
    if not rows:
        return None
    return Table("Headline numbers", ["problem", "quantity", "source", "reference",
                                      "workbench", "deviation", "tolerance", ""], rows,
                 note="The most telling comparison of each problem: one out of tolerance if "
                      "there is one, else the one the problem names its headline, else the "
                      "value printed in a paper (else a closed form's) that comes closest "
                      "to its tolerance. Every comparison, with its source, is in the HTML "
                      "report's appendix and in the CSV files beside it.",
                 status=status,
                 numeric=[False, False, False, True, True, True, True, False])


def document(outcomes: list[Any], *, quick: bool, seconds: float,
             modules: dict[str, ModuleType] | None = None, run_note: str = "",
             title: str = "Geometric pendulum workbench: report") -> Document:
    """The report of a list of outcomes.

    Parameters
    ----------
    outcomes : list of Outcome
        From :func:`workbench.app.report.runner.run_all`, in report order.
    quick : bool
        Whether the problems ran in quick mode.
    seconds : float
        Wall time of running (or re-using) all the problems.
    modules : dict of str to module, optional
        The problem modules (for their ``SUMMARY`` or docstring).
    run_note : str
        One line on what running the problems cost.
    title : str

    Returns
    -------
    Document
    """
    modules = modules or {}
    sections = [_section(o, quick, modules.get(o.name)) for o in outcomes]
    rows, status = [], []
    for s, o in zip(sections, outcomes):
        n, n_ok = o.summary.get("comparisons", 0), o.summary.get("comparisons_ok", 0)
        where = "cache" if o.cached else "run"
        mem = "" if math.isnan(o.peak_mb) else f"{o.peak_mb:.0f}"
        rows.append([s.name, s.title, s.status.value, f"{n_ok}/{n}", f"{s.seconds:.1f}",
                     mem, where])
        status.append("ok" if s.status is Status.OK else "bad")
    n_ok = sum(st == "ok" for st in status)
    summary = Table(
        "Problems", ["problem", "what it reproduces", "status", "comparisons ok",
                     "wall [s]", "peak MB", "from"], rows,
        note=f"{n_ok} of {len(rows)} problems ok; problems in {'quick' if quick else 'full'} "
             f"mode, {seconds:.1f} s for this report. Wall time and peak memory are those "
             f"of the run that produced the result ('cache': re-used, nothing changed).",
        status=status, numeric=[False, False, False, True, True, True, False],
    )
    by_name = {o.name: o.status for o in outcomes}
    return Document(title, quick, sections, summary, environment(), seconds, intro=INTRO,
                    headlines=_headlines(outcomes), errata=_claims(ERRATA, by_name),
                    findings=_claims(FINDINGS, by_name), run_note=run_note,
                    cover=cover_figure(sections))
