"""The controller problems run in quick mode, meet their comparisons and report their cost."""

from __future__ import annotations

import json

import numpy as np
import pytest

from workbench.app.registry import load, names

PROBLEMS = ["velocity_feedback_hanging", "so3_pd_closed_loop", "cart_nonlinear_inverted"]


@pytest.fixture(scope="module")
def results():
    return {name: load(name).solve(quick=True) for name in PROBLEMS}


@pytest.mark.parametrize("name", PROBLEMS)
def test_quick_run_meets_every_comparison(results, name, tmp_path):
    res = results[name]
    assert res.ok, [c.as_dict() for c in res.comparisons if not c.ok]
    assert name in names()
    assert res.build_log and res.timings and res.figures
    data = json.loads(res.write_json(tmp_path / "r.json").read_text())
    assert data["ok"] and data["quick"]


def test_velocity_feedback_numbers(results):
    v = results["velocity_feedback_hanging"].values
    assert v["max_u"] <= 10.0
    assert 0 < v["R0_projection_change"] < 1e-5  # the printed R(0) needed a tiny projection
    assert v["monte_carlo_global"]["n_converged"] == v["monte_carlo_global"]["n_samples"]
    assert v["V"]["Vf"] < 1e-10 * v["V"]["V0"]


def test_so3_saddles_have_the_papers_unstable_dimensions(results):
    spectra = results["so3_pd_closed_loop"].values["spectra"]
    assert [spectra[k]["n_unstable"] for k in ("I", "e1", "e2", "e3")] == [0, 3, 2, 1]


def _cart_setup():
    from models import controllers as ctl
    from models.chain_cart import chain_cart
    from problems.cart_nonlinear_inverted import GAINS, PLANT

    model = chain_cart(1, **PLANT)
    V = ctl.cart_lyapunov(model, **GAINS)
    b = ctl.cart_domain(model, k_w=GAINS["k_w"], k_q=GAINS["k_q"])
    return model, V, b, ctl.CartGains(**GAINS), PLANT


def _cart_rays(rng, n_rays, t):
    """States along curves from the inverted equilibrium: x, x-dot, omega1 grow linearly,
    q1 tilts from -e3 at a constant rate about a horizontal axis (all directions seeded)."""
    d = rng.standard_normal((n_rays, 8))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    T = t[None, :, None]
    rate = np.linalg.norm(d[:, 4:6], axis=1)
    axis = np.c_[d[:, 4:6] / rate[:, None], np.zeros(n_rays)]
    th = (t[None, :] * rate[:, None])[..., None]
    q = np.cos(th) * np.array([0.0, 0.0, -1.0]) + np.sin(th) * axis[:, None, :]
    w = np.c_[d[:, 6:8], np.zeros(n_rays)][:, None, :] * T
    w = w - np.sum(w * q, axis=2, keepdims=True) * q  # tangent at q
    X = np.concatenate([T * d[:, None, 0:2], T * d[:, None, 2:4], q, w], axis=2)
    return X.reshape(-1, 10)


def test_cart_certificate_holds_independently(results):
    """The certified set {V < c} (its component at the equilibrium) lies in D = {b < 0}.

    Checked without the problem's optimisers and without SublevelSet.contains: (i) on the
    boundary of D (q1 . e3 = -s) minimising V of (25) over x (y = 0), then x-dot, leaves
    k_w/2 (k_q^2 l^2 |C^T (q x w)|^2 / (1 + k_w) - k_q l^2 |w|^2) + k_w k_q g l (1 - s),
    whose quadratic part is >= 0 there since |C^T t| >= s |t| for t tangent at q; so
    min V on the boundary is k_w k_q g l (1 - s), and c may not exceed it; (ii) V at dense
    seeded samples of the boundary stays >= c; (iii) along curves leaving the equilibrium,
    every point reached before V first rises to c has b < 0 -- and the same scan finds
    points outside D at 1.1 c, so it has the power to fail.
    """
    v = results["cart_nonlinear_inverted"].values
    model, V, b, G, plant = _cart_setup()
    level, s = v["certified_level"], G.s
    length, g = plant["lengths"], plant["g"]
    assert 0 < v["K"] < 1
    min_on_boundary = G.k_w * G.k_q * g * length * (1 - s)
    assert level <= min_on_boundary * (1 + 1e-9)
    assert level == pytest.approx(min_on_boundary, rel=1e-6)  # K < 1: the boundary binds
    # (ii) the boundary of D, sampled around the family of minimisers and beyond
    rng = np.random.default_rng(11)
    n = 100_000
    phi = rng.uniform(0.0, 2 * np.pi, n)
    q = np.c_[np.sqrt(1 - s**2) * np.cos(phi), np.sqrt(1 - s**2) * np.sin(phi), -s * np.ones(n)]
    w = rng.uniform(-3.0, 3.0, (n, 3))
    w -= np.sum(w * q, axis=1, keepdims=True) * q
    Xb = np.c_[-G.k_q * length * q[:, :2] + rng.uniform(-0.5, 0.5, (n, 2)),
               rng.uniform(-1.0, 1.0, (n, 2)), q, w]
    assert np.max(np.abs(np.asarray(b.map(n)(Xb.T, model.p)))) < 1e-15  # on the boundary
    Vb = V.values(Xb)
    assert Vb.min() >= level
    assert Vb.min() <= 1.01 * level  # the samples come close: the level is the minimum
    # (iii) the equilibrium's component of {V < c}, swept by curves, lies in D
    t = np.linspace(0.0, 8.0, 200)
    X = _cart_rays(np.random.default_rng(5), 2000, t)
    Vr = V.values(X).reshape(2000, t.size)
    br = np.asarray(b.map(X.shape[0])(X.T, model.p)).reshape(2000, t.size)
    for c, expect_out in ((level, False), (1.1 * level, True)):
        reached = np.cumprod(Vr < c, axis=1).astype(bool)
        assert reached.mean() > 0.1  # the curves go well into the set before leaving it
        assert bool(np.any(reached & (br >= 0))) is expect_out, c
    axes = np.array(list(v["certified_extent_along_tangent_axes"].values()))
    assert np.all(np.isfinite(axes)) and np.all(axes > 0)
    assert v["basin"]["n_certified_not_converged"] == 0
