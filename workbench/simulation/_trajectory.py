"""The result of :func:`~workbench.simulation._simulate.simulate` and its diagnostics.

:class:`Trajectory` holds the states, inputs, cost and accuracy of a run;
:func:`constraint_residuals` and :func:`diagnostics` are the measures that need no
reference solution (invariant drift, constraint residual).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from workbench.core._evaluator import evaluate_rows
from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.manifolds import SO3
from workbench.core.types import ArrayLike

if TYPE_CHECKING:
    from workbench.simulation._simulate import Method

__all__ = ["Trajectory", "constraint_residuals", "diagnostics"]


@dataclass
class Trajectory:
    """A simulated trajectory with its cost and accuracy diagnostics.

    Attributes
    ----------
    t : ndarray, shape=(n_times,)
        Output times.
    x : ndarray, shape=(n_times, ambient_dim)
        States (stored ambient coordinates).
    u : ndarray, shape=(n_times, n_inputs)
        Inputs applied at the output times.
    model : Model
        The simulated model.
    method : Method
        Integration method.
    options : dict
        The method's knobs as used.
    cost : dict
        ``wall_seconds`` (integration), ``build_seconds`` (integrator construction),
        ``steps`` and ``rhs_evaluations`` where the method reports them.
    diagnostics : dict
        ``invariant_drift``: for every invariant, ``initial``, ``max_abs`` and ``max_rel``
        (relative to ``|initial|``; None, with the reason in ``max_rel_undefined``, when
        the invariant starts at zero — never NaN)
        deviation from its initial value; ``constraint_residual``: max-norm residual of
        every factor over the trajectory; ``closed_loop``: whether a controller acted
        (invariants are then not expected to be conserved); for the fixed-step methods,
        ``stability``: the checks the run passed (``status``, ``checked_states``,
        ``step_linearised_at``, how many of them were close enough to the stable range
        for the step map to be linearised, None for collocation; ``conserved_invariants``,
        those whose drift was checked both ways; ``non_increasing_invariants``, those the
        loop does not feed, whose rise was checked; see
        :mod:`workbench.simulation._stability`).
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    model: Model
    method: Method
    options: dict[str, Any]
    cost: dict[str, Any] = field(default_factory=dict)
    diagnostics: dict[str, Any] = field(default_factory=dict)

    def part(self, name: str) -> np.ndarray:
        """States of one factor over time; SO3 parts come as ``(n_times, 3, 3)`` matrices."""
        man = self.model.manifold
        sl = man.slices[name] if name in man.slices else None
        if sl is None:
            raise ModelError(f"unknown factor {name!r}; this model has {man.names}")
        block = self.x[:, sl]
        if isinstance(man.factor(name), SO3):
            return np.array([SO3.matrix(row) for row in block])
        return block

    @property
    def final(self) -> np.ndarray:
        """The last state."""
        return self.x[-1]

    def invariant_series(self, name: str) -> np.ndarray:
        """Values of one invariant at every output time."""
        return evaluate_rows(self.model.function(name), self.x, self.model.p)[0].ravel()

    def __str__(self) -> str:
        """A short account: samples, method, cost, drift and constraint residual."""
        drift = self.diagnostics.get("invariant_drift", {})
        drifts = ", ".join(f"{k} {v['max_rel']:.1e}" if v.get("max_rel") is not None else
                           f"{k} {v.get('max_abs', 0.0):.1e} (absolute)"
                           for k, v in drift.items())
        res = self.diagnostics.get("constraint_residual", {})
        worst = max(res.values(), default=0.0)
        cost = ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                         for k, v in self.cost.items() if k in ("wall_seconds", "steps",
                                                               "rhs_evaluations"))
        return (f"Trajectory of {self.model.name}: {len(self.t)} samples, t = {self.t[0]:g} .. "
                f"{self.t[-1]:g}, method {self.method.value}; cost: {cost or '-'}; "
                f"relative invariant drift: {drifts or '-'}; max constraint residual "
                f"{worst:.1e}")

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"

    def summary(self) -> dict[str, Any]:
        """Plain JSON-serialisable account: method, knobs, cost, diagnostics."""
        return {
            "model": self.model.name,
            "method": self.method.value,
            "options": self.options,
            "t0": float(self.t[0]),
            "tf": float(self.t[-1]),
            "n_times": int(len(self.t)),
            "cost": self.cost,
            "diagnostics": self.diagnostics,
        }


def constraint_residuals(model: Model, x: ArrayLike) -> dict[str, np.ndarray]:
    """Max-norm constraint residual of every factor at every state, vectorised.

    Parameters
    ----------
    model : Model
        The model (its manifold).
    x : array-like, shape=(n_times, ambient_dim)
        States.

    Returns
    -------
    dict of str to ndarray, shape=(n_times,)
        Per factor name, ``max |h(x)|`` at each state (zeros for R^n).
    """
    X = np.atleast_2d(np.asarray(x, dtype=float))
    out = {}
    for name, factor in model.manifold.factors:
        fns = factor.constraint_functions()  # built once per factor
        if fns is None:
            out[name] = np.zeros(len(X))
            continue
        h = evaluate_rows(fns[0], X[:, model.manifold.slices[name]])[0]
        out[name] = np.max(np.abs(h), axis=1, initial=0.0)
    return out


def _relative_drift(max_abs: float, initial: float) -> dict[str, Any]:
    """``max_rel`` relative to ``|initial|``, or None with the reason when it is undefined.

    An invariant that starts at 0 (an angular momentum at rest) has no relative drift:
    ``max_rel`` is then None and ``max_rel_undefined`` says why; ``max_abs`` is the figure
    to read. Never NaN.
    """
    if initial != 0 and np.isfinite(initial):
        return {"max_rel": max_abs / abs(initial)}
    return {"max_rel": None,
            "max_rel_undefined": f"the invariant starts at {initial:g}: a drift relative to "
                                 f"it is undefined; read max_abs"}


def diagnostics(traj: Trajectory, *, closed_loop: bool) -> dict[str, Any]:
    """Invariant drift, constraint residual and whether a controller acted.

    Parameters
    ----------
    traj : Trajectory
        The run.
    closed_loop : bool
        Whether a controller acted.

    Returns
    -------
    dict
        ``invariant_drift``, ``constraint_residual``, ``closed_loop`` (see
        :attr:`Trajectory.diagnostics`).
    """
    model = traj.model
    if getattr(model, "state_check", None) is not None:  # T definite at every output state
        model.state_check(model, traj.x, t=traj.t, what="the simulated trajectory")
    drift = {}
    for name in model.invariant_names:
        series = traj.invariant_series(name)
        dev = np.abs(series - series[0])
        drift[name] = {"initial": float(series[0]), "max_abs": float(dev.max()),
                       **_relative_drift(float(dev.max()), float(series[0]))}
    residual = {name: float(series.max())
                for name, series in constraint_residuals(model, traj.x).items()}
    return {
        "invariant_drift": drift,
        "constraint_residual": residual,
        "closed_loop": closed_loop,
    }
