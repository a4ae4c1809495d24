"""The PDF report, typeset by Typst (through its Python package).

The PDF is what people print: the first page (with a figure, :attr:`Document.cover`), then
for each problem what it reproduces, its headline comparisons, all its figures and its
notes. The full tables (every comparison with its source, the values, cost and accuracy,
the models with their equations, what was built) are in the HTML report, folded, and in
the CSV files beside it; the PDF says where.

The document is written as JSON next to a copy of ``reports/templates/report.typ`` in a
temporary directory, with each figure as an SVG file; Typst reads the JSON and lays it
out (strings from the JSON are text to Typst, never markup). The PDF holds no formulas:
the models' equations and vector fields are in the HTML report.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path
from typing import Any

import typst

from workbench.app.report.document import ProblemSection
from workbench.app.report.errors import ReportError
from workbench.app.report.figures import PRINT_WIDTH
from workbench.app.report.frontpage import Cover, Document
from workbench.app.report.html import TEMPLATES
from workbench.app.report.tables import Table

__all__ = ["render_pdf", "typst_data", "COVER_HEIGHT"]

COVER_HEIGHT = 3.0
"""Largest height of the first page's figure [in] (the page keeps room for the text)."""

def _table(t: Table | None) -> dict[str, Any] | None:
    return None if t is None else t.as_dict()


def _figure(p: ProblemSection, f: Any, figures: dict[tuple[str, str], str]) -> dict[str, Any]:
    return {"name": f.name, "caption": f.caption, "file": figures[(p.name, f.name)],
            "width": round(min(float(f.width), PRINT_WIDTH), 3)}


def _cover(c: Cover | None, figures: dict[tuple[str, str], str]) -> dict[str, Any] | None:
    if c is None or (c.problem, c.figure.name) not in figures:
        return None
    f = c.figure
    width = min(float(f.width), PRINT_WIDTH, COVER_HEIGHT * float(f.width) / float(f.height))
    return {"problem": c.problem, "caption": f.caption, "width": round(width, 3),
            "file": figures[(c.problem, f.name)]}


def _problem(p: ProblemSection, figures: dict[tuple[str, str], str]) -> dict[str, Any]:
    n_comp = len(p.comparison.rows) if p.comparison is not None else 0
    tables = [t for t in (p.comparison, *p.values, p.cost, p.built) if t is not None]
    n_tables = len(tables)
    folder = next((t.csv.rsplit("/", 1)[0] for t in tables if t.csv), "")
    return {
        "name": p.name, "title": p.title, "status": p.status.value, "seconds": p.seconds,
        "quick": p.quick, "error": p.error,
        "summary": p.summary, "cached": p.cached, "headline": _table(p.headline),
        "figures": [_figure(p, f, figures) for f in p.figures],
        "animations": len(p.animations), "notes": list(p.notes),
        "models": [{"heading": m.heading, "manifold": m.manifold} for m in p.models],
        "comparisons": n_comp, "tables": n_tables, "folder": folder,
    }


def _claim(c: Any) -> dict[str, Any]:
    return {"text": c.text, "paper": c.paper, "problem": c.problem,
            "confirmed": c.confirmed, "status": c.status}


def typst_data(doc: Document, figures: dict[tuple[str, str], str]) -> dict[str, Any]:
    """The JSON document the Typst template reads.

    Parameters
    ----------
    doc : Document
    figures : dict
        File name of each figure, by ``(problem, figure name)``.

    Returns
    -------
    dict
    """
    return {
        "title": doc.title, "quick": doc.quick, "created": doc.created,
        "seconds": doc.seconds, "summary": doc.summary.as_dict(),
        "intro": doc.intro, "run_note": doc.run_note, "counts": doc.counts,
        "headlines": _table(doc.headlines), "cover": _cover(doc.cover, figures),
        "errata": [_claim(c) for c in doc.errata],
        "findings": [_claim(c) for c in doc.findings],
        "environment": [list(r) for r in doc.environment],
        "problems": [_problem(p, figures) for p in doc.problems],
        "tables_dir": doc.tables_dir,
    }


def _compile(workdir: Path, data: dict[str, Any]) -> bytes:
    (workdir / "report.json").write_text(json.dumps(data, allow_nan=False))
    return typst.compile(str(workdir / "report.typ"), root=str(workdir),
                         sys_inputs={"data": "report.json"})


def render_pdf(doc: Document) -> bytes:
    """Typeset the report as PDF.

    Parameters
    ----------
    doc : Document

    Returns
    -------
    bytes
        The PDF.

    Raises
    ------
    ReportError
        If the template is missing or Typst fails even with formulas as source.
    """
    template = TEMPLATES / "report.typ"
    if not template.is_file():
        raise ReportError(f"report template {template} is missing (run from a source checkout)")
    with tempfile.TemporaryDirectory(prefix="workbench-report-") as tmp:
        work = Path(tmp)
        shutil.copy(template, work / "report.typ")
        figures: dict[tuple[str, str], str] = {}
        for i, p in enumerate(doc.problems):
            for j, f in enumerate(p.figures):
                fname = f"fig-{i:03d}-{j:02d}.svg"
                (work / fname).write_text(f.svg)
                figures[(p.name, f.name)] = fname
        try:
            return _compile(work, typst_data(doc, figures))
        except typst.TypstError as exc:
            message = " ".join(str(exc).split())  # one line for the command line
            raise ReportError(f"typst failed: {message}") from exc
