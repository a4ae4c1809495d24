"""How :func:`~workbench.control.ocp.solve` solves: the default strategy and the direct solve.

:class:`Direct` makes one Ipopt solve from the guess (or the geodesic guess) in the given
handling. :class:`Auto`, the default, is what a user's own underactuated swing-up needs
without a hand-made guess:

1. **Structured starts** (:mod:`workbench.control.ocp.initial`, made one at a time, as
   they are tried): the energy-pumping feedback's trajectory, the direct path along the
   great circle the inputs can drive (first, where its inverse-dynamics inputs lie within
   the bounds), then paths with 1, 2, ... reversals, both senses of an antipodal angle;
   or the user's guess alone. With ``coarse_first``, each structured
   start is first relaxed on a coarse transcription (``N // coarse_factor`` intervals):
   one that fails there is left for the next start at a fraction of a fine failure's cost.
2. **An ambient relaxation, polished on the manifold.** Each start is solved first with
   ``ManifoldHandling.AMBIENT`` (nodes free in the ambient space: the constraints of the
   manifold are relaxed to those the dynamics carry), at most ``relax_max_iter``
   iterations; its optimum warm-starts, primal and dual, the solve in the final handling
   (``PROJECTED`` unless given), which has the same variables and constraints (a
   ``LIE_GROUP`` solve has other variables: it is started from the relaxation's states
   and controls, primal only). On Drake's
   swing-up the relaxation reaches a minimum below Drake's that the projected NLP keeps
   (4.647 against 5.229), in 28 + 4 iterations, where the projected NLP from the same
   guess stops at Drake's in 50 and, cart free, at 6.69 in 104 (Drake: 5.178). If the
   relaxation does not converge, the start is solved in the final handling directly, while
   no solve of the problem itself has been made (so that a failure carries the problem's
   own diagnosis); after that, a start whose relaxation ends infeasible or at its
   iteration limit is left: the relaxation's feasible set holds the problem's, and on the
   shipped problems no such start was ever solved in the final handling (on the
   spherical cart's infeasible horizons these solves were a third of the CPU).
3. **Continuation** when no start converges, from the start that came closest (least
   primal infeasibility): in the input bound (solved with the bounds widened by
   ``bound_factors``, then narrowed back, each solve warm-starting the next), in the
   terminal condition (``|chart| <= slack`` for each of ``terminal_slacks``, then exact),
   and from a coarse transcription (``N // coarse_factor`` intervals) refined to the
   requested one.

It stops at the first success (``SUCCESS`` or ``ACCEPTABLE``, on the manifold, within
``defect_tol``) of the problem itself: its own bounds, terminal condition, transcription
and handling (a relaxation or a continuation step is a means, never returned as a
success). Every solve is recorded in :attr:`OCPSolution.attempts`; a failure returns the
solve of the problem itself that came closest (least primal infeasibility), with its
diagnosis, and its message names that attempt; if the attempts ran out before the problem
itself was solved at all, the last solve is returned with the status ``NOT_SOLVED``. The
attempts are deterministic: the same problem gives the same sequence (in the same numerical
environment: the number of BLAS threads changes the order of the linear algebra's sums, and
a long solve can end elsewhere).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from workbench.control.ocp.guess import Guess
from workbench.control.ocp.hermite_simpson import HermiteSimpson
from workbench.control.ocp.initial import StructuredGuess, iter_structured_guesses
from workbench.control.ocp.problem import OCP
from workbench.control.ocp.solution import OCPSolution, OCPStatus
from workbench.control.ocp.solve import DEFAULT_HANDLING, Settings, solve_direct
from workbench.control.ocp.transcription import (
    Collocation,
    ManifoldHandling,
    MultipleShooting,
    TranscriptionMethod,
)
from workbench.core import validate
from workbench.core._model import Symbolic
from workbench.core.errors import ParameterError

__all__ = ["Auto", "Direct"]


def _record(n: int, what: str, guess: str, sol: OCPSolution, *,
            problem: bool = True) -> dict[str, Any]:
    return {"attempt": n, "what": what, "guess": guess, "problem_itself": problem,
            "transcription": sol.method.describe(), "handling": sol.handling.value,
            "status": sol.status.name, "iterations": sol.cost["iterations"],
            "objective": sol.objective, "T": sol.T,
            "cpu_seconds": sol.cost["solve_cpu_seconds"],
            "build_seconds": sol.cost["build_seconds"],
            "primal_infeasibility": _number(sol.cost.get("last_inf_pr")),
            "manifold_residual": _number(sol.error.get("manifold_residual")),
            "local_defect": _number(sol.error.get("local_defect")),
            "defect_limit": _number(sol.error.get("defect_limit"))}


def _number(value: Any) -> float | None:
    """A finite number as a float; None where it was not measured (never NaN)."""
    return float(value) if value is not None and np.isfinite(value) else None


def _describe_guess(guess: Guess | OCPSolution | None) -> str:
    if guess is None:
        return "geodesic (Guess.geodesic)"
    if isinstance(guess, OCPSolution):
        return f"the solution given ({guess.describe()}, cost {guess.objective:.6g})"
    return "the guess given"


@dataclass(frozen=True)
class Direct:
    """One Ipopt solve from the guess (default :meth:`Guess.geodesic`), as given."""

    def run(self, ocp: OCP, method: TranscriptionMethod, *,
            handling: ManifoldHandling | None, graph: Symbolic,
            guess: Guess | OCPSolution | None, settings: Settings) -> OCPSolution:
        """Solve once; the solution's :attr:`~OCPSolution.attempts` has that one solve."""
        out = solve_direct(ocp, method, handling or DEFAULT_HANDLING, graph, guess, settings)
        out.attempts = [_record(1, "direct solve", _describe_guess(guess), out)]
        return out


