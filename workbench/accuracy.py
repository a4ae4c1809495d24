"""Work-precision measurement: accuracy against cost, and long-time behaviour.

:func:`work_precision` runs a model from one initial state over one horizon with a set of
methods, each swept over its accuracy knob (a :class:`Sweep`: cvodes' ``rtol``, the step
of the fixed-step methods), and measures for every run the error at the final time
against a high-accuracy reference, the energy error and the constraint residual over the
run, against wall time and vector-field evaluations. The reference is the first of a few
independent high-accuracy runs; their spread is its error estimate, reported with it.
The result gives the work-precision table, the fastest method for a requested accuracy,
convergence orders fitted from error against step size (beside each method's theoretical
order) and the work-precision diagram.

:func:`long_time` runs each method once over a long horizon and measures how the energy
error and the constraint residual evolve: their maxima early and late in the run and the
exponent of the growth of the energy error's envelope (about 0 when it stays bounded,
about 1 for a linear drift).

Errors are absolute max-norms over the stored (ambient) state; energy errors are relative
to the initial energy.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import casadi as ca
import numpy as np

from workbench._types import ArrayLike
from workbench.errors import ModelError, ParameterError, SolverError
from workbench.model import Model
from workbench.simulate import Method, Trajectory, constraint_residuals, simulate

__all__ = [
    "Knob",
    "Cost",
    "Sweep",
    "Run",
    "Reference",
    "WorkPrecision",
    "LongRun",
    "LongTime",
    "default_reference",
    "work_precision",
    "long_time",
]


class Knob(str, Enum):
    """The accuracy knob a :class:`Sweep` varies."""

    RTOL = "rtol"
    STEP = "step"


class Cost(str, Enum):
    """The cost measure used to rank runs."""

    WALL = "wall_seconds"
    EVALUATIONS = "evaluations"


_ORDERS = {Method.RK: 4, Method.LGVI: 2, Method.S2_VARIATIONAL: 2, Method.RKMK4: 4}
_FORBIDDEN = {"method", "rtol", "atol", "step", "controller"}


@dataclass(frozen=True)
class Sweep:
    """One method and the values of its accuracy knob.

    Parameters
    ----------
    method : Method
        The integration method.
    values : sequence of float
        ``rtol`` values for cvodes (``atol`` is set equal), step sizes otherwise; positive.
    options : mapping, optional
        Further fixed keywords of :func:`~workbench.simulate.simulate` (``degree``,
        ``newton_tol``, ``jit``, ``multistep`` ...).
    label : str, optional
        Name in tables and figures (default: the method, with ``degree`` if given).
    """

    method: Method
    values: tuple[float, ...]
    options: Mapping[str, Any] = field(default_factory=dict)
    label: str = ""

    def __post_init__(self) -> None:
        try:
            method = Method(self.method)
        except ValueError as exc:
            raise ParameterError(
                f"Sweep.method must be one of {[m.value for m in Method]}; got {self.method!r}"
            ) from exc
        object.__setattr__(self, "method", method)
        try:
            vals = tuple(float(v) for v in np.atleast_1d(np.asarray(self.values, dtype=float)))
        except (TypeError, ValueError) as exc:
            raise ParameterError(
                f"Sweep.values ({self.knob.value} of {method.value}) must be numbers; got "
                f"{self.values!r}"
            ) from exc
        if not vals or not all(np.isfinite(v) and v > 0 for v in vals):
            raise ParameterError(
                f"Sweep.values ({self.knob.value} of {method.value}) must be positive finite "
                f"numbers, at least one; got {list(vals)}"
            )
        object.__setattr__(self, "values", vals)
        bad = sorted(_FORBIDDEN & set(self.options))
        if bad:
            raise ParameterError(
                f"Sweep.options must not set {bad}: the method and knob are the sweep's own, "
                f"the controller is work_precision's"
            )
        object.__setattr__(self, "options", dict(self.options))
        if not self.label:
            extra = f" d={self.options['degree']}" if "degree" in self.options else ""
            object.__setattr__(self, "label", f"{method.value}{extra}")

    @property
    def knob(self) -> Knob:
        """``Knob.RTOL`` for cvodes, ``Knob.STEP`` otherwise."""
        return Knob.RTOL if Method(self.method) is Method.CVODES else Knob.STEP

    @property
    def order(self) -> int | None:
        """Theoretical order (collocation: ``2 degree``); ``None`` for cvodes."""
        if self.method is Method.COLLOCATION:
            return 2 * int(self.options.get("degree", 4))
        return _ORDERS.get(self.method)

    def keywords(self, value: float) -> dict[str, Any]:
        """Keywords for :func:`~workbench.simulate.simulate` at one knob value."""
        kw = {"method": self.method, **self.options}
        if self.knob is Knob.RTOL:
            kw.update(rtol=value, atol=value)
        else:
            kw["step"] = value
        return kw


@dataclass
class Run:
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
    status : str
        ``"ok"`` or the failure message.
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
    status: str = "ok"

    @property
    def ok(self) -> bool:
        """Whether the run succeeded."""
        return self.status == "ok"

    def as_dict(self) -> dict[str, Any]:
        """Plain form (one table row)."""
        return dict(self.__dict__)


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


def _energy_and_residual(traj: Trajectory, energy: str | None) -> tuple[np.ndarray | None,
                                                                        np.ndarray]:
    E = None if energy is None else traj.invariant_series(energy)
    per_factor = constraint_residuals(traj.model, traj.x)
    return E, np.max(np.array(list(per_factor.values())), axis=0)


def _relative(E: np.ndarray) -> np.ndarray:
    return np.abs(E - E[0]) / max(abs(float(E[0])), np.finfo(float).tiny)


def _check_common(model: Model, horizon: float, energy: str | None, n_samples: int) -> float:
    try:
        T = float(horizon)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"horizon must be a positive number; got {horizon!r}") from exc
    if not (np.isfinite(T) and T > 0):
        raise ParameterError(f"horizon must be positive and finite; got {horizon!r}")
    if energy is not None and energy not in model.invariant_names:
        raise ModelError(
            f"energy must name an invariant of {model.name!r} ({model.invariant_names}) or "
            f"be None; got {energy!r}"
        )
    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)) \
            or n_samples < 2:
        raise ParameterError(f"n_samples must be an integer >= 2; got {n_samples!r}")
    return T


def _check_sweeps(sweeps: Sequence[Sweep], horizon: float, n_samples: int) -> None:
    if not sweeps or not all(isinstance(s, Sweep) for s in sweeps):
        raise ParameterError(f"sweeps must be a non-empty sequence of Sweep; got {sweeps!r}")
    labels = [s.label for s in sweeps]
    if len(set(labels)) != len(labels):
        raise ParameterError(f"sweep labels must be unique; got {labels}")
    for s in sweeps:
        if s.knob is Knob.STEP:
            big = [v for v in s.values if v > horizon]
            if big:
                raise ParameterError(
                    f"steps of {s.label!r} must not exceed the horizon {horizon:g}; got {big}"
                )


def default_reference(horizon: float) -> tuple[Sweep, ...]:
    """The default reference: RK4 at ``step = horizon / 2^16``, checked at twice that step.

    The difference of the two (Richardson) over-estimates the reference's own error by
    about ``2^4``; pass a problem-specific ``reference`` to :func:`work_precision` when the
    time scale of the motion makes these steps too coarse or too fine.
    """
    return (Sweep(Method.RK, (horizon / 2**16,), label="reference rk h=T/2^16"),
            Sweep(Method.RK, (horizon / 2**15,), label="check rk h=T/2^15"))


def _run(model: Model, x0: np.ndarray, t: np.ndarray, sweep: Sweep, value: float,
         controller: ca.Function | None, repeats: int) -> tuple[Trajectory | None, list[float],
                                                                str]:
    walls: list[float] = []
    traj = None
    for _ in range(repeats):
        try:
            traj = simulate(model, x0, t, controller=controller, **sweep.keywords(value))
        except SolverError as exc:
            return None, [math.nan], f"failed: {exc}"
        walls.append(float(traj.cost["wall_seconds"]))
    return traj, walls, "ok"


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
        """Sweep labels in order."""
        return list(self.orders_theory)

    def fastest(self, accuracy: float, *, cost: Cost = Cost.WALL) -> Run | None:
        """The cheapest successful run whose final error is at most ``accuracy``."""
        cost = Cost(cost)
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
        cost = Cost(cost)
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

        fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
        floor = self.reference.error_estimate
        for lab in self.labels():
            rows = sorted((r for r in self.runs if r.label == lab and r.ok),
                          key=lambda r: r.wall_seconds)
            if not rows:
                continue
            wall = [r.wall_seconds for r in rows]
            line = ax[0].loglog(wall, [max(r.final_error, 1e-17) for r in rows], "o-",
                                label=lab, ms=4)[0]
            ev = [(r.evaluations, r.final_error) for r in rows if r.evaluations]
            if ev:
                ev.sort()
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
        ax[0].legend(fontsize=7)
        fig.suptitle(title or f"work-precision, {self.model}, T = {self.horizon:g}")
        fig.tight_layout()
        return fig


def work_precision(
    model: Model,
    x0: ArrayLike,
    horizon: float,
    sweeps: Sequence[Sweep],
    *,
    controller: ca.Function | None = None,
    reference: Sequence[Sweep] | None = None,
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
    sweeps : sequence of Sweep
        Methods and knob values; step sizes must not exceed ``T`` and should divide the
        sample spacing ``T / (n_samples - 1)`` (otherwise the step is rounded down to
        one that does, and the step used is reported).
    controller : casadi.Function, optional
        Feedback in the loop for every run.
    reference : sequence of Sweep, optional
        Reference runs, one value each (default :func:`default_reference`); the first is
        the reference, the spread of all is its error estimate.
    n_samples : int
        Equally spaced sample times (including 0 and ``T``) at which the energy and the
        constraint residual are measured.
    repeats : int
        Runs per knob value; the median wall time is reported.
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
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise ParameterError(f"repeats must be an integer >= 1; got {repeats!r}")
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
                                math.nan, math.nan, None, None, status))
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


# ----------------------------------------------------------------------------------------
# long-time behaviour


@dataclass
class LongRun:
    """One method over a long horizon.

    Attributes
    ----------
    label, method : str
        Sweep label and method.
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
    status : str
        ``"ok"`` or the failure message.
    """

    label: str
    method: str
    value: float
    t: np.ndarray
    energy_error: np.ndarray | None
    constraint: np.ndarray
    wall_seconds: float
    steps: int | None
    status: str = "ok"

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
                               "steps": self.steps, "status": self.status}
        if self.status != "ok":
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
        for r in self.runs:
            if r.status != "ok":
                continue
            tt = r.t[1:] / time_unit
            lab = f"{r.label} ({'rtol' if r.method == 'cvodes' else 'h'} = {r.value:g})"
            if r.energy_error is not None:
                ax[0].loglog(tt, np.maximum(r.energy_error[1:], 1e-17), lw=0.7, label=lab)
            ax[1].loglog(tt, np.maximum(r.constraint[1:], 1e-17), lw=0.7, label=lab)
        ax[0].set_ylabel("|E - E0| / |E0|")
        ax[1].set_ylabel("constraint residual (max over factors)")
        for a in ax:
            a.set_xlabel(f"t [{unit_name}]")
        ax[0].legend(fontsize=7)
        fig.suptitle(title or f"long-time behaviour, {self.model}, T = {self.horizon:g}")
        fig.tight_layout()
        return fig


def long_time(
    model: Model,
    x0: ArrayLike,
    horizon: float,
    settings: Sequence[Sweep],
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
    settings : sequence of Sweep
        One method each, with exactly one knob value.
    controller : casadi.Function, optional
        Feedback in the loop.
    n_samples : int
        Equally spaced sample times (including 0 and ``horizon``).
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
                                None, status))
            continue
        E, resid = _energy_and_residual(tr, energy)
        runs.append(LongRun(s.label, s.method.value, v, t,
                            None if E is None else _relative(E), resid, walls[0],
                            tr.cost.get("steps"), status))
    return LongTime(model.name, T, runs)
