"""Choose the model for a scene by measured speed and accuracy.

:func:`compare_models` runs every level of a model that applies to a scene (the full
model, its reductions by a symmetry, special cases whose assumptions hold, the
linearisation near an equilibrium: :mod:`._model_levels`), measures each one's CPU time
(``time.process_time``, median of repeats, build time apart) and its error on the scene's
outputs against a reference run of the full model at a tight tolerance (itself checked:
two tolerances must agree far below the scene's), and names the cheapest level that meets
the tolerance, with the reason each other level was not chosen.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from workbench.core import validate
from workbench.core.errors import ParameterError, WorkbenchError
from workbench.core.status import StatusEnum, StatusResult
from workbench.simulation import Method
from workbench.simulation.accuracy._legend import legend_below
from workbench.study._figures import _grid
from workbench.study._model_levels import (
    FullLevel,
    Level,
    LevelKind,
    Prepared,
    default_levels,
    sequence_of,
)
from workbench.study._model_scene import Integration, Scene, _Flow

__all__ = ["ChoiceStatus", "LevelRun", "ModelChoice", "compare_models", "choice_figure",
           "MAX_REPEATS"]

MAX_REPEATS = 1000
"""Largest accepted ``repeats`` of :func:`compare_models` (each repeat runs every level over
every state of the scene)."""


class ChoiceStatus(str, StatusEnum):
    """How a model choice ended.

    Attributes
    ----------
    CHOSEN
        A level meets the tolerance; the cheapest one is chosen.
    NONE_MEETS
        No level meets the tolerance on the outputs (loosen it, or tighten ``rtol``).
    REFERENCE_UNCONFIRMED
        The reference run at two tolerances disagrees by more than ``reference_margin``
        times the scene's tolerance: the errors cannot be measured at that tolerance.
    """

    CHOSEN = "a level meets the tolerance; the cheapest one is chosen"
    NONE_MEETS = "no level meets the tolerance on the outputs"
    REFERENCE_UNCONFIRMED = ("the reference run at two tolerances disagrees by more than the "
                             "margin below the scene's tolerance")

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"CHOSEN"})


@dataclass
class LevelRun:
    """One level's cost and error on a scene, side by side.

    Attributes
    ----------
    name : str
        The level's name.
    kind : LevelKind
        Its kind.
    applies : bool
        Whether it applies to the scene.
    detail : str
        How it ran, or why it does not apply.
    cpu_seconds : float or None
        Median CPU time (``process_time``) of a run over all the scene's states: map the
        states to the level, integrate (or evaluate the closed form), map back to full
        states. None when it did not run.
    cpu_repeats : list of float
        Every repeat's CPU time.
    build_seconds : float or None
        CPU time of deriving and preparing the level (models, integrators, maps).
    error : float or None
        Max-norm error of the outputs against the reference, over every state and time.
    meets : bool
        ``error <= tolerance``.
    failure : str
        The message of a failed build or run (empty otherwise).
    """

    name: str
    kind: LevelKind
    applies: bool
    detail: str
    cpu_seconds: float | None = None
    cpu_repeats: list[float] = field(default_factory=list)
    build_seconds: float | None = None
    error: float | None = None
    meets: bool = False
    failure: str = ""

    def as_dict(self) -> dict[str, Any]:
        """Plain form (one table row)."""
        return {"level": self.name, "kind": self.kind.value, "applies": self.applies,
                "cpu_seconds": self.cpu_seconds, "build_seconds": self.build_seconds,
                "error": self.error, "meets": self.meets, "detail": self.detail,
                "failure": self.failure, "cpu_repeats": list(self.cpu_repeats)}


@dataclass
class ModelChoice(StatusResult):
    """The levels of a model compared on a scene, and the one chosen.

    Attributes
    ----------
    scene : str
        The scene's name.
    tolerance : float
        The scene's tolerance on the outputs.
    levels : list of LevelRun
        Every level, in the order given.
    choice : str or None
        The cheapest level that meets the tolerance (None when none does).
    excluded : dict of str to str
        Why each other level was not chosen.
    reference : dict
        ``rtol``, ``check_rtol``, ``difference`` (max output difference between the two
        reference runs), ``margin``, ``cpu_seconds``.
    knobs : dict
        The integration knobs, ``repeats`` and ``horizon``, ``n_states``, ``n_times``.
    status : ChoiceStatus
        How it ended.
    """

    scene: str
    tolerance: float
    levels: list[LevelRun]
    choice: str | None
    excluded: dict[str, str]
    reference: dict[str, float]
    knobs: dict[str, Any]
    status: ChoiceStatus

    def level(self, name: str) -> LevelRun:
        """The run of the level called ``name``."""
        for lv in self.levels:
            if lv.name == name:
                return lv
        raise ParameterError(f"no level {name!r}; levels: {[lv.name for lv in self.levels]}")

    @property
    def chosen(self) -> LevelRun | None:
        """The chosen level's run."""
        return None if self.choice is None else self.level(self.choice)

    @property
    def speedup(self) -> float | None:
        """CPU time of the full model over the chosen level's (None without both)."""
        full = next((lv for lv in self.levels if lv.kind is LevelKind.FULL
                     and lv.cpu_seconds), None)
        ch = self.chosen
        if full is None or ch is None or not ch.cpu_seconds:
            return None
        return float(full.cpu_seconds / ch.cpu_seconds)

    def table(self) -> list[dict[str, Any]]:
        """One row per level: cost and error side by side, and why it was not chosen."""
        return [{**lv.as_dict(), "chosen": lv.name == self.choice,
                 "why_not": self.excluded.get(lv.name, "")} for lv in self.levels]

    def as_dict(self) -> dict[str, Any]:
        """Plain form."""
        return {"scene": self.scene, "tolerance": self.tolerance, "choice": self.choice,
                "speedup": self.speedup, "status": self.status.code,
                "reference": dict(self.reference), "knobs": dict(self.knobs),
                "levels": self.table()}

    def __str__(self) -> str:
        """The table as text."""
        head = (f"scene {self.scene!r}: tolerance {self.tolerance:.1e}; choice "
                f"{self.choice or '-'}" + (f" ({self.speedup:.1f}x less CPU than full)"
                                           if self.speedup else "")
                + f"; {self.status.message}")
        rows = [f"  {lv.name:<28} " + (
            f"cpu {lv.cpu_seconds:.3g} s, build {lv.build_seconds:.3g} s, error "
            f"{lv.error:.2e}" if lv.cpu_seconds is not None and lv.error is not None
            else "-") + (f"  [{self.excluded[lv.name]}]" if lv.name in self.excluded else
                         "  [chosen]") for lv in self.levels]
        return "\n".join([head, *rows])


