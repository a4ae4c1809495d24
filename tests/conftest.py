"""Shared test helpers: one allclose with explicit tolerances (``ulps`` for rounding-level
ones), seeded generators; the skips
of the report tests whose tools (Chromium, poppler-utils) are not installed."""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

import numpy as np
import pytest


def assert_close(actual, expected, *, atol: float, rtol: float = 0.0, what: str = "") -> None:
    """The suite's single allclose: explicit tolerances, and the worst deviation on failure."""
    a, e = np.asarray(actual), np.asarray(expected)
    # complex stays complex (spectra): |a - e| then measures both parts
    kind = complex if np.iscomplexobj(a) or np.iscomplexobj(e) else float
    a, e = a.astype(kind), e.astype(kind)
    assert a.shape == e.shape, f"{what}: shape {a.shape} != {e.shape}"
    dev = np.abs(a - e)
    bound = atol + rtol * np.abs(e)
    worst = float(np.max(dev - bound)) if dev.size else -1.0
    assert np.all(dev <= bound), (
        f"{what}: max deviation {float(np.max(dev)):.3e} exceeds atol={atol:g}, rtol={rtol:g} "
        f"(by {worst:.3e})"
    )


def ulps(n: float, data) -> float:
    """``n`` units in the last place of the data's magnitude (its largest absolute entry).

    The absolute tolerance of a result that only rounding separates from its exact value:
    stated as a count of ulps of the numbers involved, it holds at every magnitude, where a
    fixed ``atol=1e-15`` is 4.5 ulps of 1.0 and less than one of 8.0.
    """
    return n * float(np.spacing(np.max(np.abs(np.asarray(data, dtype=float)))))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


# -- the report's tools from the distribution ----------------------------------------------
# Chromium (screenshots of the HTML report) and poppler-utils (pdftoppm, pdftotext, pdfinfo:
# the PDF's pages and text) are Debian packages, not Python ones: `make test-deps` installs
# them with apt-get. Where they are missing, every test that needs one is skipped with the
# same reason naming what to install, which pytest's summary prints as one line. A test needs
# a tool when it, a fixture it uses, or a module-level helper either calls, calls
# ``need("tool")`` (the helper that fails the test when the tool is missing).
TOOL_PACKAGES = {"chromium": "chromium", "pdftoppm": "poppler-utils",
                 "pdftotext": "poppler-utils", "pdfinfo": "poppler-utils"}
_MISSING = sorted(tool for tool in TOOL_PACKAGES if shutil.which(tool) is None)


def _tools_of_helpers(module) -> dict[str, set[str]]:
    """{module-level function: the tools it needs, directly or through other functions}."""
    tree = ast.parse(Path(module.__file__).read_text())
    direct, calls = {}, {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            called = [c for c in ast.walk(node) if isinstance(c, ast.Call)
                      and isinstance(c.func, ast.Name)]
            direct[node.name] = {c.args[0].value for c in called if c.func.id == "need" and c.args
                                 and isinstance(c.args[0], ast.Constant)}
            calls[node.name] = {c.func.id for c in called}
    changed = True
    while changed:  # through helpers that call helpers
        changed = False
        for name, callees in calls.items():
            more = set().union(*(direct.get(c, set()) for c in callees)) - direct[name]
            if more:
                direct[name] |= more
                changed = True
    return direct


_NEEDS_MISSING: set[str] = set()  # node ids of the tests that need a missing tool


def pytest_collection_modifyitems(config, items):
    if not _MISSING:
        return
    helpers: dict[str, dict[str, set[str]]] = {}
    for item in items:
        module = getattr(item, "module", None)
        if module is None or not hasattr(module, "need"):
            continue
        tools = helpers.setdefault(module.__name__, _tools_of_helpers(module))
        used = {getattr(item, "originalname", item.name), *item.fixturenames}
        if set().union(*(tools.get(name, set()) for name in used)) & set(_MISSING):
            _NEEDS_MISSING.add(item.nodeid)


def pytest_runtest_setup(item):
    """Skipped here, before the fixtures are built, from one place: one line in the summary."""
    if item.nodeid in _NEEDS_MISSING:
        packages = sorted({TOOL_PACKAGES[t] for t in _MISSING})
        pytest.skip(f"{', '.join(_MISSING)} not found: install Debian's {' and '.join(packages)} "
                    f"(`make test-deps` does, as root) to run the report's browser and PDF tests")
