"""Global stable and unstable manifolds of hyperbolic equilibria, grown from a small sphere.

For a hyperbolic equilibrium ``x_e`` of a model (open or closed loop) with stable subspace
``E^s`` of dimension ``k`` (paper 002, Section II-D, (9)-(12)), the local stable manifold
is tangent to ``E^s`` and the global one is the union of its backward images::

    W^s(x_e) = { F^{-t}(B_delta) }_{t > 0}                                          (10)

``B_delta`` is a small sphere around ``x_e`` in ``E^s``: ``n`` unit directions ``u_j``,
spread evenly over the unit sphere ``S^{k-1}`` of an orthonormal basis ``W`` of ``E^s``
(tangent coordinates of the linearisation,
:func:`~workbench.global_dynamics._seeds.sphere_directions`), are mapped to the
state manifold by the retraction, ``x_j = retract(x_e, r_j W u_j)``, with each radius
``r_j`` chosen so that the distance (12) to the equilibrium is exactly ``delta`` (measured
in the chart of the retraction, so exact to rounding for any orientation of ``x_e``)::

    d(x, x_e) = sum over configuration factors sqrt(Psi) + sum over velocity factors |v - v_e|

with ``Psi = 1 - q . q_e = |q - q_e|^2 / 2`` on S^2 (paper 002 (12)) and its SO(3)
analogue ``Psi = tr(I - R_e^T R) / 2 = |R - R_e|_F^2 / 4`` (the error function of Section
III-A with ``G = I``); R^n factors count as velocities. The unstable manifold is grown the
same way from ``E^u`` forward in time.

The seeds come from :mod:`workbench.global_dynamics._seeds`. The points are integrated all at
once: one step of a fixed-step scheme (the geometric integrators of
:mod:`workbench.simulation.integrators` run with a negative step, or classical RK4 in ambient
coordinates) is wrapped with a stopping rule, chained over the steps of an output interval
(``mapaccum``) and mapped over the points (``map``, optionally threaded), so one casadi
call advances every running point by one output interval; ``jit=True`` compiles the chained
steps to C. A trajectory whose distance to the equilibrium exceeds ``max_distance`` is stopped
there (the backward flow spins up exponentially and a fixed step stops resolving it; the
stop time is recorded) and drops out of the batch. Every step's implicit-update residual
and finiteness are checked; a failure raises :class:`~workbench.core.errors.SolverError`
naming the point and the time. Checks of the result that do not rely on pictures are in
:mod:`workbench.global_dynamics._manifold_validation`.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Evaluator, Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import SO3
from workbench.core.types import ArrayLike
from workbench.global_dynamics._seeds import (
    _distance_expr,
    ball_points,
    batch_evaluate,
    direction_spread,
    distances,
    positive_float,
    positive_int,
    seed_report,
    sphere_directions,
)
from workbench.global_dynamics._sizes import check_size
from workbench.linear._eigen import Eigenstructure, Subspace, eigenstructure
from workbench.linear._linearize import linearize
from workbench.simulation._simulate import Method, closed_loop_function
from workbench.simulation.integrators import lgvi, rkmk4, s2_variational
from workbench.simulation.integrators.common import (
    NEWTON_MAX_ITER,
    NEWTON_TOL,
    DiscreteFlow,
    controller_key,
    jit_function,
)

__all__ = [
    "InvariantManifold",
    "Subspace",
    "VECTORISED_METHODS",
    "invariant_manifold",
    "stable_manifold",
    "unstable_manifold",
]

VECTORISED_METHODS = (Method.RKMK4, Method.LGVI, Method.S2_VARIATIONAL, Method.RK)
"""Fixed-step methods that :func:`invariant_manifold` runs on all points at once."""


# ----------------------------------------------------------------------------------------
# the vectorised stepper


def _rk4_scheme(model: Model, controller: ca.Function | None) -> DiscreteFlow:
    loop = closed_loop_function(model, controller)
    S = model.sym
    x, p, h = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params), S.sym("h")

    def f(y):  # noqa: ANN001, ANN202
        return loop(y, p)[0]

    k1 = f(x)
    k2 = f(x + h / 2 * k1)
    k3 = f(x + h / 2 * k2)
    k4 = f(x + h * k3)
    step = ca.Function("rk4_step", [x, p, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4),
                                               S.zeros(1), S.zeros(1)],
                       ["x", "p", "h"], ["x_next", "residual", "iterations"])
    return DiscreteFlow(name="rk4", step=step, order=4, newton_tol=0.0, newton_max_iter=0,
                  evaluations_per_step=4,
                  structure={"manifold": "not preserved (ambient RK4): the drift is the "
                             "constraint residual", "symplectic": False, "symmetric": False,
                             "implicit": False})


def _scheme(model: Model, controller: ca.Function | None, method: Method, newton_tol: float,
            newton_max_iter: int) -> DiscreteFlow:
    if method is Method.RKMK4:
        return rkmk4(model, controller)
    if method is Method.LGVI:
        return lgvi(model, controller, newton_tol=newton_tol, newton_max_iter=newton_max_iter)
    if method is Method.S2_VARIATIONAL:
        return s2_variational(model, controller, newton_tol=newton_tol,
                              newton_max_iter=newton_max_iter)
    return _rk4_scheme(model, controller)


def _guarded_step(model: Model, scheme: DiscreteFlow, key: str) -> ca.Function:
    """``(x, p, h, x_e, dmax) -> (x_next, residual, active)``, frozen once ``d > dmax``."""

    def make() -> ca.Function:
        S = model.sym
        n = model.manifold.ambient_dim
        x, p, h = S.sym("x", n), S.sym("p", model.n_params), S.sym("h")
        xe, dmax = S.sym("x_e", n), S.sym("dmax")
        active = _distance_expr(model, x, xe) <= dmax
        x1, res, _ = scheme.step(x, p, h)
        return ca.Function("manifold_step", [x, p, h, xe, dmax],
                           [ca.if_else(active, x1, x), ca.if_else(active, res, 0), active],
                           ["x", "p", "h", "x_e", "dmax"], ["x_next", "residual", "active"],
                           {"cse": True} if S is ca.SX else {})

    return model._build(key, make)


def _interval(model: Model, step: ca.Function, key: str, n_sub: int, jit: bool
              ) -> ca.Function:
    """``n_sub`` guarded steps of one point: ``(x, p, h, x_e, dmax) -> (x, max res, n active)``.

    With ``jit`` the whole interval (the step chained by ``mapaccum``) is compiled to C,
    which removes the virtual machine's per-step overhead (about 3 times faster than
    compiling the step alone).
    """

    def make() -> ca.Function:
        m = step.nnz_in(0)
        x, p, h = ca.MX.sym("x", m), ca.MX.sym("p", step.nnz_in(1)), ca.MX.sym("h")
        xe, dmax = ca.MX.sym("x_e", m), ca.MX.sym("dmax")
        X, R, A = step.mapaccum("steps", n_sub)(x, p, h, xe, dmax)
        outs = [X[:, -1], ca.mmax(R), ca.sum2(A)]
        if not jit:
            return ca.Function("manifold_interval", [x, p, h, xe, dmax], outs)
        if not step.is_a("SXFunction"):
            raise ModelError(f"jit=True compiles scalar (SX) steps; model {model.name!r} is "
                             f"built on MX; run it with jit=False")
        return jit_function("manifold_interval_jit", [x, p, h, xe, dmax], outs,
                            what="the manifold step")

    return model._build(f"{key},n_sub={n_sub}{',jit' if jit else ''}", make)


def _interval_map(one: ca.Function, n_points: int, threads: int) -> Evaluator:
    """Evaluator of one interval of every point: one call per output interval."""
    m = one.nnz_in(0)
    p, h = ca.MX.sym("p", one.nnz_in(1)), ca.MX.sym("h")
    xe, dmax = ca.MX.sym("x_e", m), ca.MX.sym("dmax")
    mapped = one.map(n_points, "thread", threads) if threads > 1 else one.map(n_points)
    Xs = ca.MX.sym("X", m, n_points)
    # p, h, x_e and dmax are shared: a non-widened argument is repeated by the call
    return Evaluator(ca.Function("manifold_batch", [Xs, p, h, xe, dmax],
                                 mapped(Xs, p, h, xe, dmax)))


# ----------------------------------------------------------------------------------------
# results


@dataclass
class InvariantManifold:
    """A stable or unstable manifold grown from ``B_delta``, as trajectories in ``t``.

    Attributes
    ----------
    which : Subspace
        ``STABLE`` (grown backward, ``F^{-t}(B_delta)``) or ``UNSTABLE`` (forward).
    model : Model
        The model.
    controller : casadi.Function or None
        The feedback in the loop.
    x_e : ndarray, shape=(ambient_dim,)
        The equilibrium.
    eigen : Eigenstructure
        Of the (closed-loop) linearisation at ``x_e``.
    basis : ndarray, shape=(dim, k)
        Orthonormal basis of the eigenspace (tangent coordinates).
    directions : ndarray, shape=(n_points, k)
        Unit directions of the seeds in the coordinates of ``basis``.
    radii : ndarray, shape=(n_points,)
        Tangent-coordinate radii of the seeds.
    delta : float
        Radius of ``B_delta`` in the distance (12).
    t : ndarray, shape=(n_times,)
        The parameter ``t >= 0`` of (10): the states are ``F^{-t}`` (stable) or ``F^{t}``
        (unstable) of the seeds.
    x : ndarray, shape=(n_times, n_points, ambient_dim)
        States; a stopped trajectory keeps its last state.
    stop_time : ndarray, shape=(n_points,)
        Parameter ``t`` at which each trajectory exceeded ``max_distance`` (``inf`` if never).
    method : Method
        Integration method.
    options : dict
        Knobs as used (``step``, ``output_step``, ``horizon``, ``max_distance``, ...).
    cost : dict
        ``wall_seconds`` (stepping), ``build_seconds`` (linearisation, seeds, functions,
        compilation), ``steps`` (per point), ``point_steps`` (steps of running
        trajectories), ``evaluated_point_steps`` (including the padding of a shrinking
        batch), ``seconds_per_point_step`` (per evaluated one), ``rhs_evaluations``.
    diagnostics : dict
        ``constraint_residual`` (max over all states, per factor), ``seed_distance_error``
        (max ``|d - delta| / delta``, ``d`` measured in the chart the seeds are placed in),
        ``seed_ambient_distance_error`` (the same from the stored coordinates) and
        ``seed_rounding_bound`` (what their rounding allows, ``~EPS / delta``; see
        :func:`~workbench.global_dynamics._seeds.seed_report`), ``seed_tangency`` (max
        relative component of the seeds' chart coordinates outside the eigenspace,
        ``O(delta)``), ``spread`` (see
        :func:`direction_spread`), ``newton`` (largest residual), ``n_stopped``,
        ``max_step_displacement`` (largest ``|h| |x-dot|`` at the stored states of running
        trajectories: the resolution of the fixed step), ``structure``.
    """

    which: Subspace
    model: Model
    controller: ca.Function | None
    x_e: np.ndarray
    eigen: Eigenstructure
    basis: np.ndarray
    directions: np.ndarray
    radii: np.ndarray
    delta: float
    t: np.ndarray
    x: np.ndarray
    stop_time: np.ndarray
    method: Method
    options: dict[str, Any]
    cost: dict[str, Any] = field(default_factory=dict)
    diagnostics: dict[str, Any] = field(default_factory=dict)

    @property
    def sign(self) -> float:
        """Direction of the flow: -1 for a stable manifold, +1 for an unstable one."""
        return -1.0 if self.which is Subspace.STABLE else 1.0

    @property
    def n_points(self) -> int:
        """Number of trajectories."""
        return int(self.x.shape[1])

    @property
    def seeds(self) -> np.ndarray:
        """The points on ``B_delta``, shape ``(n_points, ambient_dim)``."""
        return self.x[0]

    def index(self, t: float) -> int:
        """Index of the stored parameter value ``t`` (must be on the output grid)."""
        i = int(np.argmin(np.abs(self.t - float(t))))
        if abs(self.t[i] - float(t)) > 1e-9 * max(1.0, abs(float(t))):
            raise ParameterError(f"t = {t!r} is not an output time; stored times run from "
                                 f"0 to {self.t[-1]:.6g} every {self.options['output_step']:.6g}")
        return i

    def at(self, t: float) -> np.ndarray:
        """States of all trajectories at parameter ``t``, shape ``(n_points, ambient_dim)``."""
        return self.x[self.index(t)]

    def running(self, t: float) -> np.ndarray:
        """Mask of the trajectories not yet stopped at parameter ``t``."""
        return self.stop_time > float(t)

    def part(self, name: str) -> np.ndarray:
        """One factor over time: ``(n_times, n_points, m)``; SO3 as ``(..., 3, 3)`` matrices."""
        man = self.model.manifold
        if name not in man.slices:
            raise ModelError(f"unknown factor {name!r}; this model has {man.names}")
        block = self.x[:, :, man.slices[name]]
        if isinstance(man.factor(name), SO3):
            return block.reshape(*block.shape[:2], 3, 3).transpose(0, 1, 3, 2)
        return block

    def distance(self) -> np.ndarray:
        """Distance (12) of every stored state to the equilibrium, ``(n_times, n_points)``."""
        X = self.x.reshape(-1, self.x.shape[2])
        return distances(self.model, X, self.x_e).reshape(self.x.shape[:2])

    def summary(self) -> dict[str, Any]:
        """Plain JSON-serialisable account (no states)."""
        return {
            "which": self.which.value, "model": self.model.name,
            "dimension": int(self.basis.shape[1]), "n_points": self.n_points,
            "delta": self.delta, "eigenvalues": [complex(v) for v in self.eigen.eigenvalues],
            "method": self.method.value, "options": self.options, "cost": self.cost,
            "diagnostics": self.diagnostics,
        }


def _check_equilibrium(model: Model, x_e: ArrayLike, controller: ca.Function | None,
                       which: Subspace) -> tuple[np.ndarray, Eigenstructure, np.ndarray]:
    lin = linearize(model, x_e, controller=controller)
    es = eigenstructure(lin)
    if es.n_centre:
        raise ModelError(
            f"x_e must be a hyperbolic equilibrium; its linearisation has {es.n_centre} "
            f"eigenvalue(s) on the imaginary axis (within {es.tol:.2g}): "
            f"{np.array2string(es.eigenvalues, precision=4)}")
    W = es.subspace(which)
    if W.shape[1] == 0:
        raise ModelError(f"the equilibrium has no {which.value} eigenvalues (eigenvalues "
                         f"{np.array2string(es.eigenvalues, precision=4)}); its "
                         f"{which.value} manifold is the point itself")
    return lin.x_e, es, W


@validate.arguments(
    model=validate.instance(Model, "a workbench Model"), delta=validate.positive,
    horizon=validate.positive, step=validate.positive, output_step=validate.positive,
    n_points=validate.count, newton_tol=validate.tolerance
)
def invariant_manifold(
    model: Model,
    x_e: ArrayLike,
    *,
    which: Subspace = Subspace.STABLE,
    controller: ca.Function | None = None,
    delta: float = 1e-6,
    n_points: int = 100,
    horizon: float,
    step: float,
    output_step: float,
    method: Method = Method.RKMK4,
    max_distance: float = np.inf,
    jit: bool = False,
    threads: int = 1,
    newton_tol: float = NEWTON_TOL,
    newton_max_iter: int = NEWTON_MAX_ITER,
    spread_seed: int = 0,
    spread_iterations: int = 100,
    progress: bool | None = None,
) -> InvariantManifold:
    """Grow the stable (backward) or unstable (forward) manifold of a hyperbolic equilibrium.

    Parameters
    ----------
    model : Model
        The model (any factors with a retraction and a distance: R^n, S1, S2, SO3, TS2).
    x_e : array-like, shape=(ambient_dim,)
        A hyperbolic equilibrium of the (closed-loop) field, on the manifold.
    which : Subspace
        ``STABLE`` or ``UNSTABLE``.
    controller : casadi.Function, optional
        Feedback ``u = k(x)`` or ``k(x, p)`` in the loop.
    delta : float
        Radius of ``B_delta`` in the distance (12).
    n_points : int
        Number of seeds on ``B_delta`` (2 for a one-dimensional eigenspace).
    horizon : float
        Largest parameter ``t`` (time integrated, backward for ``STABLE``).
    step : float
        Largest fixed step; every output interval is split into
        ``ceil(output_step / step)`` equal steps.
    output_step : float
        Spacing of the stored parameter values (a divisor of ``horizon`` up to 1e-9).
    method : Method
        ``RKMK4`` (any factors), ``LGVI`` (rigid body on TSO(3)), ``S2_VARIATIONAL`` (TS^2)
        or ``RK`` (ambient RK4, not structure-preserving).
    max_distance : float
        Stop a trajectory once its distance (12) to ``x_e`` exceeds this (``inf``: never).
    jit : bool
        Compile the steps of an output interval to C (SX models; about a second once per
        process and output step).
    threads : int
        Threads of casadi's ``map`` over the points (1: serial).
    newton_tol, newton_max_iter : float, int
        Implicit-update knobs of ``LGVI`` and ``S2_VARIATIONAL``.
    spread_seed, spread_iterations : int
        Knobs of :func:`sphere_directions` (used for eigenspaces of dimension >= 4).
    progress : bool, optional
        Show a progress bar (default: when stderr is a terminal).

    Returns
    -------
    InvariantManifold

    Raises
    ------
    ModelError
        ``x_e`` not an equilibrium, not hyperbolic, or without ``which`` eigenvalues.
    ParameterError
        Bad knobs, or a method that is not vectorised (CVODES and collocation run point by
        point in :mod:`workbench.global_dynamics._manifold_validation`).
    SolverError
        A step whose implicit update fails, or a non-finite state (point, time, status).
    """
    t_build = time.perf_counter()
    try:
        method = Method(method)
        which = Subspace(which)
    except ValueError as exc:
        raise ParameterError(f"bad method or which: {exc}") from exc
    if method not in VECTORISED_METHODS:
        raise ParameterError(
            f"method must be one of {[m.value for m in VECTORISED_METHODS]} (fixed-step, run "
            f"on all points at once); got {method.value!r}. CVODES runs point by point in "
            f"workbench.global_dynamics._manifold_validation (validate, compare_per_point)")
    if which is Subspace.CENTRE:
        raise ParameterError("which must be Subspace.STABLE or Subspace.UNSTABLE; got CENTRE")
    n_points = positive_int(n_points, "n_points")
    delta = positive_float(delta, "delta")
    horizon = positive_float(horizon, "horizon")
    step = positive_float(step, "step")
    dt_out = positive_float(output_step, "output_step")
    dmax = positive_float(max_distance, "max_distance", allow_inf=True)
    threads = positive_int(threads, "threads")
    n_out = round(horizon / dt_out)
    if n_out < 1 or abs(n_out * dt_out - horizon) > 1e-9 * horizon:
        raise ParameterError(f"output_step must divide horizon; got horizon {horizon:.6g}, "
                             f"output_step {dt_out:.6g}")
    if step > dt_out:
        raise ParameterError(f"step must not exceed output_step = {dt_out:.6g}; got {step:.6g}")
    check_size(n_points, horizon, step, dt_out, model.manifold.ambient_dim)
    xe, es, W = _check_equilibrium(model, x_e, controller, which)
    if dmax <= delta:
        raise ParameterError(f"max_distance must exceed delta = {delta:.3g}; got {dmax:.3g}")
    U = sphere_directions(W.shape[1], n_points, seed=spread_seed, iterations=spread_iterations)
    X0, radii = ball_points(model, xe, W, U, delta=delta)
    scheme = _scheme(model, controller, method, newton_tol, newton_max_iter)
    key = (f"manifold_step[{method.value},tol={scheme.newton_tol:.3g},"
           f"max_iter={scheme.newton_max_iter},controller={controller_key(controller)}]")
    n_sub = max(1, math.ceil(dt_out / step - 1e-12))
    one = _interval(model, _guarded_step(model, scheme, key), key, n_sub, bool(jit))
    h = (-1.0 if which is Subspace.STABLE else 1.0) * dt_out / n_sub
    build = time.perf_counter() - t_build

    X = np.empty((n_out + 1, n_points, model.manifold.ambient_dim))
    X[0] = X0
    steps_run = np.zeros(n_points, dtype=int)
    alive = np.arange(n_points)
    evaluators: dict[int, Evaluator] = {}
    size, max_res, evaluated = n_points, 0.0, 0
    bar = _progress(n_out, f"{which.value} manifold", progress)
    t_run = time.perf_counter()
    for i in range(n_out):
        X[i + 1] = X[i]
        if alive.size == 0:
            continue
        if alive.size < 0.8 * size:  # shrink the batch geometrically as trajectories stop
            size = alive.size
        if size not in evaluators:
            t0 = time.perf_counter()
            evaluators[size] = _interval_map(one, size, threads)
            build += time.perf_counter() - t0
        batch = X[i, np.r_[alive, np.repeat(alive[:1], size - alive.size)]]  # padded
        nxt, res, act = evaluators[size](batch, model.p, h, xe, dmax)
        nxt, res, act = nxt.reshape(size, -1)[:alive.size], res[:alive.size], act[:alive.size]
        evaluated += size * n_sub
        bad = ~(res <= scheme.newton_tol) | ~np.all(np.isfinite(nxt), axis=1)
        if np.any(bad):
            if bar is not None:
                bar.close()
            raise _step_failure(scheme, model, which, int(alive[np.flatnonzero(bad)[0]]),
                                n_points, i * dt_out, dt_out, h, nxt, res, bad)
        max_res = max(max_res, float(np.max(res)))
        X[i + 1, alive] = nxt
        steps_run[alive] += act.astype(int)
        alive = alive[act.astype(int) == n_sub]
        if bar is not None:
            bar.update(1)
    wall = time.perf_counter() - t_run
    if bar is not None:
        bar.close()

    total = n_sub * n_out
    stop_time = np.where(steps_run < total, steps_run * abs(h), np.inf)
    options = {"horizon": horizon, "step": abs(h), "requested_step": step,
               "output_step": dt_out, "max_distance": dmax, "jit": bool(jit),
               "threads": threads, "spread_seed": spread_seed,
               "spread_iterations": spread_iterations}
    if scheme.newton_max_iter:
        options.update(newton_tol=scheme.newton_tol, newton_max_iter=scheme.newton_max_iter)
    point_steps = int(steps_run.sum())
    cost = {"wall_seconds": wall, "build_seconds": build, "steps": total,
            "point_steps": point_steps, "evaluated_point_steps": evaluated,
            "seconds_per_point_step": wall / max(evaluated, 1),
            "rhs_evaluations": scheme.evaluations_per_step * evaluated}
    out = InvariantManifold(which, model, controller, xe, es, W, U, radii, float(delta),
                            np.arange(n_out + 1) * dt_out, X, stop_time, method, options, cost)
    out.diagnostics = _diagnostics(out, scheme, max_res, abs(h))
    return out


def _step_failure(scheme: DiscreteFlow, model: Model, which: Subspace, j: int, n_points: int,
                  t0: float, dt: float, h: float, nxt: np.ndarray, res: np.ndarray,
                  bad: np.ndarray) -> SolverError:
    k = int(np.flatnonzero(bad)[0])
    finite = bool(np.all(np.isfinite(nxt[k])))
    what = (f"the implicit update did not converge (relative residual {res[k]:.3g} > "
            f"newton_tol {scheme.newton_tol:.1g})" if finite else "the state became non-finite")
    return SolverError(
        f"{scheme.name} failed for point {j} of {n_points} between t = {t0:.6g} and "
        f"{t0 + dt:.6g} (step {abs(h):.3g}, {which.value} manifold of {model.name}): {what}. "
        f"Reduce step, or stop trajectories earlier with max_distance",
        status="newton_not_converged" if finite else "non-finite")


def _progress(total: int, desc: str, progress: bool | None) -> Any:
    show = progress if progress is not None else sys.stderr.isatty()
    if not show:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="interval", file=sys.stderr)


def _residual_function(model: Model) -> ca.Function:
    """``x -> (max |h_i(x)|)_i`` per manifold factor, SX."""
    x = ca.SX.sym("x", model.manifold.ambient_dim)
    parts = []
    for name, f in model.manifold.factors:
        h = ca.vec(ca.SX(f.residual(x[model.manifold.slices[name]])))
        parts.append(ca.norm_inf(h) if h.numel() else ca.SX(0))
    return ca.Function("factor_residuals", [x], [ca.vertcat(*parts)])


def _diagnostics(m: InvariantManifold, scheme: DiscreteFlow, max_res: float, h: float
                 ) -> dict[str, Any]:
    model = m.model
    run = np.repeat(m.t[:, None], m.n_points, axis=1) < m.stop_time[None, :]
    run[-1] |= True  # the last (or frozen) state of every trajectory
    states = m.x[run]  # every distinct stored state (stopped ones once, when frozen)
    res = batch_evaluate(_residual_function(model), states).max(axis=0)
    V = m.radii[:, None] * (m.directions @ m.basis.T)
    chart = np.array([model.manifold.chart(m.x_e, s) for s in m.seeds])
    outside = chart - (chart @ m.basis) @ m.basis.T
    tangency = float(np.max(np.linalg.norm(outside, axis=1) / np.linalg.norm(chart, axis=1)))
    loop = closed_loop_function(model, m.controller)
    moving = m.x[run & (np.repeat(m.t[:, None], m.n_points, axis=1) < m.stop_time[None, :])]
    speed = np.linalg.norm(batch_evaluate(loop, moving, model.p), axis=1)
    return {
        "constraint_residual": {n: float(r) for n, r in zip(model.manifold.names, res)},
        **seed_report(model, m.x_e, m.seeds, V, m.delta),
        "seed_tangency": tangency,
        "spread": direction_spread(m.directions) if m.n_points >= 2 else {},
        "newton": {"tol": scheme.newton_tol, "max_residual": max_res},
        "n_stopped": int(np.sum(np.isfinite(m.stop_time))),
        "max_step_displacement": float(h * speed.max()) if speed.size else 0.0,
        "structure": dict(scheme.structure),
    }


def stable_manifold(model: Model, x_e: ArrayLike, **options: Any) -> InvariantManifold:
    """:func:`invariant_manifold` with ``which=Subspace.STABLE`` (backward integration)."""
    return invariant_manifold(model, x_e, which=Subspace.STABLE, **options)


def unstable_manifold(model: Model, x_e: ArrayLike, **options: Any) -> InvariantManifold:
    """:func:`invariant_manifold` with ``which=Subspace.UNSTABLE`` (forward integration)."""
    return invariant_manifold(model, x_e, which=Subspace.UNSTABLE, **options)
