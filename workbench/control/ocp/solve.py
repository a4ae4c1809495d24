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
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import casadi as ca
import numpy as np

from workbench.control.ocp.compiled import Compiled
from workbench.control.ocp.guess import Guess, check_guess
from workbench.control.ocp.problem import OCP
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
from workbench.core.status import StatusEnum, StatusResult

__all__ = ["OCPStatus", "OCPSolution", "solve", "transcribe"]


class OCPStatus(StatusEnum):
    """Outcome of a solve; the value is the readable part of the message."""

    SUCCESS = "solved to the requested tolerance"
    ACCEPTABLE = "solved to Ipopt's acceptable tolerance only"
    INFEASIBLE = ("locally infeasible: Ipopt stopped at a local minimum of the constraint "
                  "violation (there may be no feasible point, or none near this guess)")
    MAX_ITERATIONS = "the iteration limit was reached before convergence"
    FAILED = "Ipopt failed"
    INACCURATE = ("Ipopt converged, but the transcribed trajectory does not follow the "
                  "dynamics to defect_tol (local defect against CVODES on each interval)")

    @classmethod
    def from_ipopt(cls, status: str) -> OCPStatus:
        """Map Ipopt's return status string to a status."""
        return {
            "Solve_Succeeded": cls.SUCCESS,
            "Solved_To_Acceptable_Level": cls.ACCEPTABLE,
            "Infeasible_Problem_Detected": cls.INFEASIBLE,
            "Maximum_Iterations_Exceeded": cls.MAX_ITERATIONS,
            "Maximum_CpuTime_Exceeded": cls.MAX_ITERATIONS,
            "Maximum_WallTime_Exceeded": cls.MAX_ITERATIONS,
        }.get(status, cls.FAILED)

    @classmethod
    def successes(cls) -> frozenset[str]:
        """The usable outcomes (converged): SUCCESS and ACCEPTABLE."""
        return frozenset({"SUCCESS", "ACCEPTABLE"})


