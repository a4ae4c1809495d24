"""The report as a format-neutral document, assembled from the problems' runs.

Everything shown is computed from the runs: the model sheets from the Model objects
(:mod:`workbench.app.report.symbolic`), the tables from the results
(:mod:`workbench.app.report.tables`), the environment from the interpreter. The HTML and
Typst writers only print this document.

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
from workbench.app.report.environment import environment
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
    value_tables,
)
from workbench.core._model import Model

__all__ = ["Math", "ModelSheet", "ProblemSection", "Document", "math", "model_sheet",
           "problem_section", "document"]


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
    """What the report shows of one problem."""

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
    figures: list[tuple[str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


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
    sec.cost = cost_accuracy_table(res, wall_seconds=run.seconds)
    sec.figures = list(run.figures.items())
    sec.notes = list(res.notes) + sec.notes
    return sec


@dataclass
class Document:
    """The whole report."""

    title: str
    quick: bool
    problems: list[ProblemSection]
    summary: Table
    environment: list[tuple[str, str]]
    seconds: float

    @property
    def created(self) -> str:
        """The date line of the environment."""
        return dict(self.environment).get("date", "")


def document(runs: list[ProblemRun], *, quick: bool, seconds: float,
             title: str = "Geometric pendulum workbench: report") -> Document:
    """The report of a list of runs.

    Parameters
    ----------
    runs : list of ProblemRun
    quick : bool
        Whether the problems ran in quick mode.
    seconds : float
        Wall time of running all the problems.
    title : str

    Returns
    -------
    Document
    """
    sections = [problem_section(r, quick=quick) for r in runs]
    rows, status = [], []
    for s, r in zip(sections, runs):
        comps = r.result.comparisons if r.result else []
        n_ok = sum(c.ok for c in comps)
        rows.append([
            s.name, s.status.value, f"{n_ok}/{len(comps)}", f"{s.seconds:.2f}",
            str(len(r.result.build_log)) if r.result else "-",
            ", ".join(dict.fromkeys(m.name for m in s.models)) or "-",
        ])
        status.append("ok" if s.status is Status.OK else "bad")
    n_ok = sum(st == "ok" for st in status)
    summary = Table(
        "Problems", ["problem", "status", "comparisons ok", "wall [s]", "functions built",
                     "models"], rows,
        note=f"{n_ok} of {len(rows)} problems ok; problems run in "
             f"{'quick' if quick else 'full'} mode in {seconds:.1f} s.",
        status=status, numeric=[False, False, True, True, True, False],
    )
    return Document(title, quick, sections, summary, environment(), seconds)
