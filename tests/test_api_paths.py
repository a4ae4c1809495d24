"""Every module path and name the docs show imports; the paths of 0.1.0 behave as promised.

The docs: each ``import`` / ``from ... import`` of README.md's and docs/*.md's python blocks,
and each dotted ``workbench.*``, ``models.*``, ``problems.*`` name in their text, is imported
(or reached by attribute, as a reader would: ``workbench.simulate`` is the function). None
may go through a deprecated path, and none may warn.

The paths of 0.1.0 (``workbench/_moved.py``, recorded in CHANGELOG.md): a deprecated path
warns once per import with a DeprecationWarning naming its new home, attributed to the
importing line (so a script shows it by default), and gives exactly the names its module
exported in 0.1.0, as the same objects; a documented alias is the room's own module, and so
are its submodules, without a warning; a path that cannot return fails with an error naming
the new home. Where the repository's history is present, the 0.1.0 modules themselves are
read from it (``git show``) to check that every one of them is accounted for.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from workbench import _moved

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: The last commit of the flat layout, released as 0.1.0 (CHANGELOG.md).
V010 = "43c5914"
DOTTED = re.compile(r"(?<![\w./-])((?:workbench|models|problems)(?:\.[A-Za-z_]\w*)+)")


def _doc_paths() -> dict[str, str]:
    """{dotted path: where the docs show it} (import lines of python blocks, dotted names)."""
    found: dict[str, str] = {}
    for page in PAGES:
        text = page.read_text()
        for block in re.findall(r"```python\n(.*?)```", text, flags=re.S):
            for node in ast.walk(ast.parse(block)):
                if isinstance(node, ast.Import):
                    found.update({a.name: f"{page.name}: import {a.name}" for a in node.names})
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    for a in node.names:
                        found[f"{node.module}:{a.name}"] = (
                            f"{page.name}: from {node.module} import {a.name}")
        for lineno, line in enumerate(text.splitlines(), start=1):
            for name in DOTTED.findall(line):
                # an upper-case module is a placeholder (``python -m problems.NAME``)
                if not name.split(".")[1].isupper():
                    found.setdefault(name, f"{page.name}:{lineno}")
    return {k: v for k, v in found.items()
            if k.split(".")[0].split(":")[0] in ("workbench", "models", "problems")}


DOC_PATHS = _doc_paths()


def _reach(path: str):
    """The object at a dotted path (``a.b:name`` is ``from a.b import name``), as Python does.

    ``import a.b.c`` imports each module; a dotted name in prose is reached by attribute
    where the attribute exists (``workbench.simulate`` is the function) and imported where it
    does not (a submodule).
    """
    if ":" in path:
        module, name = path.split(":")
        obj = importlib.import_module(module)
        if not hasattr(obj, name):
            return importlib.import_module(f"{module}.{name}")
        return getattr(obj, name)
    parts = path.split(".")
    obj = importlib.import_module(parts[0])
    for i, part in enumerate(parts[1:], start=1):
        if hasattr(obj, part):
            obj = getattr(obj, part)
        else:
            obj = importlib.import_module(".".join(parts[: i + 1]))
    return obj


def _deprecated(path: str) -> str | None:
    """The deprecated path that ``path`` goes through, if any."""
    parts = path.replace(":", ".").split(".")
    return next((p for p in (".".join(parts[:k]) for k in range(len(parts), 0, -1))
                 if p in _moved.DEPRECATED), None)


def _moved_warnings(record: list[warnings.WarningMessage]) -> list[str]:
    return [str(w.message) for w in record if issubclass(w.category, DeprecationWarning)
            and str(w.message).startswith("workbench.")]


def _fresh_import(path: str) -> tuple[object, list[str]]:
    """Import ``path`` as if for the first time; the deprecation messages it issued."""
    for name in [n for n in sys.modules if n == path or n.startswith(path + ".")]:
        if name in _moved.DEPRECATED:  # only shims: a second copy of a real module would differ
            del sys.modules[name]
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        module = importlib.import_module(path)
    return module, _moved_warnings(record)


def test_the_docs_show_paths():
    """The parser finds the docs' imports and names (a broken parser would test nothing)."""
    assert "workbench:simulate" in DOC_PATHS and "models.chain_cart:link_state" in DOC_PATHS
    assert "workbench.mechanics" in DOC_PATHS and "workbench.linear.symbolic" in DOC_PATHS
    assert len(DOC_PATHS) > 40, sorted(DOC_PATHS)


