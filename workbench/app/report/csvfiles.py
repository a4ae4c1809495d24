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
and folder the report wrote there, with each file's SHA-256 (as ``export-c`` does in its
manifest). A report replaces or removes only its own files that nobody edited since:

- a folder that holds other files and no marker is refused before any problem runs
  (:func:`check_tables_dir`), and so is one where a file the report wrote was edited
  since (its SHA-256 differs from the marker's), or was replaced by a link or a folder;
- after the problems ran, a file at one of the new tables' names that the report did not
  write (and that does not already hold exactly the new table), or a file of the last
  run that it would remove and cannot show to be unedited, stops the report before
  anything is written (:func:`write_tables`), naming the files;
- a file the user adds among the report's (``notes.txt``) is never touched; a folder of
  the report's that is no longer used is removed only when empty.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import re
from pathlib import Path, PurePosixPath
from typing import Any

from workbench.app.report.errors import ReportInputError
from workbench.app.report.tables import Table
from workbench.core.files import make_dir, writable_file, write_atomic

__all__ = ["MARKER", "tables_dir", "check_tables_dir", "assign_csv", "write_tables",
           "csv_text", "csv_cell", "safe_name"]

MARKER = ".workbench-report-tables"
"""The file that marks a folder as the report's tables, and lists what the report wrote
(``files``: the files and folders; ``sha256``: each file's accepted SHA-256 digests)."""

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


def _sha(data: bytes | str) -> str:
    return hashlib.sha256(data.encode("utf-8") if isinstance(data, str) else data).hexdigest()


def _file_sha(path: Path) -> str | None:
    try:
        return _sha(path.read_bytes())
    except OSError:
        return None


def _manifest(folder: Path) -> tuple[list[str], dict[str, set[str]]]:
    """What the report wrote in ``folder`` last time, from its marker.

    Returns the files and folders (``sub/``) listed, and each file's accepted SHA-256
    digests (none for a marker written before digests were recorded); nothing if there is
    no readable marker.
    """
    try:
        data = json.loads((folder / MARKER).read_text(encoding="utf-8"))
        files = [str(f) for f in data.get("files", [])]
        digests = data.get("sha256", {})
        sha = {str(k): {str(v)} if isinstance(v, str) else {str(h) for h in v}
               for k, v in (digests.items() if isinstance(digests, dict) else ())}
    except (OSError, ValueError, AttributeError, TypeError):
        return [], {}
    return files, sha


def _write_marker(folder: Path, files: list[str], sha: dict[str, set[str]]) -> None:
    text = json.dumps({
        "what": "tables of a workbench report: every file listed here was written by "
                "'workbench report', which replaces or removes them (and nothing else) "
                "when it writes the report again, unless they were edited (their SHA-256 "
                "is no longer one listed here)",
        "files": sorted(set(files)),
        "sha256": {rel: sorted(h) for rel, h in sorted(sha.items())},
    }, indent=1)
    write_atomic(folder / MARKER, text, name="--out", error=ReportInputError)


def _not_a_file(path: Path) -> str | None:
    """What ``path`` is if it exists and is not a regular file (for the message)."""
    if path.is_symlink():
        return "a symbolic link"
    if os.path.lexists(path) and not path.is_file():
        return "a folder" if path.is_dir() else "not a regular file"
    return None


_UNKNOWN = "recorded without its SHA-256 by an older report: cannot be shown unedited"


def _edited(folder: Path, files: list[str], sha: dict[str, set[str]],
            *, unknown: bool) -> list[str]:
    """The report's recorded files (not folders) in ``folder`` it may no longer touch.

    Those that exist and are not regular files, or whose SHA-256 is not a recorded one;
    with ``unknown``, also those recorded without a digest (a marker older than digests).
    """
    bad = []
    for rel in files:
        path = _inside(folder, rel)
        if rel.endswith("/") or path is None or not os.path.lexists(path):
            continue
        what = _not_a_file(path)
        if what is not None:
            bad.append(f"{rel} (now {what})")
        elif rel in sha and _file_sha(path) not in sha[rel]:
            bad.append(f"{rel} (edited since)")
        elif rel not in sha and unknown:
            bad.append(f"{rel} ({_UNKNOWN})")
    return bad


def _refuse(folder: Path, bad: list[str]) -> None:
    shown = ", ".join(bad[:8]) + (f", ... ({len(bad)} in all)" if len(bad) > 8 else "")
    raise ReportInputError(
        f"--out: the report's tables folder {str(folder)!r} holds files it would replace "
        f"or remove that it did not write, or that were edited since it wrote them: "
        f"{shown}; nothing was written (move them away, or choose another --out)")


def check_tables_dir(folder: Path) -> None:
    """Refuse a tables folder that is not the report's own, or where its files were edited.

    Parameters
    ----------
    folder : Path
        The folder (it may not exist yet).

    Raises
    ------
    ReportInputError
        It is not a folder; it holds files and carries no :data:`MARKER`; its marker is
        not a regular file; or a file the marker lists was edited since the report wrote
        it (its SHA-256 is not the recorded one), or is now a link or a folder.
    """
    folder = Path(folder)
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        what = "a symbolic link" if folder.is_symlink() else "not a folder"
        raise ReportInputError(
            f"--out: {str(folder)!r} is {what}; the report writes its CSV tables in a "
            "folder of that name, its own: move it away or choose another --out")
    if not folder.is_dir():
        return
    marker = folder / MARKER
    what = _not_a_file(marker)
    if what is not None:
        raise ReportInputError(
            f"--out: {str(marker)!r} (the mark of the report's tables folder) is {what}; "
            "nothing was written (move it away, or choose another --out)")
    if marker.is_file():
        bad = _edited(folder, *_manifest(folder), unknown=False)
        if bad:
            _refuse(folder, bad)
        return
    others = sorted(p.name for p in folder.iterdir())
    if others:
        raise ReportInputError(
            f"--out: {str(folder)!r} holds files the report did not write "
            f"({', '.join(others[:5])}{', ...' if len(others) > 5 else ''}) and is not a "
            f"report's tables folder (no {MARKER}); the report writes and removes files "
            "there: move it away or choose another --out")


def _inside(folder: Path, rel: str) -> Path | None:
    """``folder / rel`` if ``rel`` is a plain relative path that stays in ``folder``.

    None also when one of its folders in ``folder`` is a symbolic link (which could lead
    out of it).
    """
    parts = PurePosixPath(rel).parts
    if not parts or PurePosixPath(rel).is_absolute() or any(p in ("", ".", "..")
                                                             for p in parts):
        return None
    if any(folder.joinpath(*parts[:k]).is_symlink() for k in range(1, len(parts))):
        return None
    return folder.joinpath(*parts)


def _conflicts(folder: Path, texts: dict[str, str], new_dirs: list[str], old: list[str],
               sha: dict[str, set[str]]) -> list[str]:
    """What the report would replace or remove that is not its own unedited file.

    At a new table's name: a link, a folder, or a file that is neither recorded with its
    SHA-256 nor already the new table. A folder of the new tables that is a link or a
    file. A recorded file the report would remove that cannot be shown unedited.
    """
    bad = []
    for rel in new_dirs:
        path = folder / rel.rstrip("/")
        if path.is_symlink() or (os.path.lexists(path) and not path.is_dir()):
            bad.append(f"{rel} (a {'symbolic link' if path.is_symlink() else 'file'}, "
                       "where the report writes a folder)")
    for rel, text in texts.items():
        path = folder / rel
        if not os.path.lexists(path) or (folder / rel.split("/")[0]).is_symlink():
            continue
        what = _not_a_file(path)
        digest = _file_sha(path) if what is None else None
        if what is not None:
            bad.append(f"{rel} ({what})")
        elif digest not in sha.get(rel, set()) and digest != _sha(text):
            bad.append(f"{rel} (edited since)" if rel in sha else f"{rel} ({_UNKNOWN})"
                       if rel in old else f"{rel} (not written by the report)")
    stale = [rel for rel in old if rel not in texts and not rel.endswith("/")]
    return bad + _edited(folder, stale, sha, unknown=True)


def _remove_stale(folder: Path, stale: list[str], sha: dict[str, set[str]]) -> None:
    """Remove the report's files and (empty) folders of the last run it no longer writes."""
    for rel in sorted(stale, key=lambda r: (r.endswith("/"), r)):  # files first
        path = _inside(folder, rel.rstrip("/"))
        if path is None or path.is_symlink():
            continue  # a link is never the report's: left as it is
        if rel.endswith("/"):
            if path.is_dir() and not any(path.iterdir()):
                path.rmdir()
        elif path.is_file() and _file_sha(path) in sha.get(rel, set()):
            path.unlink()


def write_tables(problems: list[Any], folder: Path) -> list[Path]:
    """Write every table of ``problems`` as CSV in ``folder``; drop the report's stale ones.

    First everything the report would replace or remove is checked to be its own and
    unedited (see the module's description); any other file stops it before anything is
    written. Then the marker lists the old and the new files together, with the digests
    of both their old and their new content (so that every file the report creates is
    recorded before it exists, and an interrupted run leaves only recorded files), the
    files are written (each atomically), the old files not written again are removed
    (unedited regular files only, and their folders when empty and the report's own), and
    the marker is rewritten with the new files and their digests.

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

    Raises
    ------
    ReportInputError
        The folder is not the report's own (:func:`check_tables_dir`); it holds a file
        the report would replace or remove that it did not write, or that was edited
        since; a file it replaces cannot be written (read-only, other hard links, ...).
    """
    folder = Path(folder)
    check_tables_dir(folder)
    tables = assign_csv(problems, folder.name)
    texts = {rel: csv_text(table) for rel, table in tables.items()}
    old, old_sha = _manifest(folder) if folder.is_dir() else ([], {})
    subdirs = sorted({rel.split("/")[0] + "/" for rel in tables})
    bad = _conflicts(folder, texts, subdirs, old, old_sha)
    if bad:
        _refuse(folder, bad)
    for rel in texts:  # read-only, hard-linked ...: refused before anything is written
        if os.path.lexists(folder / rel):
            writable_file(folder / rel, name="--out", error=ReportInputError)
    make_dir(folder, name="--out", error=ReportInputError)
    new_sha = {rel: {_sha(text)} for rel, text in texts.items()}
    both = {rel: old_sha.get(rel, set()) | new_sha.get(rel, set())
            for rel in {*old_sha, *new_sha}}
    new = [*subdirs, *texts]
    _write_marker(folder, old + new, both)
    written = []
    for rel, text in texts.items():
        path = folder / rel
        make_dir(path.parent, name="--out", error=ReportInputError)
        written.append(write_atomic(path, text, name="--out", error=ReportInputError))
    _remove_stale(folder, sorted(set(old) - set(new)), old_sha)
    _write_marker(folder, new, new_sha)
    return written