@dataclass
class OCPSolution(StatusResult):
    """A solved (or failed) OCP.

    Attributes
    ----------
    status : OCPStatus
        Outcome.
    ipopt_status : str
        Ipopt's own return status.
    objective : float
        Optimal cost.
    T : float
        Final time.
    t : ndarray, shape=(N+1,)
        Node times.
    x : ndarray, shape=(N+1, ambient_dim)
        Node states.
    u : ndarray, shape=(N, n_inputs) or (N+1, n_inputs)
        Piecewise-constant control, or the knot values of a first-order hold
        (:class:`~workbench.control.ocp.hermite_simpson.HermiteSimpson`: linear in between).
    method : Collocation, MultipleShooting or HermiteSimpson
        The transcription.
    handling : ManifoldHandling
        Manifold handling.
    graph : Symbolic
        SX or MX.
    cost : dict
        ``build_seconds`` (0 when the transcription was cached), ``transcription_cached``
        (whether this solve reused an earlier build), ``first_build_seconds``,
        ``solve_seconds``, ``solve_cpu_seconds``, ``iterations``, ``nlp_variables``,
        ``nlp_constraints``.
    error : dict
        ``constraint_violation`` (max over the NLP's constraints, from their bounds),
        ``manifold_residual`` (max over the nodes), ``target_residual``,
        ``local_defect`` (converged solves: max over the intervals of
        ``|Phi_h(x_k, u_k) - x_(k+1)|``, the node ``x_k`` integrated over the interval
        with its control by CVODES, rtol 1e-10: how far the transcribed trajectory is
        from one of the model, independent of the open-loop growth of errors); after
        :meth:`resimulate`, also ``resim_end_error``, ``resim_target_residual``.
    ocp : OCP
        The problem.
    w, lam_x, lam_g : ndarray
        Primal and dual NLP solution (for warm starts).
    gauge : str
        How a continuous symmetry of the problem was handled: ``"none"`` (no symmetry
        found), the symmetry and its phase condition with the condition's multiplier (zero
        when the gauge only picks one optimum of a circle), or why it was not used.
    """

    status: OCPStatus
    ipopt_status: str
    objective: float
    T: float
    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    method: TranscriptionMethod
    handling: ManifoldHandling
    graph: Symbolic
    cost: dict[str, Any]
    error: dict[str, Any]
    ocp: OCP
    w: np.ndarray = field(repr=False)
    lam_x: np.ndarray = field(repr=False)
    lam_g: np.ndarray = field(repr=False)
    gauge: str = "none"

    @property
    def first_order_hold(self) -> bool:
        """Whether :attr:`u` holds knot values, linear in between."""
        return len(self.u) == len(self.x)

    def interval_inputs(self) -> list[tuple[np.ndarray, np.ndarray | None]]:
        """Per interval: ``(u, None)`` (constant) or ``(u_k, u_(k+1))`` (linear)."""
        if self.first_order_hold:
            return list(zip(self.u[:-1], self.u[1:]))
        return [(u, None) for u in self.u]

    @property
    def message(self) -> str:
        """One readable line: status, Ipopt's status, iterations, times, cost."""
        c = self.cost
        defect = (f", local defect {self.error['local_defect']:.1e}"
                  if "local_defect" in self.error else "")
        return (
            f"{self.status.name}: {self.status.value}; Ipopt returned {self.ipopt_status} "
            f"after {c['iterations']} iterations (solve {c['solve_seconds']:.3f} s, build "
            f"{c['first_build_seconds']:.3f} s); cost {self.objective:.6g}, T = {self.T:.4g} s"
            f"{defect}; symmetry: {self.gauge} [{self.describe()}]"
        )

    def __str__(self) -> str:
        """The one-line :attr:`message` (status, iterations, times, cost, defect)."""
        return f"OCPSolution of {self.ocp.name}: {self.message}"

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"

    def describe(self) -> str:
        """Transcription, handling and graph in words."""
        return f"{self.method.describe()}, {self.handling.value}, {self.graph.value.upper()}"

    def guess(self) -> Guess:
        """Return the solution as a guess (for warm-starting another transcription)."""
        return Guess.from_solution(self)

    def control(self, t: float) -> np.ndarray:
        """The optimal control at time ``t`` in ``[0, T]`` (piecewise constant, or linear).

        Raises
        ------
        ParameterError
            ``t`` not a finite number in ``[0, T]`` (it is never clamped).
        """
        t = validate.real("t", t)
        if not 0.0 <= t <= self.T * (1 + 1e-12):
            raise ParameterError(f"t must be in [0, T] = [0, {self.T:g}]; got {t!r}")
        if self.first_order_hold:
            return np.array([np.interp(t, self.t, uj) for uj in self.u.T])
        k = int(np.clip(np.floor(t / self.T * len(self.u)), 0, len(self.u) - 1))
        return self.u[k]

    def resimulate(self, *, rtol: float = 1e-10, atol: float = 1e-10,
                   substeps: int = 1) -> dict[str, Any]:
        """Integrate the optimal control open loop with CVODES and measure the error.

        Parameters
        ----------
        rtol, atol : float
            CVODES tolerances.
        substeps : int
            Output samples per interval (for figures).

        Returns
        -------
        dict
            ``t``, ``x`` (the re-simulated samples), ``end_error`` (max-norm of the ambient
            difference between the re-simulated and the transcribed final state),
            ``target_residual`` (of the re-simulated final state), ``max_node_error``,
            ``manifold_residual`` (of the re-simulation), ``seconds``. The first three are
            also stored in :attr:`error`.
        """
        from workbench.control.ocp.stepper import Stepper

        substeps = validate.count("substeps", substeps, maximum=validate.MAX_DIM)
        stepper = Stepper(self.ocp.model, rtol=rtol, atol=atol)
        t0 = time.perf_counter()
        h = self.T / (len(self.x) - 1)
        xs, ts = [self.x[0]], [0.0]
        x = self.x[0]
        node_err = 0.0
        for k, (uk, uk1) in enumerate(self.interval_inputs()):
            for j in range(substeps):
                a, b = j / substeps, (j + 1) / substeps
                u0 = uk if uk1 is None else (1 - a) * uk + a * uk1
                u1 = None if uk1 is None else (1 - b) * uk + b * uk1
                x = stepper.step(x, u0, h / substeps, u_end=u1)
                xs.append(x)
                ts.append(k * h + (j + 1) * h / substeps)
            node_err = max(node_err, float(np.max(np.abs(x - self.x[k + 1]))))
        xs_arr = np.array(xs)
        man = self.ocp.model.manifold
        out = {
            "t": np.array(ts),
            "x": xs_arr,
            "end_error": float(np.max(np.abs(xs_arr[-1] - self.x[-1]))),
            "max_node_error": node_err,
            "target_residual": self.ocp.target.distance(xs_arr[-1]),
            "manifold_residual": float(max(max(man.residual_norms(r).values()) for r in xs_arr)),
            "seconds": time.perf_counter() - t0,
            "rtol": rtol,
        }
        self.error.update(resim_end_error=out["end_error"],
                          resim_target_residual=out["target_residual"],
                          resim_max_node_error=node_err)
        return out

    def summary(self) -> dict[str, Any]:
        """Plain JSON-serialisable account (no arrays of the trajectory)."""
        return {
            "status": self.status.name,
            "ipopt_status": self.ipopt_status,
            "message": self.message,
            "objective": self.objective,
            "T": self.T,
            "transcription": self.describe(),
            "gauge": self.gauge,
            "cost": dict(self.cost),
            "error": dict(self.error),
        }