@pytest.mark.parametrize("path", sorted(DOC_PATHS))
def test_every_path_the_docs_show_imports_without_a_warning(path):
    where = DOC_PATHS[path]
    assert _deprecated(path) is None, (
        f"{where} shows {path}, a deprecated path: show its new home "
        f"({_moved.DEPRECATED[_deprecated(path)][0]})")
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        try:
            _reach(path)
        except (ImportError, AttributeError) as exc:
            pytest.fail(f"{where} shows {path}, which does not import: {exc}")
    assert not _moved_warnings(record), (where, _moved_warnings(record))


# -- the paths of 0.1.0 -------------------------------------------------------------------


@pytest.mark.parametrize("path", sorted(_moved.DEPRECATED))
def test_a_deprecated_path_warns_and_gives_its_old_names(path):
    new = _moved.DEPRECATED[path][0]
    if "." in path.removeprefix("workbench."):  # a submodule: its parent warns on its own
        _fresh_import(path.rsplit(".", 1)[0])
    module, messages = _fresh_import(path)
    assert len(messages) == 1, messages
    assert messages[0].startswith(f"{path} is deprecated") and f"import from {new}" in messages[0]
    assert _moved.REMOVED_IN in messages[0]
    sources = _moved._sources(path)
    assert module.__all__ == [old for old, _, _ in sources]
    for old, source, attr in sources:
        assert getattr(module, old) is getattr(importlib.import_module(source), attr), old
        if source != new or attr != old:
            assert f"{old} is {source}.{attr}" in messages[0]


def test_the_warning_names_the_importing_line_so_a_script_shows_it():
    """Attributed to ``__main__``: Python's default filters show it without -W."""
    run = subprocess.run([sys.executable, "-c", "from workbench.poincare import poincare_map"],
                         capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "<string>:1: DeprecationWarning: workbench.poincare is deprecated" in run.stderr
    assert "import from workbench.global_dynamics" in run.stderr
    strict = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c",
                             "import workbench.model"], capture_output=True, text=True,
                            cwd=ROOT, timeout=300)
    assert strict.returncode != 0 and "workbench.model is deprecated" in strict.stderr


@pytest.mark.parametrize("alias", sorted(_moved.ALIASES))
def test_a_documented_alias_and_its_submodules_are_the_rooms_own_modules(alias):
    target = importlib.import_module(_moved.ALIASES[alias])
    names = [alias]
    if hasattr(target, "__path__"):
        names += [f"{alias}.{m.name}" for m in pkgutil.iter_modules(target.__path__)]
    for name in names:
        real = name.replace(alias, _moved.ALIASES[alias], 1)
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            module = importlib.import_module(name)
        assert module is importlib.import_module(real), name
        assert sys.modules[name] is sys.modules[real]
        assert not _moved_warnings(record), (name, _moved_warnings(record))


def test_a_class_through_an_alias_is_the_class():
    """``import workbench.manifolds.factors`` once loaded a second copy of the module."""
    from workbench.manifolds.factors import S2
    from workbench.ocp.problem import OCP

    import workbench

    assert S2 is workbench.S2 and isinstance(S2(), workbench.core.manifolds.S2)
    assert OCP is workbench.OCP
    assert workbench.core.manifolds.factors is sys.modules["workbench.core.manifolds.factors"]


@pytest.mark.parametrize("path", sorted(_moved.GONE))
def test_a_path_that_cannot_return_says_where_its_names_went(path):
    why, new, names = _moved.GONE[path]
    if path in _moved._ROOT_NAMES:
        with pytest.raises(ImportError, match="from 'workbench'") as err:
            exec(f"from workbench import {path.rsplit('.', 1)[1]}", {})
    else:
        with pytest.raises(ModuleNotFoundError) as err:
            importlib.import_module(path)
        assert err.value.name == path
    assert new in str(err.value) and _moved.MOVED_IN in str(err.value)
    home = importlib.import_module(new)
    for name in names.split():
        assert name in str(err.value) and hasattr(home, name), name
    if why == _moved._FUNCTION:
        import workbench

        assert callable(getattr(workbench, path.rsplit(".", 1)[1]))  # still the function


