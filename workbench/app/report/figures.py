"""Figures for print: the report's matplotlib style, sizes and fonts readable in the PDF.

The PDF places each figure at its natural size, at most :data:`PRINT_WIDTH` wide, so a
font size in points in the figure is its size on paper. :func:`report_style` sets the
style while a problem draws its figures; :func:`readable` then shrinks a figure wider
than the page to the page's width (keeping its aspect), raises every text of it to at
least :data:`MIN_POINTS`, and lays it out again. :func:`auto_caption` reads a caption
from the figure's own titles (the report's own words, in :mod:`~workbench.app.report.texts`,
replace it when the document is assembled).
"""

from __future__ import annotations

import contextlib
import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

__all__ = ["PRINT_WIDTH", "MAX_HEIGHT", "MIN_POINTS", "FigureData", "report_style", "warm_up",
           "readable", "auto_caption"]

PRINT_WIDTH = 7.0
"""Width of the PDF's text block [in] (A4 with 1.5 cm margins is 7.09 in)."""

MAX_HEIGHT = 5.2
"""Largest figure height on paper [in], so that a page holds a figure and its text."""

MIN_POINTS = 7.0
"""Smallest font size in a figure at print size [pt]."""

@dataclass
class FigureData:
    """A figure as the report keeps it.

    Attributes
    ----------
    name : str
        Its key in ``Result.figures``.
    caption : str
        What it shows, in words.
    svg : str
        Self-contained SVG text.
    width, height : float
        Printed size [in].
    own : bool
        Whether the caption is the problem's own (``Result.figure(..., caption=)``) rather
        than read from the figure's titles.
    """

    name: str
    caption: str
    svg: str
    width: float
    height: float
    own: bool = False


STYLE = {
    "font.size": 8.5,
    "axes.titlesize": 9.0,
    "axes.labelsize": 8.5,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "legend.fontsize": 7.5,
    "figure.titlesize": 10.0,
    "lines.linewidth": 1.3,
    "savefig.bbox": "standard",
}


@contextlib.contextmanager
def report_style() -> Iterator[None]:
    """The report's font sizes for the duration of a block, drawn with Agg.

    Selects matplotlib's Agg backend for the whole process (``matplotlib.use``; the report
    draws off-screen, and a backend cannot be switched back safely once figures exist);
    the font sizes are restored when the block ends.
    """
    import matplotlib

    matplotlib.use("Agg")
    with matplotlib.rc_context(STYLE):
        yield


def warm_up() -> None:
    """Load matplotlib, its fonts and its mathtext parser once, in this process.

    The report runs each problem in a process forked from its own; a child inherits what
    the parent has loaded, so warming up once before the fork saves every problem that
    draws a figure the same start-up (measured 0.1 to 0.35 s CPU per problem, against
    0.4-0.7 s once here). Draws one throw-away figure in :func:`report_style` and writes
    no file; like :func:`report_style` it leaves the process on the Agg backend.
    """
    import io

    with report_style():
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots()
        try:
            ax.semilogy([1.0, 2.0], [1e-3, 1e3])
            ax.set_title(r"$\omega^2$")
            fig.tight_layout()
            fig.savefig(io.StringIO(), format="svg")
        finally:
            plt.close(fig)


def readable(fig: Any) -> dict[str, float]:
    """Fit a figure to the printed page and raise its fonts to :data:`MIN_POINTS`.

    Parameters
    ----------
    fig : matplotlib.figure.Figure

    Returns
    -------
    dict
        ``scale`` (the size factor applied, <= 1), ``raised`` (texts enlarged),
        ``width`` and ``height`` [in] after the change.
    """
    from matplotlib.text import Text

    w, h = (float(v) for v in fig.get_size_inches())
    scale = min(1.0, PRINT_WIDTH / w, MAX_HEIGHT / h)
    if scale < 1.0:
        fig.set_size_inches(w * scale, h * scale)
    raised = 0
    for text in fig.findobj(Text):
        if text.get_text() and text.get_fontsize() < MIN_POINTS:
            text.set_fontsize(MIN_POINTS)
            raised += 1
    if scale < 1.0 or raised:
        engine = fig.get_layout_engine() if hasattr(fig, "get_layout_engine") else None
        if engine is None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                with contextlib.suppress(Exception):
                    fig.tight_layout()
    w2, h2 = (float(v) for v in fig.get_size_inches())
    return {"scale": scale, "raised": raised, "width": w2, "height": h2}


def _clean(text: str) -> str:
    return re.sub(r"\s+", " ", text).strip()


def auto_caption(key: str, fig: Any) -> str:
    """A caption from a figure's own titles (suptitle, then panel titles), else its key.

    Parameters
    ----------
    key : str
        The figure's name in ``Result.figures``.
    fig : matplotlib.figure.Figure

    Returns
    -------
    str
    """
    sup = getattr(fig, "_suptitle", None)
    titles = [_clean(ax.get_title()) for ax in fig.get_axes() if _clean(ax.get_title())]
    parts = ([_clean(sup.get_text())] if sup is not None and _clean(sup.get_text()) else [])
    if titles:
        shown = titles[:4] + (["..."] if len(titles) > 4 else [])
        parts.append(("Panels: " if len(titles) > 1 else "") + "; ".join(shown))
    if parts:
        return ". ".join(parts)
    return key.replace("_", " ").capitalize()
