"""Tables of a problem's result: values, paper versus workbench, cost and accuracy.

A :class:`Table` is format-neutral (strings in cells); the HTML and Typst writers print
it. :func:`value_tables` lays out a result's ``values`` (arbitrary nested plain data)
generically: scalars and short vectors of one dictionary go into one two-column table,
matrices into a matrix table, lists of records into a table with one column per field,
long vectors into an indexed table (the shown cells truncated, with the count of what was
left out). Every table also keeps every value it stands for, unformatted and untruncated
(``data_header``, ``data``), which the report writes as a CSV file
(:mod:`~workbench.app.report.csvfiles`).
:func:`cost_accuracy_table` collects every timing and every value whose key names a cost
or an accuracy measure (wall time, tolerance, error, residual, drift, steps, ...).
:func:`telling_order` ranks a problem's comparisons for its headline.
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
    "telling_key",
    "telling_order",
    "MAX_ROWS",
    "MAX_COLS",
]

MAX_ROWS = 24
"""Rows shown of a long vector or matrix (the rest is counted in the table's note)."""

MAX_COLS = 12
"""Columns shown of a wide matrix."""

_EVERY = " (every value in the CSV file and in --json)"

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
    name : str
        Its name among the problem's tables (the CSV file's stem before it is made safe).
    data_header : list of str or None
        Column names of ``data``.
    data : list of list or None
        Every value the table stands for, as plain JSON data (floats unrounded, nothing
        truncated); None for a table of words only.
    csv : str
        Where its CSV file is, relative to the report's folder ("" until assigned).
    shown : bool
        Whether the HTML shows its cells (False: only a link to its CSV file).
    """

    title: str
    header: list[str]
    rows: list[list[str]]
    note: str = ""
    status: list[str] = field(default_factory=list)
    numeric: list[bool] = field(default_factory=list)
    name: str = ""
    data_header: list[str] | None = None
    data: list[list[Any]] | None = None
    csv: str = ""
    shown: bool = True

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
        name="comparisons",
        data_header=["quantity", "source", "reference", "workbench", "deviation",
                     "relative", "tolerance", "ok", "headline"],
        data=[[d["quantity"], d["source"], d["reference"], d["workbench"], d["deviation"],
               d["relative"], d["tolerance"], d["ok"], d["headline"]]
              for d in (c.as_dict() for c in result.comparisons)],
    )


HEADLINE_ROWS = 6
"""Rows of a problem's headline table in the main body."""


def _printed(reference: float, source: str) -> bool:
    """Whether a reference is a number a paper prints (not a zero residual, not a count)."""
    return "paper" in str(source).lower() and float(reference) != 0.0


def telling_key(*, ok: bool, reference: float, deviation: float, tolerance: float,
                source: str, headline: bool = False) -> tuple[int, float]:
    """Sort key of a comparison: the most telling first.

    The tiers, in order:

    0. out of tolerance (a reader must see it first);
    1. marked by the problem (``Result.compare(..., headline=True)``);
    2. a non-zero value printed in a paper (``source`` names a paper);
    3. any other non-zero reference (a closed form's value, a count);
    4. a zero reference (residuals, drifts, errors: checks of a property).

    Within a tier, the smaller the margin to the tolerance, the earlier: the key is
    ``-deviation / tolerance`` (an exact match with a zero tolerance counts as 0, a
    non-finite deviation as infinitely far).

    Parameters
    ----------
    ok : bool
    reference, deviation, tolerance : float
    source : str
    headline : bool

    Returns
    -------
    tuple of (int, float)
    """
    if not ok:
        tier = 0
    elif headline:
        tier = 1
    elif _printed(reference, source):
        tier = 2
    elif float(reference) != 0.0:
        tier = 3
    else:
        tier = 4
    dev, tol = float(deviation), float(tolerance)
    if not math.isfinite(dev):
        used = math.inf
    elif tol > 0:
        used = dev / tol
    else:
        used = 0.0 if dev == 0 else math.inf
    return tier, -used


def telling_order(comparisons: list[Any]) -> list[Any]:
    """The comparisons, most telling first (:func:`telling_key`; ties keep their order).

    Parameters
    ----------
    comparisons : list of Comparison
        Objects with ``ok``, ``reference``, ``deviation``, ``tolerance``, ``source`` and
        (optionally) ``headline``.

    Returns
    -------
    list of Comparison
    """
    return sorted(comparisons, key=lambda c: telling_key(
        ok=bool(c.ok), reference=c.reference, deviation=c.deviation, tolerance=c.tolerance,
        source=c.source, headline=bool(getattr(c, "headline", False))))


