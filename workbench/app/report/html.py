"""The HTML report: one self-contained file (inline CSS, MathML and SVG; no scripts).

Rendered with jinja2 from ``reports/templates/report.html.j2`` (autoescaped; only the
MathML and SVG produced by the report itself are inserted unescaped).
"""

from __future__ import annotations

from pathlib import Path

import jinja2

from workbench.app.report.frontpage import Document

__all__ = ["TEMPLATES", "render_html"]

TEMPLATES = Path(__file__).resolve().parents[3] / "reports" / "templates"
"""Directory of the report templates."""


def _environment() -> jinja2.Environment:
    if not (TEMPLATES / "report.html.j2").is_file():
        raise FileNotFoundError(
            f"report template {TEMPLATES / 'report.html.j2'} is missing; the report needs "
            "the repository's reports/templates/ (run from a source checkout)"
        )
    return jinja2.Environment(
        loader=jinja2.FileSystemLoader(TEMPLATES),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=False,
        lstrip_blocks=False,
    )


def render_html(doc: Document) -> str:
    """The report as one HTML page.

    Parameters
    ----------
    doc : Document

    Returns
    -------
    str
    """
    return _environment().get_template("report.html.j2").render(doc=doc)
