"""Results of problems: values, paper-versus-workbench comparisons, figures, costs.

A problem's ``solve(*, quick=False)`` returns a :class:`Result`. Its ``values`` are plain
JSON-serialisable data; its ``comparisons`` put each number a paper prints (or a closed
form) next to the workbench's, with the deviation and the tolerance it is held to; its
``figures`` are matplotlib figures; ``build_log`` lists every casadi.Function the problem
built; ``timings`` the wall time of its steps.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from workbench.core._model import Model
from workbench.core.errors import OutputError, ParameterError
from workbench.core.files import write_atomic
from workbench.core.status import StatusEnum, StatusResult
from workbench.core.validate import output_path

__all__ = ["Comparison", "Result", "ResultStatus", "to_jsonable", "format_result", "progress",
           "PROGRESS_ENV", "CORES_ENV", "cores"]

PROGRESS_ENV = "WORKBENCH_PROGRESS"
"""Environment variable naming the file that :func:`progress` appends to (set by the report)."""


CORES_ENV = "WORKBENCH_CORES"
"""Environment variable: the cores one problem may use for its own pools (see :func:`cores`)."""


def cores() -> int:
    """The cores a problem may use for its own process pools.

    ``workbench report`` runs one problem per core and sets :data:`CORES_ENV` in each
    problem's process to its share (the cores over the problems run at once: 1 when
    there are as many of them as cores, all of them for a report of one problem):
    a pool inside a problem would then only compete with the other problems and pay its
    workers' start-up (the Poincare sweep's two spawned workers cost 3 s CPU more than the
    same orbits in the calling process, for no gain in wall time, measured). Elsewhere the
    variable is unset and every core is available.

    Returns
    -------
    int
        ``$WORKBENCH_CORES`` if set, else ``os.cpu_count()`` (1 if unknown).

    Raises
    ------
    ParameterError
        If the variable is set to anything but a positive integer.
    """
    raw = os.environ.get(CORES_ENV)
    if raw is None:
        return os.cpu_count() or 1
    n = int(raw) if raw.strip().isdecimal() else 0  # int() reads every decimal digit
    if n < 1:
        raise ParameterError(f"environment variable {CORES_ENV} must be a positive integer "
                             f"(cores per problem); got {raw!r}")
    return n


def progress(message: str, *, done: float | None = None, total: float | None = None) -> None:
    """Say how far a long problem has got (shown by ``workbench report`` while it runs).

    The report runs each problem in its own process and points :data:`PROGRESS_ENV` at a
    file; every call appends one line to it, which the report prints with the problem's
    elapsed time and, when ``done`` and ``total`` are given, an estimate of the time left
    in the problem (elapsed * (total - done) / done). ``workbench run`` sets it to ``-``:
    the line goes to stderr as text. Elsewhere (tests, notebooks) the variable is unset
    and the call does nothing.

    Parameters
    ----------
    message : str
        What the problem is doing now ("OCP on 40 nodes", "orbit 3 of 12").
    done, total : float, optional
        Work done so far and in all, in any unit (steps, orbits, solves); both or neither.

    Raises
    ------
    ParameterError
        If only one of ``done`` and ``total`` is given, or they are not finite numbers with
        ``0 <= done <= total`` and ``total > 0``.

    Examples
    --------
    >>> for i, n in enumerate(grid):                      # doctest: +SKIP
    ...     progress(f"OCP on {n} nodes", done=i, total=len(grid))
    """
    if (done is None) != (total is None):
        raise ParameterError(f"progress: give both done and total or neither; got done={done!r}"
                             f", total={total!r}")
    if done is not None:
        try:
            d, t = float(done), float(total)  # type: ignore[arg-type]
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"progress: done and total must be numbers; got done="
                                 f"{done!r}, total={total!r}") from exc
        if not (math.isfinite(d) and math.isfinite(t) and t > 0 and 0 <= d <= t):
            raise ParameterError(f"progress: expected finite 0 <= done <= total with total > 0;"
                                 f" got done={done!r}, total={total!r}")
        done, total = d, t
    path = os.environ.get(PROGRESS_ENV)
    if not path:
        return
    if path == "-":
        of = f" ({done:g}/{total:g})" if done is not None else ""
        print(f"  progress: {message}{of}", file=sys.stderr, flush=True)
        return
    line = json.dumps({"time": time.time(), "message": str(message), "done": done,
                       "total": total})
    with open(path, "a", encoding="utf-8") as fh:  # one short write: lines stay whole
        fh.write(line + "\n")


def to_jsonable(obj: Any) -> Any:
    """Convert numpy scalars/arrays (also complex) and nested containers to plain JSON data."""
    if isinstance(obj, Mapping):  # dicts and typed records (workbench.core.status.Record)
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (complex, np.complexfloating)):
        return {"re": to_jsonable(float(obj.real)), "im": to_jsonable(float(obj.imag))}
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return f if math.isfinite(f) else str(f)
    return obj


@dataclass
class Comparison:
    """A reference value (printed in a paper, or a closed form) beside the workbench's.

    Attributes
    ----------
    quantity : str
        What is compared.
    reference : float
        The paper's or closed form's value.
    workbench : float
        The workbench's value.
    tolerance : float
        Largest accepted deviation (absolute, or relative when ``relative``).
    source : str
        Where the reference comes from ("paper 000 (3.22)", "closed form", ...).
    relative : bool
        Whether deviation and tolerance are relative to ``|reference|``.
    headline : bool
        Whether the problem names this comparison its headline: the report shows it
        first among those within tolerance (one out of tolerance is always shown first).
    """

    quantity: str
    reference: float
    workbench: float
    tolerance: float
    source: str
    relative: bool = False
    headline: bool = False

    @property
    def deviation(self) -> float:
        """``|workbench - reference|``, divided by ``|reference|`` when relative."""
        d = abs(float(self.workbench) - float(self.reference))
        if self.relative:
            d /= max(abs(float(self.reference)), np.finfo(float).tiny)
        return d

    @property
    def ok(self) -> bool:
        """Whether the deviation is within the tolerance."""
        return bool(self.deviation <= self.tolerance)

    def as_dict(self) -> dict[str, Any]:
        """Plain form."""
        return to_jsonable(
            {
                "quantity": self.quantity,
                "reference": self.reference,
                "workbench": self.workbench,
                "deviation": self.deviation,
                "tolerance": self.tolerance,
                "relative": self.relative,
                "source": self.source,
                "ok": self.ok,
                "headline": self.headline,
            }
        )


class ResultStatus(StatusEnum):
    """Outcome of a problem's comparisons; the value is a readable message."""

    OK = "every comparison within its tolerance"
    OUT_OF_TOLERANCE = "some comparisons out of tolerance"
    NO_COMPARISONS = "no reference values to compare with"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"OK", "NO_COMPARISONS"})


