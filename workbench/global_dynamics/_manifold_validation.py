"""Checks of computed invariant manifolds that do not rely on pictures.

* :func:`validate` -- points of a computed stable (unstable) manifold, taken at several
  parameter values ``t``, are integrated forward (backward) in time point by point with an
  independent method (CVODES by default, through :func:`workbench.simulation._simulate.simulate`):
  they must approach the equilibrium, and after time ``t`` land back on their seed in
  ``B_delta``. The same points pushed off the manifold by a small seeded perturbation
  must pass the equilibrium and leave its neighbourhood.
* :func:`compare_per_point` -- the vectorised integration against
  :func:`~workbench.simulation._simulate.simulate` run from the same seeds one at a time (the same
  method gives agreement to round-off; another method measures the accuracy).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from workbench.core.errors import ParameterError
from workbench.core.status import Record
from workbench.core.types import ArrayLike
from workbench.global_dynamics._invariant_manifolds import InvariantManifold
from workbench.global_dynamics._seeds import distances
from workbench.simulation._simulate import GEOMETRIC_METHODS, Method, simulate

__all__ = ["Validation", "ValidationCost", "validate", "compare_per_point"]


@dataclass(frozen=True)
class ValidationCost(Record):
    """What :func:`validate` cost.

    Attributes
    ----------
    wall_seconds : float
        All simulations.
    simulations : int
        Independent integrations run.
    """

    wall_seconds: float
    simulations: int


@dataclass
class Validation:
    """What :func:`validate` measured.

    Attributes
    ----------
    on : list of dict
        One entry per sampled manifold point: ``index`` (trajectory), ``t`` (parameter),
        ``d_start`` (distance (12) to the equilibrium), ``d_min`` and ``t_min`` (closest
        approach and when), ``ratio = d_min / d_start``, ``d_return`` (distance at time
        ``t``, where the point should be back on ``B_delta``), ``seed_error`` (max-norm
        distance between that state and the seed), ``d_end`` (at the end of the run) and
        ``x_end`` (the final state).
    off : list of dict
        The same points moved by ``perturbation`` off the manifold: ``d_start``,
        ``d_min``, ``t_min``, ``d_end``, ``x_end`` and, with a target, ``d_end_target``.
    method : Method
        The independent integrator.
    options : dict
        Knobs as used.
    cost : ValidationCost
        ``wall_seconds``, ``simulations`` (a typed record that also reads as a mapping).
    """

    on: list[dict[str, Any]]
    off: list[dict[str, Any]]
    method: Method
    options: dict[str, Any]
    cost: ValidationCost | dict[str, Any] = field(default_factory=dict)

    @property
    def worst_ratio(self) -> float:
        """Largest ``d_min / d_start`` over the manifold points (small: they approach)."""
        return max(r["ratio"] for r in self.on)

    @property
    def worst_seed_error(self) -> float:
        """Largest distance between a point integrated back over ``t`` and its seed."""
        return max(r["seed_error"] for r in self.on)

    @property
    def worst_target_distance(self) -> float:
        """Largest final distance of a perturbed point to the ``target`` (nan without one)."""
        vals = [r["d_end_target"] for r in self.off if "d_end_target" in r]
        return max(vals) if vals else float("nan")

    @property
    def least_escape(self) -> float:
        """Smallest final distance of a perturbed point (large: they all left)."""
        return min(r["d_end"] for r in self.off) if self.off else float("nan")

    def final_states(self, *, off: bool) -> np.ndarray:
        """Final states of the manifold points (``off=False``) or the perturbed ones."""
        return np.array([r["x_end"] for r in (self.off if off else self.on)])

    def summary(self) -> dict[str, Any]:
        """Plain JSON-serialisable account (without the final states)."""
        return {"method": self.method.value, "options": self.options, "cost": self.cost,
                "n_samples": len(self.on), "worst_ratio": self.worst_ratio,
                "worst_seed_error": self.worst_seed_error, "least_escape": self.least_escape,
                "worst_target_distance": self.worst_target_distance,
                "on": [{k: v for k, v in r.items() if k != "x_end"} for r in self.on],
                "off": [{k: v for k, v in r.items() if k != "x_end"} for r in self.off]}


def _sim_kwargs(method: Method, rtol: float, atol: float, step: float | None
                ) -> dict[str, Any]:
    if method is Method.CVODES:
        return {"method": method, "rtol": rtol, "atol": atol}
    if step is None:
        raise ParameterError(f"step is required for the fixed-step method {method.value!r}")
    return {"method": method, "step": step}


def validate(
    manifold: InvariantManifold,
    *,
    times: list[float],
    n_per_time: int,
    min_distance: float,
    extra_time: float,
    perturbation: float,
    seed: int = 0,
    method: Method = Method.CVODES,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    step: float | None = None,
    output_step: float | None = None,
    target: ArrayLike | None = None,
) -> Validation:
    """Integrate manifold points in the other time direction; they must reach the equilibrium.

    Parameters
    ----------
    manifold : InvariantManifold
        The computed manifold.
    times : list of float
        Parameter values ``t`` (output times of the manifold) to take points from.
    n_per_time : int
        Points per ``t``, drawn (seeded) among the running trajectories whose distance to
        the equilibrium is at least ``min_distance``.
    min_distance : float
        Smallest distance (12) of a sampled point (points still on ``B_delta`` prove
        nothing).
    extra_time : float
        Integrate over ``t + extra_time`` (past the return to ``B_delta``).
    perturbation : float
        Size of the seeded off-manifold displacement (tangent coordinates, retraction).
    seed : int
        Seed of the sampling and of the perturbation directions.
    method : Method
        Independent integrator (CVODES, or any method of :func:`simulate`).
    rtol, atol : float
        Tolerances of CVODES.
    step : float, optional
        Step of a fixed-step method.
    output_step : float, optional
        Spacing of the distances recorded (default: the manifold's output step).
    target : array-like, shape=(ambient_dim,), optional
        A state the perturbed points are expected to reach (e.g. the stable equilibrium):
        their final distance (12) to it is recorded as ``d_end_target``.

    Returns
    -------
    Validation

    Raises
    ------
    ParameterError
        Bad knobs, or no point at some ``t`` is as far as ``min_distance``.
    """
    method = Method(method)
    if not (isinstance(n_per_time, int) and n_per_time >= 1):
        raise ParameterError(f"n_per_time must be an integer >= 1; got {n_per_time!r}")
    for name, v in (("min_distance", min_distance), ("extra_time", extra_time),
                    ("perturbation", perturbation)):
        if not (np.isfinite(v) and v >= 0):
            raise ParameterError(f"{name} must be a finite number >= 0; got {v!r}")
    dt = float(output_step if output_step is not None else manifold.options["output_step"])
    kw = _sim_kwargs(method, rtol, atol, step)
    model, x_e = manifold.model, manifold.x_e
    man = model.manifold
    xt = None if target is None else model.check_state(target, name="target")
    rng = np.random.default_rng(seed)
    dist = manifold.distance()
    on: list[dict[str, Any]] = []
    off: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    runs = 0
    for t in times:
        i = manifold.index(t)
        ok = np.flatnonzero(manifold.running(manifold.t[i]) & (dist[i] >= min_distance))
        if ok.size == 0:
            raise ParameterError(
                f"no running trajectory is at distance >= min_distance = {min_distance:.3g} "
                f"at t = {t:g} (largest {float(dist[i].max()):.3g}); take a later t or a "
                f"smaller min_distance")
        pick = rng.choice(ok, size=min(n_per_time, ok.size), replace=False)
        n_t = max(2, int(np.ceil((manifold.t[i] + extra_time) / dt - 1e-9)) + 1)
        grid = -manifold.sign * np.arange(n_t) * dt
        k_ret = int(round(manifold.t[i] / dt))
        for j in sorted(pick.tolist()):
            x = manifold.x[i, j]
            tr = simulate(model, x, grid, controller=manifold.controller, **kw)
            d = distances(model, tr.x, x_e)
            k = int(np.argmin(d))
            on.append({"index": j, "t": float(manifold.t[i]), "d_start": float(d[0]),
                       "d_min": float(d[k]), "t_min": float(abs(grid[k])),
                       "ratio": float(d[k] / d[0]), "d_return": float(d[k_ret]),
                       "seed_error": float(np.max(np.abs(tr.x[k_ret] - manifold.x[0, j]))),
                       "d_end": float(d[-1]), "x_end": tr.x[-1].tolist()})
            v = rng.standard_normal(man.dim)
            xp = man.retract(x, perturbation * v / np.linalg.norm(v))
            trp = simulate(model, xp, grid, controller=manifold.controller, **kw)
            dp = distances(model, trp.x, x_e)
            kp = int(np.argmin(dp))
            entry = {"index": j, "t": float(manifold.t[i]), "d_start": float(dp[0]),
                     "d_min": float(dp[kp]), "t_min": float(abs(grid[kp])),
                     "d_end": float(dp[-1]), "x_end": trp.x[-1].tolist()}
            if xt is not None:
                entry["d_end_target"] = float(distances(model, trp.x[-1:], xt)[0])
            off.append(entry)
            runs += 2
    options = {"times": [float(t) for t in times], "n_per_time": n_per_time,
               "min_distance": min_distance, "extra_time": extra_time,
               "perturbation": perturbation, "seed": seed, "output_step": dt,
               **{k: (v.value if isinstance(v, Method) else v) for k, v in kw.items()}}
    return Validation(on, off, method, options,
                      ValidationCost(wall_seconds=time.perf_counter() - t0, simulations=runs))


def compare_per_point(
    manifold: InvariantManifold,
    *,
    indices: list[int],
    method: Method | None = None,
    step: float | None = None,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    jit: bool = False,
) -> dict[str, Any]:
    """Integrate some seeds one at a time with :func:`simulate` and compare.

    Each trajectory is compared on the manifold's output grid up to its stop time.

    Parameters
    ----------
    manifold : InvariantManifold
        The computed manifold.
    indices : list of int
        Trajectories to recompute.
    method : Method, optional
        Default: the manifold's own method and step (agreement to round-off expected).
    step : float, optional
        Step of a fixed-step method (default: the manifold's step).
    rtol, atol : float
        Tolerances of CVODES.
    jit : bool
        Compile the step of a geometric method.

    Returns
    -------
    dict
        ``max_deviation`` (max-norm over states and times, per trajectory, and its
        maximum ``worst``), ``max_relative_deviation`` (divided by ``1 + |x|``),
        ``wall_seconds`` (per-point runs), ``seconds_per_point_step`` of both, ``method``.
    """
    method = manifold.method if method is None else Method(method)
    if method is Method.CVODES:
        kw: dict[str, Any] = {"method": method, "rtol": rtol, "atol": atol}
    else:
        kw = {"method": method, "step": manifold.options["step"] if step is None else step}
        if method in GEOMETRIC_METHODS:
            kw["jit"] = jit
        if "newton_tol" in manifold.options and method is manifold.method:
            kw.update(newton_tol=manifold.options["newton_tol"],
                      newton_max_iter=manifold.options["newton_max_iter"])
    dev, rel = [], []
    wall = 0.0
    steps = 0
    for j in indices:
        n_t = int(np.sum(manifold.t < manifold.stop_time[j]))
        if n_t < 2:
            raise ParameterError(f"trajectory {j} stopped before the first output time")
        grid = manifold.sign * manifold.t[:n_t]
        t0 = time.perf_counter()
        tr = simulate(manifold.model, manifold.x[0, j], grid, controller=manifold.controller,
                      **kw)
        wall += time.perf_counter() - t0
        steps += int(tr.cost.get("steps", 0) or 0)
        ref = manifold.x[:n_t, j]
        dev.append(float(np.max(np.abs(tr.x - ref))))
        rel.append(float(np.max(np.abs(tr.x - ref) / (1 + np.abs(ref)))))
    return {
        "method": method.value, "indices": list(indices), "max_deviation": dev,
        "worst": max(dev), "max_relative_deviation": rel, "worst_relative": max(rel),
        "wall_seconds": wall,
        "seconds_per_point_step": wall / steps if steps else float("nan"),
        "vectorised_seconds_per_point_step": manifold.cost["seconds_per_point_step"],
    }