def _coarse(method: TranscriptionMethod, factor: int) -> TranscriptionMethod | None:
    """``method`` with ``N // factor`` intervals (None below 5 or where it is no coarser)."""
    n = method.N // factor
    if n < 5 or n == method.N:
        return None
    if not isinstance(method, (Collocation, HermiteSimpson, MultipleShooting)):
        return None
    return dataclasses.replace(method, N=n)


@dataclass(frozen=True)
class Auto:
    """The default strategy of :func:`~workbench.control.ocp.solve` (module docstring).

    Parameters
    ----------
    swings : int
        Structured starts with up to this many reversals of the factors to invert.
    relax : bool
        Solve each start first in the ambient relaxation, then polish on the manifold.
    relax_max_iter : int
        Iteration limit of a relaxation (it is a means: a start that does not converge in
        it is solved in the final handling directly); ``max_iter`` of :func:`solve` caps
        it too.
    attempt_max_iter : int
        Iteration limit of every other solve (and ``max_iter`` of :func:`solve`, the
        smaller applies): a start that needs more is left for the next one. A problem
        whose solves need more than 300 iterations from every start needs a larger one.
    bound_factors : tuple of float
        Continuation in the input bound: the factors the finite bounds are widened by
        (each > 1, decreasing), before the problem's own bounds (a list is stored as a
        tuple).
    terminal_slacks : tuple of float
        Continuation in the terminal condition: ``|chart| <= slack`` for each (decreasing),
        before the exact condition (a list is stored as a tuple).
    coarse_factor : int
        The coarse transcription has ``N // coarse_factor`` intervals (at least 5): the
        structured starts' first relaxation and the last continuation (``0``: none).
    coarse_first : bool
        Solve each structured start on the coarse transcription first (a start that fails
        there costs a fraction of a fine failure; one that converges starts the fine
        solves). Not applied to a guess given. Off by default: measured on the swing-ups
        it reached cheaper minima on the acrobot (24.4 against 67.1) and the 3D pendulum's
        reduced model, but dearer ones on the spherical cart (18.5 against 7.4) and the
        rail pendulum, and on the Furuta pendulum (N = 60 over up to 4 s: 15 coarse
        intervals cannot hold its pumping) it cost 15 s instead of 1.4 s.
    max_attempts : int
        At most this many solves in all.
    patience : int
        After this many structured starts in a row fail (to converge: INFEASIBLE, the
        iteration limit, a failure; or to INACCURATE trajectories), the other starts are
        not tried and the strategy goes on to continuation; where one of them converged to
        INACCURATE trajectories (the transcription too coarse for what it finds), it stops
        there: continuation changes the bounds and the terminal condition, not the
        transcription's resolution (the diagnosis says: more intervals). The solution's
        ``cost["strategy_stopped"]`` says so.
    """

    swings: int = 3
    relax: bool = True
    relax_max_iter: int = 300
    attempt_max_iter: int = 300
    bound_factors: tuple[float, ...] = (4.0, 2.0)
    terminal_slacks: tuple[float, ...] = (0.1, 0.01)
    coarse_factor: int = 4
    coarse_first: bool = False
    max_attempts: int = 30
    patience: int = 3

    def __post_init__(self) -> None:
        validate.count("swings", self.swings, minimum=0, maximum=20)
        validate.count("relax_max_iter", self.relax_max_iter, maximum=100_000)
        validate.count("attempt_max_iter", self.attempt_max_iter, maximum=100_000)
        validate.count("coarse_factor", self.coarse_factor, minimum=0, maximum=64)
        validate.count("max_attempts", self.max_attempts, maximum=1000)
        validate.count("patience", self.patience, maximum=1000)
        for name in ("relax", "coarse_first"):
            if not isinstance(getattr(self, name), bool):
                raise ParameterError(f"{name} must be True or False; got "
                                     f"{getattr(self, name)!r}")
        for name, seq in (("bound_factors", self.bound_factors),
                          ("terminal_slacks", self.terminal_slacks)):
            ok = isinstance(seq, (tuple, list)) and all(
                isinstance(v, (int, float, np.integer, np.floating))
                and not isinstance(v, (bool, np.bool_)) for v in seq)
            vals = np.asarray(seq, float) if ok else np.zeros(0)
            if not ok or not np.all(np.isfinite(vals)) or np.any(np.diff(vals) >= 0):
                raise ParameterError(f"{name} must be a decreasing tuple of finite real "
                                     f"numbers; got {seq!r}")
        if np.any(np.asarray(self.bound_factors, float) <= 1):
            raise ParameterError(f"bound_factors must be > 1; got {self.bound_factors!r}")
        if np.any(np.asarray(self.terminal_slacks, float) <= 0):
            raise ParameterError(f"terminal_slacks must be > 0; got {self.terminal_slacks!r}")
        for name in ("bound_factors", "terminal_slacks"):  # hashable, immutable
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))

    def run(self, ocp: OCP, method: TranscriptionMethod, *,
            handling: ManifoldHandling | None, graph: Symbolic,
            guess: Guess | OCPSolution | None, settings: Settings) -> OCPSolution:
        """Run the strategy; the first success, or the closest failure, with every attempt."""
        run = _Run(self, ocp, method, handling or DEFAULT_HANDLING, graph, settings)
        if guess is not None:
            starts: Iterator[StructuredGuess] = iter(
                [StructuredGuess("given", guess, _describe_guess(guess))])
        else:  # made one at a time: a start not tried is never built
            starts = iter_structured_guesses(ocp, swings=self.swings)
        outcomes: list[str] = []
        for start in starts:
            run.tried.append(start)
            done = run.start(start, coarse=guess is None and self.coarse_first)
            if done is not None:
                return run.finish(done)
            if run.exhausted():
                break
            outcomes.append(_outcome(run.last))
            tail = outcomes[-self.patience:]
            if len(tail) == self.patience and all(tail):
                why = tail[0] if len(set(tail)) == 1 else \
                    f"{FAILED_STARTS} or {INACCURATE_STARTS}"
                run.stopped = (f"{self.patience} starts in a row {why}: the other starts "
                               f"were not tried")
                break
        if run.stopped and INACCURATE_STARTS in outcomes[-self.patience:]:
            run.stopped += (", nor continuation (the transcription is too coarse for the "
                            "trajectories it finds: more intervals N)")
        elif run.tried and not run.exhausted():
            done = run.continuation()
            if done is not None:
                return run.finish(done)
        return run.finish(None)


