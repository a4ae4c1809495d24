"""Pieces shared by the fixed-step geometric integrators.

A geometric integrator is described by a :class:`DiscreteFlow`: one casadi.Function
``step(x, p, h) -> (x_next, residual, iterations)`` that advances the stored ambient state
by one step of signed size ``h`` (negative for backward integration), built from the
model's graph, plus what it preserves and what one step costs. :func:`integrate` runs a
scheme over an equally spaced output grid, evaluating chunks of steps in one casadi call
(``mapaccum``), and checks every step: the relative residual of its implicit update (zero
for explicit schemes) must be at most the scheme's Newton tolerance, and the state must
stay finite. A failing step raises :class:`~workbench.core.errors.SolverError` naming the step,
its time and its residual; nothing is retried or repaired.

:func:`newton` writes a Newton iteration into a graph: a fixed number of iterations is
unrolled, each applied only while the residual is above the tolerance, so the result is
that of a ``while residual > tol`` loop capped at ``max_iter``; the Jacobian comes from
casadi's automatic differentiation of the residual.
"""

from __future__ import annotations

import hashlib
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._evaluator import cached_evaluator
from workbench.core._feedback import (
    feedback_function,  # re-exported: the integrators' users import it here
)
from workbench.core._model import Evaluator, Model
from workbench.core.errors import ParameterError, SolverError, WorkbenchError
from workbench.core.status import Record
from workbench.core.types import ArrayLike
from workbench.core.validate import count, positive
from workbench.simulation.integrators._jit import (  # re-exported: the schemes import them here
    compile_step,
    jit_function,
)

__all__ = [
    "DiscreteFlow",
    "Integration",
    "IntegrationCost",
    "NEWTON_TOL",
    "NEWTON_MAX_ITER",
    "MAX_NEWTON_ITER",
    "CHUNK",
    "feedback_function",
    "controller_key",
    "newton",
    "integrate",
    "field_failure",
    "MAX_CHUNK",
    "MAX_FIXED_STEPS",
    "check_newton_options",
    "compile_step",
    "jit_function",
]

NEWTON_TOL = 1e-13
"""Default tolerance on the relative residual of an implicit update (round-off is ~1e-15)."""

NEWTON_MAX_ITER = 4
"""Default cap on Newton iterations per implicit update (2 suffice for ``|h omega| < 0.1``
from the second-order initial guesses used here)."""

MAX_NEWTON_ITER = 50
"""Largest accepted ``newton_max_iter``: the iterations are unrolled into the step's graph
(about 20 ms of building and 0.5 MB per iteration for a small model, more for a large one),
and Newton from the schemes' second-order guesses needs 2 to 4 where it converges at all."""

CHUNK = 512
"""Steps evaluated per casadi call by :func:`integrate` (memory grows with it)."""


@dataclass(frozen=True)
class DiscreteFlow:
    """The discrete flow map ``Phi_h`` of a one-step method on a model's manifold.

    One casadi.Function ``x_(k+1) = Phi_h(x_k)`` with what it preserves and what a step
    costs (named for the map it computes; the OCP's ``Scheme`` is the choice of
    collocation points).

    Attributes
    ----------
    name : str
        Short name, e.g. ``"lgvi"``.
    step : casadi.Function
        ``(x, p, h) -> (x_next, residual, iterations)``: ``x`` the stored state, shape
        ``(ambient_dim,)``; ``p`` the model parameters; ``h`` the signed step; ``residual``
        the relative residual of the implicit update after the Newton iterations (0 for an
        explicit update; ``inf`` when the update has no solution); ``iterations`` the
        number of Newton updates applied.
    order : int
        Classical order of convergence.
    newton_tol : float
        Largest accepted ``residual`` (relative).
    newton_max_iter : int
        Newton iterations unrolled per implicit solve (0 for explicit schemes).
    evaluations_per_step : int
        Evaluations of the model's vector field per step outside Newton solves.
    structure : dict
        What the scheme preserves, in words and flags (``manifold``, ``symplectic``,
        ``symmetric``, ``implicit``), copied into the trajectory's diagnostics.
    no_solution : str
        When the step reports an infinite residual (its update has no solution), in words.
    """

    name: str
    step: ca.Function
    order: int
    newton_tol: float
    newton_max_iter: int
    evaluations_per_step: int
    structure: dict[str, Any] = field(default_factory=dict)
    no_solution: str = ""


