"""The on-disk cache of problem outcomes, keyed by a hash of everything they depend on.

A problem's outcome (:class:`~workbench.app.report.runner.Outcome`: its document section,
figures as SVG text, status, cost) is stored as a pickle named after the problem, the mode
and the key. The key is the SHA-256 of

* the problem module's source and every shared helper of the catalogue (``_*.py`` beside
  it);
* the sources of the engine (``workbench/``, except the command line and the parts of the
  report that only lay out finished sections) and of ``models/``;
* quick or full mode, and the report's figure style;
* the versions of Python, casadi (which bundles Ipopt; the Ipopt library's file name is
  hashed too), numpy, scipy, sympy, python-control and matplotlib.

A problem without a source file (a catalogue built at run time) is never cached. Entries
are written under a unique temporary name in the cache folder and renamed into place; an
entry of the same problem and mode with another key is removed when the new one is
written (only files of this cache's own naming pattern are ever removed).

A cache folder is the report's own: one it created, an empty one, or the default
``reports/out/cache/``; it is marked with :data:`MARKER`. A folder that holds other files
and no marker is refused (the report would write ``timings.json`` into it, remove files
that look like its entries, and unpickle what it finds there).
"""

from __future__ import annotations

import hashlib
import os
import pickle
import re
import sys
import tempfile
from importlib import metadata
from pathlib import Path
from types import ModuleType
from typing import Any

from workbench.core.files import apply_umask, write_atomic

__all__ = ["STYLE_VERSION", "PARENT_ONLY", "MARKER", "problem_key", "engine_digest",
           "versions", "load", "store", "entry_path", "check_foreign", "claim"]

MARKER = ".workbench-report-cache"
"""The file that marks a folder as the report's cache."""

STYLE_VERSION = "report-style-2"
"""Changes whenever the figure style of the report changes (invalidates every entry)."""

ROOT = Path(__file__).resolve().parents[3]
"""The repository (``workbench/app/report/cache.py`` -> three levels up)."""

PARENT_ONLY = frozenset({
    "workbench/app/cli.py", "workbench/app/export_cli.py",
    "workbench/app/report/build.py", "workbench/app/report/runner.py",
    "workbench/app/report/cache.py", "workbench/app/report/html.py",
    "workbench/app/report/pdf.py", "workbench/app/report/frontpage.py",
    "workbench/app/report/progress.py", "workbench/app/report/csvfiles.py",
})
"""Sources that only schedule problems or lay out finished sections: not in the key."""

_PACKAGES = ("casadi", "numpy", "scipy", "sympy", "control", "matplotlib")
_NAME = re.compile(r"^(?P<name>[A-Za-z0-9_]+)-(?P<mode>quick|full)-(?P<key>[0-9a-f]{16})\.pkl$")


def versions() -> dict[str, str]:
    """Versions the cached results depend on (Python, casadi and Ipopt, numerics)."""
    out = {"python": sys.version.split()[0]}
    for pkg in _PACKAGES:
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "absent"
    try:
        import casadi

        libs = sorted(p.name for p in Path(casadi.__file__).parent.glob("*ipopt*"))
        out["ipopt"] = ",".join(libs) or "absent"
    except ImportError:
        out["ipopt"] = "absent"
    return out


def _sources(root: Path) -> list[Path]:
    files = sorted((root / "workbench").rglob("*.py")) + sorted((root / "models").rglob("*.py"))
    return [f for f in files if f.relative_to(root).as_posix() not in PARENT_ONLY]


def problem_key(module_file: str | os.PathLike | None, *, quick: bool,
                root: Path | None = None, engine: bytes | None = None) -> str | None:
    """The cache key of a problem, or None when it has no source file to hash.

    Parameters
    ----------
    module_file : path or None
        The problem module's source (its ``__file__``).
    quick : bool
        Quick or full mode.
    root : Path, optional
        The repository whose engine and models are hashed (default :data:`ROOT`).
    engine : bytes, optional
        :func:`engine_digest` of ``root`` when already computed (a report computes it
        once for all its problems).

    Returns
    -------
    str or None
        64 hexadecimal digits.
    """
    if not module_file or not Path(module_file).is_file():
        return None
    path = Path(module_file).resolve()
    root = ROOT if root is None else Path(root)
    h = hashlib.sha256()
    helpers = sorted(p for p in path.parent.glob("_*.py") if p.name != "__init__.py")
    for f in [path, *helpers]:
        h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    h.update(engine_digest(root) if engine is None else engine)
    h.update(f"quick={bool(quick)};style={STYLE_VERSION}".encode())
    for k, v in sorted(_versions().items()):
        h.update(f"{k}={v};".encode())
    return h.hexdigest()