def _knobs(method: Any, rtol: float, atol: float, multistep: Any, step: Any,
           max_steps: int) -> Integration:
    return Integration(method=method, rtol=rtol, atol=atol, multistep=multistep, step=step,
                       max_steps=max_steps)


def _reference(scene: Scene, rtol: float, check_rtol: float, max_steps: int
               ) -> tuple[list[np.ndarray], float, float]:
    """Reference outputs (full model, CVODES Adams at ``rtol``) and their checked spread."""
    c0 = time.process_time()
    out = []
    for r in (rtol, check_rtol):
        flow = _Flow(scene.model, scene.times, Integration(rtol=r, atol=r, max_steps=max_steps))
        out.append([scene.output(flow(x, scene.model.p)) for x in scene.states])
    diff = max(float(np.max(np.abs(a - b))) for a, b in zip(*out))
    return out[0], diff, time.process_time() - c0


def _prepare(level: Level, scene: Scene, knobs: Integration
             ) -> tuple[LevelRun, Prepared | None]:
    why = level.refusal(scene)
    if why is not None:
        return LevelRun(level.name, level.kind, False, why), None
    c0 = time.process_time()
    try:
        prep = level.prepare(scene, knobs)
    except WorkbenchError as exc:
        return LevelRun(level.name, level.kind, True, "", failure=f"build failed: {exc}"), None
    build = level.derive_seconds + time.process_time() - c0
    return LevelRun(level.name, level.kind, True, prep.detail, build_seconds=build), prep


def _why_not(run: LevelRun, chosen: LevelRun | None, tol: float, unconfirmed: str) -> str:
    if not run.applies:
        return f"does not apply: {run.detail}"
    if run.failure:
        return f"failed: {run.failure}"
    if not run.meets:
        return f"error {run.error:.2e} > tolerance {tol:.1e}"
    if unconfirmed:
        return f"meets the tolerance, but {unconfirmed}"
    assert chosen is not None and run.cpu_seconds is not None
    return (f"meets the tolerance but costs {run.cpu_seconds:.3g} s, "
            f"{run.cpu_seconds / chosen.cpu_seconds:.2f}x the chosen level's")


