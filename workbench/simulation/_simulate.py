"""Simulation with measured cost and accuracy.

:func:`simulate` integrates a model (optionally in closed loop with a controller given as
a casadi.Function of the state) with one of casadi's integrators, and returns a
:class:`Trajectory` that carries what it cost (wall time, build time, steps, right-hand
side evaluations) and how accurate it is by the measures that need no reference
solution: the drift of every invariant and the constraint residual of every manifold
factor. Knobs that trade speed for accuracy (``rtol``, ``atol``, ``step``, ``degree``)
are explicit keywords. A fixed-step run is checked before it is returned: a step beyond
the method's stable range, a state that explodes or a conserved invariant that drifts by
orders of magnitude raises a SolverError naming the step and the stable step estimated
for it (:mod:`workbench.simulation._stability`). A CVODES run is checked too
(:class:`~workbench.simulation._cvodes.RunCheck`): a state that explodes or leaves the
manifold, or (without a controller) an invariant that moves beyond what the tolerances
allow, raises a SolverError naming the time and the state; ``max_step`` bounds its
adaptive step, which can otherwise jump a feature of the field narrower than a step.
"""

from __future__ import annotations

import time
from enum import Enum
from typing import Any

import casadi as ca
import numpy as np

from workbench.codegen.functions import Compilation, CompileOptions
from workbench.core import validate
from workbench.core._evaluator import evaluate_rows
from workbench.core._feedback import feedback_function
from workbench.core._model import Model
from workbench.core.errors import ModelError, SolverError
from workbench.core.manifolds import DEFAULT_TOL
from workbench.core.types import ArrayLike
from workbench.core.validate import choice, count
from workbench.simulation._compiled_rhs import compiled_ode
from workbench.simulation._cvodes import (
    MAX_STEPS,
    Corrector,
    Multistep,
    RunCheck,
    check_max_step,
    check_max_steps,
    check_rtol,
    cvodes_options,
)
from workbench.simulation._failure import (
    REACH_STEPS,
    REACH_TRIES,
    casadi_non_finite,
    cvodes_reach,
    geometric_failure,
    kinetic_energy_error,
)
from workbench.simulation._intervals import Intervals
from workbench.simulation._stability import StepCheck, probe_for
from workbench.simulation._trajectory import Trajectory, constraint_residuals
from workbench.simulation._trajectory import diagnostics as _diagnostics
from workbench.simulation.integrators import (
    NEWTON_MAX_ITER,
    NEWTON_TOL,
    integrate,
    lgvi,
    mechanics_variational,
    rkmk4,
    s2_variational,
)
from workbench.simulation.integrators.common import (
    check_newton_options,
    check_step,
    field_failure,
    steps_per_interval,
)

__all__ = [
    "GEOMETRIC_METHODS",
    "Method",
    "Multistep",
    "Trajectory",
    "simulate",
    "closed_loop_function",
    "constraint_residuals",
]


class Method(str, Enum):
    """Integration methods of :func:`simulate`.

    Attributes
    ----------
    CVODES
        SUNDIALS CVODES (variable order BDF, adaptive step); knobs ``rtol``, ``atol``.
    RK
        Classical fixed-step Runge-Kutta of order 4 (casadi ``rk``); knob ``step``.
    COLLOCATION
        Fixed-step Legendre collocation of ``degree`` d (order 2d; casadi
        ``collocation``); knobs ``step``, ``degree``.
    LGVI
        Lie group variational integrator on TSO(3) (order 2, symplectic, implicit; Newton
        on the graph's derivatives) for rigid-body models such as the full 3D pendulum;
        knobs ``step``, ``newton_tol``, ``newton_max_iter``, ``jit``.
    S2_VARIATIONAL
        Variational integrator on S^2 (order 2, symplectic) for models on TS^2 such as the
        spherical pendulum; knobs ``step``, ``newton_tol``, ``newton_max_iter``, ``jit``.
    RKMK4
        Explicit Runge-Kutta-Munthe-Kaas Lie-group method of order 4 for any model on
        R^n, S1, S2, SO3 and TS2 factors; knobs ``step``, ``jit``.
    MECHANICS_VARIATIONAL
        Variational integrator (order 2, symmetric, symplectic and momentum-preserving
        when unforced; Cayley update on SO(3)) for any model made by
        :mod:`workbench.mechanics` with R^k, SO(3) and S^2 factors, from its Lagrangian;
        knobs ``step``, ``newton_tol``, ``newton_max_iter``, ``jit``.

    The last four are :mod:`workbench.simulation.integrators`; they keep the state on the manifold
    to round-off and report it in the trajectory's diagnostics.
    """

    CVODES = "cvodes"
    RK = "rk"
    COLLOCATION = "collocation"
    LGVI = "lgvi"
    S2_VARIATIONAL = "s2_variational"
    RKMK4 = "rkmk4"
    MECHANICS_VARIATIONAL = "mechanics_variational"