def headline_table(result: Result, values: list[Table] | None = None) -> Table | None:
    """The one table of a problem's main section: its key numbers, short enough to read.

    The paper-versus-workbench rows, most telling first (:func:`telling_order`), at most
    :data:`HEADLINE_ROWS`; for a problem without comparisons, the first rows of its first
    value table.

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
        shown = telling_order(comps)[:HEADLINE_ROWS]
        rows = [[c.quantity, c.source, fmt(c.reference, digits=8), fmt(c.workbench, digits=8),
                 f"{c.deviation:.1e}", f"{c.tolerance:.0e}", "ok" if c.ok else "OUT"]
                for c in shown]
        n_ok = sum(c.ok for c in comps)
        more = len(comps) - len(shown)
        note = (f"{n_ok} of {len(comps)} within tolerance; most telling first (out of "
                f"tolerance, then the problem's headline, then the paper's printed values "
                f"closest to their tolerance)" + (
                    f"; {more} more in the HTML report and the CSV files." if more else "."))
        return Table("Key numbers: paper (or closed form) vs workbench",
                     ["quantity", "source", "reference", "workbench", "deviation",
                      "tolerance", ""],
                     rows, note=note, status=["ok" if c.ok else "bad" for c in shown],
                     numeric=[False, False, True, True, True, True, False])
    values = value_tables(result) if values is None else values
    if not values:
        return None
    first = values[0]
    more = len(first.rows) - HEADLINE_ROWS
    note = (f"{more} more rows and every other table in the HTML report and the CSV files."
            if more > 0 else "Every other table in the HTML report and the CSV files.")
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
        rows, note=("; ".join(note) + _EVERY) if note else "",
        numeric=[False] + [True] * min(n_c, MAX_COLS), name=title,
        data_header=["row"] + [str(j + 1) for j in range(n_c)],
        data=[[i + 1, *r] for i, r in enumerate(m)],
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
    note = f"{n_more} more entries{_EVERY}" if n_more > 0 else ""
    return Table(f"{title}  ({len(v)} entries)", ["entries"] + [""] * VECTOR_COLS, rows, note=note,
                 numeric=[False] + [True] * VECTOR_COLS, name=title,
                 data_header=["entry", "value"], data=[[i + 1, x] for i, x in enumerate(v)])


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
                 note=("; ".join(note) + _EVERY) if note else "", name=title,
                 data_header=["#", *cols],
                 data=[[i + 1, *(r.get(c) for c in cols)] for i, r in enumerate(flat)])


def _walk(path: str, v: Any, pairs: list[tuple[str, Any]], tables: list[Table],
          cost: list[tuple[str, Any]], *, shown: bool = True) -> None:
    """Lay out ``v`` under ``path`` into ``pairs``, ``tables`` and ``cost``.

    Items of a list past :data:`MAX_ROWS` are laid out too (every value reaches the CSV
    files), but their tables are not shown in the HTML (``shown=False``).
    """
    inline = _is_scalar(v) or (
        isinstance(v, list) and len(v) <= INLINE_LIST and all(_is_scalar(x) for x in v)
    )
    new: Table | None = None
    if inline:
        (cost if _cost_key(path) else pairs).append((path, v))
    elif isinstance(v, dict):
        for k, sub in v.items():
            _walk(f"{path}.{k}" if path else str(k), sub, pairs, tables, cost, shown=shown)
    elif _is_matrix(v):
        new = _matrix_table(path, v)
    elif isinstance(v, list) and all(_is_scalar(x) for x in v):
        new = _vector_table(path, v)
    elif _is_records(v):
        new = _records_table(path, v)
    elif isinstance(v, list):
        for i, sub in enumerate(v):
            _walk(f"{path}[{i}]", sub, pairs, tables, cost, shown=shown and i < MAX_ROWS)
    else:
        pairs.append((path, str(v)))
    if new is not None:
        new.shown = shown
        tables.append(new)


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
            keys = [k.removeprefix(f"{group}.") if group else k for k, _ in pairs]
            rows = [[k, fmt(v)] for k, (_, v) in zip(keys, pairs)]
            head.append(Table(group or "Values", ["quantity", "value"], rows,
                              numeric=[False, True], name=group or "values",
                              data_header=["quantity", "value"],
                              data=[[k, v] for k, (_, v) in zip(keys, pairs)]))
    return head + tables, cost


def symbols_table(result: Result) -> Table | None:
    """What the problem's codes mean (:attr:`Result.labels`), or None when it gave none."""
    labels = getattr(result, "labels", None) or {}
    if not labels:
        return None
    return Table("Symbols", ["code", "meaning"], [[k, v] for k, v in labels.items()],
                 note="The codes in this problem's figures and tables, in words.",
                 numeric=[False, False], name="symbols", data_header=["code", "meaning"],
                 data=[[k, v] for k, v in labels.items()])


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
    raw: list[list[Any]] = []
    if wall_seconds is not None:
        raw.append(["whole problem", "wall time [s]", float(wall_seconds)])
    for step, sec in result.timings.items():
        raw.append([step, "wall time [s]", float(sec)])
    rows = [[a, b, fmt(v, digits=3)] for a, b, v in raw]
    for path, v in split_values(result.values)[1]:
        head, _, last = path.rpartition(".")
        raw.append([head or "(values)", last, v])
        rows.append([head or "(values)", last, fmt(v, digits=4)])
    return Table("Cost and accuracy", ["computation", "measure", "value"], rows,
                 note="Wall times are measured; tolerances are the knobs used; errors, "
                      "residuals and drifts are the problem's own error estimates.",
                 numeric=[False, False, True], name="cost-and-accuracy",
                 data_header=["computation", "measure", "value"], data=to_jsonable(raw))


def build_table(result: Result) -> Table:
    """What was built: every casadi.Function of the models used, with size and time."""
    rows = [[r["function"], str(r["n_nodes"]), f"{r['build_seconds'] * 1e3:.2f}",
             str(r.get("symbolic", ""))] for r in result.build_log]
    total = sum(r["build_seconds"] for r in result.build_log)
    return Table("Functions built", ["function", "nodes", "build [ms]", "graph"], rows,
                 note=f"{len(rows)} functions, {total * 1e3:.1f} ms in all.",
                 numeric=[False, True, True, False], name="functions-built",
                 data_header=["function", "nodes", "build seconds", "graph"],
                 data=to_jsonable([[r["function"], r["n_nodes"], r["build_seconds"],
                                    r.get("symbolic", "")] for r in result.build_log]))
