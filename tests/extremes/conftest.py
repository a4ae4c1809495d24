"""The hostile pass's summary: every entry point with its number of draws and failures."""

from __future__ import annotations

import sys
from typing import Any


def pytest_terminal_summary(terminalreporter: Any) -> None:
    """Print the draw count per entry point after the hostile pass ran."""
    # the module as pytest imported it (its name depends on the rootdir and import mode)
    found = [m for n, m in list(sys.modules.items())
             if n.endswith("test_hostile") and getattr(m, "DRAWN", None)]
    if not found:
        return
    hostile = found[0]
    tr = terminalreporter
    tr.section("hostile pass: draws per public entry point")
    total = sum(hostile.DRAWN.values())
    bad = sum(len(v) for v in hostile.FAILURES.values())
    for name in sorted(hostile.DRAWN):
        fails = len(hostile.FAILURES.get(name, []))
        tr.write_line(f"{name:48s} {hostile.DRAWN[name]:4d} draws (of "
                      f"{hostile.SPACE.get(name, 0):3d} in its grammar), {fails} failures")
    tr.write_line(f"{len(hostile.DRAWN)} entry points, {total} draws, {bad} failures "
                  f"(silent or raw-library); {len(hostile.EXCLUDED)} public names excluded "
                  f"with reasons")
