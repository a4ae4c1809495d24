"""Solving an OCP: one call, a solution with a status, its cost and its measured error.

:func:`solve` builds (once per problem, transcription, handling and graph; cached on the
:class:`~workbench.control.ocp.problem.OCP`) and solves the NLP with Ipopt, and returns an
:class:`OCPSolution` whose :class:`OCPStatus` carries a readable message with Ipopt's
return status, the iterations and the build and solve times. A failed solve raises
:class:`~workbench.core.errors.SolverError` (with the solution attached as ``.solution``)
unless ``raise_on_failure=False``. The accuracy is measured, not assumed:
:meth:`OCPSolution.resimulate` integrates the optimal piecewise-constant control open loop
with CVODES and reports the end-state error and the target residual.

Strategies for nonconvex problems (seeded starts, coarse-to-fine, homotopy) are in
:mod:`workbench.control.ocp.strategies`.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import casadi as ca
import numpy as np

from workbench.control.ocp.compiled import Compiled
from workbench.control.ocp.diagnose import (
    BOUND_RELAX,
    POLISH_RESIDUAL,
    diagnose,
    judge_constraints,
)
from workbench.control.ocp.guess import Guess, check_guess
from workbench.control.ocp.problem import OCP
from workbench.control.ocp.solution import OCPSolution, OCPStatus
from workbench.control.ocp.transcription import (
    Collocation,
    ManifoldHandling,
    Transcription,
    TranscriptionMethod,
    check_method,
)
from workbench.core import validate
from workbench.core._model import Symbolic
from workbench.core.errors import ParameterError, SolverError

__all__ = ["OCPStatus", "OCPSolution", "Settings", "settings", "solve", "solve_direct",
           "transcribe", "DEFAULT_HANDLING", "MANIFOLD_TOL"]


WARM_START = {"warm_start_init_point": "yes", "mu_init": 1e-6, "warm_start_bound_push": 1e-9,
              "warm_start_mult_bound_push": 1e-9, "warm_start_slack_bound_push": 1e-9}
"""Ipopt options added when a solution of the same transcription warm-starts a solve."""


DEFECT_TOL = 1e-2
"""Default ``defect_tol`` of :func:`solve`: the largest accepted local defect (relative to
``max(1, max |x|)``); a converged solve above it is INACCURATE, not SUCCESS."""


DEFAULT_HANDLING = ManifoldHandling.PROJECTED
"""The handling of a solve that names none: every node on the manifold, ambient cost."""

MANIFOLD_TOL = 1e-10
"""Default ``manifold_tol`` of :func:`solve`: the largest accepted constraint residual of the
nodes of a converged solve; above it the status is OFF_MANIFOLD, not SUCCESS."""

MANIFOLD_TOL_MIN = 1e-14
"""The smallest ``manifold_tol`` accepted: residuals below it are rounding errors."""


MUMPS_ORDERING = 5
"""MUMPS's fill-reducing ordering in Ipopt's default options (``mumps_pivot_order``: 5 METIS,
7 MUMPS's automatic choice); measured by ``benchmarks/bench_ocp_ordering.py``."""


@lru_cache(maxsize=64)
def _check_ipopt_options(items: str) -> None:
    """Let Ipopt itself read the options on a one-variable problem; ParameterError if not."""
    x = ca.SX.sym("x")
    try:
        ca.nlpsol("check", "ipopt", {"x": x, "f": x**2},
                  {"print_time": False, "ipopt": dict(json.loads(items))})
    except RuntimeError as exc:
        reason = str(exc).strip().splitlines()
        raise ParameterError(f"ipopt_options must be Ipopt options with valid values; got "
                             f"{items} (Ipopt: {' '.join(reason)[-300:]})") from exc


_IPOPT_INT_MAX = 2**31 - 1
"""Ipopt's integer options are C ints: a larger value would wrap (2**32 + 3 became 3)."""

_IPOPT_INTEGER_OPTIONS = frozenset({
    "max_iter", "max_soc", "max_refinement_steps", "min_refinement_steps", "acceptable_iter",
    "watchdog_shortened_iter_trigger", "watchdog_trial_iter_max", "max_resto_iter",
    "limited_memory_max_history", "limited_memory_max_skipping", "print_level",
    "file_print_level", "print_frequency_iter", "mumps_mem_percent", "mumps_pivot_order",
    "mumps_permuting_scaling", "mumps_scaling", "max_filter_resets", "filter_reset_trigger",
    "accept_after_max_steps", "soc_method", "num_linear_variables",
})
"""Integer options of Ipopt that casadi would truncate a float or a bool into."""


_IPOPT_TOLERANCES = frozenset({
    "tol", "constr_viol_tol", "dual_inf_tol", "compl_inf_tol", "acceptable_tol",
    "acceptable_constr_viol_tol", "acceptable_dual_inf_tol", "acceptable_compl_inf_tol",
})
"""Ipopt's termination tolerances: positive finite numbers (Ipopt takes NaN and 1e300)."""

def _check_ipopt_values(extra: dict[str, Any]) -> None:
    for k, v in extra.items():
        if v is None or isinstance(v, bool) or not isinstance(v, (str, int, float, np.integer,
                                                                   np.floating)):
            raise ParameterError(f"ipopt_options[{k!r}] must be a number or a string (Ipopt "
                                 f"has no booleans: 'yes'/'no'); got {v!r}")
        if k in _IPOPT_INTEGER_OPTIONS:  # a C int in Ipopt: a float would be truncated
            validate.count(f"ipopt_options[{k!r}]", v, minimum=0, maximum=_IPOPT_INT_MAX)
        elif k in _IPOPT_TOLERANCES:
            validate.tolerance(f"ipopt_options[{k!r}]", v)
        elif not isinstance(v, str) and np.isnan(v):  # no Ipopt option means anything by it
            raise ParameterError(f"ipopt_options[{k!r}] must be a number, not NaN; got {v!r}")


def _ipopt_options(tol: float, max_iter: int, print_level: int,
                   extra: dict[str, Any] | None) -> dict[str, Any]:
    tol = validate.tolerance("tol", tol)
    max_iter = validate.count("max_iter", max_iter, maximum=_IPOPT_INT_MAX)
    if extra is not None:
        if not isinstance(extra, dict) or not all(isinstance(k, str) for k in extra):
            raise ParameterError(f"ipopt_options must be a dict of Ipopt option names to "
                                 f"values; got {extra!r}")
        _check_ipopt_values(extra)
        try:
            _check_ipopt_options(json.dumps(sorted(extra.items())))
        except TypeError as exc:
            raise ParameterError(f"ipopt_options values must be numbers or strings; got "
                                 f"{extra!r}") from exc
    if isinstance(print_level, (bool, np.bool_)) or not isinstance(
            print_level, (int, np.integer)) or not 0 <= print_level <= 12:
        raise ParameterError(f"print_level must be an integer in [0, 12]; got {print_level!r}")
    opts = {"tol": tol, "max_iter": int(max_iter), "print_level": int(print_level),
            "sb": "yes", "mu_strategy": "adaptive", "mumps_pivot_order": MUMPS_ORDERING,
            "mumps_permuting_scaling": 0, "mumps_scaling": 0}
    opts.update(extra or {})
    return opts


def transcribe(ocp: OCP, method: TranscriptionMethod, *,
               handling: ManifoldHandling = DEFAULT_HANDLING,
               graph: Symbolic = Symbolic.SX, ipopt: dict[str, Any] | None = None,
               ) -> tuple[Transcription, bool]:
    """The transcription of ``ocp`` (built on first use, cached on the OCP).

    Parameters
    ----------
    ocp : OCP
        The problem.
    method : Collocation or MultipleShooting
        The transcription.
    handling : ManifoldHandling
        Manifold handling.
    graph : Symbolic
        SX or MX.
    ipopt : dict, optional
        Ipopt options of the first solver (others are created on demand, sharing the
        generated derivatives).

    Returns
    -------
    (Transcription, bool)
        The transcription and whether it was built by this call.
    """
    check_method(method)
    key = (method, handling, graph, bool(ocp.gauge and ocp.symmetry is not None),
           ocp.model.spd_solves)  # how the SX replay writes the model's solves
    if key in ocp._cache:
        return ocp._cache[key], False
    tr = Transcription(ocp, method, handling, graph, ipopt or _ipopt_options(1e-8, 1000, 0, None))
    ocp._cache[key] = tr
    return tr, True


@dataclass(frozen=True)
class Settings:
    """The numeric settings of one solve, validated once (passed between attempts).

    Attributes
    ----------
    ipopt : dict
        Ipopt's options (validated).
    user_ipopt : bool
        Whether the caller gave Ipopt options (then no warm-start options are added).
    defect_tol : float or None
        See :func:`solve`.
    manifold_tol : float or None
        See :func:`solve`.
    compiled : Compiled or None
        See :func:`solve`.
    tol : float
        :func:`solve`'s ``tol``: Ipopt's tolerance unless ``ipopt_options`` names another,
        and the largest accepted constraint violation of a converged solve either way.
    """

    ipopt: dict[str, Any]
    user_ipopt: bool
    defect_tol: float | None
    manifold_tol: float | None
    compiled: Compiled | None
    tol: float

    def replace(self, **changes: Any) -> Settings:
        """A copy with some fields changed (``max_iter=`` changes Ipopt's limit)."""
        ipopt = dict(self.ipopt)
        if "max_iter" in changes:
            ipopt["max_iter"] = int(changes.pop("max_iter"))
        return Settings(**{**self.__dict__, "ipopt": ipopt, **changes})


def settings(*, tol: float = 1e-8, max_iter: int = 1000, print_level: int = 0,
             ipopt_options: dict[str, Any] | None = None,
             defect_tol: float | None = DEFECT_TOL,
             manifold_tol: float | None = MANIFOLD_TOL,
             compiled: Compiled | None = None) -> Settings:
    """Validate :func:`solve`'s numeric options into a :class:`Settings`."""
    opts = _ipopt_options(tol, max_iter, print_level, ipopt_options)
    if defect_tol is not None:
        defect_tol = validate.tolerance("defect_tol", defect_tol)
    if manifold_tol is not None:
        manifold_tol = validate.tolerance("manifold_tol", manifold_tol)
        if manifold_tol < MANIFOLD_TOL_MIN:
            raise ParameterError(
                f"manifold_tol must be at least {MANIFOLD_TOL_MIN:g}: the nodes' residuals "
                f"are computed in double precision (|q|^2 - 1, R^T R - I: rounding errors of "
                f"a few 1e-16); got {manifold_tol!r}")
    if compiled is not None and not isinstance(compiled, Compiled):
        raise ParameterError(f"compiled must be a Compiled(...) or None; got {compiled!r}")
    return Settings(opts, ipopt_options is not None, defect_tol, manifold_tol, compiled,
                    validate.tolerance("tol", tol))


@validate.arguments(ocp=validate.instance(OCP, "an OCP"))
def solve(
    ocp: OCP,
    method: TranscriptionMethod | None = None,
    *,
    handling: ManifoldHandling | None = None,
    graph: Symbolic = Symbolic.SX,
    guess: Guess | OCPSolution | None = None,
    strategy: Any = None,
    tol: float = 1e-8,
    max_iter: int = 1000,
    print_level: int = 0,
    ipopt_options: dict[str, Any] | None = None,
    raise_on_failure: bool = True,
    defect_tol: float | None = DEFECT_TOL,
    manifold_tol: float | None = MANIFOLD_TOL,
    compiled: Compiled | None = None,
) -> OCPSolution:
    """Transcribe and solve an OCP with Ipopt (exact Hessian).

    With no guess, no handling and no strategy, the default strategy
    (:class:`~workbench.control.ocp.auto.Auto`) builds its initial guesses from the model
    and the OCP (the directions the inputs drive, energy-pumping swings), solves each in
    an ambient relaxation polished on the manifold, and falls back on continuation in the
    input bound, the terminal condition and from a coarser transcription; the solution
    records every attempt (:attr:`OCPSolution.attempts`). Each of its solves stops after
    ``Auto(attempt_max_iter=300)`` iterations (``max_iter`` here caps it). ``strategy=Direct()``
    makes one solve.

    Parameters
    ----------
    ocp : OCP
        The problem.
    method : Collocation, MultipleShooting or HermiteSimpson, optional
        The transcription (default ``Collocation(N=40, degree=3)``).
    handling : ManifoldHandling, optional
        ``PROJECTED`` (the default: ambient intervals, nodes projected onto the manifold),
        ``LIE_GROUP`` (local exponential coordinates) or ``AMBIENT`` (nodes free in the
        ambient space: on the manifold at convergence only for Gauss-Legendre collocation of
        fields that conserve its quadratic constraints); see
        :mod:`workbench.control.ocp.transcription`. The default strategy uses ``AMBIENT``
        as a relaxation before its on-manifold solve.
    graph : Symbolic
        ``SX`` (scalar graph, fastest) or ``MX``.
    guess : Guess or OCPSolution, optional
        Initial guess; a solution of the *same* transcription also warm-starts the
        multipliers. Default: the strategy's structured guesses (``Direct``:
        :meth:`Guess.geodesic`). The guess vector is moved into the variable bounds before
        the solve (as Ipopt would); the problem's data are never changed.
    strategy : Auto or Direct, optional
        How to solve: ``Auto()`` (default) or ``Direct()`` (one Ipopt solve from the guess).
    tol : float
        Ipopt's tolerance (unless ``ipopt_options`` names another ``"tol"``), and the
        largest accepted constraint violation of a converged solve whatever Ipopt's own
        tolerances are: a solve that Ipopt reports converged (SUCCESS or ACCEPTABLE) whose
        point violates an NLP constraint (dynamics, terminal condition, path constraint,
        measured unscaled against its bounds) by more than ``tol max(1, |bound|, max |x|)``
        (inequalities and the variables' bounds: also by Ipopt's bound relaxation
        ``r max(1, |bound|)``, ``r`` its ``bound_relax_factor`` up to its default
        :data:`BOUND_RELAX`, 1e-8: a control may exceed its bound by that much, reported in
        ``error["bound_violation"]``) is CONSTRAINTS_VIOLATED, with the numbers in its
        message.
    max_iter : int
        Ipopt's iteration limit of each attempt (the default strategy's own limits,
        ``Auto(attempt_max_iter=300, relax_max_iter=300)``, apply where smaller).
    print_level : int
        Ipopt's print level (0 = quiet).
    ipopt_options : dict, optional
        Further Ipopt options.
    raise_on_failure : bool
        Raise :class:`SolverError` unless the status is SUCCESS or ACCEPTABLE.
    defect_tol : float or None
        Largest accepted ``error["local_defect"]`` of a converged solve, relative to
        ``max(1, max |x|)`` over the nodes; above it the status is INACCURATE (a too
        coarse transcription, e.g. a long horizon on few intervals, can converge to an NLP
        solution that is no trajectory of the model) and, with ``raise_on_failure``, a
        SolverError quotes the measured defect. On by default (:data:`DEFECT_TOL`);
        ``None`` explicitly asks for a report only.
    manifold_tol : float or None
        Largest accepted manifold residual of the nodes a converged solve chose (nodes 1
        to N; node 0 is ``x0``, whose residual is ``error["x0_manifold_residual"]``; default
        :data:`MANIFOLD_TOL` = 1e-10); above it the status is OFF_MANIFOLD. ``None`` asks
        for a report only.
    compiled : Compiled, optional
        Compile the NLP's functions with the system compiler, cached by hash (see
        :mod:`workbench.control.ocp.compiled`): faster iterations for a one-off build.
        ``cost["compile"]`` reports generation, compilation and loading seconds.

    Returns
    -------
    OCPSolution

    Raises
    ------
    SolverError
        If no attempt converged and ``raise_on_failure``; ``.solution`` holds the result,
        whose message gives the diagnosis (infeasibilities, manifold residual, the worst
        constraint and its knot, what to try next).
    """
    from workbench.control.ocp.auto import Auto, Direct

    method = check_method(method or Collocation())
    if handling is not None and not isinstance(handling, ManifoldHandling):
        raise ParameterError(f"handling must be a ManifoldHandling or None; got {handling!r}")
    check_guess(guess, ocp, OCPSolution)  # an array, or a guess of another problem
    if not isinstance(raise_on_failure, (bool, np.bool_)):  # "no" would be truthy
        raise ParameterError(f"raise_on_failure must be True or False; got "
                             f"{raise_on_failure!r}")
    strategy = Auto() if strategy is None else strategy
    if not isinstance(strategy, (Auto, Direct)):
        raise ParameterError(f"strategy must be Auto(...) or Direct(); got {strategy!r}")
    conf = settings(tol=tol, max_iter=max_iter, print_level=print_level,
                    ipopt_options=ipopt_options, defect_tol=defect_tol,
                    manifold_tol=manifold_tol, compiled=compiled)
    out = strategy.run(ocp, method, handling=handling, graph=graph, guess=guess,
                       settings=conf)
    if raise_on_failure and not out.status.ok:
        err = SolverError(f"OCP {ocp.name!r}: {out.message}", status=out.ipopt_status)
        err.solution = out  # type: ignore[attr-defined]
        raise err
    return out


def solve_direct(ocp: OCP, method: TranscriptionMethod, handling: ManifoldHandling,
                 graph: Symbolic, guess: Guess | OCPSolution | None, conf: Settings, *,
                 terminal_slack: float = 0.0) -> OCPSolution:
    """One Ipopt solve (never raises on a solver failure): the ``Direct`` strategy.

    ``terminal_slack`` relaxes the terminal equations to ``|chart| <= slack`` (data of the
    NLP: no rebuild), for the strategies' continuation in the terminal condition.
    """
    tr, built = transcribe(ocp, method, handling=handling, graph=graph, ipopt=conf.ipopt)
    opts = conf.ipopt
    args, opts = _start(tr, ocp, guess, opts, warm_options=not conf.user_ipopt)
    if terminal_slack:
        rows = tr.g_kinds == "terminal"
        args["lbg"][rows], args["ubg"][rows] = -terminal_slack, terminal_slack
    out = _run(tr, ocp, built, args, opts, conf.compiled)
    if tr.i_gauge is not None and out.status.ok:
        out, tr, args = _check_gauge(out, tr, args, opts, not conf.user_ipopt, conf.compiled)
    if out.status.ok and conf.manifold_tol is not None and \
            not out.error["manifold_residual"] <= conf.manifold_tol:
        out = _polish(out, tr, args, opts, conf)
    limit = None
    if out.status.ok:  # Ipopt's word, held to solve's tol (ipopt_options may loosen Ipopt's)
        relax = min(float(opts.get("bound_relax_factor", BOUND_RELAX)), BOUND_RELAX)
        limit = judge_constraints(out, args, tol=conf.tol, relax=relax)
    if out.status.ok:
        ocp.check_states(out.x, out.t, what="the solution's nodes")  # mechanics: T definite
        out.error["local_defect"] = _local_defect(out)
        limit = (None if conf.defect_tol is None else
                 validate.scaled_tolerance(conf.defect_tol, float(np.max(np.abs(out.x)))))
        if limit is not None:
            out.error["defect_limit"] = limit
            if not out.error["local_defect"] <= limit:
                out.status = OCPStatus.INACCURATE
    if not out.status.ok:
        out.diagnosis = diagnose(out, tr, args, tol=float(opts["tol"]) if limit is None
                                 else min(float(opts["tol"]), limit))
    return out


def _polish(out: OCPSolution, tr: Transcription, args: dict[str, Any], opts: dict[str, Any],
            conf: Settings) -> OCPSolution:
    """Meet ``manifold_tol`` on the nodes, or report OFF_MANIFOLD.

    With ``PROJECTED`` or ``LIE_GROUP`` handling the nodes are on the manifold exactly where
    the continuity constraints hold, so a residual above ``manifold_tol`` is the constraints'
    own final violation: one warm-started re-solve with Ipopt's ``constr_viol_tol`` at
    ``manifold_tol / 10`` removes it (usually in one or two iterations; recorded in
    ``cost["polish_iterations"]``). With ``AMBIENT`` handling the nodes are free in the
    ambient space and the residual is the scheme's: the status is OFF_MANIFOLD.
    """
    res = out.error["manifold_residual"]
    if tr.handling is not ManifoldHandling.AMBIENT and res <= POLISH_RESIDUAL:
        tight = {**WARM_START, **opts} if not conf.user_ipopt else dict(opts)
        tight["constr_viol_tol"] = conf.manifold_tol / 10
        again = _run(tr, out.ocp, False, {**args, "x0": out.w, "lam_x0": out.lam_x,
                                          "lam_g0": out.lam_g}, tight, conf.compiled)
        again.gauge = out.gauge
        again.cost["polish_iterations"] = again.cost["iterations"]
        for key in ("iterations", "solve_seconds", "solve_cpu_seconds"):
            again.cost[key] += out.cost[key]
        for key in ("build_seconds", "transcription_cached", "iterations_gauged"):
            if key in out.cost:
                again.cost[key] = out.cost[key]
        if "gauge_multiplier" in out.error:
            again.error["gauge_multiplier"] = out.error["gauge_multiplier"]
        if again.status.ok and again.error["manifold_residual"] <= conf.manifold_tol:
            return again
        out = again if again.status.ok else out
    out.status = OCPStatus.OFF_MANIFOLD
    out.error["manifold_limit"] = conf.manifold_tol
    return out


GAUGE_BINDING = 1e-6
"""Largest ``|multiplier|`` of the phase condition read as "only picks one optimum"."""


def _start(tr: Transcription, ocp: OCP, guess: Guess | OCPSolution | None,
           opts: dict[str, Any], *, warm_options: bool) -> tuple[dict[str, Any], dict]:
    """Solver arguments: bounds, parameters (with the gauge), start point."""
    lbw, ubw = tr.bounds(ocp)
    args: dict[str, Any] = {"lbx": lbw, "ubx": ubw, "lbg": tr.lbg.copy(),
                            "ubg": tr.ubg.copy()}
    if isinstance(guess, OCPSolution) and _same_layout(guess, tr):
        args["x0"] = guess.w
        if len(guess.lam_g) == tr.ng:
            # primal-dual warm start: start close to the central path, not at mu = 0.1
            opts = {**WARM_START, **opts} if warm_options else opts
            args.update(lam_x0=guess.lam_x, lam_g0=guess.lam_g)
    else:
        if isinstance(guess, OCPSolution):
            guess = guess.guess()
        g = guess if guess is not None else Guess.geodesic(ocp)
        u = g.node_controls(tr.N) if tr.foh else g.controls(tr.N)
        args["x0"] = tr.pack(g.state, u, g.T)
    args["x0"] = np.clip(args["x0"], lbw, ubw)
    args["p"] = ocp.model.p
    if tr.i_gauge is not None:
        c = tr.gauge_direction(args["x0"])
        args["p"] = np.r_[ocp.model.p, c]
        args["lbg"][tr.i_gauge] = args["ubg"][tr.i_gauge] = float(c @ args["x0"])
    return args, opts


_AMBIENT_LAYOUT = frozenset({ManifoldHandling.AMBIENT, ManifoldHandling.PROJECTED})
"""Handlings with the same NLP variables and constraints (a solution of one starts the other)."""


def _same_layout(sol: OCPSolution, tr: Transcription) -> bool:
    """Whether ``sol``'s primal (and dual) vector is a point of ``tr``'s NLP."""
    same = sol.handling is tr.handling or {sol.handling, tr.handling} <= _AMBIENT_LAYOUT
    return (same and sol.method == tr.method and sol.graph is tr.graph
            and len(sol.w) == tr.nw)


def _run(tr: Transcription, ocp: OCP, built: bool, args: dict[str, Any],
         opts: dict[str, Any], compiled: Compiled | None = None) -> OCPSolution:
    """One Ipopt solve of ``ocp`` (``tr``'s problem or one sharing its graph), timed."""
    solver = tr.solver(opts, compiled)
    t0, c0 = time.perf_counter(), time.process_time()
    sol = solver(**args)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    stats = solver.stats()
    ipopt_status = str(stats.get("return_status", "unknown"))
    w = np.asarray(sol["x"], float).ravel()
    X, U, T = tr.unpack(w)
    gval = np.asarray(sol["g"], float).ravel()
    viol = np.maximum(np.maximum(args["lbg"] - gval, gval - args["ubg"]), 0.0)
    man = ocp.model.manifold
    cost = {
        "build_seconds": tr.build_seconds if built else 0.0,
        "transcription_cached": not built,
        "first_build_seconds": tr.build_seconds,
        "solve_seconds": seconds,
        "solve_cpu_seconds": cpu,
        "hessian_seconds": float(stats.get("t_wall_nlp_hess_l", float("nan"))),
        "jacobian_seconds": float(stats.get("t_wall_nlp_jac_g", float("nan"))),
        "iterations": int(stats.get("iter_count", -1)),
        "nlp_variables": tr.nw,
        "nlp_constraints": tr.ng,
        "compile": tr.compile_info.get(compiled) if compiled is not None else None,
    }
    trace = stats.get("iterations") or {}
    for key in ("inf_pr", "inf_du"):  # the last iterate's infeasibilities (for diagnoses)
        cost[f"last_{key}"] = float(trace[key][-1]) if trace.get(key) else None
    residuals = [max(man.residual_norms(r).values()) for r in X]
    bounds = np.maximum(np.maximum(args["lbx"] - w, w - args["ubx"]), 0.0)
    error = {
        "constraint_violation": float(viol.max(initial=0.0)),
        # Ipopt relaxes bounds (bound_relax_factor): u may exceed its bound by 1e-8 |bound|
        "bound_violation": float(bounds.max(initial=0.0)),
        # the nodes the solve chose (node 0 is x0, fixed: its residual is the caller's)
        "manifold_residual": float(max(residuals[1:])),
        "x0_manifold_residual": float(residuals[0]),
        "target_residual": ocp.target.distance(X[-1]),
    }
    sym = ocp.symmetry
    gauge = "none found" if sym is None else (
        f"{sym.describe()}, not gauged (gauge=False)" if tr.i_gauge is None else
        f"{sym.describe()}, gauged by the phase condition through the guess")
    return OCPSolution(
        status=OCPStatus.from_ipopt(ipopt_status), ipopt_status=ipopt_status,
        objective=float(sol["f"]), T=T, t=tr.times(T), x=X, u=U, method=tr.method,
        handling=tr.handling, graph=tr.graph, cost=cost, error=error, ocp=ocp, w=w,
        lam_x=np.asarray(sol["lam_x"], float).ravel(),
        lam_g=np.asarray(sol["lam_g"], float).ravel(), gauge=gauge, g=gval,
    )


def _check_gauge(out: OCPSolution, tr: Transcription, args: dict[str, Any],
                 opts: dict[str, Any], warm_options: bool, compiled: Compiled | None
                 ) -> tuple[OCPSolution, Transcription, dict[str, Any]]:
    """Read the phase condition's multiplier; if it binds, re-solve without the gauge.

    The gauge only selects one optimum of a circle when the problem is symmetric along the
    solution (multiplier zero). Control bounds are not rotation invariant: where they are
    active the gauge can bind, and the gauged optimum is not one of the problem as posed.
    Returns the solution with the transcription and the solver arguments it was solved with
    (the ungauged ones after a re-solve; the solution's ``ocp`` stays the problem as posed).
    """
    lam = float(out.lam_g[tr.i_gauge])
    out.error["gauge_multiplier"] = lam
    if not np.any(args["p"][out.ocp.model.n_params:]):
        out.gauge = (f"{tr.symmetry.describe()}; not gauged: the guess is invariant (no "
                     f"phase condition through it)")
        return out, tr, args
    if abs(lam) <= GAUGE_BINDING * max(1.0, abs(out.objective)):
        out.gauge += f" (multiplier {lam:.1e}: not binding)"
        return out, tr, args
    free = out.ocp.with_bounds(gauge=False)
    tr2, built = transcribe(free, tr.method, handling=tr.handling, graph=tr.graph)
    lbw, ubw = tr2.bounds(free)
    keep = np.arange(tr.ng) != tr.i_gauge
    # the rows of the ungauged NLP are the gauged one's without the gauge: their bounds are
    # the solve's own (a terminal slack of the continuation is kept)
    args = {"lbx": lbw, "ubx": ubw, "lbg": args["lbg"][keep], "ubg": args["ubg"][keep],
            "p": free.model.p, "x0": out.w, "lam_x0": out.lam_x, "lam_g0": out.lam_g[keep]}
    again = _run(tr2, free, built, args, {**WARM_START, **opts} if warm_options else opts,
                 compiled)
    again.cost["iterations_gauged"] = out.cost["iterations"]
    again.cost["iterations"] += out.cost["iterations"]
    again.cost["solve_seconds"] += out.cost["solve_seconds"]
    again.cost["solve_cpu_seconds"] += out.cost["solve_cpu_seconds"]
    again.error["gauge_multiplier"] = lam
    again.gauge = (f"{tr.symmetry.describe()}; the gauge bound (multiplier {lam:.2e}: the "
                   f"control bounds break the symmetry here), so the gauged solution "
                   f"(cost {out.objective:.6g}) was re-solved without it")
    again.ocp = out.ocp  # the problem as posed (the ungauged copy shares its builds)
    return again, tr2, args


def _local_defect(sol: OCPSolution) -> float:
    """Max over intervals of ``|Phi_h(x_k, u_k) - x_(k+1)|`` (CVODES, rtol 1e-10)."""
    from workbench.control.ocp.stepper import Stepper

    key = ("local_defect_stepper", 1e-10)  # one CVODES build per problem, not per solve
    if key not in sol.ocp._cache:
        sol.ocp._cache[key] = Stepper(sol.ocp.model, rtol=1e-10, atol=1e-10)
    stepper = sol.ocp._cache[key]
    h = sol.T / (len(sol.x) - 1)
    try:
        return max(float(np.max(np.abs(stepper.step(x, u, h, u_end=u1) - xn)))
                   for x, (u, u1), xn in zip(sol.x[:-1], sol.interval_inputs(), sol.x[1:]))
    except SolverError:  # the nodes are not even integrable: no trajectory at all
        return float("inf")
