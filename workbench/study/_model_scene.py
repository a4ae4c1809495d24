"""The scene of a model choice, and the unforced integration every level shares.

A :class:`Scene` is what a user wants to know: initial states of a full model, a horizon,
the outputs that matter (a function of the full state) and a tolerance on them.
:class:`Integration` holds the integrator knobs of every level; ``_Flow`` is a model's
integrator over the scene's output times, built once (the level's build) and called per
initial state (the level's run), with the same CVODES options as
:func:`workbench.simulate`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Model
from workbench.core.errors import ParameterError, SolverError
from workbench.simulation import Method, Multistep, closed_loop_function, cvodes_options

__all__ = ["Scene", "Integration", "Outputs", "MAX_TIMES"]

MAX_TIMES = 100_000
"""Largest accepted ``Scene.n_times``: every level of a comparison stores its states at
each output time (and a linearisation a matrix per time), so the count is bounded before
anything is allocated."""

Outputs = Callable[[np.ndarray], np.ndarray]
"""``(n, ambient_dim) -> (n, n_outputs)``: the outputs of full states."""


@dataclass(frozen=True)
class Scene:
    """Initial states, a horizon, the outputs that matter and a tolerance on them.

    Attributes
    ----------
    model : Model
        The full model the states belong to.
    states : array-like, shape=(n_states, ambient_dim) or (ambient_dim,)
        Initial states (one, or a set), each checked on the model's manifold.
    horizon : float
        Final time [s], positive; outputs at ``n_times`` equally spaced times from 0.
    outputs : callable
        ``y = outputs(X)``: full states ``X`` of shape ``(n, ambient_dim)`` to real outputs
        of shape ``(n, n_outputs)``, ``n_outputs >= 1`` (vectorised; e.g. the attitude's
        ``Gamma = R^T e3``).
    tolerance : float
        Largest accepted max-norm error of the outputs, over every state and time
        (absolute, in the outputs' units).
    n_times : int
        Output times, in ``[2, MAX_TIMES]``.
    name : str
        The scene's name (tables, figures).

    Raises
    ------
    ParameterError
        A bad horizon, tolerance, ``n_times`` or name, or outputs that are not a finite real
        2-D array with one row per state and at least one column (complex, boolean, empty
        or non-finite outputs are refused).
    ManifoldError
        A state off the model's manifold.
    """

    model: Model
    states: Any
    horizon: float
    outputs: Outputs
    tolerance: float
    n_times: int = 101
    name: str = "scene"

    def __post_init__(self) -> None:
        if not isinstance(self.model, Model):
            raise ParameterError(f"model must be a workbench Model; got "
                                 f"{type(self.model).__name__}")
        X = validate.array("states", self.states, error=ParameterError)
        X = X.reshape(1, -1) if X.ndim == 1 else X
        if X.ndim != 2 or X.shape[0] < 1:
            raise ParameterError(f"states must be one state or an array (n_states, "
                                 f"{self.model.manifold.ambient_dim}); got shape {X.shape}")
        X = np.array([self.model.check_state(x, name=f"states[{i}]") for i, x in enumerate(X)])
        object.__setattr__(self, "states", X)
        horizon = validate.positive("horizon", self.horizon, error=ParameterError)
        object.__setattr__(self, "horizon", horizon)
        object.__setattr__(self, "tolerance", validate.tolerance("tolerance", self.tolerance))
        object.__setattr__(self, "n_times", validate.count("n_times", self.n_times, minimum=2,
                                                           maximum=MAX_TIMES))
        if not isinstance(self.name, str):
            raise ParameterError(f"name must be a str; got {type(self.name).__name__} "
                                 f"{self.name!r:.80}")
        if not callable(self.outputs):
            raise ParameterError(f"outputs must be a function of full states (n, "
                                 f"{X.shape[1]}) -> (n, n_outputs); got {self.outputs!r}")
        self.output(X)

    @property
    def times(self) -> np.ndarray:
        """The output times, shape ``(n_times,)``."""
        return np.linspace(0.0, self.horizon, self.n_times)

    def output(self, X: np.ndarray) -> np.ndarray:
        """The outputs of full states ``X``, shape ``(n, n_outputs)``.

        Checked real (a complex output is refused, never truncated to its real part), finite,
        2-D with one row per state and at least one output (the error of no outputs is
        undefined).

        Raises
        ------
        ParameterError
            Naming ``outputs``, what it gave and what was expected.
        """
        X = np.asarray(X, dtype=float)
        Y = validate.array("outputs", self.outputs(X), error=ParameterError)
        if Y.ndim != 2 or Y.shape[0] != len(X) or Y.shape[1] < 1:
            raise ParameterError(
                f"outputs must map full states of shape (n, n_full) to a finite real array "
                f"of shape (n, n_outputs) with n_outputs >= 1; for n = {len(X)} it gave "
                f"shape {Y.shape}")
        return Y


@dataclass(frozen=True)
class Integration:
    """The integrator knobs of every level (unforced, ``u = 0``).

    Attributes
    ----------
    method : Method or {"cvodes", "rk"}
        CVODES (adaptive; knobs ``rtol``, ``atol``, ``multistep``, ``max_steps``) or the
        classical fixed-step RK4 (knob ``step``).
    rtol, atol : float
        CVODES' tolerances.
    multistep : Multistep or {"adams", "bdf"}
        CVODES' multistep family.
    step : float, optional
        RK4's largest step (required for it, refused for CVODES).
    max_steps : int
        CVODES' internal steps per output interval.
    """

    method: Method | str = Method.CVODES
    rtol: float = 1e-8
    atol: float = 1e-8
    multistep: Multistep | str = Multistep.ADAMS
    step: float | None = None
    max_steps: int = 100_000

    def __post_init__(self) -> None:
        method = validate.choice(Method, self.method, "method", error=ParameterError)
        if method not in (Method.CVODES, Method.RK):
            raise ParameterError(f"method must be 'cvodes' or 'rk' for comparing model levels; "
                                 f"got {method.value!r}")
        object.__setattr__(self, "method", method)
        for name in ("rtol", "atol"):
            object.__setattr__(self, name, validate.tolerance(name, getattr(self, name)))
        object.__setattr__(self, "multistep", validate.choice(
            Multistep, self.multistep, "multistep", error=ParameterError))
        object.__setattr__(self, "max_steps", validate.count("max_steps", self.max_steps))
        if method is Method.RK:
            if self.step is None:
                raise ParameterError("step (the largest RK4 step) is required for method 'rk'")
            object.__setattr__(self, "step", validate.positive("step", self.step))
        elif self.step is not None:
            raise ParameterError(f"step is RK4's knob; method 'cvodes' chooses its own steps "
                                 f"(set rtol, atol); got step={self.step!r}")

    def as_dict(self) -> dict[str, Any]:
        """The knobs as plain values."""
        out: dict[str, Any] = {"method": self.method.value}
        if self.method is Method.CVODES:
            out.update(rtol=self.rtol, atol=self.atol, multistep=self.multistep.value,
                       max_steps=self.max_steps)
        else:
            out["step"] = self.step
        return out


class _Flow:
    """A model's unforced integrator over fixed output times, built once, called per state."""

    def __init__(self, model: Model, times: np.ndarray, knobs: Integration) -> None:
        loop = closed_loop_function(model, None)
        S = model.sym
        xs, ps = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
        dae = {"x": xs, "p": ps, "ode": loop(xs, ps)[0]}
        self.model, self._tile = model, 0
        if knobs.method is Method.CVODES:
            opts = cvodes_options(multistep=knobs.multistep, rtol=knobs.rtol, atol=knobs.atol,
                                  max_steps=knobs.max_steps)
            self._fn = ca.integrator(f"levels_{model.name}", "cvodes", dae, 0.0, times[1:], opts)
        else:  # one interval repeated: exactly n_fe RK4 steps per output interval
            dt = float(times[1] - times[0])
            n_fe = max(1, math.ceil(dt / float(knobs.step) - 1e-9))
            one = ca.integrator(f"levels_{model.name}_interval", "rk", dae, 0.0, dt,
                                {"number_of_finite_elements": n_fe})
            self._tile = len(times) - 1
            self._fn = one.mapaccum(f"levels_{model.name}", self._tile)

    def __call__(self, x0: np.ndarray, p: np.ndarray) -> np.ndarray:
        pin = p if not self._tile else np.tile(p.reshape(-1, 1), (1, self._tile))
        try:
            res = self._fn(x0=x0, p=pin)
        except RuntimeError as exc:
            status = str(self._fn.stats().get("return_status", "integrator error"))
            raise SolverError(f"integrating {self.model.name} failed: "
                              f"{str(exc).splitlines()[-1] if str(exc) else exc!r}",
                              status=status) from exc
        X = np.column_stack([x0, np.asarray(res["xf"])]).T
        if not np.all(np.isfinite(X)):
            raise SolverError(f"integrating {self.model.name} gave non-finite states",
                              status="non-finite")
        return X
