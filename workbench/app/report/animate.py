"""Animations for the HTML report: swing-ups and closed loops, played back (SVG with SMIL).

Only the swing-ups and the closed loops are animated (:data:`SWINGUPS`,
:data:`CLOSED_LOOPS`), from their figures' own data:

* a trajectory on a unit sphere (a 3D panel with a curve of unit vectors: the link
  direction of a swing-up) is played back with the sphere's outline, the path, and the
  link from the centre to the moving point, seen from the panel's own view angles, the
  samples at a constant rate in the order they were drawn (time order);
* a panel of time histories (x axis ``t``) is played back with a cursor sweeping the time
  axis and a dot riding each curve, in the panel's own scales (log where it is log).

The SVG is self-contained: no script, no network; user text in it is escaped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Animation", "animations_of", "sphere_animation", "time_animation", "MAX_FRAMES",
           "SWINGUPS", "CLOSED_LOOPS"]

SWINGUPS = ("swingup_",)
"""Name prefixes of the swing-up problems (their sphere trajectories are played back)."""

CLOSED_LOOPS = frozenset({"velocity_feedback_hanging", "cart_nonlinear_inverted", "chain_lqr",
                          "so3_pd_closed_loop", "pendulum3d_cart"})
"""Problems whose closed-loop time histories are played back."""

MAX_FRAMES = 160
"""Frames of one animation (the path is subsampled to this many points)."""

DURATION = 8.0
"""Seconds of one loop of an animation."""

MIN_POINTS = 20
"""A 3D curve with fewer samples is not animated."""


@dataclass
class Animation:
    """An animation of the HTML report.

    Attributes
    ----------
    caption : str
        What it shows.
    svg : str
        Self-contained SVG with SMIL animation.
    """

    caption: str
    svg: str


def _project(points: np.ndarray, elev: float, azim: float) -> np.ndarray:
    """Orthographic view of 3D points from matplotlib's (elev, azim), screen y up."""
    a, e = math.radians(azim), math.radians(elev)
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    sx = -math.sin(a) * x + math.cos(a) * y
    sy = -math.sin(e) * math.cos(a) * x - math.sin(e) * math.sin(a) * y + math.cos(e) * z
    return np.column_stack([sx, sy])


def _fmt(v: float) -> str:
    return f"{v:.4f}".rstrip("0").rstrip(".") if v else "0"


def sphere_animation(points: np.ndarray, *, elev: float = 30.0, azim: float = -60.0,
                     label: str = "") -> str:
    """SVG playing back a curve on the unit sphere, with a link from the centre.

    Parameters
    ----------
    points : array-like, shape=(n, 3)
        Unit vectors in drawing order (the figure's coordinates: ``z`` up).
    elev, azim : float
        View angles [deg], as matplotlib's 3D axes.
    label : str
        Text under the sphere (escaped).

    Returns
    -------
    str
        An ``<svg>`` element.
    """
    from html import escape

    pts = np.asarray(points, dtype=float)
    idx = np.unique(np.linspace(0, len(pts) - 1, min(MAX_FRAMES, len(pts))).round().astype(int))
    screen = _project(pts, elev, azim) * np.array([1.0, -1.0])
    path = " ".join(f"{_fmt(x)},{_fmt(y)}" for x, y in screen)
    frames = screen[idx]
    xs = ";".join(_fmt(x) for x in frames[:, 0])
    ys = ";".join(_fmt(y) for y in frames[:, 1])
    anim = f'dur="{DURATION:g}s" repeatCount="indefinite" calcMode="linear"'
    text = (f'<text x="0" y="1.38" font-size="0.14" text-anchor="middle" '
            f'fill="#57606a">{escape(label)}</text>' if label else "")
    return (
        '<svg xmlns="http://www.w3.org/2000/svg" viewBox="-1.3 -1.3 2.6 2.8" width="260" '
        'height="280" role="img">'
        '<circle r="1" fill="#f6f8fa" stroke="#afb8c1" stroke-width="0.012"/>'
        '<ellipse rx="1" ry="0.3" fill="none" stroke="#d0d7de" stroke-width="0.008"/>'
        f'<polyline points="{path}" fill="none" stroke="#1f77b4" stroke-width="0.018" '
        'stroke-opacity="0.55"/>'
        '<circle r="0.035" fill="#24292f"/>'
        f'<line x1="0" y1="0" x2="{_fmt(frames[0, 0])}" y2="{_fmt(frames[0, 1])}" '
        'stroke="#24292f" stroke-width="0.035" stroke-linecap="round">'
        f'<animate attributeName="x2" values="{xs}" {anim}/>'
        f'<animate attributeName="y2" values="{ys}" {anim}/></line>'
        f'<circle cx="{_fmt(frames[0, 0])}" cy="{_fmt(frames[0, 1])}" r="0.08" fill="#d62728">'
        f'<animate attributeName="cx" values="{xs}" {anim}/>'
        f'<animate attributeName="cy" values="{ys}" {anim}/></circle>'
        f"{text}</svg>"
    )


