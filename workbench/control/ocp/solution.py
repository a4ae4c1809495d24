"""The result of an OCP solve: its status, trajectory, costs, errors and attempts.

:class:`OCPSolution` is what :func:`~workbench.control.ocp.solve` returns, for a success or
a failure: Ipopt's status mapped to an :class:`OCPStatus`, the node states and controls,
the cost of the solve (iterations, seconds) and its measured errors (constraint
violation, manifold residual of the nodes, target residual, local defect against
CVODES). A failure also carries a diagnosis in numbers (:attr:`OCPSolution.diagnosis`):
the primal and dual infeasibility of the last iterate, the worst constraint with its knot,
and what to try next. The default strategy records every attempt it made
(:attr:`OCPSolution.attempts`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from workbench.control.ocp.guess import Guess
from workbench.control.ocp.problem import OCP
from workbench.control.ocp.transcription import ManifoldHandling, TranscriptionMethod
from workbench.core import validate
from workbench.core._model import Symbolic
from workbench.core.errors import ParameterError
from workbench.core.status import StatusEnum, StatusResult

__all__ = ["OCPStatus", "OCPSolution", "MAX_RESIM_SAMPLES"]

MAX_RESIM_SAMPLES = 1_000_000
"""Largest ``N * substeps`` of :meth:`OCPSolution.resimulate` (one CVODES call each, about
125 us on a pendulum: two minutes), as for :func:`~workbench.control.tvlqr_along`'s grid.
``substeps`` alone was bounded by 10^5, times up to 10^5 intervals."""


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
    OFF_MANIFOLD = ("Ipopt converged, but the nodes are off the manifold by more than "
                    "manifold_tol")
    CONSTRAINTS_VIOLATED = ("Ipopt reported convergence, but its point violates the NLP's "
                            "constraints (dynamics, terminal condition, path constraints) by "
                            "more than solve's tol allows (Ipopt's own tolerances, from "
                            "ipopt_options, were looser)")
    NOT_SOLVED = ("the strategy's attempts ran out before the problem itself (its bounds, "
                  "terminal condition, transcription and handling) was solved: the solution "
                  "returned is an intermediate step's (a relaxation or a continuation step)")

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
        ``nlp_constraints``; from the default strategy also ``strategy_attempt`` (which
        attempt this solution is), ``strategy_attempts`` (how many were made),
        ``strategy_cpu_seconds`` (CPU of the whole strategy, its guesses included),
        ``strategy_solve_cpu_seconds`` (of its solves only) and, where it stopped early,
        ``strategy_stopped`` (why).
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
    g : ndarray
        The NLP's constraint values at the returned point.
    attempts : list of dict
        Every solve the strategy made, in order: ``attempt``, ``what`` (the role: a
        relaxation, an on-manifold solve, a continuation step), ``guess`` (how it was
        made), ``problem_itself`` (whether the solve was of the problem as posed, not a
        means such as a relaxation or a continuation step), ``transcription``,
        ``handling``, ``status``, ``iterations``,
        ``objective``, ``T``, ``cpu_seconds``, ``build_seconds``,
        ``primal_infeasibility``, ``manifold_residual``, ``local_defect`` and
        ``defect_limit`` (None where not measured). One entry for ``Direct``.
    diagnosis : dict or None
        For a failure, what went wrong in numbers (see
        :func:`workbench.control.ocp.diagnose.diagnose`): primal and dual infeasibility,
        the node manifold residual, the worst constraint and its knot, the advice.
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
    g: np.ndarray | None = field(default=None, repr=False)
    attempts: list[dict[str, Any]] = field(default_factory=list, repr=False)
    diagnosis: dict[str, Any] | None = field(default=None, repr=False)

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
        if self.status is OCPStatus.CONSTRAINTS_VIOLATED:
            e = self.error
            defect = (f", constraint violation {e['constraint_violation']:.3g} (allowed "
                      f"{e.get('constraint_limit', float('nan')):.3g} at the worst row), target "
                      f"residual {e['target_residual']:.3g}")
        text = (
            f"{self.status.name}: {self.status.value}; Ipopt returned {self.ipopt_status} "
            f"after {c['iterations']} iterations (solve {c['solve_seconds']:.3f} s, build "
            f"{c['first_build_seconds']:.3f} s); cost {self.objective:.6g}, T = {self.T:.4g} s"
            f"{defect}; symmetry: {self.gauge} [{self.describe()}]"
        )
        n = c.get("strategy_attempt")
        if len(self.attempts) > 1 and n is not None:
            text += (f"; attempt {n} of the strategy ({self.attempts[n - 1]['what']}; "
                     f"{len(self.attempts)} solves, "
                     f"{c.get('strategy_cpu_seconds', 0.0):.2f} s CPU in all)")
        if c.get("strategy_stopped"):
            text += f"; the strategy stopped: {c['strategy_stopped']}"
        if self.diagnosis is not None:
            from workbench.control.ocp.diagnose import describe_diagnosis

            text += ". Diagnosis: " + describe_diagnosis(self.diagnosis)
        return text

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
        rtol : float
            CVODES' relative tolerance, in ``(0, 1)``.
        atol : float
            CVODES' absolute tolerance (positive, finite).
        substeps : int
            Output samples per interval (for figures); ``N * substeps`` at most
            :data:`MAX_RESIM_SAMPLES`.

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
        n = len(self.x) - 1
        if n * substeps > MAX_RESIM_SAMPLES:
            raise ParameterError(
                f"substeps = {substeps} on {n} intervals gives {n * substeps} samples; at "
                f"most {MAX_RESIM_SAMPLES} (one CVODES call each): fewer substeps")
        rtol = validate.relative_tolerance("rtol", rtol)
        atol = validate.tolerance("atol", atol)
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
            "attempts": [dict(a) for a in self.attempts],
            "diagnosis": self.diagnosis,
        }
