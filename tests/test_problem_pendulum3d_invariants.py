"""The foundation problem runs in quick mode, meets its tolerances and reports what it built."""

from __future__ import annotations

import json

from problems.pendulum3d_invariants import solve
from workbench.app.registry import load, names


def test_quick_run_meets_every_comparison(tmp_path):
    res = solve(quick=True)
    assert res.ok, [c.as_dict() for c in res.comparisons if not c.ok]
    assert len(res.comparisons) >= 8
    built = {r["function"] for r in res.build_log}
    assert "pendulum3d_full.f" in built and "pendulum3d_reduced.f" in built
    # only what the scene needs: no Jacobians, no chain
    assert not any(f.endswith(("f_x", "f_u")) or f.startswith("chain") for f in built)
    data = json.loads(json.dumps(res.as_dict()))
    assert data["values"]["full"]["cost"]["rhs_evaluations"] > 0
    path = res.write_json(tmp_path / "r.json")
    assert json.loads(path.read_text())["name"] == "pendulum3d_invariants"


def test_registry_loads_problems_lazily():
    assert "pendulum3d_invariants" in names()
    mod = load("pendulum3d_invariants")
    assert mod.TITLE and callable(mod.solve)