@dataclass(frozen=True)
class IntegrationCost(Record):
    """What :func:`integrate` cost.

    Attributes
    ----------
    wall_seconds, setup_seconds : float
        Stepping, and building the chunk functions.
    steps, rhs_evaluations, newton_iterations : int
        Steps, vector-field evaluations outside Newton solves, Newton iterations (total).
    seconds_per_step : float
        ``wall_seconds / steps``.
    """

    wall_seconds: float
    setup_seconds: float
    steps: int
    rhs_evaluations: int
    newton_iterations: int
    seconds_per_step: float


@dataclass
class Integration:
    """What :func:`integrate` returns.

    Attributes
    ----------
    t : ndarray, shape=(n_times,)
        Output times.
    x : ndarray, shape=(n_times, ambient_dim)
        States at the output times.
    step : float
        The signed step actually used (the output spacing divided by the steps per
        output interval).
    cost : IntegrationCost
        ``wall_seconds`` (stepping), ``setup_seconds`` (chunk functions), ``steps``,
        ``rhs_evaluations`` (vector-field evaluations outside Newton solves),
        ``newton_iterations`` (total), ``seconds_per_step`` (a typed record that also
        reads as a mapping).
    diagnostics : dict
        ``newton`` (tolerance, largest residual, iterations per step: max and mean) and
        ``structure`` (the scheme's :attr:`DiscreteFlow.structure`).
    between : list of (float, ndarray, str)
        The largest state (max-norm) and the fastest (largest ``|x_(k+1) - x_k| / |h|``)
        among all the steps, outputs or not: ``(time, state, what)``, for the stability
        checks (they cost two reductions per chunk of steps).
    """

    t: np.ndarray
    x: np.ndarray
    step: float
    cost: IntegrationCost
    diagnostics: dict[str, Any]
    between: list[tuple[float, np.ndarray, str]] = field(default_factory=list)


def check_newton_options(newton_tol: float, newton_max_iter: int) -> tuple[float, int]:
    """Validate the Newton knobs; return them as ``(float, int)``.

    Raises
    ------
    ParameterError
        ``newton_tol`` not in ``(0, 1)``, or ``newton_max_iter`` not an integer in
        ``[1, MAX_NEWTON_ITER]`` (checked before anything is built: the iterations are
        unrolled into the step's graph).
    """
    try:
        tol = float(newton_tol)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"newton_tol must be a number in (0, 1); got {newton_tol!r}") \
            from exc
    if not (np.isfinite(tol) and 0 < tol < 1):
        raise ParameterError(
            f"newton_tol (relative residual of the implicit update) must be in (0, 1); "
            f"got {newton_tol!r}"
        )
    if (isinstance(newton_max_iter, (int, np.integer)) and not isinstance(newton_max_iter, bool)
            and newton_max_iter > MAX_NEWTON_ITER):
        raise ParameterError(
            f"newton_max_iter must be an integer >= 1 and <= {MAX_NEWTON_ITER}; got "
            f"{newton_max_iter}: every iteration is unrolled into the step's graph (about "
            f"20 ms of building and 0.5 MB each for a small model), and a Newton iteration "
            f"that has not converged in {MAX_NEWTON_ITER} from the scheme's guess will not: "
            f"reduce step instead")
    return tol, count("newton_max_iter", newton_max_iter, maximum=MAX_NEWTON_ITER)


def controller_key(controller: ca.Function | None) -> str:
    """A short stable key of a controller (hash of its serialisation), for caching."""
    if controller is None:
        return "none"
    try:
        text = controller.serialize()
    except RuntimeError:  # functions that cannot be serialised are keyed by identity
        text = f"{controller.name()}@{id(controller)}"
    return hashlib.sha1(text.encode()).hexdigest()[:12]


