"""The problems relative_equilibria and chain_equilibria run in quick mode within tolerance."""

from __future__ import annotations

import json

import numpy as np

from problems import chain_equilibria, relative_equilibria


def test_relative_equilibria_quick(tmp_path):
    res = relative_equilibria.solve(quick=True)
    assert res.ok, [c.as_dict() for c in res.comparisons if not c.ok]
    fams = res.values["families"]
    assert sorted(fams) == ["L1+", "L1-", "L2+", "L2-", "L3+", "L3-", "L4+", "L4-"]
    inv_j = res.values["one_over_J"]
    # where Section 4.3 says the families end (erratum: hanging at 0+, inverted at 0-)
    ends = {name: {(e["kind"], e.get("static"), round(e.get("J_inverse", 0.0), 6))
                   for e in fam["ends"]} for name, fam in fams.items()}
    assert ends["L2+"] == {("static", "hanging", 0.0), ("infinity", None, round(inv_j[0], 6))}
    assert ends["L1-"] == {("static", "inverted", 0.0), ("infinity", None, round(inv_j[2], 6))}
    assert ends["L3+"] == {("infinity", None, round(inv_j[0], 6)),
                           ("infinity", None, round(inv_j[1], 6))}
    assert ends["L4-"] == {("infinity", None, round(inv_j[1], 6)),
                           ("infinity", None, round(inv_j[2], 6))}
    assert fams["L1+"]["case3_events"] == 1 and fams["L2+"]["case3_events"] == 0
    # mu along each family: odd in the sign of omega
    assert np.allclose(fams["L3+"]["mu_range"], -np.array(fams["L3-"]["mu_range"][::-1]))
    assert res.values["balanced_error"].startswith("parameter 'rho'")
    assert "relative_equilibria" in res.figures
    built = {r["function"] for r in res.build_log}
    assert any("relative_equilibria[" in f for f in built)
    data = json.loads(json.dumps(res.as_dict()))
    assert data["values"]["continuation"]["points"] > 100
    res.write_json(tmp_path / "r.json")


def test_chain_equilibria_quick():
    res = chain_equilibria.solve(quick=True)
    assert res.ok, [c.as_dict() for c in res.comparisons if not c.ok]
    per_n = res.values["per_n"]
    assert [per_n[str(n)]["equilibria"] for n in range(1, 6)] == [2, 4, 8, 16, 32]
    assert res.values["pushed"]["status"] == "stagnated"
    assert res.values["far_start"]["status"] == "max_iterations"
    # without guesses: the same 2^n equilibria, every sign pattern, at the same states
    assert [per_n[str(n)]["guess_free"]["sets"] for n in range(1, 6)] == [2, 4, 8, 16, 32]
    rows = [c for c in res.comparisons if "guess" in c.quantity or "(Newton)" in c.quantity]
    assert len(rows) == 4 * 5 and all(c.ok for c in rows)
