"""The figure of the ``relative_equilibria`` problem: paper 000 Fig. 4.1 recomputed.

:func:`relative_equilibria_figure` draws the attitudes of the traced families of
:func:`models.relative_families.trace_relative_equilibria` on the sphere, coloured by the
family parameter alpha, and the momentum mu along each family with its stability.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from models.relative_equilibria import alpha
from models.relative_families import RelativeEquilibria
from workbench.equilibria import PointKind

__all__ = ["relative_equilibria_figure"]


def _colour(a: np.ndarray, Jd: np.ndarray) -> np.ndarray:
    """Monotone map of alpha in [-inf, inf] to [0, 1] with the breakpoints 0, 1/J_i."""
    inv = np.sort(1.0 / Jd)
    knots = np.array([0.0, *inv])
    vals = np.array([0.12, 0.35, 0.55, 0.82])
    out = np.interp(a, knots, vals)
    out = np.where(a < 0, 0.12 * (1 + 2 / np.pi * np.arctan(a)), out)
    out = np.where(a > inv[2], 0.82 + 0.18 * 2 / np.pi * np.arctan(a - inv[2]), out)
    return np.clip(out, 0, 1)


def relative_equilibria_figure(atlas: RelativeEquilibria, names: list[str],
                               J: np.ndarray) -> Any:
    """Paper 000 Fig. 4.1 recomputed, and the momentum along each family.

    Parameters
    ----------
    atlas : RelativeEquilibria
        The traced families.
    names : list of str
        A name per branch of ``atlas.branches`` (the legend).
    J : numpy.ndarray
        The inertia matrix (its diagonal places the breakpoints 1/J_i of the colour scale).

    Returns
    -------
    matplotlib.figure.Figure
        Two views of the attitudes Gamma_e on the sphere, coloured by alpha (static
        equilibria and (4.10) marked), and mu against alpha, stable stretches solid.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    Jd = np.diag(J)
    cmap = plt.get_cmap("jet")
    # drawn at its printed size: the two views side by side, the momentum below them
    # (three panels in a row, shrunk to the page, had titles running into each other)
    fig = plt.figure(figsize=(7.0, 5.2), layout="constrained")
    grid = fig.add_gridspec(2, 2, height_ratios=(1.15, 1.0))
    u, v = np.mgrid[0:2 * np.pi:36j, 0:np.pi:18j]
    views = (("seen from above", 25, 35), ("seen from below", -25, 125))
    for panel, (view, elev, azim) in enumerate(views):
        ax = fig.add_subplot(grid[0, panel], projection="3d")
        ax.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v),
                          color="0.88", lw=0.3)
        for b in atlas.branches:
            a = alpha(b.monitors["k"], b.monitors["k1"])
            c = _colour(a, Jd)
            P = b.points[:, :3]
            segs = np.stack([P[:-1], P[1:]], axis=1)
            ax.add_collection(Line3DCollection(segs, colors=cmap(0.5 * (c[:-1] + c[1:])),
                                               linewidths=2.2))
        for name, col in (("hanging", "blue"), ("inverted", "red")):
            ax.scatter(*atlas.static[name].x[:3], color=col, s=45, label=name,
                       edgecolor="k")
        for b in atlas.branches:
            for sp in b.specials(PointKind.EVENT, "k1"):
                ax.scatter(*sp.y[:3], color="magenta", s=35, marker="D", edgecolor="k",
                           label="(4.10)")
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.invert_zaxis()
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_ticks([-1.0, 0.0, 1.0])
        if panel == 0:  # the view from below shares them (its labels would crowd the title)
            ax.set_xlabel("Gamma_1", fontsize=7)
            ax.set_ylabel("Gamma_2", fontsize=7)
            ax.set_zlabel("Gamma_3 (down)", fontsize=7)
            ax.tick_params(labelsize=7)
            handles, labels = ax.get_legend_handles_labels()
            keep = dict(zip(labels, handles))
            fig.legend(keep.values(), keep.keys(), fontsize=7, loc="upper right",
                       bbox_to_anchor=(1.0, 0.86))
        else:
            for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
                axis.set_ticklabels([])
        ax.set_title(view, fontsize=8)
    fig.suptitle("Gamma_e of the families (Fig. 4.1), colour = alpha: -inf blue .. 0 .. "
                 "1/J1 cyan\n.. 1/J2 green .. 1/J3 orange .. +inf red", fontsize=8)
    ax2 = fig.add_subplot(grid[1, :])
    for b, name in zip(atlas.branches, names):
        x = _colour(alpha(b.monitors["k"], b.monitors["k1"]), Jd)
        jump = np.r_[False, np.abs(np.diff(x)) > 0.3]
        x = np.where(jump, np.nan, x)
        stable = np.array([lab == (0, 0) for lab in b.labels])
        mu = b.monitors["mu"]
        ax2.plot(np.where(stable, x, np.nan), mu, "-", lw=1.6, label=name)
        ax2.plot(np.where(~stable, x, np.nan), mu, ":", lw=1.0, color="k")
    ax2.set_yscale("symlog", linthresh=1.0)
    ax2.set_xticks(_colour(np.array([-10.0, 0.0, *np.sort(1 / Jd)]), Jd))
    ax2.set_xticklabels(["-10", "0", "1/J1", "1/J2", "1/J3"])
    ax2.set_xlabel("alpha (compressed scale)")
    ax2.set_ylabel("mu (5.22)")
    ax2.set_title("momentum along the families; solid: spectrally stable, dotted: unstable",
                  fontsize=8)
    ax2.legend(fontsize=7, ncol=4)
    return fig
