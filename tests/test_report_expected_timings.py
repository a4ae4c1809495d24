"""The timings shipped with the code cover every problem, so a first report is planned.

A report whose cache has no timings yet (a fresh clone) starts the longest problems first
and packs them by memory from ``workbench/app/report/expected_timings.json``; a problem
missing there would be started last and counted as free of memory.
"""

from __future__ import annotations

import json

from workbench.app import registry
from workbench.app.report.runner import EXPECTED_TIMINGS, _read_timings


def test_every_problem_has_expected_seconds_and_memory_in_both_modes():
    data = json.loads(EXPECTED_TIMINGS.read_text())
    for name in registry.names():
        for mode in ("quick", "full"):
            assert data[f"{mode}/{name}"] > 0, (mode, name)
            assert data[f"{mode}/{name}/peak_mb"] > 50, (mode, name)
    unknown = {k.split("/")[1] for k in data} - set(registry.names())
    assert not unknown, f"timings of problems that no longer exist: {sorted(unknown)}"


def test_measured_timings_take_precedence(tmp_path):
    (tmp_path / "timings.json").write_text(json.dumps({"quick/chain_lqr": 123.0}))
    merged = {**_read_timings(None, path=EXPECTED_TIMINGS), **_read_timings(tmp_path)}
    assert merged["quick/chain_lqr"] == 123.0
    assert merged["full/chain_lqr"] == json.loads(EXPECTED_TIMINGS.read_text())["full/chain_lqr"]
