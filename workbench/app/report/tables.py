"""Tables of a problem's result: values, paper versus workbench, cost and accuracy.

A :class:`Table` is format-neutral (strings in cells); the HTML and Typst writers print
it. :func:`value_tables` lays out a result's ``values`` (arbitrary nested plain data)
generically: scalars and short vectors of one dictionary go into one two-column table,
matrices into a matrix table, lists of records into a table with one column per field,
long vectors into an indexed table (truncated, with the count of what was left out).
:func:`cost_accuracy_table` collects every timing and every value whose key names a cost
or an accuracy measure (wall time, tolerance, error, residual, drift, steps, ...).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from workbench.study._result import Result, to_jsonable

__all__ = [
    "Table",
    "fmt",
    "comparison_table",
    "value_tables",
    "cost_accuracy_table",
    "build_table",
    "headline_table",
    "HEADLINE_ROWS",
    "MAX_ROWS",
    "MAX_COLS",
]

MAX_ROWS = 24
"""Rows shown of a long vector or matrix (the rest is counted in the table's note)."""

MAX_COLS = 12
"""Columns shown of a wide matrix."""

INLINE_LIST = 6
"""Lists up to this length are printed inline in a two-column table."""

_COST_ACCURACY = re.compile(
    r"(^|_)(wall|seconds|time|tol|tolerance|rtol|atol|err|error|errors|residual|"
    r"residuals|drift|max_abs|max_rel|steps|step|iterations|iter|evaluations|nfev|status|"
    r"rhs_evaluations|build_seconds|accuracy|cost)($|_)"
)


@dataclass
class Table:
    """A titled table of formatted cells.

    Attributes
    ----------
    title : str
        Caption.
    header : list of str
        Column names.
    rows : list of list of str
        Cells, already formatted.
    note : str
        A remark under the table (truncation, units).
    status : list of str
        Per row ``"ok"``, ``"bad"`` or ``""`` (used to colour paper-vs-workbench rows).
    numeric : list of bool
        Per column, whether it holds numbers (right-aligned).
    """

    title: str
    header: list[str]
    rows: list[list[str]]
    note: str = ""
    status: list[str] = field(default_factory=list)
    numeric: list[bool] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        """Plain form (for the Typst writer's JSON)."""
        return {
            "title": self.title,
            "header": self.header,
            "rows": self.rows,
            "note": self.note,
            "status": self.status or [""] * len(self.rows),
            "numeric": self.numeric or [False] * len(self.header),
        }


def _is_complex(v: Any) -> bool:
    return isinstance(v, dict) and set(v) == {"re", "im"}


def _is_scalar(v: Any) -> bool:
    return v is None or isinstance(v, (bool, int, float, str)) or _is_complex(v)


def fmt(v: Any, *, digits: int = 6) -> str:
    """Format a plain value for a table cell.

    Parameters
    ----------
    v : object
        A number, a complex number as ``{"re", "im"}``, a string, or a short list.
    digits : int
        Significant digits of floats.

    Returns
    -------
    str
    """
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if v == 0:
            return "0"
        if not math.isfinite(v):
            return str(v)
        return f"{v:.{digits}g}"
    if _is_complex(v):
        re_, im = v["re"], v["im"]
        if isinstance(im, (int, float)) and im == 0:
            return fmt(re_, digits=digits)
        sign = "−" if isinstance(im, (int, float)) and im < 0 else "+"
        mag = abs(im) if isinstance(im, (int, float)) else im
        return f"{fmt(re_, digits=digits)} {sign} {fmt(mag, digits=digits)}i"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(fmt(x, digits=digits) for x in v) + "]"
    return str(v)


def comparison_table(result: Result) -> Table | None:
    """The paper-versus-workbench table: one row per :class:`Comparison`, all computed.

    Returns ``None`` when the result has no comparisons.
    """
    if not result.comparisons:
        return None
    rows, status = [], []
    for c in result.comparisons:
        kind = "rel" if c.relative else "abs"
        rows.append([
            c.quantity, c.source, fmt(c.reference, digits=10), fmt(c.workbench, digits=10),
            f"{c.deviation:.2e} ({kind})", f"{c.tolerance:.0e}", "ok" if c.ok else "OUT",
        ])
        status.append("ok" if c.ok else "bad")
    n_ok = sum(s == "ok" for s in status)
    return Table(
        "Paper vs workbench",
        ["quantity", "source", "paper / reference", "workbench", "deviation", "tolerance",
         ""],
        rows,
        note=f"{n_ok} of {len(rows)} within tolerance.",
        status=status,
        numeric=[False, False, True, True, True, True, False],
    )


HEADLINE_ROWS = 6
"""Rows of a problem's headline table in the main body."""


def headline_table(result: Result, values: list[Table] | None = None) -> Table | None:
    """The one table of a problem's main section: its key numbers, short enough to read.

    The paper-versus-workbench rows (those out of tolerance first, then in the problem's
    order) without the source column, at most :data:`HEADLINE_ROWS`; for a problem without
    comparisons, the first rows of its first value table.

    Parameters
    ----------
    result : Result
        The problem's result.
    values : list of Table, optional
        Its value tables (:func:`value_tables`), when already laid out.

    Returns
    -------
    Table or None
    """
    comps = list(result.comparisons)
    if comps:
        order = [c for c in comps if not c.ok] + [c for c in comps if c.ok]
        shown = order[:HEADLINE_ROWS]
        rows = [[c.quantity, fmt(c.reference, digits=8), fmt(c.workbench, digits=8),
                 f"{c.deviation:.1e}", f"{c.tolerance:.0e}", "ok" if c.ok else "OUT"]
                for c in shown]
        n_ok = sum(c.ok for c in comps)
        more = len(comps) - len(shown)
        note = f"{n_ok} of {len(comps)} within tolerance" + (
            f"; {more} more in the appendix, with their sources." if more else
            "; sources in the appendix.")
        return Table("Key numbers: paper (or closed form) vs workbench",
                     ["quantity", "reference", "workbench", "deviation", "tolerance", ""],
                     rows, note=note, status=["ok" if c.ok else "bad" for c in shown],
                     numeric=[False, True, True, True, True, False])
    values = value_tables(result) if values is None else values
    if not values:
        return None
    first = values[0]
    more = len(first.rows) - HEADLINE_ROWS
    note = (f"{more} more rows and every other table in the appendix." if more > 0 else
            "Every other table in the appendix.")
    return Table(f"Key numbers: {first.title}", list(first.header),
                 [list(r) for r in first.rows[:HEADLINE_ROWS]], note=note,
                 status=list(first.status[:HEADLINE_ROWS]), numeric=list(first.numeric))


def _is_matrix(v: Any) -> bool:
    return (
        isinstance(v, list) and len(v) > 0 and all(isinstance(r, list) for r in v)
        and len({len(r) for r in v}) == 1 and len(v[0]) > 0
        and all(_is_scalar(x) for r in v for x in r)
    )


def _is_records(v: Any) -> bool:
    return isinstance(v, list) and len(v) > 0 and all(isinstance(r, dict) and r for r in v)


def _cost_key(path: str) -> bool:
    return any(_COST_ACCURACY.search(part) for part in path.split("."))


def _matrix_table(title: str, m: list[list[Any]]) -> Table:
    n_r, n_c = len(m), len(m[0])
    rows = [[str(i + 1)] + [fmt(x) for x in r[:MAX_COLS]] for i, r in enumerate(m[:MAX_ROWS])]
    note = []
    if n_r > MAX_ROWS:
        note.append(f"{n_r - MAX_ROWS} more rows")
    if n_c > MAX_COLS:
        note.append(f"{n_c - MAX_COLS} more columns")
    return Table(
        f"{title}  ({n_r}×{n_c})", [""] + [str(j + 1) for j in range(min(n_c, MAX_COLS))],
        rows, note=("; ".join(note) + " (all in --json)") if note else "",
        numeric=[False] + [True] * min(n_c, MAX_COLS),
    )


VECTOR_COLS = 6
"""A long vector is shown in rows of this many entries."""


def _vector_table(title: str, v: list[Any]) -> Table:
    shown = v[: MAX_ROWS * VECTOR_COLS]
    rows = []
    for k in range(0, len(shown), VECTOR_COLS):
        chunk = [fmt(x) for x in shown[k : k + VECTOR_COLS]]
        rows.append([f"{k + 1}–{k + len(chunk)}"] + chunk + [""] * (VECTOR_COLS - len(chunk)))
    n_more = len(v) - len(shown)
    note = f"{n_more} more entries (all in --json)" if n_more > 0 else ""
    return Table(f"{title}  ({len(v)} entries)", ["entries"] + [""] * VECTOR_COLS, rows, note=note,
                 numeric=[False] + [True] * VECTOR_COLS)


def _flat_record(r: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in r.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and not _is_complex(v):
            out.update(_flat_record(v, key + "."))
        else:
            out[key] = v
    return out


def _records_table(title: str, recs: list[dict[str, Any]]) -> Table:
    flat = [_flat_record(r) for r in recs]
    cols: list[str] = []
    for r in flat:
        cols += [k for k in r if k not in cols]
    rows = [[str(i + 1)] + [fmt(r.get(c, "")) for c in cols[:MAX_COLS]]
            for i, r in enumerate(flat[:MAX_ROWS])]
    note = []
    if len(flat) > MAX_ROWS:
        note.append(f"{len(flat) - MAX_ROWS} more records")
    if len(cols) > MAX_COLS:
        note.append(f"fields {', '.join(cols[MAX_COLS:])} not shown")
    return Table(f"{title}  ({len(flat)} records)", ["#"] + cols[:MAX_COLS], rows,
                 note=("; ".join(note) + " (all in --json)") if note else "")


def _walk(path: str, v: Any, pairs: list[tuple[str, Any]], tables: list[Table],
          cost: list[tuple[str, Any]]) -> None:
    inline = _is_scalar(v) or (
        isinstance(v, list) and len(v) <= INLINE_LIST and all(_is_scalar(x) for x in v)
    )
    if inline:
        (cost if _cost_key(path) else pairs).append((path, v))
    elif isinstance(v, dict):
        for k, sub in v.items():
            _walk(f"{path}.{k}" if path else str(k), sub, pairs, tables, cost)
    elif _is_matrix(v):
        tables.append(_matrix_table(path, v))
    elif isinstance(v, list) and all(_is_scalar(x) for x in v):
        tables.append(_vector_table(path, v))
    elif _is_records(v):
        tables.append(_records_table(path, v))
    elif isinstance(v, list):
        for i, sub in enumerate(v[:MAX_ROWS]):
            _walk(f"{path}[{i}]", sub, pairs, tables, cost)
    else:
        pairs.append((path, str(v)))


def split_values(values: dict[str, Any]) -> tuple[list[Table], list[tuple[str, Any]]]:
    """Lay out ``values`` as tables; return them and the cost/accuracy pairs set aside."""
    data = to_jsonable(values)
    tables: list[Table] = []
    cost: list[tuple[str, Any]] = []
    groups: dict[str, list[tuple[str, Any]]] = {}
    for key, v in data.items():
        pairs: list[tuple[str, Any]] = []
        sub_tables: list[Table] = []
        _walk(str(key), v, pairs, sub_tables, cost)
        group = "" if _is_scalar(v) or (isinstance(v, list) and len(v) <= INLINE_LIST) else key
        groups.setdefault(group, []).extend(pairs)
        tables.extend(sub_tables)
    head = []
    for group, pairs in groups.items():
        if pairs:
            rows = [[k.removeprefix(f"{group}.") if group else k, fmt(v)] for k, v in pairs]
            head.append(Table(group or "Values", ["quantity", "value"], rows,
                              numeric=[False, True]))
    return head + tables, cost


def symbols_table(result: Result) -> Table | None:
    """What the problem's codes mean (:attr:`Result.labels`), or None when it gave none."""
    labels = getattr(result, "labels", None) or {}
    if not labels:
        return None
    return Table("Symbols", ["code", "meaning"], [[k, v] for k, v in labels.items()],
                 note="The codes in this problem's figures and tables, in words.",
                 numeric=[False, False])


def symbols_sentence(result: Result, *, most: int = 8) -> str:
    """``"Symbols: q1 tilt of link 1; ..."`` for figure captions ("" without labels)."""
    labels = getattr(result, "labels", None) or {}
    if not labels:
        return ""
    items = [f"{k}: {v}" for k, v in list(labels.items())[:most]]
    more = f"; {len(labels) - most} more in the table of symbols" if len(labels) > most else ""
    return "Symbols: " + "; ".join(items) + more + "."


def value_tables(result: Result) -> list[Table]:
    """The result's values as tables (cost and accuracy entries are set aside)."""
    return split_values(result.values)[0]


def cost_accuracy_table(result: Result, *, wall_seconds: float | None = None) -> Table:
    """Cost (wall times, steps, evaluations) and accuracy (tolerances, errors, residuals).

    Parameters
    ----------
    result : Result
        The problem's result.
    wall_seconds : float, optional
        The problem's total wall time measured by the report.

    Returns
    -------
    Table
        Rows ``(computation, measure, value)``: first the timed steps, then every value
        whose key names a cost or accuracy measure.
    """
    rows: list[list[str]] = []
    if wall_seconds is not None:
        rows.append(["whole problem", "wall time [s]", fmt(wall_seconds, digits=3)])
    for step, sec in result.timings.items():
        rows.append([step, "wall time [s]", fmt(float(sec), digits=3)])
    for path, v in split_values(result.values)[1]:
        head, _, last = path.rpartition(".")
        rows.append([head or "(values)", last, fmt(v, digits=4)])
    return Table("Cost and accuracy", ["computation", "measure", "value"], rows,
                 note="Wall times are measured; tolerances are the knobs used; errors, "
                      "residuals and drifts are the problem's own error estimates.",
                 numeric=[False, False, True])


def build_table(result: Result) -> Table:
    """What was built: every casadi.Function of the models used, with size and time."""
    rows = [[r["function"], str(r["n_nodes"]), f"{r['build_seconds'] * 1e3:.2f}",
             str(r.get("symbolic", ""))] for r in result.build_log]
    total = sum(r["build_seconds"] for r in result.build_log)
    return Table("Functions built", ["function", "nodes", "build [ms]", "graph"], rows,
                 note=f"{len(rows)} functions, {total * 1e3:.1f} ms in all.",
                 numeric=[False, True, True, False])
