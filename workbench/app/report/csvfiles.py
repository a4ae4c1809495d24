"""Every table of a report as a CSV file, in a folder beside the HTML and the PDF.

The folder is ``<out>/<stem>-tables/`` (``reports/out/report-tables/`` for the default
report), with one sub-folder per problem and one file per table: every value the table
stands for, unrounded and untruncated (floats as Python's shortest exact repr, complex
numbers as ``1.5-2j``, booleans as ``true``/``false``, short lists as JSON, missing
cells empty). The HTML links each table to its file.

Generated files never carry unescaped user text: the ``csv`` module quotes every cell
that needs it, and a text cell that a spreadsheet would run as a formula (one starting
with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return, and not a number) is written
with a leading ``'``. File and folder names are made of letters, digits, ``_``, ``-``, ``+``
and ``.`` only, never start with a dot or a dash, and are unique within their folder.

The folder is the report's own: it is marked by :data:`MARKER`, which lists every file
and folder the report wrote there. A folder that holds other files and no marker is
refused before any problem runs (:func:`check_tables_dir`); a report removes only the
files of its earlier run that it no longer writes, as listed in the marker, and never a
file it did not create.
"""

from __future__ import annotations

import csv
import io
import json
import re
from pathlib import Path, PurePosixPath
from typing import Any

from workbench.app.report.errors import ReportInputError
from workbench.app.report.tables import Table
from workbench.core.files import make_dir, write_atomic

__all__ = ["MARKER", "tables_dir", "check_tables_dir", "assign_csv", "write_tables",
           "csv_text", "csv_cell", "safe_name"]

MARKER = ".workbench-report-tables"
"""The file that marks a folder as the report's tables, and lists what the report wrote."""

NAME_LENGTH = 80
"""Longest file or folder name made from a table's or problem's name (characters)."""

_UNSAFE = re.compile(r"[^A-Za-z0-9_.+-]+")
_FORMULA = ("=", "+", "-", "@", "\t", "\r")


def tables_dir(out_dir: Path, stem: str) -> Path:
    """The tables folder of the report ``<out_dir>/<stem>.html``."""
    return Path(out_dir) / f"{stem}-tables"


def safe_name(text: str, taken: set[str] | None = None) -> str:
    """A file name from ``text``: letters, digits, ``_-+.``; no leading dot; not in ``taken``.

    Parameters
    ----------
    text : str
        A table's or a problem's name (any text).
    taken : set of str, optional
        Names already used in the folder (compared in lower case, for case-insensitive
        file systems); the new name is added to it.

    Returns
    -------
    str
        At most :data:`NAME_LENGTH` characters (plus ``-2``, ``-3`` ... when taken).
    """
    base = _UNSAFE.sub("-", str(text)).strip("-.+")[:NAME_LENGTH].strip("-.+") or "table"
    name, k = base, 1
    used = taken if taken is not None else set()
    while name.lower() in used:
        k += 1
        name = f"{base}-{k}"
    used.add(name.lower())
    return name


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def csv_cell(v: Any) -> str:
    """One cell of a CSV file from plain JSON data (see the module's description).

    Parameters
    ----------
    v : object
        None, bool, int, float, str, a complex number as ``{"re", "im"}``, or a list or
        dict (written as JSON).

    Returns
    -------
    str
    """
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, dict) and set(v) == {"re", "im"}:
        try:
            return repr(complex(float(v["re"]), float(v["im"]))).strip("()")
        except (TypeError, ValueError):
            pass
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v, allow_nan=True)
    text = str(v)
    if text.startswith(_FORMULA) and not _is_number(text):
        return "'" + text  # a spreadsheet would run it as a formula
    return text


def csv_text(table: Table) -> str:
    """The CSV file of a table: its ``data_header`` and every row of its ``data``."""
    header = table.data_header if table.data_header is not None else table.header
    rows = table.data if table.data is not None else table.rows
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([csv_cell(h) for h in header])
    for row in rows:
        writer.writerow([csv_cell(c) for c in row])
    return buf.getvalue()


def _tables_of(section: Any) -> list[Table]:
    out = [section.comparison, *section.values, section.cost, section.built]
    return [t for t in out if t is not None]