def _xy(ax: Any, lines: list[Any]) -> tuple[list[np.ndarray], list[np.ndarray], bool]:
    log = ax.get_yscale() == "log"
    xs, ys = [], []
    for line in lines:
        x = np.asarray(line.get_xdata(), dtype=float)
        y = np.asarray(line.get_ydata(), dtype=float)
        if log:
            y = np.log10(np.where(y > 0, y, np.nan))
        xs.append(x)
        ys.append(y)
    return xs, ys, log


def time_animation(ax: Any, lines: list[Any]) -> str:
    """SVG playing back the time histories of one panel: a sweeping cursor, a dot per curve.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The panel (its title, labels and y scale are used).
    lines : list of matplotlib.lines.Line2D
        Curves over time (x increasing).

    Returns
    -------
    str
        An ``<svg>`` element.
    """
    from html import escape

    from matplotlib.colors import to_hex

    xs, ys, log = _xy(ax, lines)
    t0 = min(float(np.nanmin(x)) for x in xs)
    t1 = max(float(np.nanmax(x)) for x in xs)
    finite = np.concatenate([y[np.isfinite(y)] for y in ys])
    lo, hi = float(np.min(finite)), float(np.max(finite))
    hi = hi if hi > lo else lo + 1.0
    W, H, L, R, T, B = 420.0, 230.0, 46.0, 410.0, 26.0, 196.0

    def sx(t: np.ndarray) -> np.ndarray:
        return L + (np.asarray(t) - t0) / (t1 - t0) * (R - L)

    def sy(y: np.ndarray) -> np.ndarray:
        return B - (np.asarray(y) - lo) / (hi - lo) * (B - T)

    frames = np.linspace(t0, t1, MAX_FRAMES)
    anim = f'dur="{DURATION:g}s" repeatCount="indefinite" calcMode="linear"'
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {W:g} {H:g}" '
             f'width="{W:g}" height="{H:g}" role="img">',
             f'<rect x="{L}" y="{T}" width="{R - L}" height="{B - T}" fill="#f6f8fa" '
             'stroke="#afb8c1"/>',
             f'<text x="{W / 2}" y="16" font-size="12" text-anchor="middle" fill="#24292f">'
             f'{escape(ax.get_title())}</text>',
             f'<text x="{L}" y="{B + 16}" font-size="10" fill="#57606a">{t0:.3g}</text>',
             f'<text x="{R}" y="{B + 16}" font-size="10" text-anchor="end" fill="#57606a">'
             f'{t1:.3g}</text>',
             f'<text x="{(L + R) / 2}" y="{B + 28}" font-size="10" text-anchor="middle" '
             f'fill="#57606a">{escape(ax.get_xlabel())}</text>',
             f'<text x="{L - 4}" y="{T + 8}" font-size="10" text-anchor="end" fill="#57606a">'
             f'{(f"1e{hi:.0f}" if log else f"{hi:.3g}")}</text>',
             f'<text x="{L - 4}" y="{B}" font-size="10" text-anchor="end" fill="#57606a">'
             f'{(f"1e{lo:.0f}" if log else f"{lo:.3g}")}</text>']
    for line, x, y in zip(lines, xs, ys):
        ok = np.isfinite(y)
        if ok.sum() < 2:
            continue
        color = to_hex(line.get_color())
        pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(sx(x[ok]), sy(y[ok])))
        parts.append(f'<polyline points="{pts}" fill="none" stroke="{color}" '
                     'stroke-width="1.2" stroke-opacity="0.45"/>')
        yk = np.interp(frames, x[ok], y[ok])
        cx = ";".join(f"{v:.1f}" for v in sx(frames))
        cy = ";".join(f"{v:.1f}" for v in sy(yk))
        parts.append(f'<circle r="4" fill="{color}"><animate attributeName="cx" values="{cx}" '
                     f'{anim}/><animate attributeName="cy" values="{cy}" {anim}/></circle>')
    cx = ";".join(f"{v:.1f}" for v in sx(frames))
    parts.append(f'<line y1="{T}" y2="{B}" stroke="#24292f" stroke-width="1" '
                 f'stroke-dasharray="3,3"><animate attributeName="x1" values="{cx}" {anim}/>'
                 f'<animate attributeName="x2" values="{cx}" {anim}/></line></svg>')
    return "".join(parts)