GEOMETRIC_METHODS = (Method.LGVI, Method.S2_VARIATIONAL, Method.RKMK4,
                     Method.MECHANICS_VARIATIONAL)
"""Methods implemented in :mod:`workbench.simulation.integrators` (fixed step, manifold kept)."""


STALL_GROWTH = 1e3
"""A CVODES run that stalls where the field has grown this many times over its value at
``x0`` has met a singularity of the equations (more steps do not pass it)."""

MAX_POINTS = 1_000_000
"""Default ``max_points`` of :func:`simulate`: the largest output grid accepted unasked."""


def _times(t: ArrayLike, max_points: int = MAX_POINTS) -> np.ndarray:
    n = int(np.size(t)) if validate.is_real_array_like(t) else 0
    if n > max_points:
        raise ModelError(
            f"t has {n} output times > max_points = {max_points} (about "
            f"{n * 8 / 1e6:.0f} MB per state entry, and every invariant is evaluated at "
            f"every time); pass a coarser t, or raise max_points= if you mean it")
    tv = validate.array("t (a 1-D array of output times)", t, finite=False, error=ModelError)
    if tv.ndim != 1:
        raise ModelError(f"t must be a 1-D array of output times; got shape {tv.shape}")
    if tv.size < 2:
        raise ModelError(f"t must hold at least two times (start and end); got {tv.size}")
    if not np.all(np.isfinite(tv)):
        raise ModelError("t must be finite")
    d = np.diff(tv)
    if not (np.all(d > 0) or np.all(d < 0)):
        raise ModelError(
            "t must be strictly increasing (forward) or strictly decreasing (backward); "
            f"got steps between {d.min():.3g} and {d.max():.3g}"
        )
    return tv


def closed_loop_function(model: Model, controller: ca.Function | None) -> ca.Function:
    """``(x, p) -> (xdot, u)`` of the model with the controller in the loop (or u = 0).

    Parameters
    ----------
    model : Model
        The plant.
    controller : casadi.Function or None
        ``u = k(x)`` or ``u = k(x, p)`` (``p`` the model's parameters), output of size
        ``model.n_inputs``.

    Returns
    -------
    casadi.Function
    """
    f = model.function("f")
    S = model.sym
    x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
    u = feedback_function(model, controller)(x, p)
    return ca.Function("closed_loop", [x, p], [f(x, u, p), u], ["x", "p"], ["xdot", "u"])


