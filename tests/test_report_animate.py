"""Animations of the HTML report: SVG/SMIL played back from the figures' own data."""

from __future__ import annotations

import types
import xml.etree.ElementTree as ET

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from workbench.app.report.animate import (  # noqa: E402
    MAX_FRAMES,
    animations_of,
    sphere_animation,
    time_animation,
)

SVG = "{http://www.w3.org/2000/svg}"


def great_circle(n: int = 400) -> np.ndarray:
    a = np.linspace(0, np.pi, n)
    return np.column_stack([np.sin(a), np.zeros(n), np.cos(a)])


def test_sphere_playback_follows_the_curve_and_escapes_text():
    pts = great_circle()
    svg = sphere_animation(pts, elev=0.0, azim=-90.0, label="q1 <up = -e3> & more")
    root = ET.fromstring(svg)  # well-formed XML
    anims = {a.get("attributeName"): a.get("values") for a in root.iter(f"{SVG}animate")}
    cx = np.array(anims["cx"].split(";"), float)
    cy = np.array(anims["cy"].split(";"), float)
    assert 2 <= len(cx) <= MAX_FRAMES
    # seen from -e2 (elev 0, azim -90): screen x = x, screen y = -z (SVG y points down)
    np.testing.assert_allclose(cx[[0, -1]], [0.0, 0.0], atol=1e-4)
    np.testing.assert_allclose(cy[[0, -1]], [-1.0, 1.0], atol=1e-4)
    np.testing.assert_allclose(np.hypot(cx, cy), 1.0, atol=1e-3)  # stays on the outline
    assert "&lt;up = -e3&gt; &amp; more" in svg and "<up" not in svg
    assert "<script" not in svg and "href" not in svg


def fake_run(name: str, fig) -> types.SimpleNamespace:
    fig_data = types.SimpleNamespace(caption="the swing-up")
    res = types.SimpleNamespace(figures={"f": fig})
    return types.SimpleNamespace(name=name, result=res, figures={"f": fig_data})


def test_only_swingups_and_closed_loops_are_animated():
    fig = plt.figure()
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    p = great_circle()
    ax.plot(p[:, 0], p[:, 1], p[:, 2], lw=0.4)
    ax.plot(p[:, 0], -p[:, 1], p[:, 2], lw=1.5)  # the heaviest: the one played back
    (anim,) = animations_of(fake_run("swingup_test", fig))
    assert "Played back: the swing-up" in anim.caption
    assert animations_of(fake_run("stable_manifold_s2", fig)) == []
    plt.close(fig)


def test_time_playback_maps_the_data_in_the_panels_scales():
    fig, ax = plt.subplots()
    t = np.linspace(0.0, 10.0, 200)
    (line,) = ax.plot(t, 10.0 ** (-t))
    ax.set(yscale="log", xlabel="t [s]", title="decay")
    root = ET.fromstring(time_animation(ax, [line]))
    circle = next(root.iter(f"{SVG}circle"))
    cy = np.array([a.get("values") for a in circle.iter(f"{SVG}animate")
                   if a.get("attributeName") == "cy"][0].split(";"), float)
    # log10(y) = -t is linear in t: the dot moves at a constant vertical speed, top to bottom
    steps = np.diff(cy)
    assert np.all(steps > 0) and np.ptp(steps) < 0.2
    assert (run := animations_of(types.SimpleNamespace(
        name="chain_lqr", result=types.SimpleNamespace(figures={"f": fig}),
        figures={"f": types.SimpleNamespace(caption="closed loop")})))
    assert "cursor" in run[0].caption
    plt.close(fig)