def assign_csv(problems: list[Any], folder_name: str) -> dict[str, Table]:
    """Give every table of every problem its CSV path (``Table.csv``); return them by path.

    Parameters
    ----------
    problems : list of ProblemSection
        The document's problems.
    folder_name : str
        The tables folder's name (relative to the HTML file).

    Returns
    -------
    dict of str to Table
        The tables by their path relative to the tables folder (``problem/table.csv``).
    """
    out: dict[str, Table] = {}
    folders: set[str] = set()
    for sec in problems:
        sub = safe_name(sec.name, folders)
        names: set[str] = set()
        for t in _tables_of(sec):
            rel = f"{sub}/{safe_name(t.name or t.title, names)}.csv"
            t.csv = f"{folder_name}/{rel}"
            out[rel] = t
    return out


def _manifest(folder: Path) -> list[str]:
    """What the report wrote in ``folder`` last time (from its marker; [] if none)."""
    try:
        data = json.loads((folder / MARKER).read_text(encoding="utf-8"))
        return [str(f) for f in data.get("files", [])]
    except (OSError, ValueError, AttributeError):
        return []


def _write_marker(folder: Path, files: list[str]) -> None:
    text = json.dumps({
        "what": "tables of a workbench report: every file listed here was written by "
                "'workbench report', which replaces or removes them (and nothing else) "
                "when it writes the report again",
        "files": sorted(set(files)),
    }, indent=1)
    write_atomic(folder / MARKER, text, name="--out", error=ReportInputError)


def check_tables_dir(folder: Path) -> None:
    """Refuse a tables folder that holds files and is not the report's own.

    Parameters
    ----------
    folder : Path
        The folder (it may not exist yet).

    Raises
    ------
    ReportInputError
        It is not a folder, or it holds files and carries no :data:`MARKER`.
    """
    folder = Path(folder)
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        what = "a symbolic link" if folder.is_symlink() else "not a folder"
        raise ReportInputError(
            f"--out: {str(folder)!r} is {what}; the report writes its CSV tables in a "
            "folder of that name, its own: move it away or choose another --out")
    if not folder.is_dir() or (folder / MARKER).is_file():
        return
    others = sorted(p.name for p in folder.iterdir())
    if others:
        raise ReportInputError(
            f"--out: {str(folder)!r} holds files the report did not write "
            f"({', '.join(others[:5])}{', ...' if len(others) > 5 else ''}) and is not a "
            f"report's tables folder (no {MARKER}); the report writes and removes files "
            "there: move it away or choose another --out")


def _inside(folder: Path, rel: str) -> Path | None:
    """``folder / rel`` if ``rel`` is a plain relative path that stays in ``folder``."""
    parts = PurePosixPath(rel).parts
    if not parts or PurePosixPath(rel).is_absolute() or any(p in ("", ".", "..")
                                                             for p in parts):
        return None
    return folder.joinpath(*parts)


def write_tables(problems: list[Any], folder: Path) -> list[Path]:
    """Write every table of ``problems`` as CSV in ``folder``; drop the report's stale ones.

    The marker first lists the old and the new files together (so that every file the
    report creates is recorded before it exists), then the files are written (each
    atomically), then the old files not written again are removed (regular files only,
    and their folders when empty and the report's own), and the marker is rewritten with
    the new list.

    Parameters
    ----------
    problems : list of ProblemSection
        With their CSV paths assigned (:func:`assign_csv`).
    folder : Path
        The tables folder (checked by :func:`check_tables_dir`).

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(folder)
    check_tables_dir(folder)
    tables = assign_csv(problems, folder.name)
    make_dir(folder, name="--out", error=ReportInputError)
    old = _manifest(folder)
    subdirs = sorted({rel.split("/")[0] + "/" for rel in tables})
    new = [*subdirs, *tables]
    _write_marker(folder, old + new)
    written = []
    for rel, table in tables.items():
        path = folder / rel
        make_dir(path.parent, name="--out", error=ReportInputError)
        written.append(write_atomic(path, csv_text(table), name="--out",
                                    error=ReportInputError))
    keep = set(new)
    for rel in sorted(set(old) - keep, key=lambda r: (r.endswith("/"), r)):  # files first
        path = _inside(folder, rel.rstrip("/"))
        if path is None or path.is_symlink():
            continue
        if rel.endswith("/"):
            if path.is_dir() and not any(path.iterdir()):
                path.rmdir()
        elif path.is_file():
            path.unlink()
    _write_marker(folder, new)
    return written