def engine_digest(root: Path | None = None) -> bytes:
    """SHA-256 of the engine's and the models' sources (their part of every key).

    Computed once per report and passed to :func:`problem_key` as ``engine``, so the ~30
    problems of a report do not each read the ~200 sources again.
    """
    root = ROOT if root is None else Path(root)
    h = hashlib.sha256()
    for f in _sources(root):  # the path inside the repository: a moved module changes it
        h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    return h.digest()


_VERSIONS: dict[str, str] = {}


def _versions() -> dict[str, str]:
    """:func:`versions`, looked up once per process (installed packages do not change)."""
    if not _VERSIONS:
        _VERSIONS.update(versions())
    return _VERSIONS


def check_foreign(cache_dir: Path, *, default: Path | None = None) -> None:
    """Refuse a ``--cache`` folder that holds files and is not the report's own cache.

    Parameters
    ----------
    cache_dir : Path
        The folder (it may not exist yet).
    default : Path, optional
        The default cache folder, the report's own even without a marker (made by
        versions before the marker).

    Raises
    ------
    ReportInputError
        The folder holds files and neither carries :data:`MARKER` nor is ``default``.
    """
    from workbench.app.report.errors import ReportInputError

    path = Path(cache_dir)
    if not path.is_dir() or (path / MARKER).is_file():
        return
    if default is not None and path.resolve() == Path(default).resolve():
        return
    others = sorted(p.name for p in path.iterdir())
    if others:
        raise ReportInputError(
            f"--cache: {str(path)!r} holds files the report did not write "
            f"({', '.join(others[:5])}{', ...' if len(others) > 5 else ''}) and is not a "
            f"report cache (no {MARKER}); the cache writes and removes files in its folder: "
            "give a new or empty folder")


def claim(cache_dir: Path) -> None:
    """Mark an existing folder (checked by :func:`check_foreign`) as the report's cache."""
    marker = Path(cache_dir) / MARKER
    if not marker.is_file():
        write_atomic(marker, "workbench report cache: its entries are written and removed by "
                             "'workbench report'\n", name="--cache")


def entry_path(cache_dir: Path, name: str, *, quick: bool, key: str) -> Path:
    """Where the outcome of ``name`` with ``key`` is stored."""
    return Path(cache_dir) / f"{name}-{'quick' if quick else 'full'}-{key[:16]}.pkl"


def load(cache_dir: Path, name: str, *, quick: bool, key: str) -> Any | None:
    """The stored outcome, or None when absent, unreadable or of another key."""
    path = entry_path(cache_dir, name, quick=quick, key=key)
    try:
        with path.open("rb") as fh:
            stored_key, outcome = pickle.load(fh)
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError,
            ValueError, TypeError):
        return None
    return outcome if stored_key == key else None


def store(cache_dir: Path, name: str, outcome: Any, *, quick: bool, key: str) -> Path:
    """Store an outcome atomically; drop this cache's older entries of the same problem."""
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    path = entry_path(cache_dir, name, quick=quick, key=key)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial", dir=cache_dir)
    try:
        with os.fdopen(fd, "wb") as fh:
            pickle.dump((key, outcome), fh, protocol=pickle.HIGHEST_PROTOCOL)
        apply_umask(tmp)  # mkstemp made it 0600
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    mode = "quick" if quick else "full"
    for old in cache_dir.iterdir():
        m = _NAME.match(old.name)
        if m and m["name"] == name and m["mode"] == mode and old != path:
            old.unlink(missing_ok=True)
    return path


def module_file(module: ModuleType) -> str | None:
    """The source file of a problem module, if it has one."""
    f = getattr(module, "__file__", None)
    return f if f and f.endswith(".py") else None