def newton(
    residual: Callable[[Any], Any],
    z0: Any,
    scale: Any,
    *,
    tol: float,
    max_iter: int,
) -> tuple[Any, Any, Any]:
    """Unrolled Newton iteration for ``residual(z) = 0`` inside a casadi graph.

    Parameters
    ----------
    residual : callable
        ``residual(z) -> r``, casadi expressions of the same size as ``z``.
    z0 : casadi expression, shape=(n, 1)
        Initial guess.
    scale : casadi expression
        Positive scale of the equation; the residual is measured as ``|r|_inf / scale``
        (a zero scale is replaced by the smallest normal number).
    tol : float
        Stop updating once the relative residual is at most ``tol``.
    max_iter : int
        Iterations unrolled.

    Returns
    -------
    z : casadi expression, shape=(n, 1)
        The last iterate.
    relres : casadi expression
        Its relative residual.
    iterations : casadi expression
        Number of Newton updates applied (``<= max_iter``).

    Notes
    -----
    The Jacobian ``dr/dz`` is the automatic derivative of ``residual``. A residual that
    is NaN counts as not converged (``not (relres <= tol)``).
    """
    S = ca.SX if isinstance(z0, ca.SX) else ca.MX
    zs = S.sym("z", z0.shape[0])
    rs = residual(zs)
    js = ca.jacobian(rs, zs)
    sc = ca.fmax(scale, np.finfo(float).tiny)
    z, its = z0, 0
    r = ca.substitute(rs, zs, z)
    rel = ca.norm_inf(r) / sc
    for _ in range(max_iter):
        go = ca.logic_not(rel <= tol)
        jac = ca.substitute(js, zs, z)
        z = ca.if_else(go, z - ca.solve(jac, r), z)
        its = its + go
        r = ca.substitute(rs, zs, z)
        rel = ca.norm_inf(r) / sc
    return z, rel, its


# ----------------------------------------------------------------------------------------
# driving a scheme over an output grid


_CHUNKS: dict[tuple[int, int], tuple[ca.Function, Evaluator]] = {}
_CHUNKS_MAX = 64  # entries kept; each holds its step function, so ids are never reused


def _chunk_evaluator(step: ca.Function, n: int) -> Evaluator:
    """A cached evaluator of ``n`` steps in one call (``mapaccum``)."""
    return cached_evaluator(_CHUNKS, step, n, lambda: _chunk_function(step, n), _CHUNKS_MAX)


def _chunk_function(step: ca.Function, n: int) -> ca.Function:
    xm = ca.MX.sym("x", step.nnz_in(0))
    pm = ca.MX.sym("p", step.nnz_in(1))
    hm = ca.MX.sym("h")
    X, res, its = step.mapaccum(f"{step.name()}_x{n}", n)(
        xm, ca.repmat(pm, 1, n), ca.repmat(hm, 1, n)
    )
    return ca.Function(f"{step.name()}_chunk{n}", [xm, pm, hm], [X, res, its])


def steps_per_interval(dt_out: float, step: float) -> int:
    """Number of equal steps per output interval: ``ceil(dt_out / step)`` (at least 1)."""
    return max(1, math.ceil(dt_out / step - 1e-12))


def check_step(
    step: Any, horizon: float, *, error: type[WorkbenchError] = ParameterError
) -> float:
    """Validate a step size against the horizon; return it as a float.

    Parameters
    ----------
    step : float
        The largest step size.
    horizon : float
        ``|t[-1] - t[0]|``.
    error : type of WorkbenchError
        The exception class raised (the caller's documented one:
        :func:`~workbench.simulation._simulate.simulate` raises ModelError).

    Returns
    -------
    float

    Raises
    ------
    ParameterError
        (or ``error``) ``step`` not a positive finite number, larger than ``horizon``, or
        so small that the horizon would take more than :data:`MAX_FIXED_STEPS` steps.
    """
    s = positive("step", step, error=error)
    if s > horizon:
        raise error(
            f"step must not exceed the horizon |t[-1] - t[0]| = {horizon:.6g}; got {s:.6g}"
        )
    if horizon / s > MAX_FIXED_STEPS:
        raise error(
            f"step {s:.3g} would take {horizon / s:.3g} fixed steps over the horizon "
            f"{horizon:.6g} (at most {MAX_FIXED_STEPS:.0e}: hours of work); use a larger "
            "step, or an adaptive method (cvodes)")
    return s


MAX_FIXED_STEPS = 10**8
"""Fixed steps one simulation may take (1e8 steps of a small model: minutes)."""

MAX_CHUNK = 100_000
"""Largest ``chunk`` of :func:`integrate`: one call holds the states of its steps."""


