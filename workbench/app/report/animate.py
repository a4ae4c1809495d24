"""Animations for the HTML report: trajectories on spheres, played back (SVG with SMIL).

A problem's figures that draw a trajectory on a unit sphere (a 3D panel with a curve of
unit vectors: the link direction of a swing-up, a closed loop's attitude) are played back
from the figure's own data: the sphere's outline, the path, and the link from the centre
to the moving point, seen from the panel's own view angles. The samples are shown at a
constant rate, in the order they were drawn (time order). The SVG is self-contained: no
script, no network.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Animation", "animations_of", "sphere_animation", "MAX_FRAMES"]

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
    """Animations of a problem's run: each figure's trajectories on spheres, played back.

    Parameters
    ----------
    run : ProblemRun
        A run whose ``result.figures`` still hold the matplotlib figures.

    Returns
    -------
    list of Animation
    """
    res = getattr(run, "result", None)
    if res is None:
        return []
    out = []
    for key, fig in res.figures.items():
        curves = _sphere_curves(fig)
        if not curves:
            continue
        svgs = [sphere_animation(p, elev=e, azim=a, label=t) for p, e, a, t in curves]
        caption = run.figures[key].caption if key in run.figures else key
        body = "".join(svgs)
        out.append(Animation(
            f"Played back: {caption} (the heaviest curve of each sphere panel, samples at a "
            f"constant rate in time order; {DURATION:g} s per loop).",
            f'<div style="display:flex;flex-wrap:wrap;gap:1em">{body}</div>'))
    return out