class _Run:
    """The state of one :meth:`Auto.run`: attempts so far, the closest failure."""

    def __init__(self, auto: Auto, ocp: OCP, method: TranscriptionMethod,
                 handling: ManifoldHandling, graph: Symbolic, user: Settings) -> None:
        self.auto, self.ocp, self.method = auto, ocp, method
        self.handling, self.graph = handling, graph
        self.settings = user.replace(max_iter=min(auto.attempt_max_iter,
                                                  user.ipopt["max_iter"]))
        # a relaxation's own limit, capped by the caller's max_iter, not by attempt_max_iter
        self.relax = user.replace(max_iter=min(auto.relax_max_iter, user.ipopt["max_iter"]),
                                  defect_tol=None, manifold_tol=None)
        self.attempts: list[dict[str, Any]] = []
        self.tried: list[StructuredGuess] = []
        self.closest: OCPSolution | None = None
        self.closest_start: StructuredGuess | None = None
        self.last: OCPSolution | None = None
        self.stopped = ""
        self.t0 = time.process_time()

    def exhausted(self) -> bool:
        return len(self.attempts) >= self.auto.max_attempts

    def solve(self, what: str, start: StructuredGuess, ocp: OCP,
              method: TranscriptionMethod, handling: ManifoldHandling,
              guess: Guess | OCPSolution, settings: Settings,
              **kwargs: Any) -> OCPSolution | None:
        """One recorded solve (``None`` when the attempts are used up)."""
        if self.exhausted():
            return None
        sol = solve_direct(ocp, method, handling, self.graph, guess, settings, **kwargs)
        n = len(self.attempts) + 1
        problem = (ocp is self.ocp and method == self.method and handling is self.handling
                   and not kwargs.get("terminal_slack"))
        self.attempts.append(_record(n, what, f"{start.name}: {start.description}", sol,
                                     problem=problem))
        sol.cost["strategy_attempt"] = n
        self.last = sol
        return sol

    def final(self, sol: OCPSolution | None, start: StructuredGuess) -> OCPSolution | None:
        """``sol`` if it is a success of the problem itself; else keep the closest failure."""
        if sol is None or not self.attempts[sol.cost["strategy_attempt"] - 1][
                "problem_itself"]:
            return None
        if sol.status.ok:
            return sol
        if self.closest is None or _infeasibility(sol) < _infeasibility(self.closest):
            self.closest, self.closest_start = sol, start
        return None

    def start(self, start: StructuredGuess, *, coarse: bool = False) -> OCPSolution | None:
        """(A coarse relaxation first,) relaxation then polish; or the final handling directly.

        With ``coarse``, the start is first solved on ``N // coarse_factor`` intervals: a
        start that does not converge there is left (cheaply) for the next one; one that
        does starts the solves on the problem's own transcription.
        """
        guess: Guess | OCPSolution = start.guess
        cm = _coarse(self.method, self.auto.coarse_factor) if coarse and \
            self.auto.coarse_factor else None
        if cm is not None:
            first = self.solve(f"coarse relaxation ({cm.describe()})", start, self.ocp, cm,
                               self.relax_handling(), guess, self.relax)
            if first is None or not first.status.ok:
                return None
            guess = first
        if self.auto.relax and self.handling is not ManifoldHandling.AMBIENT:
            relaxed = self.solve("ambient relaxation", start, self.ocp, self.method,
                                 ManifoldHandling.AMBIENT, guess, self.relax)
            if relaxed is not None and relaxed.status.ok:
                polished = self.solve(f"{self.handling.value} from the relaxation", start,
                                      self.ocp, self.method, self.handling, relaxed,
                                      self.settings)
                done = self.final(polished, start)
                if done is not None or polished is None or \
                        polished.status.name == "INACCURATE":  # converged, too coarse: a
                    return done  # solve from the start itself would not be finer
            elif relaxed is None or (self.closest is not None and relaxed.status.name in (
                    "INFEASIBLE", "MAX_ITERATIONS")):
                return None  # the relaxation holds the problem's feasible set: left

        return self.final(self.solve(f"{self.handling.value} solve", start, self.ocp,
                                     self.method, self.handling, guess, self.settings),
                          start)

    def relax_handling(self) -> ManifoldHandling:
        """The handling of relaxations: ambient, unless the relaxation is switched off."""
        return ManifoldHandling.AMBIENT if self.auto.relax else self.handling

    def chain(self, start: StructuredGuess, steps: list[tuple[str, OCP, TranscriptionMethod,
                                                               dict[str, Any]]]
              ) -> OCPSolution | None:
        """Solve ``steps`` in turn, each from the previous one; only the last is the problem.

        The intermediate steps (wider bounds, a relaxed terminal condition, a coarser
        transcription) are means: no defect limit, and a failure there just ends the chain.
        """
        current: Guess | OCPSolution = start.guess
        sol = None
        for i, (what, ocp, method, kwargs) in enumerate(steps):
            last = i == len(steps) - 1
            sol = self.solve(what, start, ocp, method, self.handling, current,
                             self.settings if last else self.settings.replace(
                                 defect_tol=None), **kwargs)
            if sol is None:
                return None
            if not sol.status.ok:
                return self.final(sol, start) if last else None
            current = sol
        return self.final(sol, start)

    def continuation(self) -> OCPSolution | None:
        """Bound, terminal and coarse-to-fine continuations from the closest start."""
        start = self.closest_start or self.tried[0]
        ocp, auto = self.ocp, self.auto
        finite = np.isfinite(ocp.u_lower) & np.isfinite(ocp.u_upper)
        if auto.bound_factors and np.any(finite):
            mid = np.where(finite, 0.5 * (ocp.u_lower + ocp.u_upper), 0.0)
            steps = []
            for factor in auto.bound_factors:
                half = np.where(finite, 0.5 * (ocp.u_upper - ocp.u_lower) * factor, np.inf)
                wide = ocp.with_bounds(u_lower=np.where(finite, mid - half, ocp.u_lower),
                                       u_upper=np.where(finite, mid + half, ocp.u_upper))
                steps.append((f"bound continuation x{factor:g}", wide, self.method, {}))
            steps.append(("bound continuation, the problem's bounds", ocp, self.method, {}))
            done = self.chain(start, steps)
            if done is not None:
                return done
        if auto.terminal_slacks:
            steps = [(f"terminal continuation |chart| <= {sl:g}", ocp, self.method,
                      {"terminal_slack": float(sl)}) for sl in auto.terminal_slacks]
            steps.append(("terminal continuation, exact", ocp, self.method, {}))
            done = self.chain(start, steps)
            if done is not None:
                return done
        coarse = _coarse(self.method, auto.coarse_factor) if auto.coarse_factor else None
        if coarse is not None:
            done = self.chain(start, [(f"coarse {coarse.describe()}", ocp, coarse, {}),
                                      (f"refined {self.method.describe()}", ocp, self.method,
                                       {})])
            if done is not None:
                return done
        return None

    def finish(self, sol: OCPSolution | None) -> OCPSolution:
        """The success ``sol``; else the closest failure of the problem itself; else NOT_SOLVED.

        A relaxation or a continuation step solved a problem other than the one posed:
        where no solve of the problem itself was made, the last solve is returned with the
        status ``NOT_SOLVED`` (never as a success).
        """
        sol = sol if sol is not None else self.closest
        if sol is None:
            sol = self.last
            if sol is None:  # no attempt at all (max_attempts reached before any)
                raise ParameterError("max_attempts allowed no solve")
            sol.status = OCPStatus.NOT_SOLVED
            sol.diagnosis = {"primal_infeasibility": _number(sol.cost.get("last_inf_pr")),
                             "dual_infeasibility": _number(sol.cost.get("last_inf_du")),
                             "manifold_residual": float(sol.error["manifold_residual"]),
                             "worst_constraint": {"where": "not judged", "kind": None,
                                                  "knot": None, "violation": 0.0},
                             "advice": [f"the strategy's {len(self.attempts)} solves "
                                        f"(max_attempts) ran out before the problem itself "
                                        f"was solved: a larger Auto(max_attempts=), or a "
                                        f"guess="]}
        sol.attempts = list(self.attempts)
        sol.cost["strategy_cpu_seconds"] = time.process_time() - self.t0  # guesses included
        sol.cost["strategy_solve_cpu_seconds"] = float(sum(a["cpu_seconds"]
                                                           for a in self.attempts))
        sol.cost["strategy_attempts"] = len(self.attempts)
        if self.stopped and not sol.status.ok:
            sol.cost["strategy_stopped"] = self.stopped
        return sol


INACCURATE_STARTS = "converged to trajectories the transcription does not follow"
FAILED_STARTS = "did not converge"


def _outcome(sol: OCPSolution | None) -> str:
    """A start's outcome for :attr:`Auto.patience` ("" when it says nothing)."""
    if sol is None:
        return ""
    if sol.status.name == "INACCURATE":
        return INACCURATE_STARTS
    if sol.status.name in ("INFEASIBLE", "MAX_ITERATIONS", "FAILED"):
        return FAILED_STARTS
    return ""


def _infeasibility(sol: OCPSolution) -> float:
    v = _number(sol.cost.get("last_inf_pr"))
    return np.inf if v is None else v