WARM_START = {"warm_start_init_point": "yes", "mu_init": 1e-6, "warm_start_bound_push": 1e-9,
              "warm_start_mult_bound_push": 1e-9, "warm_start_slack_bound_push": 1e-9}
"""Ipopt options added when a solution of the same transcription warm-starts a solve."""


DEFECT_TOL = 1e-2
"""Default ``defect_tol`` of :func:`solve`: the largest accepted local defect (relative to
``max(1, max |x|)``); a converged solve above it is INACCURATE, not SUCCESS."""


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


def _check_ipopt_values(extra: dict[str, Any]) -> None:
    for k, v in extra.items():
        if v is None or isinstance(v, bool) or not isinstance(v, (str, int, float, np.integer,
                                                                   np.floating)):
            raise ParameterError(f"ipopt_options[{k!r}] must be a number or a string (Ipopt "
                                 f"has no booleans: 'yes'/'no'); got {v!r}")
        if k in _IPOPT_INTEGER_OPTIONS:  # a C int in Ipopt: a float would be truncated
            validate.count(f"ipopt_options[{k!r}]", v, minimum=0, maximum=_IPOPT_INT_MAX)


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
    if not isinstance(print_level, (int, np.integer)) or not 0 <= print_level <= 12:
        raise ParameterError(f"print_level must be an integer in [0, 12]; got {print_level!r}")
    opts = {"tol": tol, "max_iter": int(max_iter), "print_level": int(print_level),
            "sb": "yes", "mu_strategy": "adaptive", "mumps_pivot_order": 5,
            "mumps_permuting_scaling": 0, "mumps_scaling": 0}
    opts.update(extra or {})
    return opts