def test_other_workbench_paths_are_left_to_python():
    with pytest.raises(ModuleNotFoundError, match="No module named 'workbench.no_such'") as err:
        importlib.import_module("workbench.no_such")
    assert err.value.name == "workbench.no_such"


def test_the_changelog_records_every_moved_path():
    text = (ROOT / "CHANGELOG.md").read_text()
    unreleased = text[text.index("## [Unreleased]"):text.index("## [0.1.0]")]
    deprecated = unreleased[unreleased.index("### Deprecated"):unreleased.index("### Removed")]
    removed = unreleased[unreleased.index("### Removed"):unreleased.index("### Fixed")]
    assert _moved.REMOVED_IN in deprecated
    for path in _moved.DEPRECATED:  # a submodule goes with its package ("and its submodules")
        short = path.split(".")[1]
        assert f"`.{short}`" in deprecated or f"`workbench.{short}`" in deprecated, path
    for path in _moved.GONE:
        assert f"`{path}`" in removed, path
    for alias in _moved.ALIASES:
        assert f"`{alias}`" in deprecated, alias


def test_code_and_docs_cite_no_tracker_issue():
    """History lives in CHANGELOG.md: a user cannot open the tracker an "issue 18" points to.

    Docstrings and comments say what the code does and why.
    """
    cite = re.compile(r"\b[Ii]ssues?\s*#?\s*\d+")
    files = [p for folder in ("workbench", "models", "problems")
             for p in sorted((ROOT / folder).rglob("*.py"))] + PAGES
    found = [f"{p.relative_to(ROOT)}:{i}: {line.strip()}" for p in files
             for i, line in enumerate(p.read_text().splitlines(), start=1) if cite.search(line)]
    assert not found, "tracker issues cited (say what and why instead):\n" + "\n".join(found)


# -- against the 0.1.0 sources, where the history is present -------------------------------


def _git(*args: str) -> str | None:
    try:
        run = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True,
                             timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return run.stdout if run.returncode == 0 else None


def _v010_modules() -> dict[str, list[str]]:
    """{module path: its ``__all__``} of every module of 0.1.0 (empty without the history)."""
    files = _git("ls-tree", "-r", "--name-only", V010, "workbench")
    if files is None:
        return {}
    modules = {}
    for f in files.split():
        if f.endswith(".py"):
            tree = ast.parse(_git("show", f"{V010}:{f}") or "")
            exported = next((ast.literal_eval(n.value) for n in tree.body
                             if isinstance(n, ast.Assign)
                             and any(getattr(t, "id", "") == "__all__" for t in n.targets)),
                            [])
            modules[f[:-3].replace("/", ".").removesuffix(".__init__")] = exported
    return modules


V010_MODULES = _v010_modules()
needs_history = pytest.mark.skipif(not V010_MODULES,
                                   reason=f"the 0.1.0 commit {V010} is not in this clone")


@needs_history
def test_every_public_module_of_010_is_accounted_for():
    """Still there, a silent alias, deprecated, or gone with an error: none just vanished."""
    lost = []
    for path, exported in V010_MODULES.items():
        if any(p.startswith("_") for p in path.split(".")) or path == "workbench":
            continue
        if path in _moved.DEPRECATED or path in _moved.GONE or _moved._alias_target(path):
            continue
        module = importlib.import_module(path)
        if missing := [n for n in exported if not hasattr(module, n)]:
            lost.append(f"{path}: {missing}")
    assert not lost, lost


@needs_history
@pytest.mark.parametrize("path", sorted(_moved.DEPRECATED))
def test_a_shim_exports_exactly_what_its_module_exported_in_010(path):
    assert [old for old, _, _ in _moved._sources(path)] == V010_MODULES[path]


@needs_history
def test_the_gone_paths_list_what_they_exported_in_010():
    for path, (_, _, names) in _moved.GONE.items():
        exported = (V010_MODULES[path] if path not in _moved._ROOT_NAMES
                    else [path.rsplit(".", 1)[1]])
        assert sorted(names.split()) == sorted(exported), path
