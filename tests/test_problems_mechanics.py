"""The problems of the systems defined by their Lagrangians, run in quick mode.

Each problem compares against an independent derivation (Kane's method in sympy) and
closed forms; here every comparison must hold and the key figures be what they claim.
"""

from __future__ import annotations

import pytest

from workbench.app.registry import load


def _run(name):
    res = load(name).solve(quick=True)
    bad = [c.quantity for c in res.comparisons if not c.ok]
    assert res.ok, bad
    assert res.figures and all(res.captions.get(k) for k in res.figures)
    return res


def test_double_pendulum3d_quick():
    res = _run("double_pendulum3d")
    kane = next(c for c in res.comparisons if "Kane" in c.quantity)
    assert kane.workbench < 1e-10
    unstable = sorted(int(c.workbench) for c in res.comparisons if "unstable modes" in c.quantity)
    assert unstable == [0, 2, 2, 4]
    # the long runs at the same step: RKMK4's energy error grows, the variational one's not
    rk, vi = res.values["rkmk4_long_run"], res.values["variational_long_run"]
    assert rk["last_tenth"] > 5 * rk["first_tenth"] and rk["growth_exponent"] > 0.8
    assert vi["last_tenth"] < 1.5 * vi["first_tenth"] and abs(vi["growth_exponent"]) < 0.1
    assert vi["L_z_drift"] < 1e-10 < rk["L_z_drift"]


@pytest.mark.slow
def test_pendulum3d_cart_quick():
    res = _run("pendulum3d_cart")
    assert any("Omega3" in m for m in res.values["inverted_uncontrollable_by_cart_force"])


@pytest.mark.slow
def test_quadrotor_slung_load_quick():
    res = _run("quadrotor_slung_load")
    assert res.values["transport"]["iterations"] < 200


@pytest.mark.slow
def test_mechanics_paper_models_quick():
    _run("mechanics_paper_models")
