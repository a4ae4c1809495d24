"""Running the problems for a report: one at a time, each failure captured, with progress.

A problem that raises does not abort the report: its :class:`ProblemRun` carries the
error (type, message and traceback) and the report shows it as failed. Figures are
turned into SVG text right after the problem runs (and closed), so a long report does
not hold every matplotlib figure in memory.
"""

from __future__ import annotations

import html
import io
import re
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any, TextIO

from workbench.app.report.figures import FigureData, auto_caption, plain_log_labels, readable
from workbench.core._model import Model
from workbench.core.status import StatusEnum, StatusResult
from workbench.study._result import Result

__all__ = ["Status", "ProblemRun", "models_of", "figure_svg", "run_problem", "run_problems"]


class Status(str, StatusEnum):
    """Outcome of one problem in a report (short values: they label the report's tables).

    Attributes
    ----------
    OK
        Ran; every comparison within its tolerance.
    OUT_OF_TOLERANCE
        Ran; some comparison outside its tolerance.
    FAILED
        Raised an exception, or its process died (shown in the report).
    TIMED_OUT
        Stopped at its time limit (shown in the report).
    """

    OK = "ok"
    OUT_OF_TOLERANCE = "out of tolerance"
    FAILED = "failed"
    TIMED_OUT = "timed out"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"OK"})


@dataclass
class ProblemRun(StatusResult):
    """One problem as run for a report.

    Attributes
    ----------
    name, title : str
        The problem's name and one-line title.
    status : Status
    seconds : float
        Wall time of ``solve`` (including the models' builds).
    result : Result or None
        ``None`` when the problem failed.
    models : list of Model
        The Model objects the problem used (empty when it failed).
    figures : dict of str to FigureData
        Each figure as SVG text with its caption and printed size, by name.
    error : str
        ``"ExceptionType: message"`` when failed.
    traceback : str
        The traceback when failed.
    """

    name: str
    title: str
    status: Status
    seconds: float
    result: Result | None = None
    models: list[Model] = field(default_factory=list)
    figures: dict[str, FigureData] = field(default_factory=dict)
    error: str = ""
    traceback: str = ""


def models_of(result: Result) -> list[Model]:
    """The Model objects a result declared with ``Result.use`` (deduplicated, in order)."""
    out: list[Model] = []
    for m in result.used_models:
        if not any(m is o for o in out):
            out.append(m)
    return out


_TIGHT_LAYOUT_WARNINGS = ("Tight layout not applied", "This figure includes Axes that are not "
                          "compatible with tight_layout")


def figure_svg(fig: Any, *, salt: str) -> str:
    """A matplotlib figure as self-contained SVG text (text as paths, no date, stable ids).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    salt : str
        Makes the SVG's internal ids unique within one HTML page (use the problem and
        figure names) and the output reproducible.

    Returns
    -------
    str
        The ``<svg>`` element, without the XML prolog. Links an artist carries
        (``set_url``) are kept only to ``http(s)://`` or ``#`` targets: the report is a
        page without scripts, and a ``javascript:`` link would be one.
    """
    import matplotlib

    buf = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "path", "svg.hashsalt": salt}), \
            warnings.catch_warnings():
        # a tight layout engine lays the figure out while it is drawn here; what it cannot
        # fit (3D axes, crowded panels) it leaves as drawn, as fig.tight_layout() did
        for message in _TIGHT_LAYOUT_WARNINGS:
            warnings.filterwarnings("ignore", message=message, category=UserWarning)
        fig.savefig(buf, format="svg", metadata={"Date": None})
    text = buf.getvalue()
    return _SVG_ANCHOR.sub(_safe_anchor, text[text.index("<svg"):])


_SVG_ANCHOR = re.compile(r"<a\b[^>]*>")
_HREF = re.compile(r'((?:xlink:)?href)="([^"]*)"')


