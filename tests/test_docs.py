"""The documentation in the repository: every relative link resolves, every python block runs.

Links: every Markdown link ``[text](target)`` of README.md and docs/*.md whose target is
not a URL must name a file or directory of the repository (``#anchors`` are checked
against the target's headings). Code: every fenced ``python`` block of README.md and
docs/*.md runs as it stands in a fresh interpreter (they import only from ``workbench`` and
``models``). The Markdown files that the code names (in notes and sources the report
shows, e.g. ``docs/science.md`` for the errata) exist.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = sorted((ROOT / "docs").glob("*.md"))
PAGES = [ROOT / "README.md", *DOCS]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def anchors(page: Path) -> set[str]:
    """GitHub-style anchors of a Markdown page's headings."""
    out = set()
    for line in page.read_text(encoding="utf-8").splitlines():
        m = re.match(r"^#+\s+(.*)$", line)
        if m:
            slug = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
            out.add(slug)
    return out


def links(page: Path) -> list[str]:
    text = page.read_text(encoding="utf-8")
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)  # not inside code blocks
    return LINK.findall(text)


SOURCES = [p for d in ("workbench", "problems", "models", "tests")
           for p in sorted((ROOT / d).rglob("*.py"))]
MD_PATH = re.compile(r"(?<![\w/.])((?:[\w-]+/)*[\w-]+\.md)\b")


def test_markdown_files_named_in_the_code_exist():
    """A note such as "errata applied (docs/science.md)" must point at a file of a clone."""
    bad = []
    for src in SOURCES:
        for m in MD_PATH.finditer(src.read_text(encoding="utf-8")):
            path = m.group(1)
            if "/" in path and not (ROOT / path).exists():
                bad.append(f"{src.relative_to(ROOT)}: {path}")
    assert not bad, f"Markdown files named but missing: {bad}"


def test_docs_exist_and_are_indexed():
    names = {p.name for p in DOCS}
    assert {"README.md", "conventions.md", "user-guide.md", "science.md"} <= names
    index = links(ROOT / "docs" / "README.md")
    for page in DOCS:
        if page.name != "README.md":
            assert page.name in index, f"docs/README.md does not link {page.name}"


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(ROOT).as_posix() for p in PAGES])
def test_relative_links_resolve(page):
    bad = []
    for target in links(page):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        path_part, _, anchor = target.partition("#")
        dest = page if not path_part else (page.parent / path_part).resolve()
        if not dest.exists():
            bad.append(f"{target} (no such file)")
            continue
        if not dest.resolve().is_relative_to(ROOT):
            bad.append(f"{target} (outside the repository)")
            continue
        if anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            bad.append(f"{target} (no heading #{anchor})")
    assert not bad, f"{page.relative_to(ROOT)}: broken links {bad}"


BLOCKS = [(page, i, code) for page in PAGES for i, code in enumerate(FENCE.findall(
    page.read_text(encoding="utf-8")))]


def test_the_docs_have_code_to_run():
    pages = {p.name for p, _, _ in BLOCKS}
    assert {"conventions.md", "user-guide.md"} <= pages


KNOWN_BROKEN: dict[tuple[str, int], str] = {}


def _block_params():
    for page, i, code in BLOCKS:
        reason = KNOWN_BROKEN.get((page.name, i))
        marks = [pytest.mark.xfail(strict=False, reason=reason)] if reason else []
        yield pytest.param(page, i, code, id=f"{page.name}-{i}", marks=marks)


@pytest.mark.parametrize("page, index, code", list(_block_params()))
def test_python_block_runs(page, index, code, tmp_path):
    for line in code.splitlines():
        m = re.match(r"\s*(?:from|import)\s+([\w.]+)", line)
        if m and m.group(1).split(".")[0] in ("workbench", "models"):
            mod = m.group(1)
            assert mod == "workbench" or mod.startswith("models"), (
                f"{page.name} block {index} imports {mod}: docs import only from "
                f"'workbench' or 'models'")
    env = {**os.environ, "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, (
        f"{page.name} python block {index} failed:\n{proc.stderr[-3000:]}")
