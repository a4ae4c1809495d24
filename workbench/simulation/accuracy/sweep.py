"""Sweeps of a method's accuracy knob, and the measurements shared by the studies.

An :class:`AccuracySweep` names a method of :func:`~workbench.simulation._simulate.simulate`
and the values of its accuracy knob (cvodes' ``rtol``, the step of the fixed-step methods;
not to be confused with :func:`workbench.simulation.sweep`, a parameter sweep over worker
processes). The helpers here
run one knob value and measure a trajectory's energy error and constraint residual.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.status import StatusEnum
from workbench.core.validate import choice, count
from workbench.simulation._simulate import (
    MAX_POINTS,
    Method,
    Trajectory,
    constraint_residuals,
    simulate,
)

__all__ = ["Knob", "AccuracySweep", "RunStatus"]


class Knob(str, Enum):
    """The accuracy knob a :class:`AccuracySweep` varies."""

    RTOL = "rtol"
    STEP = "step"


_ORDERS = {Method.RK: 4, Method.LGVI: 2, Method.S2_VARIATIONAL: 2, Method.RKMK4: 4,
           Method.MECHANICS_VARIATIONAL: 2}
_FORBIDDEN = {"method", "rtol", "atol", "step", "controller"}


@dataclass(frozen=True)
class AccuracySweep:
    """One method and the values of its accuracy knob.

    Parameters
    ----------
    method : Method
        The integration method.
    values : sequence of float
        ``rtol`` values for cvodes (``atol`` is set equal), step sizes otherwise; positive.
    options : mapping, optional
        Further fixed keywords of :func:`~workbench.simulation._simulate.simulate` (``degree``,
        ``newton_tol``, ``jit``, ``multistep`` ...).
    label : str, optional
        Name in tables and figures (default: the method, with ``degree`` if given).
    """

    method: Method
    values: tuple[float, ...]
    options: Mapping[str, Any] = field(default_factory=dict)
    label: str = ""

    def __post_init__(self) -> None:
        method = choice(Method, self.method, "AccuracySweep.method")
        object.__setattr__(self, "method", method)
        try:
            vals = tuple(float(v) for v in np.atleast_1d(np.asarray(self.values, dtype=float)))
        except (TypeError, ValueError) as exc:
            raise ParameterError(
                f"AccuracySweep.values ({self.knob.value} of {method.value}) must be numbers; "
                f"got {self.values!r}"
            ) from exc
        if not vals or not all(np.isfinite(v) and v > 0 for v in vals):
            raise ParameterError(
                f"AccuracySweep.values ({self.knob.value} of {method.value}) must be positive "
                f"finite numbers, at least one; got {list(vals)}"
            )
        object.__setattr__(self, "values", vals)
        bad = sorted(_FORBIDDEN & set(self.options))
        if bad:
            raise ParameterError(
                f"AccuracySweep.options must not set {bad}: the method and knob are the sweep's "
                f"own, the controller is work_precision's"
            )
        object.__setattr__(self, "options", dict(self.options))
        if not self.label:
            extra = f" d={self.options['degree']}" if "degree" in self.options else ""
            object.__setattr__(self, "label", f"{method.value}{extra}")

    @property
    def knob(self) -> Knob:
        """``Knob.RTOL`` for cvodes, ``Knob.STEP`` otherwise."""
        return Knob.RTOL if self.method is Method.CVODES else Knob.STEP

    @property
    def order(self) -> int | None:
        """Theoretical order (collocation: ``2 degree``); ``None`` for cvodes."""
        if self.method is Method.COLLOCATION:
            return 2 * int(self.options.get("degree", 4))
        return _ORDERS.get(self.method)

    def keywords(self, value: float) -> dict[str, Any]:
        """Keywords for :func:`~workbench.simulation._simulate.simulate` at one knob value."""
        kw = {"method": self.method, **self.options}
        if self.knob is Knob.RTOL:
            kw.update(rtol=value, atol=value)
        else:
            kw["step"] = value
        return kw


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
    # allocated (and every invariant evaluated at every sample): bounded like simulate's t
    count("n_samples", n_samples, minimum=2, maximum=MAX_POINTS)
    return T


def _check_sweeps(sweeps: Sequence[AccuracySweep], horizon: float, n_samples: int) -> None:
    if not sweeps or not all(isinstance(s, AccuracySweep) for s in sweeps):
        raise ParameterError(
            f"sweeps must be a non-empty sequence of AccuracySweep; got {sweeps!r}")
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


class RunStatus(StatusEnum):
    """Outcome of one run of a sweep; the value is a readable message."""

    OK = "integrated to the final time"
    FAILED = "the integration failed (the run's message says why)"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"OK"})

    @classmethod
    def of(cls, outcome: str) -> tuple[RunStatus, str]:
        """``(status, message)`` from :func:`_run`'s ``"ok"`` or ``"failed: ..."``."""
        return (cls.OK, "") if outcome == "ok" else (cls.FAILED, outcome)


def _run(model: Model, x0: np.ndarray, t: np.ndarray, sweep: AccuracySweep, value: float,
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