def _safe_anchor(m: re.Match) -> str:
    """An ``<a>`` start tag with any link but ``http(s)://`` or ``#`` replaced by ``#``.

    Only links (``<a>``) are touched: ``<use>`` and ``<image>`` refer to the SVG's own
    glyphs and embedded rasters (``#id``, ``data:image/png``).
    """
    def one(h: re.Match) -> str:
        target = html.unescape(h.group(2)).strip()
        if target.startswith("#") or re.match(r"https?://", target, re.I):
            return h.group(0)
        return f'{h.group(1)}="#"'  # javascript:, data:, file: ... are dropped

    return _HREF.sub(one, m.group(0))


def _close(fig: Any) -> None:
    import matplotlib.pyplot as plt

    plt.close(fig)


def run_problem(name: str, *, quick: bool, catalogue: ModuleType) -> ProblemRun:
    """Run one problem, capturing any exception.

    Parameters
    ----------
    name : str
        A name from ``catalogue.names()``.
    quick : bool
        Passed to ``solve``.
    catalogue : module
        Provides ``load(name)`` and ``title(name)`` (the ``problems`` package).

    Returns
    -------
    ProblemRun
    """
    t0 = time.perf_counter()
    title = name
    try:
        module = catalogue.load(name)
        title = str(getattr(module, "TITLE", name))
        result = module.solve(quick=quick)
        if not isinstance(result, Result):
            raise TypeError(f"solve() returned {type(result).__name__}, expected Result")
    except Exception as exc:  # noqa: BLE001 - a failing problem is reported, not fatal
        return ProblemRun(
            name, title, Status.FAILED, time.perf_counter() - t0,
            error=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc(),
        )
    seconds = time.perf_counter() - t0
    result.timings.setdefault("total", seconds)
    run = ProblemRun(
        name, result.title or title, Status.OK if result.ok else Status.OUT_OF_TOLERANCE,
        seconds, result=result, models=models_of(result),
    )
    for fname, fig in result.figures.items():
        try:
            own = str(getattr(result, "captions", {}).get(fname, "")).strip()
            plain_log_labels(fig)
            size = readable(fig)
            run.figures[fname] = FigureData(fname, own or auto_caption(fname, fig),
                                            figure_svg(fig, salt=f"{name}/{fname}"),
                                            size["width"], size["height"], own=bool(own))
        except Exception as exc:  # noqa: BLE001 - one bad figure does not lose the problem
            result.notes.append(f"figure {fname!r} could not be drawn: {exc}")
        finally:
            _close(fig)
    return run


def run_problems(
    names: Sequence[str],
    *,
    quick: bool,
    catalogue: ModuleType,
    progress: bool = True,
    stream: TextIO | None = None,
    on_done: Callable[[ProblemRun], None] | None = None,
) -> list[ProblemRun]:
    """Run problems one after the other, showing progress on stderr.

    Parameters
    ----------
    names : sequence of str
        Problems to run, in order.
    quick : bool
        Passed to every ``solve``.
    catalogue : module
        The problem catalogue (``problems``).
    progress : bool
        Show progress (a tqdm bar on a terminal, one line per problem otherwise).
    stream : file, optional
        Where progress goes (default ``sys.stderr``).
    on_done : callable, optional
        Called with each finished run.

    Returns
    -------
    list of ProblemRun
    """
    stream = stream or sys.stderr
    runs: list[ProblemRun] = []
    bar = None
    if progress and stream.isatty():
        from tqdm import tqdm

        bar = tqdm(total=len(names), file=stream, unit="problem", dynamic_ncols=True)
    for i, name in enumerate(names):
        if bar is not None:
            bar.set_description(name)
        elif progress:
            print(f"[{i + 1}/{len(names)}] {name} ...", file=stream, flush=True)
        run = run_problem(name, quick=quick, catalogue=catalogue)
        runs.append(run)
        if bar is not None:
            bar.update(1)
            if run.status is Status.FAILED:
                bar.write(f"{name}: FAILED ({run.error})", file=stream)
        elif progress:
            extra = f" ({run.error})" if run.error else ""
            print(f"[{i + 1}/{len(names)}] {name}: {run.status.value} in {run.seconds:.1f} s"
                  f"{extra}", file=stream, flush=True)
        if on_done is not None:
            on_done(run)
    if bar is not None:
        bar.close()
    return runs