def transcribe(ocp: OCP, method: TranscriptionMethod, *,
               handling: ManifoldHandling = ManifoldHandling.AMBIENT,
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


@validate.arguments(ocp=validate.instance(OCP, "an OCP"))
def solve(
    ocp: OCP,
    method: TranscriptionMethod | None = None,
    *,
    handling: ManifoldHandling = ManifoldHandling.AMBIENT,
    graph: Symbolic = Symbolic.SX,
    guess: Guess | OCPSolution | None = None,
    tol: float = 1e-8,
    max_iter: int = 1000,
    print_level: int = 0,
    ipopt_options: dict[str, Any] | None = None,
    raise_on_failure: bool = True,
    defect_tol: float | None = DEFECT_TOL,
    compiled: Compiled | None = None,
) -> OCPSolution:
    """Transcribe and solve an OCP with Ipopt (exact Hessian).

    Parameters
    ----------
    ocp : OCP
        The problem.
    method : Collocation or MultipleShooting, optional
        The transcription (default ``Collocation(N=40, degree=3)``).
    handling : ManifoldHandling
        ``AMBIENT`` or ``LIE_GROUP`` (see :mod:`workbench.control.ocp.transcription`).
    graph : Symbolic
        ``SX`` (scalar graph, fastest) or ``MX``.
    guess : Guess or OCPSolution, optional
        Initial guess; a solution of the *same* transcription also warm-starts the
        multipliers. Default: :meth:`Guess.geodesic` (deterministic great circles). The
        guess vector is moved into the variable bounds before the solve (as Ipopt would);
        the problem's data are never changed.
    tol : float
        Ipopt's tolerance.
    max_iter : int
        Ipopt's iteration limit.
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
        If Ipopt does not converge and ``raise_on_failure``; ``.solution`` holds the result.
    """
    check_guess(guess, ocp, OCPSolution)  # an array, or a guess of another problem
    method = method or Collocation()
    opts = _ipopt_options(tol, max_iter, print_level, ipopt_options)
    if defect_tol is not None:
        defect_tol = validate.tolerance("defect_tol", defect_tol)
    tr, built = transcribe(ocp, method, handling=handling, graph=graph, ipopt=opts)
    args, opts = _start(tr, ocp, guess, opts, warm_options=ipopt_options is None)
    out = _run(tr, ocp, built, args, opts, compiled)
    if tr.i_gauge is not None and out.status.ok:
        out = _check_gauge(out, tr, args, opts, ipopt_options is None, compiled)
    if out.status.ok:
        ocp.check_states(out.x, out.t, what="the solution's nodes")  # mechanics: T definite
        out.error["local_defect"] = _local_defect(out)
        limit = (None if defect_tol is None else
                 validate.scaled_tolerance(defect_tol, float(np.max(np.abs(out.x)))))
        if limit is not None and not out.error["local_defect"] <= limit:
            out.status = OCPStatus.INACCURATE
            out.error["defect_limit"] = limit
    if raise_on_failure and not out.status.ok:
        err = SolverError(f"OCP {ocp.name!r}: {out.message}", status=out.ipopt_status)
        err.solution = out  # type: ignore[attr-defined]
        raise err
    return out


GAUGE_BINDING = 1e-6
"""Largest ``|multiplier|`` of the phase condition read as "only picks one optimum"."""


def _start(tr: Transcription, ocp: OCP, guess: Guess | OCPSolution | None,
           opts: dict[str, Any], *, warm_options: bool) -> tuple[dict[str, Any], dict]:
    """Solver arguments: bounds, parameters (with the gauge), start point."""
    lbw, ubw = tr.bounds(ocp)
    args: dict[str, Any] = {"lbx": lbw, "ubx": ubw, "lbg": tr.lbg.copy(),
                            "ubg": tr.ubg.copy()}
    if isinstance(guess, OCPSolution) and guess.method == tr.method and \
            guess.handling is tr.handling and guess.graph is tr.graph:
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
    error = {
        "constraint_violation": float(viol.max(initial=0.0)),
        "manifold_residual": float(max(max(man.residual_norms(r).values()) for r in X)),
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
        lam_g=np.asarray(sol["lam_g"], float).ravel(), gauge=gauge,
    )


def _check_gauge(out: OCPSolution, tr: Transcription, args: dict[str, Any],
                 opts: dict[str, Any], warm_options: bool,
                 compiled: Compiled | None) -> OCPSolution:
    """Read the phase condition's multiplier; if it binds, re-solve without the gauge.

    The gauge only selects one optimum of a circle when the problem is symmetric along the
    solution (multiplier zero). Control bounds are not rotation invariant: where they are
    active the gauge can bind, and the gauged optimum is not one of the problem as posed.
    """
    lam = float(out.lam_g[tr.i_gauge])
    out.error["gauge_multiplier"] = lam
    if not np.any(args["p"][out.ocp.model.n_params:]):
        out.gauge = (f"{tr.symmetry.describe()}; not gauged: the guess is invariant (no "
                     f"phase condition through it)")
        return out
    if abs(lam) <= GAUGE_BINDING * max(1.0, abs(out.objective)):
        out.gauge += f" (multiplier {lam:.1e}: not binding)"
        return out
    free = out.ocp.with_bounds(gauge=False)
    tr2, built = transcribe(free, tr.method, handling=tr.handling, graph=tr.graph)
    lbw, ubw = tr2.bounds(free)
    keep = np.arange(tr.ng) != tr.i_gauge
    args = {"lbx": lbw, "ubx": ubw, "lbg": tr2.lbg, "ubg": tr2.ubg, "p": free.model.p,
            "x0": out.w, "lam_x0": out.lam_x, "lam_g0": out.lam_g[keep]}
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
    return again


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
