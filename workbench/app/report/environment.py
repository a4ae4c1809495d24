"""The environment a report was made in: date, machine, Python and package versions, commit."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

__all__ = ["environment", "PACKAGES"]

PACKAGES = ("casadi", "numpy", "scipy", "sympy", "control", "matplotlib", "jinja2", "typst",
            "tqdm")
"""Distributions whose versions the report lists."""


def _git(root: Path, *args: str) -> str:
    try:
        out = subprocess.run(["git", *args], cwd=root, capture_output=True, text=True,
                             timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return ""
    return out.stdout.strip() if out.returncode == 0 else ""


def environment(*, root: Path | None = None) -> list[tuple[str, str]]:
    """What the report was made with, as ``(item, value)`` pairs.

    Parameters
    ----------
    root : Path, optional
        The repository (for the commit); default: the directory above ``workbench``.

    Returns
    -------
    list of (str, str)
    """
    root = root or Path(__file__).resolve().parents[3]
    now = _dt.datetime.now(_dt.UTC).astimezone()
    rows = [
        ("date", now.isoformat(timespec="seconds")),
        ("python", f"{platform.python_implementation()} {platform.python_version()}"),
        ("platform", platform.platform()),
        ("cpus", str(os.cpu_count())),
    ]
    for dist in PACKAGES:
        try:
            rows.append((dist, metadata.version(dist)))
        except metadata.PackageNotFoundError:
            rows.append((dist, "not installed"))
    commit = _git(root, "rev-parse", "--short=12", "HEAD")
    if commit:
        dirty = _git(root, "status", "--porcelain", "--untracked-files=no")
        rows.append(("commit", commit + (" (with uncommitted changes)" if dirty else "")))
    return rows