def field_failure(model: Model, controller: ca.Function | None, x: np.ndarray,
                  t: float) -> str | None:
    """Say so when the field or the controller is not finite at ``x`` (None: both finite).

    Parameters
    ----------
    model : Model
        The model.
    controller : casadi.Function or None
        The feedback in the loop.
    x : ndarray, shape=(ambient_dim,)
        The state.
    t : float
        Its time, for the message.

    Returns
    -------
    str or None
        A sentence naming which returned what at which state and time.
    """
    state = np.array2string(np.asarray(x), precision=4, max_line_width=10_000)
    try:
        u = np.asarray(feedback_function(model, controller)(x, model.p), dtype=float).ravel()
        xdot = np.asarray(model.function("f")(x, np.nan_to_num(u), model.p),
                          dtype=float).ravel()
    except RuntimeError as exc:
        return (f"the field or controller cannot be evaluated at t = {t:.6g}, x = {state}: "
                f"{str(exc).strip().splitlines()[-1] if str(exc).strip() else exc!r}")
    bad = [name for name, v in (("controller", u), ("field", xdot))
           if not np.all(np.isfinite(v))]
    if not bad:
        return None
    return (f"the {' and the '.join(bad)} returned non-finite values at t = {t:.6g}, "
            f"x = {state} (u = {np.array2string(u, precision=4)}, xdot = "
            f"{np.array2string(xdot, precision=4)}; the field evaluated with u = 0 where u is "
            "not finite): a defect of the model or the controller there, not of the step size")


