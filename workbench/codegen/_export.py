"""Write generated C sources to a user directory without ever leaving a partial export.

:func:`export` writes every file to a temporary directory first, then renames it into
place (or replaces file by file in an existing directory). Into an existing directory it
replaces only what an earlier export wrote and nobody edited since, as recorded in
:data:`MANIFEST`; anything else under one of its names stops it before anything is
written, with :class:`ExportError`. Re-exported by :mod:`workbench.codegen.build`.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path

from workbench.codegen.csource import CSources
from workbench.core.errors import WorkbenchError
from workbench.core.files import apply_umask

__all__ = ["MANIFEST", "ExportError", "export"]


class ExportError(WorkbenchError, ValueError):
    """The output directory of an export cannot be used (missing, not writable, a file)."""


def _writable_target(out_dir: Path) -> Path:
    """Check ``out_dir`` can receive the export; return the directory for the temp dir."""
    if out_dir.exists() and not out_dir.is_dir():
        raise ExportError(f"output directory {str(out_dir)!r} exists and is not a directory; "
                          f"expected a directory (it is created if missing)")
    parent = out_dir if out_dir.is_dir() else out_dir.parent
    if not parent.is_dir():
        raise ExportError(f"output directory {str(out_dir)!r} cannot be created: its parent "
                          f"{str(parent)!r} is not an existing directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ExportError(f"output directory {str(out_dir)!r} is not writable: no write "
                          f"permission on {str(parent)!r}")
    return parent


def _temp_dir(parent: Path, prefix: str, out_dir: Path) -> Path:
    try:
        tmp = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
        apply_umask(tmp, directory=True)  # renamed into place: the user's umask, not 0700
        return tmp
    except OSError as exc:
        raise ExportError(f"output directory {str(out_dir)!r} is not writable: cannot "
                          f"create files in {str(parent)!r} ({exc.strerror})") from exc


MANIFEST = ".workbench-export.json"
"""Written with every export: the files it wrote and their SHA-256, so that a later export
into the same directory replaces only those (and only if nobody edited them)."""


def _sha(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def _conflicts(sources: CSources, out: Path) -> list[str]:
    """Names the export would replace (or its Makefile remove) that it did not write.

    Also those written by an earlier export and edited since.
    """
    if not out.is_dir():
        return []
    try:
        old = json.loads((out / MANIFEST).read_text())
        written = dict(old["sha256"])
        products = set(old["products"])
    except (OSError, ValueError, KeyError, TypeError):
        written, products = {}, set()
    bad = []
    for name in (*sources.files, *sources.products, MANIFEST):
        target = out / name
        if not os.path.lexists(target):
            continue
        if target.is_symlink() or target.is_dir():
            bad.append(f"{name} (a {'link' if target.is_symlink() else 'directory'})")
        elif name == MANIFEST and written:
            continue
        elif name in sources.products and name in products:
            continue  # built by the Makefile of an earlier export
        elif name not in written or _sha(target) != written[name]:
            bad.append(name)
    return bad


def export(sources: CSources, out_dir: str | os.PathLike) -> list[Path]:
    """Write the sources to ``out_dir`` without ever leaving a partial export.

    The files are written to a temporary directory first. If ``out_dir`` does not exist,
    that directory is renamed to it (one atomic step); otherwise each file replaces its
    namesake atomically, after all were written. Into an existing directory the export
    replaces only files an earlier export wrote there and nobody edited since (recorded
    in :data:`MANIFEST`); any other file with the name of one of its files, or of what its
    Makefile builds and ``make clean`` removes, stops it before anything is written.

    Parameters
    ----------
    sources : CSources
        The sources (compile them first with :func:`compile_sources` to check them).
    out_dir : path-like
        Output directory; created if missing (its parent must exist).

    Returns
    -------
    list of Path
        The written files (the sources and :data:`MANIFEST`).

    Raises
    ------
    ExportError
        ``out_dir`` is a file, its parent is missing, it is not writable, or it holds files
        the export did not write under the names it would use.
    """
    out = Path(out_dir)
    parent = _writable_target(out)
    bad = _conflicts(sources, out)
    if bad:
        raise ExportError(
            f"output directory {str(out)!r} holds files this export did not write (or that "
            f"were edited since): {bad}; it would replace them (or its Makefile's clean would "
            "remove them). Export to a new or empty directory, or move them away")
    manifest = {"name": sources.name, "digest": sources.digest,
                "sha256": {f: hashlib.sha256(t.encode()).hexdigest()
                           for f, t in sources.files.items()},
                "products": list(sources.products)}
    files = {**sources.files, MANIFEST: json.dumps(manifest, indent=1) + "\n"}
    tmp = _temp_dir(parent, f".{sources.name}-export-", out)
    try:
        for fname, text in files.items():
            (tmp / fname).write_text(text, encoding="utf-8")
        renamed = False
        if not out.exists():
            try:
                os.rename(tmp, out)
                renamed = True
            except OSError:  # another process created it meanwhile: replace file by file
                if not out.is_dir():
                    raise
        if not renamed:
            for fname in files:
                os.replace(tmp / fname, out / fname)
    except OSError as exc:
        raise ExportError(f"cannot write the export to {str(out)!r} ({exc.strerror})") from exc
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return [out / f for f in files]
