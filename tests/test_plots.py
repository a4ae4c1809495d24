"""Sphere figures: coloured curves within a segment budget, body axes, manifold panels."""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from models import controllers as ctl  # noqa: E402
from models import pendulum3d as p3  # noqa: E402
from models.spherical import spherical_pendulum  # noqa: E402
from tests.conftest import assert_close  # noqa: E402
from workbench.core.errors import ModelError, ParameterError  # noqa: E402
from workbench.core.manifolds import SO3, so3_exp  # noqa: E402
from workbench.global_dynamics._invariant_manifolds import stable_manifold  # noqa: E402
from workbench.study._plots import (  # noqa: E402
    body_axis_curves,
    decimate,
    mark_directions,
    s2_manifold_figure,
    so3_manifold_figure,
    sphere_axes,
    sphere_curves,
)

E3 = np.array([0.0, 0.0, 1.0])


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def s2_manifold():
    model = spherical_pendulum()
    k = ctl.s2_pd(model, E3, k_q=1.0, k_w=1.0)
    return stable_manifold(model, np.r_[-E3, 0, 0, 0], controller=k, n_points=12,
                           horizon=10.0, step=0.005, output_step=0.05)


def test_decimate_keeps_ends_and_budget():
    idx = decimate(1001, 50)
    assert idx[0] == 0 and idx[-1] == 1000 and len(idx) <= 50
    assert np.all(np.diff(idx) > 0)
    assert np.array_equal(decimate(10, 50), np.arange(10))
    with pytest.raises(ParameterError):
        decimate(10, 1)


def test_sphere_curves_budget_and_colours():
    ax = sphere_axes()
    s = np.linspace(0, np.pi, 2001)
    curves = [np.column_stack([np.cos(s + a), np.sin(s + a), 0 * s]) for a in (0.0, 1.0, 2.0)]
    values = [s, 2 * s, 3 * s]
    coll = sphere_curves(ax, curves, values, max_segments=300, colour_run=1)
    segs = np.asarray(coll._segments3d)  # the 3D segments (matplotlib keeps them here)
    assert len(coll.get_array()) == len(segs) <= 300
    assert_close(np.linalg.norm(segs, axis=2), np.ones(segs.shape[:2]), atol=1e-12,
                 what="decimated points stay on the curves")
    assert coll.norm.vmin == pytest.approx(0.0, abs=2e-2)
    assert coll.norm.vmax == pytest.approx(3 * np.pi, rel=1e-2)
    assert coll.get_rasterized()
    with pytest.raises(ParameterError, match="same number of curves"):
        sphere_curves(ax, curves, values[:2])
    with pytest.raises(ParameterError, match="shape"):
        sphere_curves(ax, [np.zeros((5, 2))], [np.zeros(5)])
    with pytest.raises(ParameterError, match="one per"):
        sphere_curves(ax, [np.zeros((5, 3))], [np.zeros(4)])