def compare_models(scene: Scene, levels: Sequence[Level] | None = None, *,
                   special_cases: Sequence[Level] = (), symmetries: Sequence[str] | None = None,
                   equilibria: Sequence[Any] = (), radius: float | None = None,
                   method: Method | str = Method.CVODES, rtol: float = 1e-8,
                   atol: float = 1e-8, multistep: str = "adams", step: float | None = None,
                   max_steps: int = 100_000, repeats: int = 5, reference_rtol: float = 1e-12,
                   check_rtol: float = 1e-10, reference_margin: float = 0.01, seed: int = 0,
                   raise_on_failure: bool = True) -> ModelChoice:
    """Run every level of a model that applies to a scene and choose the cheapest adequate one.

    Parameters
    ----------
    scene : Scene
        Initial states, horizon, outputs, tolerance.
    levels : sequence of Level, optional
        The levels to compare; default :func:`default_levels` (full, Lagrange-Poincare and
        Routh by every symmetry, the linearisation at each of ``equilibria``).
    special_cases : sequence of Level
        Added to the levels (e.g. :class:`SpecialCase`; their assumptions are checked).
    symmetries, equilibria, radius
        Passed to :func:`default_levels` (``radius`` default 0.05); only when ``levels`` is
        None (given with ``levels`` they are refused, not ignored).
    method, rtol, atol, multistep, step, max_steps
        The integration of every level (:class:`Integration`).
    repeats : int
        Timed runs of each level, in ``[1, MAX_REPEATS]``; the levels run in turn within
        each repeat (so a change of load on the machine affects them alike) and the median
        is reported.
    reference_rtol : float
        CVODES (Adams) tolerance of the full model's reference run (``atol`` the same).
    check_rtol : float
        A second reference run, > ``reference_rtol``: the two must agree on the outputs to
        ``reference_margin * scene.tolerance``.
    reference_margin : float
        See ``check_rtol``; in (0, 1].
    seed : int
        Seed of the levels' numeric checks.
    raise_on_failure : bool
        Raise :class:`~workbench.core.errors.SolverError` unless a level is chosen (else
        return the result with its status).

    Returns
    -------
    ModelChoice

    Raises
    ------
    ParameterError
        Bad knobs, or levels that are not :class:`Level`.
    SolverError
        No level chosen (with ``raise_on_failure``); the reference integration failing.
    """
    if not isinstance(scene, Scene):
        raise ParameterError(f"scene must be a workbench.study.Scene; got {type(scene).__name__}")
    knobs = _knobs(method, rtol, atol, multistep, step, max_steps)
    repeats = validate.count("repeats", repeats, maximum=MAX_REPEATS)
    seed = validate.count("seed", seed, minimum=0)
    reference_rtol = validate.tolerance("reference_rtol", reference_rtol)
    check_rtol = validate.tolerance("check_rtol", check_rtol)
    if check_rtol <= reference_rtol:
        raise ParameterError(f"check_rtol must be larger than reference_rtol (a second, looser "
                             f"reference run); got {check_rtol!r} <= {reference_rtol!r}")
    margin = validate.tolerance("reference_margin", reference_margin)
    if margin > 1:
        raise ParameterError(f"reference_margin must be in (0, 1]; got {reference_margin!r}")
    if not isinstance(raise_on_failure, bool):
        raise ParameterError(f"raise_on_failure must be True or False; got {raise_on_failure!r}")
    if levels is not None:
        levels = sequence_of("levels", levels, Level, "Level")
    special_cases = sequence_of("special_cases", special_cases, Level, "Level")
    equilibria = sequence_of("equilibria", equilibria, object, "equilibrium state")
    if levels is not None and (symmetries is not None or len(equilibria) or radius is not None):
        raise ParameterError("symmetries, equilibria and radius make the default levels; with "
                             "levels given, make those levels yourself (they would be ignored)")
    chosen_levels = list(default_levels(
        scene, symmetries=symmetries, equilibria=equilibria,
        radius=0.05 if radius is None else radius, seed=seed) if levels is None
        else levels) + list(special_cases)
    bad = [lv for lv in chosen_levels if not isinstance(lv, Level)]
    if bad or not chosen_levels:
        raise ParameterError(f"levels must be a non-empty sequence of Level; got {bad or '[]'}")
    names = [lv.name for lv in chosen_levels]
    if len(set(names)) != len(names):
        raise ParameterError(f"levels must have distinct names; got {names}")
    if not any(isinstance(lv, FullLevel) for lv in chosen_levels):
        raise ParameterError("levels must include the full model (FullLevel): it is the "
                             "baseline of the speed-up")
    runs, prepared = zip(*[_prepare(lv, scene, knobs) for lv in chosen_levels], strict=True)
    runs = list(runs)
    ref, diff, ref_cpu = _reference(scene, reference_rtol, check_rtol, knobs.max_steps)
    outs: dict[int, list[np.ndarray]] = {}
    for _ in range(repeats):
        for i, (run, prep) in enumerate(zip(runs, prepared, strict=True)):
            if prep is None or run.failure:
                continue
            c0 = time.process_time()
            try:
                states = prep.run()
            except WorkbenchError as exc:
                run.failure = f"run failed: {exc}"
                continue
            run.cpu_repeats.append(time.process_time() - c0)
            outs[i] = states
    for i, run in enumerate(runs):
        if i in outs and not run.failure:
            run.cpu_seconds = float(np.median(run.cpu_repeats))
            run.error = max(float(np.max(np.abs(scene.output(X) - Y)))
                            for X, Y in zip(outs[i], ref, strict=True))
            run.meets = run.error <= scene.tolerance
    ok = [r for r in runs if r.meets]
    best = min(ok, key=lambda r: r.cpu_seconds) if ok else None
    unconfirmed = ""
    if diff > margin * scene.tolerance:
        status = ChoiceStatus.REFERENCE_UNCONFIRMED
        unconfirmed = (f"the reference is unconfirmed (rtol {reference_rtol:g} and "
                       f"{check_rtol:g} differ by {diff:.2e} > {margin:g} x tolerance)")
    else:
        status = ChoiceStatus.CHOSEN if best is not None else ChoiceStatus.NONE_MEETS
    choice = best.name if best is not None and status is ChoiceStatus.CHOSEN else None
    excluded = {r.name: _why_not(r, best, scene.tolerance, unconfirmed) for r in runs
                if r.name != choice}
    result = ModelChoice(
        scene=scene.name, tolerance=scene.tolerance, levels=runs, choice=choice,
        excluded=excluded, status=status,
        reference={"rtol": reference_rtol, "check_rtol": check_rtol, "difference": diff,
                   "margin": margin, "cpu_seconds": ref_cpu},
        knobs={**knobs.as_dict(), "repeats": repeats, "horizon": scene.horizon,
               "n_states": len(scene.states), "n_times": scene.n_times})
    return result.raise_for_status() if raise_on_failure else result


