"""The section of one problem, format-neutral plain data, assembled from its run.

Everything shown is computed from the run: the model sheets from the Model objects
(:mod:`workbench.app.report.symbolic`), the tables from the result
(:mod:`workbench.app.report.tables`), the figures as SVG text. A section holds no live
object, so it crosses process boundaries and is cached on disk; the whole document is
assembled from the sections by :mod:`workbench.app.report.frontpage`, and the HTML and
Typst writers only print it.

Typesetting of formulas: each LaTeX string (a model's equations, sympy's LaTeX of a
parameter value or a vector-field component) is converted by
:mod:`workbench.app.report.latexmath` to MathML and to Typst math. Where sympy printed an
expression, the HTML uses sympy's own MathML printer instead. A string the converter does
not support is shown as LaTeX source (``Math.error`` says why).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from workbench.app.report.collect import ProblemRun, Status
from workbench.app.report.figures import FigureData
from workbench.app.report.latexmath import LatexError, to_mathml, to_typst
from workbench.app.report.symbolic import (
    MAX_CONVERT,
    parameter_rows,
    state_symbols,
    vector_field_rows,
)
from workbench.app.report.tables import (
    Table,
    build_table,
    comparison_table,
    cost_accuracy_table,
    headline_table,
    symbols_sentence,
    symbols_table,
    value_tables,
)
from workbench.core._model import Model

__all__ = ["Math", "ModelSheet", "ProblemSection", "KEY_FIGURES", "math", "model_sheet",
           "problem_section"]


KEY_FIGURES = 2
"""Figures of a problem shown in the main body of the HTML (the others go to its appendix;
the PDF prints them all)."""

WIDE = 100
"""Vector-field components with longer LaTeX get a whole line of the report."""


@dataclass
class Math:
    """A formula in every form the writers need.

    Attributes
    ----------
    latex : str
        The source.
    mathml : str
        A ``<math>`` element ("" when not converted).
    typst : str
        Typst math ("" when not converted).
    error : str
        Why it was not converted.
    """

    latex: str
    mathml: str = ""
    typst: str = ""
    error: str = ""


def math(latex: str, *, display: bool = True, mathml: str | None = None) -> Math:
    """Convert a LaTeX formula (``mathml`` overrides the MathML form, e.g. sympy's)."""
    try:
        typ = to_typst(latex)
        ml = mathml if mathml is not None else to_mathml(latex, display=display)
    except LatexError as exc:
        return Math(latex, error=str(exc))
    return Math(latex, ml, typ)


@dataclass
class ModelSheet:
    """What the report shows of one model."""

    name: str
    description: str
    manifold: str
    inputs: str
    state: list[list[str]]
    parameters: list[dict[str, Any]]
    equations: list[Math]
    field: list[dict[str, Any]]
    field_note: str
    built: list[str]
    available: list[str]
    heading: str = ""

    def __post_init__(self) -> None:
        self.heading = self.heading or self.name


def _coordinates(model: Model) -> list[list[str]]:
    syms = [str(s) for s in state_symbols(model)]
    rows, k = [], 0
    for name, factor in model.manifold.factors:
        n = factor.ambient_dim
        coords = syms[k : k + n]
        k += n
        shown = ", ".join(coords) if n <= 6 else f"{coords[0]}, ..., {coords[-1]}"
        rows.append([name, factor.kind, str(n), str(factor.dim), shown])
    return rows


def model_sheet(model: Model) -> ModelSheet:
    """Typeset a model: manifold, state, parameters, equations, vector field, functions.

    Parameters
    ----------
    model : Model

    Returns
    -------
    ModelSheet
    """
    params = []
    for row in parameter_rows(model):
        params.append({
            "name": row.name, "shape": row.shape, "description": row.description,
            "value": math(row.latex, display=False, mathml=row.mathml),
        })
    fs = vector_field_rows(model)
    field_rows, omitted = [], []
    for r in fs.rows:
        if not r.latex:
            size = f"> {MAX_CONVERT}" if r.size > MAX_CONVERT else str(r.size)
            omitted.append(f"{r.name} ({size} nodes)")
            continue
        lhs = to_mathml(r.lhs, display=True)
        inner = r.mathml[r.mathml.index(">") + 1 : r.mathml.rindex("</math>")]
        ml = lhs.replace("</math>", f"<mo>=</mo>{inner}</math>")
        field_rows.append({"form": r.form, "size": r.size, "wide": len(r.latex) > WIDE,
                           "math": math(f"{r.lhs} = {r.latex}", mathml=ml)})
    note = fs.note
    if omitted:
        note = (note + " " if note else "") + (
            "Too long to typeset, even with the parameter values substituted: "
            + ", ".join(omitted) + ".")
    prefix = model.name + "."
    built = [n[len(prefix):] for n in model.build_log.names() if n.startswith(prefix)]
    available = ["f", "f_x", "f_u", "residual", "invariants", *model.invariant_names]
    inputs = (f"{model.n_inputs}: {model.input_description}" if model.input_description
              else str(model.n_inputs))
    return ModelSheet(
        name=model.name, description=model.description, manifold=model.manifold.describe(),
        inputs=inputs, state=_coordinates(model), parameters=params,
        equations=[math(e) for e in model.equations], field=field_rows,
        field_note=note, built=list(dict.fromkeys(built)), available=available,
    )


@dataclass
class ProblemSection:
    """What the report shows of one problem.

    The HTML's main body shows ``summary``, ``headline`` and the first :data:`KEY_FIGURES`
    figures and the animations; its appendix shows everything else (the full comparison,
    values, cost, models, what was built, the other figures, the notes). The PDF prints
    ``summary``, ``headline``, every figure and the notes; every table (``comparison``,
    ``values``, ``cost``, ``built``) is also written as a CSV file.
    """

    name: str
    title: str
    status: Status
    seconds: float
    quick: bool
    error: str = ""
    traceback: str = ""
    models: list[ModelSheet] = field(default_factory=list)
    built: Table | None = None
    comparison: Table | None = None
    values: list[Table] = field(default_factory=list)
    cost: Table | None = None
    figures: list[FigureData] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    headline: Table | None = None
    summary: str = ""
    animations: list[Any] = field(default_factory=list)
    cached: bool = False
    peak_mb: float = float("nan")

    @property
    def key_figures(self) -> list[FigureData]:
        """The figures of the main body."""
        return self.figures[:KEY_FIGURES]

    @property
    def more_figures(self) -> list[FigureData]:
        """The figures of the HTML's appendix."""
        return self.figures[KEY_FIGURES:]


def _distinct_models(models: list[Model]) -> list[Model]:
    out: list[Model] = []
    for m in models:
        same = [o for o in out if o.name == m.name and all(
            (o.values[k] == m.values[k]).all() for k in m.values if k in o.values)]
        if not same:
            out.append(m)
    return out


def problem_section(run: ProblemRun, *, quick: bool) -> ProblemSection:
    """Assemble the section of one problem from its run."""
    sec = ProblemSection(run.name, run.title, run.status, run.seconds, quick,
                         error=run.error, traceback=run.traceback)
    res = run.result
    if res is None:
        return sec
    seen: dict[str, int] = {}
    for m in _distinct_models(run.models):
        try:
            sheet = model_sheet(m)
            seen[m.name] = seen.get(m.name, 0) + 1
            if seen[m.name] > 1:
                sheet.heading = f"{m.name} (parameter set {seen[m.name]})"
            sec.models.append(sheet)
        except Exception as exc:  # noqa: BLE001 - a sheet that fails is noted, not fatal
            sec.notes.append(f"model {m.name!r} could not be typeset: {exc}")
    sec.built = build_table(res)
    sec.comparison = comparison_table(res)
    sec.values = value_tables(res)
    sec.headline = headline_table(res, sec.values)
    symbols = symbols_table(res)
    if symbols is not None:
        sec.values.insert(0, symbols)
    sec.cost = cost_accuracy_table(res, wall_seconds=run.seconds)
    sec.figures = list(run.figures.values())
    words = symbols_sentence(res)
    for fig in sec.key_figures if words else ():
        fig.caption = f"{fig.caption.rstrip()} {words}"
    sec.notes = list(res.notes) + sec.notes
    return sec
