"""Long-time behaviour: how the energy error and the constraint residual evolve.

:func:`long_time` runs each method once over a long horizon and measures the maxima of
the energy error and of the constraint residual early and late in the run, and the
exponent of the growth of the energy error's envelope (about 0 when it stays bounded, as
for a variational integrator; about 1 for a linear drift).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import ModelError, ParameterError
from workbench.core.status import StatusResult
from workbench.core.types import ArrayLike
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

__all__ = ["LongRun", "LongTime", "long_time"]


@dataclass
class LongRun(StatusResult):
    """One method over a long horizon.

    Attributes
    ----------
    label, method : str
        AccuracySweep label and method.
    value : float
        Its knob value.
    t : ndarray, shape=(n_samples,)
        Sample times.
    energy_error : ndarray or None, shape=(n_samples,)
        ``|E - E0| / |E0|`` at the samples.
    constraint : ndarray, shape=(n_samples,)
        Largest constraint residual of any factor at the samples.
    wall_seconds : float
        Integration wall time.
    steps : int or None
        Steps taken.
    status : RunStatus
        OK or FAILED.
    message : str
        Why it failed (empty when OK).
    """

    label: str
    method: str
    value: float
    t: np.ndarray
    energy_error: np.ndarray | None
    constraint: np.ndarray
    wall_seconds: float
    steps: int | None
    status: RunStatus = RunStatus.OK
    message: str = ""

    def summary(self, *, fraction: float = 0.1) -> dict[str, Any]:
        """Maxima early and late, and the growth exponent of the energy error.

        Parameters
        ----------
        fraction : float
            Share of the samples that counts as "early" (the first) and "late" (the last).

        Returns
        -------
        dict
            ``energy_max``, ``energy_early``, ``energy_late``, ``energy_growth``
            (late / early), ``energy_exponent`` (slope of ``log max_{s<=t} |dE(s)|``
            against ``log t`` over the last 99 % of the horizon in log time: ~0 bounded,
            ~1 linear drift), ``constraint_max``, ``constraint_early``,
            ``constraint_late``, ``wall_seconds``, ``steps``, ``status``.
        """
        out: dict[str, Any] = {"label": self.label, "method": self.method,
                               "value": self.value, "wall_seconds": self.wall_seconds,
                               "steps": self.steps, "status": "ok" if self.ok else self.message}
        if not self.ok:
            return out
        n = len(self.t)
        k = max(1, int(round(fraction * n)))
        c = self.constraint
        out.update(constraint_max=float(c.max()), constraint_early=float(c[:k].max()),
                   constraint_late=float(c[-k:].max()))
        if self.energy_error is not None:
            e = self.energy_error
            early, late = float(e[1:k + 1].max()), float(e[-k:].max())
            out.update(energy_max=float(e.max()), energy_early=early, energy_late=late,
                       energy_growth=late / early if early > 0 else math.inf,
                       energy_exponent=_growth_exponent(self.t, e))
        return out


def _growth_exponent(t: np.ndarray, e: np.ndarray) -> float | None:
    """Slope of log(running max of e) against log t, for t in [t_end / 100, t_end]."""
    env = np.maximum.accumulate(e)
    sel = (t >= t[-1] / 100) & (env > 0)
    if sel.sum() < 2:
        return None
    lt = np.log(t[sel])
    grid = np.linspace(lt[0], lt[-1], 50)  # even weight in log time
    le = np.interp(grid, lt, np.log(env[sel]))
    return float(np.polyfit(grid, le, 1)[0])


@dataclass
class LongTime:
    """Long-time behaviour of several methods on one model.

    Attributes
    ----------
    model : str
        Model name.
    horizon : float
        Final time.
    runs : list of LongRun
        One per method.
    """

    model: str
    horizon: float
    runs: list[LongRun]

    def table(self) -> list[dict[str, Any]]:
        """The summaries of all runs."""
        return [r.summary() for r in self.runs]

    def run(self, label: str) -> LongRun:
        """The run with this label."""
        for r in self.runs:
            if r.label == label:
                return r
        raise ModelError(f"no long-time run {label!r}; have {[r.label for r in self.runs]}")

    def figure(self, *, title: str = "", time_unit: float = 1.0, unit_name: str = "s"):  # noqa: ANN201
        """Energy error and constraint residual against time (log-log)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        for k, r in enumerate(self.runs):
            if not r.ok:
                continue
            tt = r.t[1:] / time_unit
            lab = f"{r.label} ({'rtol' if r.method == 'cvodes' else 'h'} = {r.value:g})"
            style = {"lw": 0.7, "label": lab, "color": f"C{k % 10}"}  # same in both panels
            if r.energy_error is not None:
                ax[0].loglog(tt, np.maximum(r.energy_error[1:], 1e-17), **style)
            ax[1].loglog(tt, np.maximum(r.constraint[1:], 1e-17), **style)
        ax[0].set_ylabel("|E - E0| / |E0|")
        # on two lines: on one it was taller than the panel at the printed size
        ax[1].set_ylabel("constraint residual\n(max over factors)")
        for a in ax:
            a.set_xlabel(f"t [{unit_name}]")
        legend_below(fig, ax)  # one legend for both panels, in a row below them
        fig.suptitle(title or f"long-time behaviour, {self.model}, T = {self.horizon:g}")
        return fig


def long_time(
    model: Model,
    x0: ArrayLike,
    horizon: float,
    settings: Sequence[AccuracySweep],
    *,
    controller: ca.Function | None = None,
    n_samples: int = 1001,
    energy: str | None = "energy",
) -> LongTime:
    """Energy error and constraint residual of several methods over a long horizon.

    Parameters
    ----------
    model : Model
        The model.
    x0 : array-like, shape=(ambient_dim,)
        Initial state.
    horizon : float
        Final time.
    settings : sequence of AccuracySweep
        One method each, with exactly one knob value.
    controller : casadi.Function, optional
        Feedback in the loop.
    n_samples : int
        Equally spaced sample times (including 0 and ``horizon``; 2 to simulate's
        ``MAX_POINTS``, 10^6).
    energy : str or None
        Invariant measured as the energy.

    Returns
    -------
    LongTime

    Raises
    ------
    ParameterError
        Bad horizon or settings (a sweep with more than one value).
    """
    T = _check_common(model, horizon, energy, n_samples)
    _check_sweeps(settings, T, n_samples)
    many = [s.label for s in settings if len(s.values) != 1]
    if many:
        raise ParameterError(f"long_time needs one knob value per setting; {many} have more")
    x0v = model.check_state(x0, name="x0")
    t = np.linspace(0.0, T, int(n_samples))
    runs = []
    for s in settings:
        v = s.values[0]
        tr, walls, status = _run(model, x0v, t, s, v, controller, 1)
        if tr is None:
            runs.append(LongRun(s.label, s.method.value, v, t, None, np.zeros(0), math.nan,
                                None, *RunStatus.of(status)))
            continue
        E, resid = _energy_and_residual(tr, energy)
        runs.append(LongRun(s.label, s.method.value, v, t,
                            None if E is None else _relative(E), resid, walls[0],
                            tr.cost.get("steps"), *RunStatus.of(status)))
    return LongTime(model.name, T, runs)