def simulate(
    model: Model,
    x0: ArrayLike,
    t: ArrayLike,
    *,
    controller: ca.Function | None = None,
    method: Method | str = Method.CVODES,
    rtol: float = 1e-10,
    atol: float = 1e-10,
    step: float | None = None,
    degree: int | None = None,
    multistep: Multistep | str = Multistep.ADAMS,
    corrector: Corrector | str | None = None,
    max_steps: int = 1_000_000,
    max_step: float | None = None,
    max_points: int = MAX_POINTS,
    tol: float = DEFAULT_TOL,
    newton_tol: float = NEWTON_TOL,
    newton_max_iter: int = NEWTON_MAX_ITER,
    jit: bool = False,
    compilation: Compilation | str = Compilation.NONE,
    compile_options: CompileOptions | None = None,
) -> Trajectory:
    """Integrate a model from ``x0`` and report the cost and the accuracy.

    Parameters
    ----------
    model : Model
        The model.
    x0 : array-like, shape=(ambient_dim,)
        Initial state; must lie on the model's manifold to ``tol`` (it is never
        projected here: call the factor's ``project`` explicitly if needed).
    t : array-like, shape=(n_times,)
        Output times, strictly increasing, or strictly decreasing for backward
        integration (the field is negated and integrated forward in ``-t``).
    controller : casadi.Function, optional
        Feedback ``u = k(x)`` or ``k(x, p)``; ``u = 0`` when omitted.
    method : Method or str
        ``"cvodes"``, ``"rk"``, ``"collocation"``, or a geometric method ``"lgvi"``,
        ``"s2_variational"``, ``"rkmk4"``, ``"mechanics_variational"`` (see
        :class:`Method`).
    rtol : float
        CVODES' relative tolerance (its local error per step, relative to the state), in
        ``(0, 1e-3]`` (:data:`~workbench.simulation._cvodes.RTOL_MAX`: SUNDIALS advises
        against more, and a relative tolerance of 1 or more accepts any answer).
    atol : float
        CVODES' absolute tolerance, positive and finite.
    step : float, optional
        Largest step for the fixed-step methods (required for them, refused for CVODES);
        each output interval is split into ``ceil(interval / step)`` equal steps.
    degree : int, optional
        Collocation degree (Legendre points), for ``"collocation"`` only (default 4).
    multistep : Multistep or str
        CVODES' multistep family, ``"adams"`` (non-stiff, default) or ``"bdf"`` (stiff).
    corrector : Corrector or str, optional
        CVODES' corrector iteration, ``"functional"`` (no Jacobian; default with Adams) or
        ``"newton"`` (default with BDF); see :class:`Corrector`. Adams with Newton, casadi's
        own default, is ``corrector="newton"``.
    max_steps : int
        CVODES' limit on internal steps per output interval, at most
        :data:`~workbench.simulation._cvodes.MAX_STEPS` (1e8: minutes for a small model);
        a long horizon between two output times may need more (the failure says so and
        names this knob).
    max_step : float, optional
        CVODES' largest internal step, positive and finite; None (default): unbounded. An
        adaptive step sees the field only at its stages: a feature of the field narrower
        than a step (a potential wall, a pulse of forcing) can be stepped over, with an
        error estimate of zero where the field is flat on both sides of it. Pass
        ``max_step`` below the feature's width. Refused when an output interval would need
        more than ``max_steps`` steps of it.
    max_points : int
        Largest accepted number of output times (default :data:`MAX_POINTS`, 10^6: the
        states alone take ``8 * ambient_dim`` bytes each, and the diagnostics evaluate
        every invariant at every output time); a longer grid is refused with its size
        unless this is raised.
    tol : float
        Largest accepted constraint residual of ``x0``.
    newton_tol : float
        Largest relative residual of the implicit update of ``"lgvi"``,
        ``"s2_variational"`` and ``"mechanics_variational"`` (a step that does not reach
        it raises SolverError).
    newton_max_iter : int
        Newton iterations per implicit update of those methods, at most
        :data:`~workbench.simulation.integrators.common.MAX_NEWTON_ITER` (50; they are
        unrolled into the step's graph); checked for every method before anything is built.
    jit : bool
        Compile the step of a geometric method to C (SX models; ~1 s once per process);
        refused for the casadi methods.
    compilation : Compilation or str
        For ``"cvodes"``, ``"rk"`` and ``"collocation"``: ``"c"`` compiles the closed-loop
        right-hand side (and its Jacobian) to C through the codegen cache
        (:func:`workbench.codegen.functions.compile_function`); the build cost is in
        ``cost["compile"]``. Refused for the geometric methods (they have ``jit``).
    compile_options : CompileOptions, optional
        Optimisation, compiler, cache and linear-solver replacement of that build.

    Returns
    -------
    Trajectory
        Its ``diagnostics`` hold, besides the invariant drift and constraint residuals,
        the checks it passed: ``stability`` for the fixed-step methods, ``checks`` for
        CVODES (``status``, ``conserved_invariants`` and ``non_increasing_invariants``
        checked, ``drift_allowance`` per checked invariant).

    Raises
    ------
    ModelError
        Bad input: an unknown ``method``, ``multistep`` or ``corrector`` (or a corrector
        given to a method other than CVODES), bad times, tolerances,
        ``max_steps``, ``step`` (the check of :func:`workbench.simulation.integrators.integrate`,
        raised as ModelError here) or ``degree``, a bad controller, or ``step``,
        ``degree`` or ``jit`` given to a method that does not use them.
    ParameterError
        ``newton_tol`` or ``newton_max_iter`` out of range.
    ManifoldError
        If ``x0`` is off the manifold.
    SolverError
        If the integrator fails (with its status), or an implicit update of a geometric
        method does not converge (with the step and its residual). A fixed-step run that
        is beyond its method's stable range (status ``unstable_step``: the step, the
        linearised estimate and the stable step estimated for it), whose conserved
        invariant drifts by orders of magnitude (``invariant_drift``), or whose field or
        controller returns NaN (``non_finite_field``: which, at which state and time) is
        never returned as a Trajectory; see :mod:`workbench.simulation._stability`. A
        CVODES run whose state exploded (``exploded``), left its manifold by more than
        the constraint's scale (``left_manifold``) or, without a controller, moved an
        invariant the field conserves (or raised one it dissipates) by more than ten
        times what ``rtol`` and ``atol`` allow over its steps, or more than the invariant's
        scale (``invariant_drift``), is refused with the time and the state; see
        :class:`~workbench.simulation._cvodes.RunCheck`. Only the output states are
        checked: a step across a narrow feature that lands where the invariant has its
        old value (a wall crossed between two outputs, at equal energy on both sides)
        is not seen; ``max_step`` below the feature's width is the remedy.
    """
    method = choice(Method, method, "method", error=ModelError)
    if not isinstance(model, Model):
        raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
    rtol = check_rtol(rtol, error=ModelError)
    for name, val in (("atol", atol), ("tol", tol)):
        validate.tolerance(name, val, error=ModelError)
    max_steps = check_max_steps(max_steps, error=ModelError)  # bounded before anything runs
    max_points = count("max_points", max_points, minimum=2, error=ModelError)
    _check_knobs_used(method, step=step, degree=degree, jit=jit, max_step=max_step)
    # unrolled into the step's graph: bounded before anything is built
    newton_tol, newton_max_iter = check_newton_options(newton_tol, newton_max_iter)
    compilation = choice(Compilation, compilation, "compilation", error=ModelError)
    if corrector is not None and method is not Method.CVODES:
        raise ModelError(f"corrector is CVODES' (method 'cvodes'); method {method.value!r} "
                         f"does not use it; got corrector={corrector!r}")
    if compilation is not Compilation.NONE and method in GEOMETRIC_METHODS:
        raise ModelError(f"method {method.value!r} does not use compilation="
                         f"{compilation.value!r} (it compiles its step with jit=True)")
    x0v = model.check_state(x0, name="x0", tol=tol)
    if getattr(model, "state_check", None) is not None:  # a mechanics model: T definite at x0
        model.state_check(model, x0v, what="x0")
    tv = _times(t, max_points)
    horizon = abs(tv[-1] - tv[0])
    opts: dict[str, Any] = {}
    options_used: dict[str, Any] = {}
    if method is Method.CVODES:
        # refused before anything runs when max_steps of it cannot cross an interval
        max_step = check_max_step(max_step, interval=float(np.max(np.abs(np.diff(tv)))),
                                  max_steps=max_steps, horizon=horizon, error=ModelError)
        opts.update(cvodes_options(multistep=multistep, corrector=corrector, rtol=rtol,
                                   atol=atol, max_steps=max_steps, max_step=max_step))
        options_used.update(rtol=rtol, atol=atol, multistep=opts["linear_multistep_method"],
                            corrector=opts["nonlinear_solver_iteration"], max_step=max_step)
    else:
        if step is None:
            raise ModelError(f"step must be a positive number for method {method.value!r}; "
                             f"got None")
        step = check_step(step, horizon, error=ModelError)
        dt_out = float(np.max(np.abs(np.diff(tv))))
        if not np.allclose(np.abs(np.diff(tv)), dt_out, rtol=1e-9, atol=0):
            raise ModelError(
                f"method {method.value!r} needs equally spaced output times t; got spacings "
                f"between {np.abs(np.diff(tv)).min():.6g} and {dt_out:.6g}"
            )
        n_fe = steps_per_interval(dt_out, step)
        opts["number_of_finite_elements"] = n_fe
        options_used.update(step=dt_out / n_fe, requested_step=step)
        if method is Method.COLLOCATION:
            degree = count("degree", 4 if degree is None else degree, maximum=9,
                           error=ModelError)  # casadi's collocation points: degree <= 9
            opts.update(interpolation_order=degree, collocation_scheme="legendre")
            options_used["degree"] = int(degree)

    if method in GEOMETRIC_METHODS:
        return _simulate_geometric(
            model, x0v, tv, controller=controller, method=method, step=float(step),
            options_used=options_used, newton_tol=newton_tol,
            newton_max_iter=newton_max_iter, jit=jit,
        )

    t_build = time.perf_counter()
    loop = closed_loop_function(model, controller)
    S = model.sym
    xs, ps = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
    sign = 1.0 if tv[-1] > tv[0] else -1.0
    ode = sign * loop(xs, ps)[0]
    compiled = None
    if compilation is Compilation.C:
        # casadi's CVODES interface builds the Jacobian function at init even for
        # functional iteration (without it: "Derivatives cannot be calculated"); RK never
        ode, compiled = compiled_ode(model, xs, ps, ode, compile_options,
                                     jacobian=method is not Method.RK,
                                     key=(model.function("f"), controller, sign))
        options_used["compilation"] = compilation.value
    s_grid = sign * (tv - tv[0])
    dae = {"x": xs, "p": ps, "ode": ode}
    p_in: np.ndarray = model.p
    if method is Method.CVODES:
        integrator = ca.integrator(f"sim_{model.name}", method.value, dae, 0.0, s_grid[1:],
                                   opts)
    else:
        # casadi spreads number_of_finite_elements over the whole output grid and rounds
        # per interval (one step per interval when it is below the number of outputs);
        # one interval repeated with mapaccum takes exactly n_fe steps in every interval.
        one = ca.integrator(f"sim_{model.name}_interval", method.value, dae, 0.0,
                            float(abs(s_grid[1])), opts)
        integrator = Intervals(one, len(tv) - 1)
    build_seconds = time.perf_counter() - t_build

    t_run = time.perf_counter()
    try:
        res = integrator(x0=x0v, p=p_in)
    except RuntimeError as exc:
        raise _integrator_failure(model, controller, method, integrator, exc, x0v, tv,
                                  opts, max_steps) from exc
    wall = time.perf_counter() - t_run
    stats = integrator.stats()
    xs_out = np.column_stack([x0v, np.asarray(res["xf"])]).T
    check: StepCheck | RunCheck
    if method is Method.CVODES:  # an exploded run, or one its error estimate missed, is refused
        check = RunCheck(model, probe_for(model, controller, sign=sign), opts,
                         int(stats.get("nsteps", 0)), controller is None)
    else:  # fixed step: an exploded run is refused
        check = StepCheck(model, probe_for(model, controller, sign=sign, rk4=method is Method.RK),
                          method.value, "rk" if method is Method.RK else None, False,
                          float(abs(s_grid[1])) / opts["number_of_finite_elements"])
    if not np.all(np.isfinite(xs_out)):
        raise casadi_non_finite(model, controller, check if isinstance(check, StepCheck) else
                                None, method.value, tv, xs_out)

    n_out = len(tv) - 1
    cost: dict[str, Any] = {"wall_seconds": wall, "build_seconds": build_seconds}
    if compiled is not None:
        cost["compile"] = {"generate_seconds": compiled.generate_seconds,
                           "compile_seconds": compiled.compile_seconds,
                           "cached": compiled.cached, "hash": compiled.hash,
                           "substitutions": list(compiled.substitutions)}
    if method is Method.CVODES:
        cost.update(steps=int(stats.get("nsteps", -1)), rhs_evaluations=int(stats["nfevals"]),
                    jacobian_evaluations=int(stats.get("n_call_jacF", 0)))
    elif method is Method.RK:
        steps = n_out * opts["number_of_finite_elements"]
        cost.update(steps=steps, rhs_evaluations=4 * steps)
    else:
        cost.update(steps=n_out * opts["number_of_finite_elements"], rhs_evaluations=None)

    xdot, u_out = evaluate_rows(loop, xs_out, model.p)
    rhs_ok = np.all(np.isfinite(xdot), axis=1)
    if not (np.all(rhs_ok) and np.all(np.isfinite(u_out))):
        # collocation's Newton step keeps the last state when the field turns NaN, without
        # an error: the trajectory would "stop" there and look like a result
        bad = int(np.argmin(rhs_ok & np.all(np.isfinite(u_out), axis=1)))
        why = field_failure(model, controller, xs_out[bad], float(tv[bad])) or \
            f"the field or the control is not finite at t = {tv[bad]:g}"
        raise SolverError(f"{method.value} integrating {model.name}: {why}; the states from "
                          f"t = {tv[bad]:g} on are not a solution", status="non_finite_field")
    traj = Trajectory(tv, xs_out, u_out, model, method, options_used, cost)
    diag = _diagnostics(traj, closed_loop=controller is not None)
    checks = (check.run(tv, xs_out, xdot, diag["invariant_drift"], diag["constraint_residual"])
              if isinstance(check, RunCheck) else
              check.run(tv, xs_out, xdot, diag["invariant_drift"]))
    traj.diagnostics = {**diag, **checks}
    return traj


