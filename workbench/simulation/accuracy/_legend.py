"""One legend for a figure's panels, in rows under them."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

__all__ = ["legend_below"]


def legend_below(fig: Any, axes: Sequence[Any], *, fontsize: float = 7.0,
                 max_columns: int | None = None) -> Any:
    """Gather the labels of ``axes`` into one legend under them (constrained layout).

    Every label appears once, with its first handle, in the order met. Constrained layout
    makes room for it at draw time, so also after the report shrinks the figure to the
    page (a legend inside a panel covered points or curves at the printed size).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    axes : sequence of matplotlib.axes.Axes
    fontsize : float
        Size of the legend's text [pt].
    max_columns : int, optional
        Entries per row (default: all in one row).

    Returns
    -------
    matplotlib.legend.Legend or None
        None when no axes has a labelled artist.
    """
    entries: dict[str, Any] = {}
    for ax in axes:
        for handle, text in zip(*ax.get_legend_handles_labels()):
            entries.setdefault(text, handle)
    fig.set_layout_engine("constrained")
    if not entries:
        return None
    return fig.legend(list(entries.values()), list(entries), loc="outside lower center",
                      ncol=min(max_columns or len(entries), len(entries)), fontsize=fontsize,
                      frameon=False)