@pytest.mark.parametrize("run", [1, 3, 4, 7])
def test_sphere_curves_colour_runs_draw_every_segment_with_the_mean_colour(run):
    # one curve of 2001 points decimated to 301 (300 segments), the value equal to the
    # angle; colour_tol = 1 merges every run: a run's colour is the mean of its segments'
    # midpoint values, read back here from the drawn points themselves
    ax = sphere_axes()
    s = np.linspace(0.0, np.pi, 2001)
    curve = np.column_stack([np.cos(s), np.sin(s), 0 * s])
    coll = sphere_curves(ax, [curve], [s], max_segments=300, colour_run=run, colour_tol=1.0)
    lines = coll._segments3d
    n_seg = sum(len(p) - 1 for p in lines)
    assert n_seg == 300 and len(lines) == -(-300 // run) == len(coll.get_array())
    for a, b in zip(lines[:-1], lines[1:]):  # consecutive runs share their end point
        assert_close(a[-1], b[0], atol=0.0, what="runs are contiguous")
    ang = [np.arctan2(p[:, 1], p[:, 0]) for p in lines]
    expected = np.array([np.mean(0.5 * (a[:-1] + a[1:])) for a in ang])
    assert_close(np.asarray(coll.get_array()), expected, atol=1e-12,
                 what="colour of each run = mean of its segments")
    for bad in (0, True, 2.5):
        with pytest.raises(ParameterError, match="colour_run"):
            sphere_curves(ax, [curve], [s], colour_run=bad)


def test_sphere_curves_colour_tol_bounds_the_colour_error_and_range_is_the_segments():
    # values growing like e^(5 s) along a half circle: slow at the start (runs merge), fast
    # at the end (runs split); every segment is drawn within colour_tol of the colour range
    # of its own value, and the default range is that of the segments, not of the runs
    ax = sphere_axes()
    s = np.linspace(0.0, np.pi, 2001)
    curve = np.column_stack([np.cos(s), np.sin(s), 0 * s])
    value = np.exp(5 * s)
    ref = sphere_curves(ax, [curve], [value], max_segments=1000, colour_run=1)
    seg_values = np.asarray(ref.get_array())
    for tol in (0.0, 0.005, 0.02, 0.1):
        coll = sphere_curves(ax, [curve], [value], max_segments=1000, colour_run=8,
                             colour_tol=tol)
        lines = coll._segments3d
        drawn = np.repeat(np.asarray(coll.get_array()), [len(p) - 1 for p in lines])
        assert len(drawn) == len(seg_values)
        assert (coll.norm.vmin, coll.norm.vmax) == (ref.norm.vmin, ref.norm.vmax) == (
            seg_values.min(), seg_values.max())
        err = np.max(np.abs(drawn - seg_values)) / (coll.norm.vmax - coll.norm.vmin)
        assert err <= tol
        if tol == 0.0:
            assert len(lines) == len(seg_values)  # no two segments share a value
        else:
            assert len(seg_values) / 8 < len(lines) < len(seg_values)  # some merged, some not
    for bad in (-0.1, float("nan"), float("inf"), True, "0.02"):
        with pytest.raises(ParameterError, match="colour_tol"):
            sphere_curves(ax, [curve], [value], colour_tol=bad)
    # a value that is not a number is drawn alone; the finite segments keep the bound
    value[1000] = np.nan
    coll = sphere_curves(ax, [curve], [value], max_segments=1000, colour_run=8,
                         vmin=0.0, vmax=float(np.exp(5 * np.pi)))
    drawn = np.repeat(np.asarray(coll.get_array()), [len(p) - 1 for p in coll._segments3d])
    own = np.asarray(sphere_curves(ax, [curve], [value], max_segments=1000, colour_run=1,
                                   vmin=0.0, vmax=float(np.exp(5 * np.pi))).get_array())
    finite = np.isfinite(own)
    assert (~finite).sum() >= 1 and np.array_equal(np.isfinite(drawn), finite)
    assert np.max(np.abs(drawn[finite] - own[finite])) <= 0.02 * np.exp(5 * np.pi)
    with pytest.raises(ParameterError, match="vmax must not be below vmin"):
        sphere_curves(ax, [curve], [value], vmin=1.0, vmax=0.5)


def test_sphere_curves_with_nothing_to_draw_returns_an_empty_collection():
    ax = sphere_axes()
    for curves, values in (([], []), ([np.array([[0.0, 0.0, 1.0]])], [np.zeros(1)])):
        coll = sphere_curves(ax, curves, values)
        assert len(coll.get_array()) == 0 and coll not in ax.collections


def test_fig3_rotation_about_e3_keeps_axis_three_fixed():
    # paper 002 Fig. 3: R(t) = exp(beta(t) e3^), beta = pi/6 (sin(pi t / 2) - 1), 0 <= t <= 1
    t = np.linspace(0.0, 1.0, 101)
    beta = np.pi / 6 * (np.sin(np.pi * t / 2) - 1)
    R = np.array([so3_exp([0.0, 0.0, b]) for b in beta])
    rate = np.abs(np.pi**2 / 12 * np.cos(np.pi * t / 2))
    ax = sphere_axes()
    coll = body_axis_curves(ax, R, rate, colour_run=1)  # one polyline per segment
    segs = np.asarray(coll._segments3d)
    n = len(t) - 1
    axis1, axis3 = segs[:n], segs[2 * n:]
    assert_close(axis3.reshape(-1, 3), np.tile(E3, (2 * n, 1)), atol=1e-15,
                 what="body axis 3 is a single point")
    ang = np.degrees(np.arctan2(axis1[-1, 1, 1], axis1[-1, 1, 0]) -
                     np.arctan2(axis1[0, 0, 1], axis1[0, 0, 0]))
    assert ang == pytest.approx(30.0, abs=1e-9)  # a 30 deg turn to R(1) = I
    assert coll.norm.vmax == pytest.approx(np.pi**2 / 12, rel=1e-3)
    with pytest.raises(ParameterError, match="shape"):
        body_axis_curves(ax, np.zeros((4, 3, 3)), np.zeros(5))


def test_mark_directions_checks_labels():
    ax = sphere_axes()
    mark_directions(ax, [E3, -E3], ["a", "b"])
    assert len(ax.texts) == 2
    with pytest.raises(ParameterError):
        mark_directions(ax, [E3], ["a", "b"])
    with pytest.raises(ParameterError):
        mark_directions(ax, [[1.0, 0.0]])


def test_s2_manifold_figure_panels_and_svg_size(s2_manifold):
    fig = s2_manifold_figure(s2_manifold, [8.0, 9.0, 10.0], marks={"hanging": E3})
    axes3d = [a for a in fig.axes if a.name == "3d"]
    assert len(axes3d) == 3
    w = np.linalg.norm(s2_manifold.at(10.0)[:, 3:], axis=1).max()
    assert f"{w:.3g}" in axes3d[-1].get_title()
    buf = io.BytesIO()
    fig.savefig(buf, format="svg")
    assert len(buf.getvalue()) < 3_000_000
    with pytest.raises(ModelError, match="S2 or TS2"):
        s2_manifold_figure(s2_manifold, [1.0], factor="nope")


def test_so3_manifold_figure_marks_the_attitudes():
    model = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.3])
    k = ctl.so3_pd(model, np.eye(3), k_R=1.0, k_Omega=1.0, G=[0.9, 1.0, 1.1])
    R_e = np.diag([1.0, -1.0, -1.0])
    W = stable_manifold(model, np.r_[SO3.flat(R_e), 0, 0, 0], controller=k, n_points=6,
                        horizon=4.0, step=0.01, output_step=0.5)
    fig = so3_manifold_figure(W, [2.0, 4.0], attitudes={"I": np.eye(3), "saddle": R_e},
                              max_trajectories=4)
    ax = [a for a in fig.axes if a.name == "3d"][0]
    labels = {t.get_text() for t in ax.texts}
    assert {"I:1", "I:2", "I:3", "saddle:1", "saddle:2", "saddle:3"} <= labels
    with pytest.raises(ModelError, match="SO3"):
        sphere = spherical_pendulum()
        Ws = stable_manifold(sphere, np.r_[-E3, 0, 0, 0],
                             controller=ctl.s2_pd(sphere, E3, k_q=1, k_w=1),
                             n_points=4, horizon=0.5, step=0.05, output_step=0.5)
        so3_manifold_figure(Ws, [0.5])
