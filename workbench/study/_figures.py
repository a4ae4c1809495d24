"""Plain figures of problems: curves in panels, spectra in the complex plane.

* :class:`Panel` and :func:`line_figure` -- named curves per panel (time series,
  convergence histories), linear or logarithmic axes;
* :func:`spectrum_figure` -- computed eigenvalues beside reference values in the complex
  plane, one panel per equilibrium.

Both make a new figure with the non-interactive Agg backend and return it; nothing is
shown or saved.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from workbench.core.errors import ParameterError
from workbench.core.types import ArrayLike

__all__ = ["Panel", "line_figure", "spectrum_figure"]


@dataclass
class Panel:
    """One axes of a :func:`line_figure`.

    Attributes
    ----------
    title : str
        The panel's title.
    curves : mapping of str to (array-like, array-like)
        ``label -> (x, y)``; ``y`` may have several columns (one line each, drawn in
        one colour under one legend entry; e.g. many trajectories of one kind).
    xlabel, ylabel : str
        Axis labels with units.
    yscale : str
        ``"linear"``, ``"log"`` (values at or below 0 are dropped from the view), or
        ``"symlog"``.
    xscale : str
        As ``yscale``.
    marker : str
        A matplotlib marker for every curve (``""``: lines only).
    linestyle : str
        A matplotlib line style for every curve (``""``: markers only).
    """

    title: str
    curves: Mapping[str, tuple[ArrayLike, ArrayLike]] = field(default_factory=dict)
    xlabel: str = ""
    ylabel: str = ""
    yscale: str = "linear"
    xscale: str = "linear"
    marker: str = ""
    linestyle: str = "-"


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _grid(n: int, ncols: int, size: tuple[float, float]) -> tuple[Any, list[Any]]:
    if n < 1:
        raise ParameterError("a figure needs at least one panel; got none")
    plt = _pyplot()
    cols = min(ncols, n)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(size[0] * cols, size[1] * rows),
                             squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.set_visible(False)
    return fig, flat[:n]


def line_figure(panels: Sequence[Panel], *, ncols: int = 2,
                size: tuple[float, float] = (4.6, 3.3)) -> Any:
    """Curves in panels, laid out ``ncols`` to a row.

    Parameters
    ----------
    panels : sequence of Panel
        What each axes shows.
    ncols : int
        Panels per row.
    size : (float, float)
        Width and height of one panel in inches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = _grid(len(panels), ncols, size)
    for ax, p in zip(axes, panels):
        for label, (x, y) in p.curves.items():
            lines = ax.plot(np.asarray(x), np.asarray(y), marker=p.marker or None,
                            linestyle=p.linestyle or "none")
            for line in lines[1:]:  # columns of a 2D y: one colour, one legend entry
                line.set_color(lines[0].get_color())
            lines[0].set_label(label)
        ax.set(title=p.title, xlabel=p.xlabel, ylabel=p.ylabel, xscale=p.xscale,
               yscale=p.yscale)
        ax.grid(True, alpha=0.3)
        if len(p.curves) > 1:
            ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def spectrum_figure(spectra: Mapping[str, tuple[ArrayLike, ArrayLike | None]], *,
                    ncols: int = 3, reference_label: str = "paper",
                    size: tuple[float, float] = (3.4, 3.2)) -> Any:
    """Computed eigenvalues (dots) beside reference values (rings) in the complex plane.

    Parameters
    ----------
    spectra : mapping of str to (array-like, array-like or None)
        ``title -> (computed, reference)``, one panel each; ``reference`` may be None.
    ncols : int
        Panels per row.
    reference_label : str
        The legend's name of the reference values.
    size : (float, float)
        Width and height of one panel in inches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = _grid(len(spectra), ncols, size)
    for ax, (title, (computed, reference)) in zip(axes, spectra.items()):
        c = np.asarray(computed, dtype=complex).ravel()
        ax.axvline(0.0, color="0.6", lw=0.8)
        ax.axhline(0.0, color="0.85", lw=0.6)
        ax.plot(c.real, c.imag, "o", ms=4, label="workbench")
        if reference is not None:
            r = np.asarray(reference, dtype=complex).ravel()
            ax.plot(r.real, r.imag, "o", ms=10, mfc="none", mec="C3", label=reference_label)
        ax.set(title=title, xlabel="Re lambda", ylabel="Im lambda")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8, loc="best")
    fig.tight_layout()
    return fig