def _check_knobs_used(method: Method, *, step: Any, degree: Any, jit: Any,
                      max_step: Any = None) -> None:
    """Refuse knobs that the method would silently ignore."""
    unused = []
    if step is not None and method is Method.CVODES:
        unused.append(f"step={step!r} (cvodes chooses its steps: set rtol, atol, and "
                      f"max_step to bound them)")
    if max_step is not None and method is not Method.CVODES:
        unused.append(f"max_step={max_step!r} (cvodes' bound on its adaptive step; the "
                      f"fixed-step methods take step=)")
    if degree is not None and method is not Method.COLLOCATION:
        unused.append(f"degree={degree!r} (the collocation degree)")
    if jit and method not in GEOMETRIC_METHODS:
        unused.append(f"jit={jit!r} (compiles the step of {[m.value for m in GEOMETRIC_METHODS]})")
    if unused:
        raise ModelError(
            f"method {method.value!r} does not use {', '.join(unused)}; drop it or choose a "
            f"method that uses it"
        )


def _simulate_geometric(
    model: Model,
    x0v: np.ndarray,
    tv: np.ndarray,
    *,
    controller: ca.Function | None,
    method: Method,
    step: float,
    options_used: dict[str, Any],
    newton_tol: float,
    newton_max_iter: int,
    jit: bool,
) -> Trajectory:
    """The branch of :func:`simulate` for :data:`GEOMETRIC_METHODS`."""
    t_build = time.perf_counter()
    if method is Method.RKMK4:
        scheme = rkmk4(model, controller, jit=jit)
    else:
        build = {Method.LGVI: lgvi, Method.S2_VARIATIONAL: s2_variational,
                 Method.MECHANICS_VARIATIONAL: mechanics_variational}[method]
        scheme = build(model, controller, newton_tol=newton_tol,
                       newton_max_iter=newton_max_iter, jit=jit)
        options_used.update(newton_tol=scheme.newton_tol,
                            newton_max_iter=scheme.newton_max_iter)
    options_used["jit"] = bool(jit)
    sign = 1.0 if tv[-1] > tv[0] else -1.0
    dt_out = abs(tv[1] - tv[0])
    check = StepCheck(model, probe_for(model, controller, sign=sign, step=scheme.step),
                      method.value, "rkmk4" if method is Method.RKMK4 else "variational", True,
                      sign * dt_out / steps_per_interval(dt_out, step))
    build_seconds = time.perf_counter() - t_build
    try:
        run = integrate(model, scheme, x0v, tv, step=step, controller=controller)
    except SolverError as err:
        raise geometric_failure(model, check, err, x0v, tv) from err
    options_used["step"] = abs(run.step)
    loop = closed_loop_function(model, controller)
    rhs_out, u_out = evaluate_rows(loop, run.x, model.p)
    cost = {"build_seconds": build_seconds, **run.cost}
    traj = Trajectory(tv, run.x, u_out, model, method, options_used, cost)
    diag = _diagnostics(traj, closed_loop=controller is not None)
    checks = check.run(tv, run.x, rhs_out, diag["invariant_drift"],
                       between=run.between)
    traj.diagnostics = {**diag, **run.diagnostics, **checks}
    return traj