def integrate(
    model: Model,
    scheme: DiscreteFlow,
    x0: ArrayLike,
    t: ArrayLike,
    *,
    step: float,
    chunk: int = CHUNK,
    controller: ca.Function | None = None,
) -> Integration:
    """Run a scheme from ``x0`` over equally spaced output times ``t``.

    Parameters
    ----------
    model : Model
        The model the scheme was built for (its parameter values are used).
    scheme : DiscreteFlow
        The one-step method.
    x0 : array-like, shape=(ambient_dim,)
        Initial state (already validated on the manifold by the caller).
    t : array-like, shape=(n_times,)
        Equally spaced output times, increasing or (backward integration) decreasing.
    step : float
        Largest step size (positive); each output interval is split into
        ``ceil(interval / step)`` equal steps, taken with the sign of ``t[-1] - t[0]``.
    chunk : int
        Steps evaluated per casadi call, at most :data:`MAX_CHUNK` (each call holds the
        states of its steps).
    controller : casadi.Function, optional
        The feedback the scheme was built with. It only serves the diagnosis of a failing
        step: a field or controller that is not finite at the step's start is reported as
        such (not as a step size to reduce).

    Returns
    -------
    Integration

    Raises
    ------
    ParameterError
        Bad ``t``, ``step`` or ``chunk``.
    SolverError
        A step whose implicit update did not converge to ``scheme.newton_tol`` (message
        with the step number, its time interval and residual), or a non-finite state; a
        field or controller that is not finite at the step's start (status
        ``non_finite_field``). The error carries ``state`` (the state at the start of the
        failing step), ``time`` (its time), ``step_index`` (zero-based) and ``outputs``
        (the states at the output times reached, ``t[:len(outputs)]``).
    """
    tv = np.asarray(t, dtype=float).ravel()
    if tv.size < 2 or not np.all(np.isfinite(tv)):
        raise ParameterError(f"t must hold at least two finite times; got {tv.tolist()[:5]}")
    d = np.diff(tv)
    if not (np.all(d > 0) or np.all(d < 0)):
        raise ParameterError("t must be strictly increasing or strictly decreasing")
    dt_out = float(np.max(np.abs(d)))
    if not np.allclose(np.abs(d), dt_out, rtol=1e-9, atol=0):
        raise ParameterError(
            f"{scheme.name} needs equally spaced output times t; got spacings between "
            f"{np.abs(d).min():.6g} and {dt_out:.6g}"
        )
    horizon = abs(tv[-1] - tv[0])
    s = check_step(step, horizon)
    chunk = count("chunk", chunk, maximum=MAX_CHUNK)
    n_sub = steps_per_interval(dt_out, s)
    sign = 1.0 if tv[-1] > tv[0] else -1.0
    h = sign * dt_out / n_sub
    n_total = n_sub * (len(tv) - 1)
    x = np.asarray(x0, dtype=float).ravel().copy()
    p = model.p

    t_setup = time.perf_counter()
    sizes = {min(int(chunk), n_total)}
    if n_total % int(chunk) and n_total > chunk:
        sizes.add(n_total % int(chunk))
    evaluators = {n: _chunk_evaluator(scheme.step, n) for n in sizes}
    setup = time.perf_counter() - t_setup
    out = [x.copy()]
    max_res, its_total, its_max = 0.0, 0, 0
    # the largest and the fastest state of all the steps: (value, step index, state)
    largest = (float(np.max(np.abs(x))), 0, x.copy())
    fastest = (0.0, 0, x.copy())
    t_run = time.perf_counter()
    done = 0
    while done < n_total:
        n = min(int(chunk), n_total - done)
        X, res, its = evaluators[n](x, p, h)
        X = X.reshape(n, -1)
        ok = (res <= scheme.newton_tol) & np.all(np.isfinite(X), axis=1)
        if not np.all(ok):
            j = int(np.flatnonzero(~ok)[0])
            k = done + j  # zero-based index of the failing step
            t_k = tv[0] + k * h
            r = float(res[j])
            x_k = x if j == 0 else X[j - 1]
            nan_field = field_failure(model, controller, x_k, t_k)
            if nan_field is not None:
                err = SolverError(
                    f"{scheme.name} failed at step {k + 1} of {n_total} (t = {t_k:.6g} -> "
                    f"{t_k + h:.6g}, h = {h:.6g}) integrating {model.name}: {nan_field}",
                    status="non_finite_field")
                err.state, err.time, err.step_index = x_k.copy(), t_k, k  # type: ignore[attr-defined]
                err.outputs = np.array(out)  # type: ignore[attr-defined]
                raise err
            if np.isinf(r):
                what = f"the discrete update has no solution ({scheme.no_solution})"
                status, fix = "no_solution", "Reduce step."
            elif not r <= scheme.newton_tol:
                what = (
                    f"Newton did not converge: relative residual {r:.3g} > newton_tol "
                    f"{scheme.newton_tol:.1g} after {int(its[j])} iterations "
                    f"(newton_max_iter = {scheme.newton_max_iter})"
                )
                status, fix = "newton_not_converged", "Reduce step or raise newton_max_iter."
                if r <= 100 * scheme.newton_tol:
                    fix += (f" The residual is within {r / scheme.newton_tol:.3g} x newton_tol,"
                            f" likely its rounding level (stiff or badly scaled inertia): "
                            f"raise newton_tol.")
            else:
                finite = ("the field is" if controller is None else
                          "the field and the controller are")
                what = (f"the state became non-finite ({finite} finite at the step's start: a "
                        "stage or the update left the field's domain, or the step is beyond "
                        "the method's stable range)")
                status, fix = "non-finite", "Reduce step."
            err = SolverError(
                f"{scheme.name} failed at step {k + 1} of {n_total} (t = {t_k:.6g} -> "
                f"{t_k + h:.6g}, h = {h:.6g}) integrating {model.name}: {what}. {fix}",
                status=status,
            )
            err.state, err.time, err.step_index = x_k.copy(), t_k, k  # type: ignore[attr-defined]
            err.outputs = np.array(out)  # type: ignore[attr-defined]  # the states at t[:len]
            raise err
        # flat argmax: ~15 us per chunk of 512 steps (row-wise reductions take ~100 us)
        size, speed = np.abs(X), np.abs(np.diff(X, axis=0, prepend=x[None, :]))
        i, j = int(size.argmax()), int(speed.argmax())
        if size.flat[i] > largest[0]:
            i //= X.shape[1]
            largest = (float(size[i].max()), done + i + 1, X[i].copy())
        if speed.flat[j] > fastest[0]:
            j //= X.shape[1]
            fastest = (float(speed[j].max()), done + j, (x if j == 0 else X[j - 1]).copy())
        max_res = max(max_res, float(res.max()))
        its_total += int(its.sum())
        its_max = max(its_max, int(its.max()))
        # global step number done + j + 1 ends an output interval when divisible by n_sub
        idx = np.arange(n_sub - 1 - (done % n_sub), n, n_sub)
        out.extend(X[idx])
        x = X[-1].copy()
        done += n
    wall = time.perf_counter() - t_run

    xs = np.array(out)
    cost = IntegrationCost(
        wall_seconds=wall,
        setup_seconds=setup,
        steps=n_total,
        rhs_evaluations=scheme.evaluations_per_step * n_total,
        newton_iterations=its_total,
        seconds_per_step=wall / n_total,
    )
    diagnostics = {
        "newton": {
            "tol": scheme.newton_tol,
            "max_iter": scheme.newton_max_iter,
            "max_residual": max_res,
            "max_iterations_per_step": its_max,
            "mean_iterations_per_step": its_total / n_total,
        },
        "structure": dict(scheme.structure),
    }
    between = [(float(tv[0] + k * h), state, what) for (_, k, state), what in
               ((largest, "the largest state"), (fastest, "the start of the fastest step"))]
    return Integration(tv, xs, h, cost, diagnostics, between)
