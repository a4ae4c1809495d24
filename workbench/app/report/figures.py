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
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

__all__ = ["PRINT_WIDTH", "MAX_HEIGHT", "MIN_POINTS", "FigureData", "report_style", "warm_up",
           "readable", "plain_log_labels", "auto_caption"]

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


_MATHDEFAULT = re.compile(
    r"\$\\mathdefault\{(-?)(?:([0-9.]+)\\times)?([0-9.]+)\^\{(-?[0-9]+)\}\}\$")
_PLAIN_NUMBER = re.compile(r"\$\\mathdefault\{(-?[0-9.]+)\}\$")
_TIMES, _MINUS = "\u00d7", "\u2212"  # as mathtext draws them
_SUPERSCRIPT = str.maketrans("0123456789-", "\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077"
                                            "\u2078\u2079\u207b")


def plain_label(label: str) -> str:
    r"""A log axis' mathtext tick label as plain text, or the label unchanged.

    ``$\mathdefault{10^{-3}}$`` becomes ``10⁻³`` and ``$\mathdefault{2\times10^{4}}$``
    ``2×10⁴`` (Unicode superscripts, drawn by the text engine without parsing); a plain
    number loses its ``$\mathdefault{}$``; anything else is returned as it is.

    Parameters
    ----------
    label : str
        A tick label as matplotlib's log formatters write it.

    Returns
    -------
    str
    """
    m = _MATHDEFAULT.fullmatch(label)
    if m:
        sign, coeff, base, exponent = m.groups()
        times = coeff + _TIMES if coeff else ""
        return f"{_MINUS if sign else ''}{times}{base}{exponent.translate(_SUPERSCRIPT)}"
    m = _PLAIN_NUMBER.fullmatch(label)
    return m.group(1).replace("-", _MINUS) if m else label


def plain_log_labels(fig: Any) -> int:
    r"""Write the tick labels of a figure's log axes as plain text instead of mathtext.

    Matplotlib labels log axes with mathtext (``$\mathdefault{10^{-3}}$``), which it
    parses for every label at every draw: half the time to write the work-precision
    figures as SVG (2.10 -> 0.99 s CPU, median of 5 interleaved rounds). The labels read
    the same as Unicode text (:func:`plain_label`). Each log formatter is replaced by a
    copy that converts its labels; other formatters are left alone.

    Parameters
    ----------
    fig : matplotlib.figure.Figure

    Returns
    -------
    int
        Number of formatters replaced.
    """
    from matplotlib.ticker import LogFormatterMathtext

    n = 0
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for get, put in ((axis.get_major_formatter, axis.set_major_formatter),
                             (axis.get_minor_formatter, axis.set_minor_formatter)):
                old = get()
                if isinstance(old, LogFormatterMathtext) and not getattr(old, "_plain", False):
                    put(_plain_copy(old))
                    n += 1
    return n


def _plain_copy(old: Any) -> Any:
    """A copy of a mathtext log formatter whose labels go through :func:`plain_label`."""
    base = type(old)

    class PlainLabels(base):  # type: ignore[valid-type, misc]
        _plain = True

        def __call__(self, x: float, pos: int | None = None) -> str:
            return plain_label(super().__call__(x, pos))

    new = PlainLabels.__new__(PlainLabels)
    new.__dict__.update(old.__dict__)
    return new


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
        from matplotlib.layout_engine import PlaceHolderLayoutEngine

        engine = fig.get_layout_engine()
        # a figure laid out once by fig.tight_layout() keeps a placeholder engine, which
        # lays nothing out: it must be laid out again at its new size (it was not: the
        # work-precision figure lost its axis labels at half size). A tight engine lays
        # it out when it is drawn, once, at its final size: the workbench's own figures
        # set one instead of calling fig.tight_layout(), which laid each out twice
        # (the quick report: 7.8 s CPU of tight layouts, 2.2 s in work_precision alone)
        if engine is None or isinstance(engine, PlaceHolderLayoutEngine):
            with contextlib.suppress(Exception):
                fig.set_layout_engine("tight")
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
