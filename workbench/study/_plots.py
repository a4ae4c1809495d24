"""Figures on the unit sphere: curves coloured by a scalar, SO(3) motions as body axes.

* :func:`sphere_axes` -- a 3D axes with a light wireframe of the unit sphere;
* :func:`sphere_curves` -- curves on the sphere coloured point by point (e.g. by
  ``|omega|``, paper 002 Fig. 1: blue at the minimum, red at the maximum), decimated to a
  segment budget and rasterised by default so that vector outputs (SVG) stay small;
* :func:`mark_directions` -- labelled points on the sphere (equilibria, body axes);
* :func:`body_axis_curves` -- an SO(3) trajectory drawn as the three curves of its body
  axes ``R(t) e_i`` (the columns of ``R``) on one sphere, coloured by ``|Omega|`` (paper
  002 Fig. 3 convention); an axis that does not move is a single point;
* :func:`s2_manifold_figure`, :func:`so3_manifold_figure` -- a computed invariant manifold
  (:class:`~workbench.global_dynamics.InvariantManifold`) at several parameter
  values ``t``, one panel each (paper 002 Figs. 1, 2, 4, 5), with the equilibria marked.

Every function takes the matplotlib objects it draws into, or makes a figure; nothing is
shown or saved here. Use a non-interactive backend (Agg) in scripts.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from workbench.core import validate
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import SO3, TS2, Rn
from workbench.core.types import ArrayLike

__all__ = [
    "MAX_SEGMENTS",
    "COLOUR_RUN",
    "COLOUR_TOL",
    "decimate",
    "sphere_axes",
    "sphere_curves",
    "mark_directions",
    "body_axis_curves",
    "s2_manifold_figure",
    "so3_manifold_figure",
]

MAX_SEGMENTS = 40_000
"""Default budget of line segments per axes (drawing time grows with it; rasterised
curves keep the size of vector outputs independent of it)."""

COLOUR_RUN = 8
"""Default largest number of consecutive segments drawn as one polyline of one colour (see
:func:`sphere_curves`)."""

COLOUR_TOL = 0.02
"""Default largest colour error of a merged run, as a fraction of the colour range (see
:func:`sphere_curves`)."""


def decimate(n: int, max_n: int) -> np.ndarray:
    """At most ``max_n`` (>= 2) evenly spaced indices of ``range(n)``, first and last kept."""
    if n <= max_n:
        return np.arange(n)
    if max_n < 2:
        raise ParameterError(f"max_n must be at least 2; got {max_n}")
    return np.unique(np.round(np.linspace(0, n - 1, max_n)).astype(int))


def sphere_axes(fig: Any = None, position: Any = 111, *, elev: float = 20.0,
                azim: float = -60.0, meridians: int = 12, parallels: int = 7) -> Any:
    """A 3D axes showing the unit sphere as a light wireframe.

    Parameters
    ----------
    fig : matplotlib.figure.Figure, optional
        Figure to add the axes to (a new one by default).
    position : int, tuple of int or SubplotSpec
        Where (``fig.add_subplot`` arguments, e.g. ``111`` or ``(2, 2, 3)``).
    elev, azim : float
        View angles [deg].
    meridians, parallels : int
        Wireframe lines (great circles through the poles, circles of latitude).

    Returns
    -------
    mpl_toolkits.mplot3d.Axes3D
    """
    import matplotlib.pyplot as plt

    fig = plt.figure() if fig is None else fig
    args = tuple(position) if isinstance(position, tuple) else (position,)
    ax = fig.add_subplot(*args, projection="3d")
    s = np.linspace(0, 2 * np.pi, 121)
    style = {"color": "0.75", "lw": 0.4, "alpha": 0.6}
    for a in np.linspace(0, np.pi, meridians, endpoint=False):
        ax.plot(np.cos(a) * np.sin(s), np.sin(a) * np.sin(s), np.cos(s), **style)
    for z in np.linspace(-1, 1, parallels + 2)[1:-1]:
        r = np.sqrt(1 - z * z)
        ax.plot(r * np.cos(s), r * np.sin(s), np.full_like(s, z), **style)
    ax.set_xlim(-1.05, 1.05)
    ax.set_ylim(-1.05, 1.05)
    ax.set_zlim(-1.05, 1.05)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    return ax


def _curve_list(curves: Any, values: Any) -> tuple[list[np.ndarray], list[np.ndarray]]:
    cs = [np.asarray(c, dtype=float) for c in curves]
    vs = [np.asarray(v, dtype=float).ravel() for v in values]
    if len(cs) != len(vs):
        raise ParameterError(f"curves and values must have the same number of curves; got "
                             f"{len(cs)} and {len(vs)}")
    for i, (c, v) in enumerate(zip(cs, vs)):
        if c.ndim != 2 or c.shape[1] != 3:
            raise ParameterError(f"curve {i} must have shape (n_t, 3); got {c.shape}")
        if v.shape[0] != c.shape[0]:
            raise ParameterError(f"values of curve {i} must have {c.shape[0]} entries (one per "
                                 f"point); got {v.shape[0]}")
    return cs, vs


def sphere_curves(ax: Any, curves: Sequence[ArrayLike], values: Sequence[ArrayLike], *,
                  cmap: str = "jet", vmin: float | None = None, vmax: float | None = None,
                  max_segments: int = MAX_SEGMENTS, linewidth: float = 0.8,
                  rasterized: bool = True, colour_run: int = COLOUR_RUN,
                  colour_tol: float = COLOUR_TOL) -> Any:
    """Draw curves on the sphere coloured by a scalar given at their points.

    Parameters
    ----------
    ax : Axes3D
        Target axes (e.g. from :func:`sphere_axes`).
    curves : sequence of array-like, each shape=(n_t, 3)
        Points of each curve (lengths may differ; a curve of one point draws nothing).
    values : sequence of array-like, each shape=(n_t,)
        The scalar at each point; a segment takes the mean of its ends.
    cmap : str
        Matplotlib colormap name ("jet": blue at ``vmin``, red at ``vmax``, as Fig. 1).
    vmin, vmax : float, optional
        Colour range (default: the range of the segments' values).
    max_segments : int
        Budget of segments; every curve is decimated evenly to stay within it.
    linewidth : float
        Line width [pt].
    rasterized : bool
        Rasterise the curves in vector outputs (keeps SVGs small).
    colour_run : int
        At most this many consecutive segments (after decimation) are drawn as one
        polyline of one colour, their mean value. Matplotlib's drawing time grows with the
        number of polylines, not of points; 1 colours every segment.
    colour_tol : float
        A run is drawn as one polyline only if its segments' values differ by at most
        ``colour_tol`` times the colour range (``vmax - vmin``); otherwise each of its
        segments is drawn in its own colour. So no segment is drawn more than
        ``colour_tol`` of the colour range away from its own value (0: only runs of
        equal values are merged). Time and colour error of the settings are measured by
        ``benchmarks/bench_figures.py``.

    Returns
    -------
    mpl_toolkits.mplot3d.art3d.Line3DCollection
        Its ``norm`` and ``cmap`` serve a colorbar; its array holds one value per polyline
        (not added to ``ax`` when there is nothing to draw).
    """
    from matplotlib.colors import Normalize
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    colour_run = validate.count("colour_run", colour_run)
    colour_tol = validate.nonnegative("colour_tol", colour_tol)
    if vmin is not None and vmax is not None and vmax < vmin:
        raise ParameterError(f"vmax must not be below vmin; got vmin={vmin!r}, vmax={vmax!r}")
    cs, vs = _curve_list(curves, values)
    total = sum(max(len(c) - 1, 0) for c in cs)
    per = max(2, int(max_segments // max(len(cs), 1)) + 1) if total > max_segments else None
    drawn = []  # (points, one value per segment) of each curve, decimated
    for c, v in zip(cs, vs):
        if len(c) >= 2:
            idx = decimate(len(c), per) if per is not None else np.arange(len(c))
            drawn.append((c[idx], 0.5 * (v[idx][:-1] + v[idx][1:])))
    mids = np.concatenate([m for _, m in drawn]) if drawn else np.zeros(0)
    lo = float(np.min(mids)) if vmin is None and mids.size else (vmin or 0.0)
    hi = float(np.max(mids)) if vmax is None and mids.size else (
        vmax if vmax is not None else 1.0)
    hi = hi if hi > lo else lo + 1
    limit = colour_tol * (hi - lo)
    seg: list[np.ndarray] = []
    cols = []
    for c, mid in drawn:
        n = len(mid)
        starts = np.arange(0, n, colour_run)
        lengths = np.diff(np.r_[starts, n])
        spread = np.maximum.reduceat(mid, starts) - np.minimum.reduceat(mid, starts)
        split = np.zeros(n, dtype=bool)  # a polyline starts before segment k
        split[starts] = True
        # too spread (or not a number): every segment its own colour
        split |= np.repeat(~(spread <= limit), lengths)
        first = np.flatnonzero(split)
        last = np.r_[first[1:], n]
        seg.extend(c[a: b + 1] for a, b in zip(first, last))
        cols.append(np.add.reduceat(mid, first) / (last - first))
    col = np.concatenate(cols) if cols else np.zeros(0)
    coll = Line3DCollection(seg if seg else np.zeros((0, 2, 3)), cmap=cmap,
                            norm=Normalize(lo, hi), linewidths=linewidth)
    coll.set_array(col)
    coll.set_rasterized(bool(rasterized))
    if seg:  # matplotlib refuses an empty 3D collection
        ax.add_collection3d(coll)
    return coll


def mark_directions(ax: Any, directions: ArrayLike, labels: Sequence[str] | None = None, *,
                    marker: str = "o", color: str = "k", size: float = 30.0,
                    label_offset: float = 1.15) -> None:
    """Mark unit vectors on the sphere, optionally labelled just outside it.

    Parameters
    ----------
    ax : Axes3D
        Target axes.
    directions : array-like, shape=(m, 3)
        Points on the sphere.
    labels : sequence of str, optional
        One label per point.
    marker, color : str
        Matplotlib marker and colour.
    size : float
        Marker area [pt^2].
    label_offset : float
        Labels are drawn at ``label_offset`` times the point.
    """
    D = np.atleast_2d(np.asarray(directions, dtype=float))
    if D.shape[1] != 3:
        raise ParameterError(f"directions must have shape (m, 3); got {D.shape}")
    if labels is not None and len(labels) != len(D):
        raise ParameterError(f"labels must have {len(D)} entries; got {len(labels)}")
    ax.scatter(D[:, 0], D[:, 1], D[:, 2], marker=marker, color=color, s=size, depthshade=False)
    for i, d in enumerate(D):
        if labels is not None:
            p = label_offset * d
            ax.text(p[0], p[1], p[2], labels[i], color=color, fontsize=8, ha="center")


def body_axis_curves(ax: Any, R: ArrayLike, speed: ArrayLike, **options: Any) -> Any:
    """Draw SO(3) trajectories as the curves of their three body axes (paper 002 Fig. 3).

    Parameters
    ----------
    ax : Axes3D
        Target axes.
    R : array-like, shape=(n_traj, n_t, 3, 3) or (n_t, 3, 3)
        Rotation matrices; column ``i`` of ``R`` is body axis ``i`` in the reference frame.
    speed : array-like, shape=(n_traj, n_t) or (n_t,)
        ``|Omega|`` at each time (the colour).
    **options
        Passed to :func:`sphere_curves` (``cmap``, ``vmin``, ``vmax``, ``max_segments``...).

    Returns
    -------
    Line3DCollection
    """
    Rm = np.asarray(R, dtype=float)
    sp = np.asarray(speed, dtype=float)
    if Rm.ndim == 3:
        Rm, sp = Rm[None], sp.reshape(1, -1)
    if Rm.ndim != 4 or Rm.shape[2:] != (3, 3) or sp.shape != Rm.shape[:2]:
        raise ParameterError(f"R must have shape (n_traj, n_t, 3, 3) and speed (n_traj, n_t); "
                             f"got {np.shape(R)} and {np.shape(speed)}")
    curves = [Rm[j, :, :, i] for j in range(Rm.shape[0]) for i in range(3)]
    values = [sp[j] for j in range(Rm.shape[0]) for _ in range(3)]
    return sphere_curves(ax, curves, values, **options)


def _panels(n: int, ncols: int, size: float) -> tuple[Any, list[Any]]:
    import matplotlib.pyplot as plt

    ncols = min(ncols, n)
    nrows = -(-n // ncols)
    # constrained layout keeps every title and colorbar label inside the figure, also after
    # the report shrinks it to the page (tight_layout does not lay out 3D axes: titles and
    # colorbar labels were clipped at the edges)
    fig = plt.figure(figsize=(size * ncols, size * nrows), layout="constrained")
    return fig, [sphere_axes(fig, (nrows, ncols, k + 1)) for k in range(n)]


def _running_curves(manifold: Any, t: float, take: Any, max_trajectories: int
                    ) -> tuple[list, list, float]:
    """Per trajectory: the states up to ``t`` (and up to its stop), mapped by ``take``."""
    i = manifold.index(t)
    out_c, out_v = [], []
    for j in decimate(manifold.n_points, max_trajectories):
        k = min(i, int(np.sum(manifold.t < manifold.stop_time[j])))  # last running index
        c, v = take(manifold.x[: k + 1, j])
        out_c.append(c)
        out_v.append(v)
    vmax = max((float(np.max(v)) for v in out_v if len(v)), default=0.0)
    return out_c, out_v, vmax


def _velocity_norm(manifold: Any, X: np.ndarray) -> np.ndarray:
    man = manifold.model.manifold
    parts = [X[:, man.slices[n]][:, 3:6] if isinstance(f, TS2) else X[:, man.slices[n]]
             for n, f in man.factors if isinstance(f, (TS2, Rn))]
    return np.linalg.norm(np.hstack(parts), axis=1)


def s2_manifold_figure(manifold: Any, times: Sequence[float], *, factor: str | None = None,
                       marks: Mapping[str, ArrayLike] | None = None, ncols: int = 2,
                       size: float = 4.0, max_segments: int = MAX_SEGMENTS,
                       max_trajectories: int = 400, rasterized: bool = True,
                       colour_run: int = COLOUR_RUN, colour_tol: float = COLOUR_TOL,
                       ) -> Any:
    """Paper 002 Fig. 1: a manifold of a model on S^2 at several ``t``, coloured by speed.

    Each trajectory is drawn from its seed to parameter ``t`` (or to its stop) as the curve
    of its S^2 component, coloured by the norm of the model's velocity parts (``|omega|``);
    every panel has its own colour range (title: ``t`` and the largest speed).

    Parameters
    ----------
    manifold : InvariantManifold
        A manifold of a model with an S2 or TS2 factor.
    times : sequence of float
        Output times of the manifold, one panel each.
    factor : str, optional
        The factor to draw (default: the first S2 or TS2 factor).
    marks : mapping of str to array-like, optional
        Labelled points to mark, e.g. ``{"hanging": e3, "inverted": -e3}``.
    ncols : int
        Panels per row.
    size : float
        Panel size [inch].
    max_segments : int
        Segment budget per panel.
    max_trajectories : int
        Draw at most this many trajectories (evenly chosen by index).
    rasterized : bool
        Rasterise the curves in vector outputs.
    colour_run, colour_tol : int, float
        Segments per colour and the colour error allowed, as in :func:`sphere_curves`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    man = manifold.model.manifold
    names = [n for n, f in man.factors if f.kind in ("S2", "TS2")]
    name = factor if factor is not None else (names[0] if names else None)
    if name is None or name not in names:
        raise ModelError(f"factor must name an S2 or TS2 factor of {manifold.model.name!r}; "
                         f"got {factor!r} (S2/TS2 factors: {names})")
    sl = man.slices[name]
    fig, axes = _panels(len(times), ncols, size)
    for ax, t in zip(axes, times):
        curves, vals, vmax = _running_curves(
            manifold, t, lambda X: (X[:, sl][:, :3], _velocity_norm(manifold, X)),
            max_trajectories)
        coll = sphere_curves(ax, curves, vals, vmin=0.0, vmax=max(vmax, 1e-300),
                             max_segments=max_segments, rasterized=rasterized,
                             colour_run=colour_run, colour_tol=colour_tol)
        if marks:
            mark_directions(ax, np.array([np.asarray(v, float) for v in marks.values()]),
                            list(marks))
        ax.set_title(f"t = {t:g} s\n|omega|max = {vmax:.3g} rad/s", fontsize=9)
        fig.colorbar(coll, ax=ax, shrink=0.6, pad=0.0, label="|omega| [rad/s]")
    return fig


def so3_manifold_figure(manifold: Any, times: Sequence[float], *,
                        attitudes: Mapping[str, ArrayLike] | None = None, ncols: int = 2,
                        size: float = 4.0, max_segments: int = MAX_SEGMENTS,
                        max_trajectories: int = 200, rasterized: bool = True,
                        colour_run: int = COLOUR_RUN, colour_tol: float = COLOUR_TOL,
                        ) -> Any:
    """Paper 002 Figs. 2, 4, 5: a manifold on TSO(3) as body-axis curves at several ``t``.

    Parameters
    ----------
    manifold : InvariantManifold
        A manifold of a model with one SO3 factor (and an R^3 angular velocity).
    times : sequence of float
        Output times, one panel each.
    attitudes : mapping of str to array-like (3, 3), optional
        Attitudes whose three axes are marked and labelled ``name:1``, ``name:2``,
        ``name:3`` (e.g. the desired attitude and the saddle); different markers each.
    ncols, size, max_segments, max_trajectories, rasterized, colour_run, colour_tol
        As in :func:`s2_manifold_figure`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    man = manifold.model.manifold
    rot = [n for n, f in man.factors if isinstance(f, SO3)]
    if len(rot) != 1:
        raise ModelError(f"so3_manifold_figure needs exactly one SO3 factor; "
                         f"{manifold.model.name!r} has {man.describe()}")
    sl = man.slices[rot[0]]
    markers = ["o", "s", "^", "D"]
    fig, axes = _panels(len(times), ncols, size)
    for ax, t in zip(axes, times):
        def take(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return X[:, sl], _velocity_norm(manifold, X)

        flat, vals, vmax = _running_curves(manifold, t, take, max_trajectories)
        Rs = [np.stack([SO3.matrix(r) for r in f]) for f in flat]
        curves = [R[:, :, i] for R in Rs for i in range(3)]
        values = [v for v in vals for _ in range(3)]
        coll = sphere_curves(ax, curves, values, vmin=0.0, vmax=max(vmax, 1e-300),
                             max_segments=max_segments, rasterized=rasterized,
                             colour_run=colour_run, colour_tol=colour_tol)
        for k, (label, A) in enumerate((attitudes or {}).items()):
            A = np.asarray(A, dtype=float).reshape(3, 3)
            mark_directions(ax, A.T, [f"{label}:{i + 1}" for i in range(3)],
                            marker=markers[k % len(markers)], color=["k", "m", "g", "b"][k % 4])
        ax.set_title(f"t = {t:g} s\n|Omega|max = {vmax:.3g} rad/s", fontsize=9)
        fig.colorbar(coll, ax=ax, shrink=0.6, pad=0.0, label="|Omega| [rad/s]")
    return fig
