"""The PDF report, typeset by Typst (through its Python package).

The document is written as JSON next to a copy of ``reports/templates/report.typ`` in a
temporary directory, with each figure as an SVG file; Typst reads the JSON and lays it
out. Formulas are Typst math from :mod:`workbench.app.report.latexmath`, evaluated by the
template; where a formula was not converted, its LaTeX source is shown in a raw block.
Should Typst reject the converted math, the PDF is compiled again with every formula as
LaTeX source, and the document says so.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from dataclasses import asdict
from pathlib import Path
from typing import Any

import typst

from workbench.app.report.document import Math, ModelSheet, ProblemSection
from workbench.app.report.errors import ReportError
from workbench.app.report.figures import PRINT_WIDTH
from workbench.app.report.frontpage import Document
from workbench.app.report.html import TEMPLATES
from workbench.app.report.tables import Table

__all__ = ["render_pdf", "typst_data"]

MATH_NOTE = (
    "Formulas: model equations are the models' LaTeX converted to Typst math by "
    "workbench.app.report.latexmath; parameter values and vector fields are printed by sympy "
    "(LaTeX) from the model itself and converted the same way. Formulas shown as LaTeX "
    "source could not be converted."
)


def _math(m: Math, raw: bool) -> dict[str, str]:
    return {"latex": m.latex, "typst": "" if raw else m.typst}


def _table(t: Table | None) -> dict[str, Any] | None:
    return None if t is None else t.as_dict()


def _model(m: ModelSheet, raw: bool) -> dict[str, Any]:
    d = asdict(m)
    d["equations"] = [_math(e, raw) for e in m.equations]
    d["parameters"] = [{**p, "value": _math(p["value"], raw)} for p in m.parameters]
    d["field"] = [{**r, "math": _math(r["math"], raw)} for r in m.field]
    return d


def _figure(p: ProblemSection, f: Any, figures: dict[tuple[str, str], str]) -> dict[str, Any]:
    return {"name": f.name, "caption": f.caption, "file": figures[(p.name, f.name)],
            "width": round(min(float(f.width), PRINT_WIDTH), 3)}


def _problem(p: ProblemSection, figures: dict[tuple[str, str], str],
             raw: bool) -> dict[str, Any]:
    return {
        "name": p.name, "title": p.title, "status": p.status.value, "seconds": p.seconds,
        "quick": p.quick, "error": p.error, "traceback": p.traceback,
        "summary": p.summary, "cached": p.cached, "headline": _table(p.headline),
        "comparison": _table(p.comparison), "values": [t.as_dict() for t in p.values],
        "cost": _table(p.cost), "built": _table(p.built),
        "figures": [_figure(p, f, figures) for f in p.key_figures],
        "more_figures": [_figure(p, f, figures) for f in p.more_figures],
        "animations": len(p.animations),
        "notes": list(p.notes), "models": [_model(m, raw) for m in p.models],
    }


def _claim(c: Any) -> dict[str, Any]:
    return {"text": c.text, "paper": c.paper, "problem": c.problem,
            "confirmed": c.confirmed, "status": c.status}


def typst_data(doc: Document, figures: dict[tuple[str, str], str], *,
               raw_math: bool = False) -> dict[str, Any]:
    """The JSON document the Typst template reads.

    Parameters
    ----------
    doc : Document
    figures : dict
        File name of each figure, by ``(problem, figure name)``.
    raw_math : bool
        Show every formula as LaTeX source.

    Returns
    -------
    dict
    """
    note = MATH_NOTE + (" Typst rejected the converted math, so every formula is shown as "
                        "LaTeX source." if raw_math else "")
    return {
        "title": doc.title, "quick": doc.quick, "created": doc.created,
        "seconds": doc.seconds, "summary": doc.summary.as_dict(),
        "intro": doc.intro, "run_note": doc.run_note, "counts": doc.counts,
        "headlines": _table(doc.headlines),
        "errata": [_claim(c) for c in doc.errata],
        "findings": [_claim(c) for c in doc.findings],
        "environment": [list(r) for r in doc.environment],
        "problems": [_problem(p, figures, raw_math) for p in doc.problems],
        "math_note": note,
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
        except typst.TypstError as first:
            try:
                return _compile(work, typst_data(doc, figures, raw_math=True))
            except typst.TypstError as exc:
                message = " ".join(str(exc).split())  # one line for the command line
                raise ReportError(f"typst failed: {message}") from first