@dataclass
class Result(StatusResult):
    """What a problem's ``solve`` returns.

    Attributes
    ----------
    name : str
        The problem's name (its module name in ``problems/``).
    title : str
        One line: what it reproduces.
    quick : bool
        Whether it ran in quick mode.
    values : dict
        Results as plain data.
    comparisons : list of Comparison
        Reference versus workbench.
    figures : dict of str to matplotlib.figure.Figure
        Figures by name.
    captions : dict of str to str
        A caption (what the figure shows, in words) per figure name; see :meth:`figure`.
    timings : dict of str to float
        Wall seconds of the problem's steps.
    build_log : list of dict
        Every casadi.Function built, from the models used.
    models : list of str
        Names of the models used.
    notes : list of str
        Remarks (departures from the paper, errata applied).
    labels : dict of str to str
        What the codes in the problem's figures, tables and values mean, in words
        (``{"q1": "tilt of link 1", "omega1": "rate of link 1", "L2": "hanging, spinning
        about e3"}``); see :meth:`label`. The report lists them beside the figures, and
        :func:`~workbench.study.line_figure` and :func:`~workbench.study.spectrum_figure`
        take them as ``labels=``.
    """

    name: str
    title: str
    quick: bool = False
    values: dict[str, Any] = field(default_factory=dict)
    comparisons: list[Comparison] = field(default_factory=list)
    figures: dict[str, Any] = field(default_factory=dict)
    captions: dict[str, str] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    build_log: list[dict[str, Any]] = field(default_factory=list)
    models: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    labels: dict[str, str] = field(default_factory=dict)

    def label(self, **words: str) -> dict[str, str]:
        """Say in words what codes mean (``res.label(q1="tilt of link 1")``); return all labels.

        Raises
        ------
        ParameterError
            If a label is empty.
        """
        empty = sorted(k for k, v in words.items() if not str(v).strip())
        if empty:
            raise ParameterError(f"label: the words for {empty} are empty; say what each "
                                 f"code is (e.g. q1='tilt of link 1')")
        self.labels.update({k: str(v).strip() for k, v in words.items()})
        return self.labels

    def compare(
        self,
        quantity: str,
        reference: float,
        workbench: float,
        *,
        tolerance: float,
        source: str,
        relative: bool = False,
        headline: bool = False,
    ) -> Comparison:
        """Record a reference-versus-workbench comparison and return it.

        Parameters
        ----------
        quantity : str
            What is compared.
        reference, workbench : float
            The paper's (or closed form's) value and the workbench's.
        tolerance : float
            Largest accepted deviation (relative to ``|reference|`` when ``relative``).
        source : str
            Where the reference comes from ("paper 000 (3.22)", "closed form").
        relative : bool
            Whether deviation and tolerance are relative.
        headline : bool
            Make this the problem's headline comparison in the report (by default the
            report picks the most telling one from the data: one out of tolerance, else
            a value printed in a paper, closest to its tolerance).

        Returns
        -------
        Comparison

        Raises
        ------
        ParameterError
            If ``headline`` is not a bool.
        """
        if not isinstance(headline, (bool, np.bool_)):
            raise ParameterError(f"compare {quantity!r}: headline must be True or False; got "
                                 f"{headline!r}")
        c = Comparison(quantity, float(reference), float(workbench), float(tolerance), source,
                       relative, bool(headline))
        self.comparisons.append(c)
        return c

    def figure(self, key: str, fig: Any, *, caption: str) -> Any:
        """Add ``fig`` to :attr:`figures` under ``key`` with its caption; return ``fig``.

        Parameters
        ----------
        key : str
            The figure's name.
        fig : matplotlib.figure.Figure
            The figure.
        caption : str
            What the figure shows, in a sentence or two (the report prints it beneath).

        Raises
        ------
        ParameterError
            If the caption is empty.
        """
        if not str(caption).strip():
            raise ParameterError(f"figure {key!r}: the caption must say what it shows; got ''")
        self.figures[key] = fig
        self.captions[key] = str(caption).strip()
        return fig

    def progress(self, message: str, *, done: float | None = None,
                 total: float | None = None) -> None:
        """Say how far the problem has got; see :func:`progress` (the same, as a method)."""
        progress(message, done=done, total=total)

    @contextmanager
    def timed(self, step: str) -> Iterator[None]:
        """Time a block into ``timings[step]`` (accumulating).

        The step is also reported as progress (:func:`progress`: shown by ``workbench
        report`` while the problem runs, a no-op elsewhere).
        """
        progress(step)
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.timings[step] = self.timings.get(step, 0.0) + time.perf_counter() - t0

    def use(self, *models: Model) -> None:
        """Declare models used; their build logs are collected by :meth:`finish`."""
        for m in models:
            if all(m is not u for u in self._used):
                self._used.append(m)

    def __post_init__(self) -> None:
        self._used: list[Model] = []

    @property
    def used_models(self) -> tuple[Model, ...]:
        """The models declared with :meth:`use`, in order (for reports: equations, builds)."""
        return tuple(self._used)

    @property
    def status(self) -> ResultStatus:
        """:class:`ResultStatus` of the comparisons (``status.value`` reads as a message)."""
        if not self.comparisons:
            return ResultStatus.NO_COMPARISONS
        return ResultStatus.OK if self.ok else ResultStatus.OUT_OF_TOLERANCE

    def finish(self) -> Result:
        """Collect the build logs of the used models (each function once); return self."""
        seen: set[int] = set()
        self.build_log = []
        self.models = []
        for m in self._used:
            self.models.append(m.name)
            if id(m.build_log) in seen:
                continue
            seen.add(id(m.build_log))
            self.build_log.extend(m.build_log.as_list())
        return self

    @property
    def ok(self) -> bool:
        """Whether every comparison is within its tolerance."""
        return all(c.ok for c in self.comparisons)

    def __str__(self) -> str:
        """A short account: status, comparisons, figures, values (:func:`format_result`: all)."""
        n_ok = sum(c.ok for c in self.comparisons)
        keys = ", ".join(list(self.values)[:8]) + (", ..." if len(self.values) > 8 else "")
        total = sum(float(v) for v in self.timings.values())
        return (f"Result {self.name}{' (quick)' if self.quick else ''}: {self.status.value} "
                f"({n_ok}/{len(self.comparisons)} comparisons ok); {len(self.figures)} "
                f"figure(s); values: {keys or '-'}; {len(self.build_log)} functions built; "
                f"{total:.3g} s in timed steps; {len(self.notes)} note(s)")

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON-serialisable form (figures are listed by name only)."""
        return to_jsonable(
            {
                "name": self.name,
                "title": self.title,
                "quick": self.quick,
                "ok": self.ok,
                "status": self.status.name,
                "values": self.values,
                "comparisons": [c.as_dict() for c in self.comparisons],
                "figures": sorted(self.figures),
                "captions": {k: self.captions[k] for k in sorted(self.captions)
                             if k in self.figures},
                "timings": self.timings,
                "build_log": self.build_log,
                "models": self.models,
                "notes": self.notes,
                "labels": self.labels,
            }
        )

    def write_json(self, path: str | Path) -> Path:
        """Write :meth:`as_dict` to ``path``: the complete file or nothing.

        Through :func:`workbench.core.files.write_atomic` (a unique temporary name in the
        target folder, renamed into place; nothing else is touched; umask respected).

        Parameters
        ----------
        path : str or Path
            The JSON file; its folder must exist; ``""`` is refused.

        Returns
        -------
        Path

        Raises
        ------
        OutputError
            Empty path, missing or read-only folder, full disk (nothing is left behind).
        TypeError
            A value that cannot be written as JSON (nothing is written).
        """
        output_path("path", path, error=OutputError)
        text = json.dumps(self.as_dict(), indent=2, allow_nan=False)
        return write_atomic(path, text, name="path")


def _fmt(x: Any) -> str:
    if isinstance(x, float):
        return f"{x:.6g}"
    return str(x)


def format_result(result: Result, *, max_values: int = 40) -> str:
    """A plain-text account of a result for the terminal."""
    lines = [f"== {result.name}: {result.title}" + ("  [quick]" if result.quick else "")]
    if result.comparisons:
        lines.append("  reference vs workbench:")
        w = max(len(c.quantity) for c in result.comparisons)
        for c in result.comparisons:
            kind = "rel" if c.relative else "abs"
            lines.append(
                f"    {'ok ' if c.ok else 'BAD'} {c.quantity:<{w}}  ref {c.reference:<14.10g} "
                f"got {c.workbench:<14.10g} {kind} dev {c.deviation:.2e} (tol {c.tolerance:.0e};"
                f" {c.source})"
            )
    flat = list(_flatten(result.values))
    if flat:
        lines.append("  values:")
        for k, v in flat[:max_values]:
            lines.append(f"    {k} = {v}")
        if len(flat) > max_values:
            lines.append(f"    ... ({len(flat) - max_values} more in --json)")
    if result.timings:
        lines.append(
            "  timings [s]: " + ", ".join(f"{k} {v:.3g}" for k, v in result.timings.items())
        )
    if result.build_log:
        lines.append("  built:")
        for r in result.build_log:
            ms = r["build_seconds"] * 1e3
            lines.append(f"    {r['function']:<44} {r['n_nodes']:>7} nodes  {ms:8.1f} ms")
    for note in result.notes:
        lines.append(f"  note: {note}")
    lines.append(f"  status: {result.status.value}")
    return "\n".join(lines)


def _flatten(values: Any, prefix: str = "") -> Iterator[tuple[str, str]]:
    if isinstance(values, dict):
        for k, v in values.items():
            yield from _flatten(v, f"{prefix}.{k}" if prefix else str(k))
    elif isinstance(values, (list, tuple)) and len(values) > 6:
        arr = np.asarray(values, dtype=object)
        yield prefix, f"[{len(values)} entries]" if arr.ndim else str(values)
    else:
        yield prefix, _fmt(values) if not isinstance(values, (list, tuple)) else str(
            [_fmt(v) for v in values]
        )