def _integrator_failure(model: Model, controller: ca.Function | None, method: Method,
                        integrator: ca.Function | Intervals, exc: RuntimeError,
                        x0v: np.ndarray, tv: np.ndarray, opts: dict[str, Any],
                        max_steps: int) -> SolverError:
    """The SolverError for a casadi integrator that raised.

    For CVODES (casadi keeps nothing of a failed call) the last state it can reach is
    found (:func:`~workbench.simulation._failure.cvodes_reach`) when the model has a state
    check or CVODES ran out of steps: a kinetic energy that is not definite there is the
    cause; a field grown by orders of magnitude there is a singularity that more steps do
    not pass.
    """
    stats = integrator.stats()
    status = str(stats.get("return_status", "integrator error"))
    text = str(exc).splitlines()[-1] if str(exc) else repr(exc)
    out_of_steps = "too_much_work" in f"{status} {exc}".lower()
    reached = ""
    has_check = getattr(model, "state_check", None) is not None
    if method is Method.CVODES and (out_of_steps or has_check):
        t_r, x_r, stalled = cvodes_reach(model, controller, x0v, tv, opts)
        singular = kinetic_energy_error(model, method.value, x_r, np.array([t_r]),
                                        f"CVODES: {text.strip()}")
        if singular is not None:
            return singular
        loop = closed_loop_function(model, controller)
        f0, fr = (float(np.max(np.abs(np.asarray(loop(x, model.p)[0], dtype=float))))
                  for x in (x0v, x_r))
        x_text = np.array2string(x_r, precision=4, max_line_width=10_000)
        reached = (f"; restarted with {REACH_STEPS} steps at a time it gets no further than "
                   f"t = {t_r:.6g}, x = {x_text}" if stalled else
                   f"; restarted {REACH_TRIES} times with {REACH_STEPS} steps at a time it "
                   f"reaches t = {t_r:.6g}, x = {x_text}")
        if stalled and fr > STALL_GROWTH * max(f0, np.finfo(float).tiny):
            out_of_steps = False  # the advice to raise max_steps would not help
            reached += (f", where the field has grown to max |f| = {fr:.3g} from {f0:.3g} at "
                        f"x0: the steps shrink without end towards a singularity of the "
                        f"equations there, which more steps do not pass")
    elif float(stats.get("tcur", 0.0)) > 0:
        reached = f" (reached t = {tv[0] + np.sign(tv[-1] - tv[0]) * float(stats['tcur']):g})"
    raise_it = (f"raise max_steps= (now {max_steps}, at most {MAX_STEPS:.0e}) or "
                if max_steps < MAX_STEPS else "")
    knob = (f"; the integrator ran out of steps: {raise_it}output at more times t (the limit "
            f"is per output interval)" if out_of_steps else "")
    return SolverError(f"{method.value} failed integrating {model.name} from t = {tv[0]:g}: "
                       f"{text}{reached}{knob}", status=status)
