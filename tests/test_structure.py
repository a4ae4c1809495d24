"""The code's structure: layers, private modules, room sizes, complexity (issue 14).

These are checks of the source tree, not of mathematics; each reads the code afresh, so a
change that breaks the structure fails here.
"""

from __future__ import annotations

import ast
import re
import statistics
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
ROOMS = ("core", "mechanics", "simulation", "linear", "equilibria", "global_dynamics",
         "control", "codegen", "study", "app")


def _python_files(*folders: str) -> list[Path]:
    return sorted(p for f in folders for p in (ROOT / f).rglob("*.py"))


def _code_lines(path: Path) -> int:
    """Lines of code: not blank, not comments, not docstrings."""
    tree = ast.parse(path.read_text())
    doc_lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                    and isinstance(body[0].value.value, str):
                doc_lines.update(range(body[0].lineno, body[0].end_lineno + 1))
    count = 0
    for i, line in enumerate(path.read_text().splitlines(), start=1):
        s = line.strip()
        if s and not s.startswith("#") and i not in doc_lines:
            count += 1
    return count


def _imported_modules(source: str) -> list[str]:
    mods = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            mods.append(node.module)
            mods += [f"{node.module}.{a.name}" for a in node.names
                     if node.module.startswith("workbench") and a.name.startswith("_")]
        elif isinstance(node, ast.Import):
            mods += [a.name for a in node.names]
    return mods


def _private(module: str) -> bool:
    return module.split(".")[0] == "workbench" and any(
        part.startswith("_") for part in module.split(".")
    )


def test_layering_contract_holds():
    """import-linter: app above problems above models above the engine's rooms (downward)."""
    config = (ROOT / "pyproject.toml").read_text()
    for layer in ('"workbench.app"', '"problems"', '"models"', '"workbench.core"'):
        assert layer in config, f"layer {layer} missing from the contract"
    run = subprocess.run([str(BIN / "lint-imports")], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert "0 broken" in run.stdout


@pytest.mark.parametrize("folder", ["problems", "models", "benchmarks"])
def test_users_code_imports_no_private_module(folder):
    """problems, models and benchmarks use the root API or a room's public package only."""
    bad = [
        f"{p.relative_to(ROOT)}: {m}"
        for p in _python_files(folder)
        for m in _imported_modules(p.read_text())
        if _private(m)
    ]
    assert not bad, "private modules imported:\n" + "\n".join(bad)


def test_docs_and_readme_import_no_private_module():
    """The python blocks of README.md and docs/ import only public modules."""
    texts = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    bad = []
    for path in texts:
        for block in re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S):
            bad += [f"{path.name}: {m}" for m in _imported_modules(block) if _private(m)]
    assert not bad, bad


def test_engine_has_rooms_not_a_flat_folder():
    """At most ~12 top-level entries under workbench/, each room a package."""
    entries = [p.name for p in (ROOT / "workbench").iterdir() if p.name != "__pycache__"]
    assert len(entries) <= 12, sorted(entries)
    for p in (ROOT / "workbench").iterdir():
        if p.is_dir() and p.name != "__pycache__":
            assert p.name in ROOMS, f"unexpected room {p.name}"
            assert (p / "__init__.py").exists(), f"room {p.name} is not a package"


def test_no_module_over_600_lines():
    big = [
        (str(p.relative_to(ROOT)), n)
        for p in _python_files("workbench", "models", "problems")
        if (n := len(p.read_text().splitlines())) > 600
    ]
    assert not big, big


def test_no_function_over_complexity_20():
    """ruff's C901 (mccabe) at 20, as configured in pyproject.toml."""
    run = subprocess.run(
        [str(BIN / "ruff"), "check", "--select", "C901", "--output-format", "concise",
         "workbench", "models", "problems"],
        cwd=ROOT, capture_output=True, text=True,
    )
    assert run.returncode == 0, run.stdout[-3000:]


def test_problems_are_short_define_and_solve_scripts():
    """Median problem length <= 100 code lines (docstrings and comments not counted)."""
    lengths = {p.stem: _code_lines(p) for p in _python_files("problems")
               if not p.name.startswith("_")}
    assert statistics.median(lengths.values()) <= 100, sorted(lengths.items(), key=lambda kv: kv[1])


def test_code_line_counter_counts_code_only(tmp_path):
    f = tmp_path / "m.py"
    f.write_text('"""Doc\n\nmore doc."""\n\n# comment\nx = 1\n\n\ndef f():\n    """Doc."""\n'
                 "    return x\n")
    assert _code_lines(f) == 3