_MARKERS = {LevelKind.FULL: "s", LevelKind.LAGRANGE_POINCARE: "^", LevelKind.ROUTH: "v",
            LevelKind.SPECIAL_CASE: "D", LevelKind.LINEARISATION: "o"}


def choice_figure(choices: Sequence[ModelChoice], *, ncols: int = 2,
                  size: tuple[float, float] = (4.6, 3.4)) -> Any:
    """CPU time against output error per level, one panel per scene, tolerance dashed.

    The chosen level is ringed; levels that do not apply or failed are not drawn (the
    result's :attr:`ModelChoice.excluded` says why).

    Parameters
    ----------
    choices : sequence of ModelChoice
        The results, one panel each.
    ncols : int
        Panels per row.
    size : (float, float)
        One panel's width and height in inches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not choices or not all(isinstance(c, ModelChoice) for c in choices):
        raise ParameterError("choices must be a non-empty sequence of ModelChoice")
    fig, axes = _grid(len(choices), ncols, size)
    import matplotlib as mpl
    from matplotlib.ticker import LogLocator, NullFormatter

    names = list(dict.fromkeys(lv.name for ch in choices for lv in ch.levels
                               if lv.cpu_seconds is not None))
    palette = mpl.colormaps["tab20" if len(names) > 10 else "tab10"]
    colour = {n: palette(i % palette.N) for i, n in enumerate(names)}
    for ax, ch in zip(axes, choices, strict=True):
        cpus = []
        for lv in ch.levels:
            if lv.cpu_seconds is None or lv.error is None:
                continue
            y = max(lv.error, 1e-17)
            cpus.append(lv.cpu_seconds)
            ax.plot(lv.cpu_seconds, y, linestyle="none", marker=_MARKERS[lv.kind],
                    color=colour[lv.name], label=lv.name)
            if lv.name == ch.choice:
                ax.plot(lv.cpu_seconds, y, linestyle="none", marker="o", markersize=14,
                        markerfacecolor="none", markeredgecolor="k", label="chosen")
        ax.axhline(ch.tolerance, color="k", linestyle="--", linewidth=1, label="tolerance")
        if cpus:  # at least a decade, so that the axis has a labelled major tick
            mid = np.sqrt(min(cpus) * max(cpus))
            half = max(np.sqrt(max(cpus) / min(cpus)) * 1.5, np.sqrt(10.0))
            ax.set_xlim(mid / half, mid * half)
        gain = f", {ch.speedup:.1f}x less CPU" if ch.speedup else ""
        ax.set(xscale="log", yscale="log", xlabel="CPU time of a run [s]",
               ylabel="max output error", title=f"{ch.scene}: {ch.choice or 'none'}{gain}")
        ax.xaxis.set_major_locator(LogLocator(base=10.0))
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.title.set_fontsize(8)
        ax.grid(True, alpha=0.3)
    legend_below(fig, axes, fontsize=7, max_columns=4)
    return fig