def _time_panels(fig: Any) -> list[tuple[Any, list[Any]]]:
    """Panels whose x axis is time, with their curves of at least :data:`MIN_POINTS`."""
    out = []
    for ax in fig.get_axes():
        label = ax.get_xlabel().strip()
        if getattr(ax, "name", "") == "3d" or not (label == "t" or label.startswith("t ")
                                                   or "time" in label.lower()):
            continue
        lines = []
        for line in ax.get_lines():
            x = np.asarray(line.get_xdata(), dtype=float)
            if len(x) >= MIN_POINTS and np.all(np.diff(x) >= 0) and x[-1] > x[0]:
                lines.append(line)
        if lines:
            out.append((ax, lines))
    return out


def _sphere_curves(fig: Any) -> list[tuple[np.ndarray, float, float, str]]:
    """The main unit-vector curve of each 3D panel: (points, elev, azim, panel title)."""
    out = []
    for ax in fig.get_axes():
        if getattr(ax, "name", "") != "3d":
            continue
        best, width = None, -1.0
        for line in ax.get_lines():
            data = getattr(line, "get_data_3d", None)
            if data is None:
                continue
            pts = np.column_stack([np.asarray(c, dtype=float) for c in data()])
            if len(pts) < MIN_POINTS or not np.all(np.isfinite(pts)):
                continue
            if np.max(np.abs(np.linalg.norm(pts, axis=1) - 1.0)) > 1e-3:
                continue  # not a curve of unit vectors
            lw = float(line.get_linewidth())
            if lw > width or (lw == width and best is not None and len(pts) > len(best)):
                best, width = pts, lw
        if best is not None:
            out.append((best, float(ax.elev), float(ax.azim), ax.get_title()))
    return out


def animations_of(run: Any) -> list[Animation]:
    """Animations of a swing-up or closed-loop problem's run, from its figures' data.

    Parameters
    ----------
    run : ProblemRun
        A run whose ``result.figures`` still hold the matplotlib figures.

    Returns
    -------
    list of Animation
        Empty for a problem that is neither a swing-up nor a closed loop.
    """
    res = getattr(run, "result", None)
    swing = run.name.startswith(SWINGUPS)
    if res is None or not (swing or run.name in CLOSED_LOOPS):
        return []
    out = []
    for key, fig in res.figures.items():
        caption = run.figures[key].caption if key in run.figures else key
        curves = _sphere_curves(fig)
        if curves:
            body = "".join(sphere_animation(p, elev=e, azim=a, label=t) for p, e, a, t in curves)
            out.append(Animation(
                f"Played back: {caption} (the heaviest curve of each sphere panel, samples at "
                f"a constant rate in time order; {DURATION:g} s per loop).",
                f'<div style="display:flex;flex-wrap:wrap;gap:1em">{body}</div>'))
            continue
        panels = _time_panels(fig)[:4]
        if panels and run.name in CLOSED_LOOPS:
            body = "".join(time_animation(ax, lines) for ax, lines in panels)
            out.append(Animation(
                f"Played back: {caption} (the time histories of the figure, a cursor sweeping "
                f"time; {DURATION:g} s per loop).",
                f'<div style="display:flex;flex-wrap:wrap;gap:1em">{body}</div>'))
    return out
