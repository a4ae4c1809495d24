"""Work-precision measurement: error, energy error and constraint residual against cost.

:func:`work_precision` runs a model from one initial state over one horizon with a set of
:class:`~workbench.simulation.accuracy.sweep.AccuracySweep` and measures, for every run, the
error at the final time against a high-accuracy reference, the energy error and the
constraint residual, against wall time and vector-field evaluations. The reference is the
first of a few high-accuracy runs; their spread is its error estimate, reported with it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.status import StatusResult
from workbench.core.types import ArrayLike
from workbench.core.validate import choice, count
from workbench.simulation._simulate import Method, simulate
from workbench.simulation.accuracy._legend import legend_below
from workbench.simulation.accuracy.sweep import (
    AccuracySweep,
    RunStatus,
    _check_common,
    _check_sweeps,
    _energy_and_residual,
    _relative,
    _run,
)

__all__ = ["Cost", "Run", "Reference", "WorkPrecision", "default_reference", "work_precision"]


class Cost(str, Enum):
    """The cost measure used to rank runs."""

    WALL = "wall_seconds"
    EVALUATIONS = "evaluations"


@dataclass
class Run(StatusResult):
    """One point of a work-precision diagram.

    Attributes
    ----------
    label, method, knob : str
        The sweep's label, method and knob.
    value : float
        The knob value asked for.
    step : float or None
        The step actually used (fixed-step methods).
    final_error : float
        Max-norm of ``x(T) - x_ref(T)`` (``inf`` when the run failed).
    energy_error : float or None
        Max over the samples of ``|E - E0| / |E0|`` (``None`` without an energy).
    constraint_residual : float
        Largest constraint residual of any factor over the samples.
    wall_seconds : float
        Median integration wall time over the repeats (construction excluded).
    evaluations : int or None
        Vector-field evaluations, where the method counts them.
    steps : int or None
        Steps taken.
    status : RunStatus
        OK or FAILED.
    message : str
        Why it failed (empty when OK).
    """

    label: str
    method: str
    knob: str
    value: float
    step: float | None
    final_error: float
    energy_error: float | None
    constraint_residual: float
    wall_seconds: float
    evaluations: int | None
    steps: int | None
    status: RunStatus = RunStatus.OK
    message: str = ""

    def as_dict(self) -> dict[str, Any]:
        """Plain form (one table row; ``status`` is ``"ok"`` or the failure message)."""
        return {**self.__dict__, "status": "ok" if self.ok else self.message}


@dataclass
class Reference:
    """The high-accuracy reference of a work-precision measurement.

    Attributes
    ----------
    x_final : ndarray, shape=(ambient_dim,)
        Reference state at the final time (from the first reference run).
    labels : list of str
        The reference runs, first the one used.
    error_estimate : float
        Largest max-norm difference between the reference runs' final states.
    wall_seconds : float
        Total wall time of the reference runs.
    """

    x_final: np.ndarray
    labels: list[str]
    error_estimate: float
    wall_seconds: float

    def as_dict(self) -> dict[str, Any]:
        """Plain form."""
        return {"labels": self.labels, "error_estimate": self.error_estimate,
                "wall_seconds": self.wall_seconds, "x_final": self.x_final.tolist()}


MAX_REPEATS = 100
"""Largest ``repeats`` of :func:`work_precision`: runs per knob value (the median is kept)."""

MAX_HALVINGS = 26
"""Largest ``halvings`` of :func:`default_reference`: its reference takes ``2^halvings``
steps, and ``2^26`` is below :data:`~workbench.simulation.integrators.common.MAX_FIXED_STEPS`
(1e8)."""


def default_reference(horizon: float, *, halvings: int = 16) -> tuple[AccuracySweep, ...]:
    """The default reference: RK4 at ``step = horizon / 2^halvings``, checked at twice that step.

    The difference of the two (Richardson) over-estimates the reference's own error by
    about ``2^4``; pass a problem-specific ``reference`` to :func:`work_precision` when the
    time scale of the motion makes these steps too coarse or too fine.

    Parameters
    ----------
    horizon : float
        The final time ``T``.
    halvings : int
        The reference's step is ``T / 2^halvings`` (4 to :data:`MAX_HALVINGS`, 26). One
        halving fewer halves
        the reference's cost and multiplies its error by about 16, until round-off limits
        it (the three-link chain of the ``work_precision`` problem: 2.9 s and an estimate
        of 9e-13 at 16, 1.7 s and 1.3e-12 at 15).
    """
    # the reference takes 2^halvings steps: at most simulate's MAX_FIXED_STEPS (1e8)
    k = count("halvings", halvings, minimum=4, maximum=MAX_HALVINGS)
    return (AccuracySweep(Method.RK, (horizon / 2**k,), label=f"reference rk h=T/2^{k}"),
            AccuracySweep(Method.RK, (horizon / 2**(k - 1),), label=f"check rk h=T/2^{k - 1}"))


@dataclass
class WorkPrecision:
    """Work-precision measurement of one model, initial state and horizon.

    Attributes
    ----------
    model : str
        Model name.
    horizon : float
        Final time.
    reference : Reference
        The reference and its error estimate.
    runs : list of Run
        Every run, in sweep order.
    orders_theory : dict of str to int or None
        Theoretical order of each sweep label.
    """

    model: str
    horizon: float
    reference: Reference
    runs: list[Run]
    orders_theory: dict[str, int | None]

    def table(self) -> list[dict[str, Any]]:
        """All runs as plain rows."""
        return [r.as_dict() for r in self.runs]

    def labels(self) -> list[str]:
        """AccuracySweep labels in order."""
        return list(self.orders_theory)

    def fastest(self, accuracy: float, *, cost: Cost = Cost.WALL) -> Run | None:
        """The cheapest successful run whose final error is at most ``accuracy``."""
        cost = choice(Cost, cost, "cost")
        ok = [r for r in self.runs if r.ok and r.final_error <= accuracy
              and getattr(r, cost.value) is not None]
        return min(ok, key=lambda r: getattr(r, cost.value)) if ok else None

    def winners(self, accuracies: Sequence[float], *, cost: Cost = Cost.WALL) -> list[dict]:
        """For each accuracy: every method's cheapest run reaching it, and the fastest.

        Returns
        -------
        list of dict
            ``accuracy``, ``fastest`` (label or None), ``costs`` (label -> cost of its
            cheapest run reaching the accuracy, or None), ``knob`` (label -> its knob
            value), ``ratio_to_fastest`` (label -> cost / fastest cost).
        """
        cost = choice(Cost, cost, "cost")
        out = []
        for acc in accuracies:
            costs: dict[str, float | None] = {}
            knob: dict[str, float | None] = {}
            for lab in self.labels():
                ok = [r for r in self.runs if r.label == lab and r.ok
                      and r.final_error <= acc and getattr(r, cost.value) is not None]
                best = min(ok, key=lambda r: getattr(r, cost.value)) if ok else None
                costs[lab] = None if best is None else float(getattr(best, cost.value))
                knob[lab] = None if best is None else best.value
            have = {k: v for k, v in costs.items() if v is not None}
            fastest = min(have, key=have.get) if have else None
            ratio = {k: (v / have[fastest] if v is not None and fastest else None)
                     for k, v in costs.items()}
            out.append({"accuracy": float(acc), "fastest": fastest, "costs": costs,
                        "knob": knob, "ratio_to_fastest": ratio})
        return out

    def orders(self, *, floor_factor: float = 100.0, max_error: float = 1e-2) -> dict[str, dict]:
        """Convergence orders fitted from final error against step size.

        Only successful runs with ``floor_factor * reference.error_estimate < error <
        max_error`` (above the reference's floor, in the asymptotic regime) enter the
        least-squares fit of ``log error`` against ``log step``.

        Returns
        -------
        dict of str to dict
            For every fixed-step label: ``fitted`` (slope, or None with fewer than two
            points), ``theory``, ``points`` (number used), ``steps`` and ``errors`` used.
        """
        floor = floor_factor * self.reference.error_estimate
        out: dict[str, dict] = {}
        for lab, theory in self.orders_theory.items():
            rows = [r for r in self.runs if r.label == lab and r.step is not None]
            if not rows:
                continue
            use = [r for r in rows if r.ok and floor < r.final_error < max_error]
            fitted = None
            if len({r.step for r in use}) >= 2:
                fitted = float(np.polyfit(np.log([r.step for r in use]),
                                          np.log([r.final_error for r in use]), 1)[0])
            out[lab] = {"fitted": fitted, "theory": theory, "points": len(use),
                        "steps": [r.step for r in use], "errors": [r.final_error for r in use]}
        return out

    def as_dict(self) -> dict[str, Any]:
        """Plain form: reference, table and orders."""
        return {"model": self.model, "horizon": self.horizon,
                "reference": self.reference.as_dict(), "runs": self.table(),
                "orders": self.orders()}

    def figure(self, *, title: str = ""):  # noqa: ANN201 - matplotlib Figure
        """The work-precision diagram.

        Final error and energy error against wall time, final error against evaluations,
        one line per sweep; the reference's error estimate as a dotted line.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.ticker import LogFormatterSciNotation

        fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
        floor = self.reference.error_estimate
        for lab in self.labels():
            rows = [r for r in self.runs if r.label == lab and r.ok]  # in knob order
            if not rows:
                continue
            wall = [r.wall_seconds for r in rows]
            line = ax[0].loglog(wall, [max(r.final_error, 1e-17) for r in rows], "o-",
                                label=lab, ms=4)[0]
            ev = [(r.evaluations, r.final_error) for r in rows if r.evaluations]
            if ev:
                ax[1].loglog(*zip(*[(e, max(v, 1e-17)) for e, v in ev]), "o-",
                             color=line.get_color(), ms=4, label=lab)
            if rows[0].energy_error is not None:
                ax[2].loglog(wall, [max(r.energy_error, 1e-17) for r in rows], "o-",
                             color=line.get_color(), ms=4, label=lab)
        for a in ax[:2]:
            a.axhline(max(floor, 1e-17), color="grey", ls=":", lw=1,
                      label="reference error estimate")
        ax[0].set_xlabel("wall time [s]")
        ax[0].set_ylabel(f"error at t = {self.horizon:g} (max-norm)")
        ax[1].set_xlabel("vector-field evaluations")
        ax[2].set_xlabel("wall time [s]")
        ax[2].set_ylabel("max |E - E0| / |E0|")
        legend_below(fig, ax)  # one legend for the three panels, in a row below them
        for a in ax:  # minor ticks labelled only on spans under half a decade: the
            # evaluations' panel had five labels such as 2x10^3 run into each other
            a.xaxis.set_minor_formatter(LogFormatterSciNotation(
                labelOnlyBase=False, minor_thresholds=(0.5, 0.2)))
        fig.suptitle(title or f"work-precision, {self.model}, T = {self.horizon:g}")
        return fig


def work_precision(
    model: Model,
    x0: ArrayLike,
    horizon: float,
    sweeps: Sequence[AccuracySweep],
    *,
    controller: ca.Function | None = None,
    reference: Sequence[AccuracySweep] | None = None,
    n_samples: int = 11,
    repeats: int = 1,
    energy: str | None = "energy",
) -> WorkPrecision:
    """Measure error, energy error and constraint residual against cost for many methods.

    Parameters
    ----------
    model : Model
        The model.
    x0 : array-like, shape=(ambient_dim,)
        Initial state (on the manifold).
    horizon : float
        Final time ``T``; runs go from 0 to ``T``.
    sweeps : sequence of AccuracySweep
        Methods and knob values; step sizes must not exceed ``T`` and should divide the
        sample spacing ``T / (n_samples - 1)`` (otherwise the step is rounded down to
        one that does, and the step used is reported).
    controller : casadi.Function, optional
        Feedback in the loop for every run.
    reference : sequence of AccuracySweep, optional
        Reference runs, one value each (default :func:`default_reference`); the first is
        the reference, the spread of all is its error estimate.
    n_samples : int
        Equally spaced sample times (including 0 and ``T``) at which the energy and the
        constraint residual are measured (2 to simulate's ``MAX_POINTS``, 10^6).
    repeats : int
        Runs per knob value (1 to :data:`MAX_REPEATS`, 100); the median wall time is
        reported.
    energy : str or None
        Invariant measured as the energy.

    Returns
    -------
    WorkPrecision

    Raises
    ------
    ParameterError
        Bad horizon, sweeps, samples or repeats.
    SolverError
        If a reference run fails (failures of swept runs are recorded in their rows).
    """
    T = _check_common(model, horizon, energy, n_samples)
    _check_sweeps(sweeps, T, n_samples)
    count("repeats", repeats, maximum=MAX_REPEATS)  # each repeat is a whole run
    refs = tuple(reference) if reference is not None else default_reference(T)
    _check_sweeps(refs, T, n_samples)
    x0v = model.check_state(x0, name="x0")
    t = np.linspace(0.0, T, int(n_samples))

    finals, wall = [], 0.0
    for s in refs:
        tr = simulate(model, x0v, t, controller=controller, **s.keywords(s.values[0]))
        finals.append(tr.final)
        wall += float(tr.cost["wall_seconds"])
    est = max((float(np.max(np.abs(f - finals[0]))) for f in finals[1:]), default=0.0)
    ref = Reference(finals[0], [s.label for s in refs], est, wall)

    runs: list[Run] = []
    for s in sweeps:
        for v in s.values:
            tr, walls, status = _run(model, x0v, t, s, v, controller, int(repeats))
            if tr is None:
                runs.append(Run(s.label, s.method.value, s.knob.value, v, None, math.inf, None,
                                math.nan, math.nan, None, None, *RunStatus.of(status)))
                continue
            E, resid = _energy_and_residual(tr, energy)
            runs.append(Run(
                label=s.label, method=s.method.value, knob=s.knob.value, value=v,
                step=tr.options.get("step"),
                final_error=float(np.max(np.abs(tr.final - ref.x_final))),
                energy_error=None if E is None else float(_relative(E).max()),
                constraint_residual=float(resid.max()),
                wall_seconds=float(np.median(walls)),
                evaluations=tr.cost.get("rhs_evaluations"),
                steps=tr.cost.get("steps"),
            ))
    return WorkPrecision(model.name, T, ref, runs, {s.label: s.order for s in sweeps})
