"""Strategies for nonconvex OCPs: seeded starts, coarse-to-fine refinement, continuation.

The swing-ups have many local minima (they differ in the number of swings) and a poor
guess can leave Ipopt far from any. :func:`multistart` solves from seeded geodesic guesses
and keeps the cheapest; :func:`coarse_to_fine` lets a cheap coarse transcription absorb
the iterations from a poor guess before a fine one converges in a few; :func:`refine`
warm-starts another transcription from a solution; :func:`continuation` walks a sequence of
bounds or horizons, each solve warm-starting the next on one build.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from workbench.control.ocp.guess import Guess
from workbench.control.ocp.problem import OCP
from workbench.control.ocp.solve import OCPSolution, solve
from workbench.control.ocp.transcription import Collocation, Method
from workbench.core.errors import ParameterError, SolverError

__all__ = ["multistart", "coarse_to_fine", "refine", "continuation"]


def multistart(
    ocp: OCP,
    method: Method | None = None,
    *,
    seeds: Sequence[int] = tuple(range(8)),
    noise: float = 0.1,
    T_guesses: Sequence[float] | None = None,
    refine_with: Sequence[Method] = (),
    describe: Callable[[OCPSolution], dict[str, Any]] | None = None,
    ipopt_variants: Sequence[dict[str, Any]] = ({},),
    **solve_options: Any,
) -> tuple[OCPSolution, list[dict[str, Any]]]:
    """Solve from seeded geodesic guesses (random great circles, control noise); keep the best.

    Parameters
    ----------
    ocp : OCP
        The problem.
    method : Collocation or MultipleShooting, optional
        The transcription of the starts (built once for all; a coarse one is cheap).
    seeds : sequence of int
        One start per seed.
    noise : float
        Control noise of the guesses (relative to the bounds' half-range).
    T_guesses : sequence of float, optional
        Final-time guesses, cycled over the seeds (default: the middle of the range).
    refine_with : sequence of Collocation or MultipleShooting
        Each converged start is refined through these transcriptions in turn (each
        warm-started by the previous one, see :func:`coarse_to_fine`); the best is chosen
        after refinement.
    describe : callable, optional
        ``describe(solution) -> dict`` of further fields for each converged start's record
        (e.g. a classification of the local minimum).
    ipopt_variants : sequence of dict
        Ipopt options cycled over the starts (e.g. ``{"mu_oracle": "probing"}``): on a
        rugged landscape the barrier strategy decides which minimum a start falls into as
        much as the guess does. The refinements use the default options.
    **solve_options
        Passed to :func:`solve` (``raise_on_failure`` is forced off for the starts).

    Returns
    -------
    (OCPSolution, list of dict)
        The converged solution of least cost, and one record per start (seed, status,
        objective, T, iterations, solve seconds, including the refinements).

    Raises
    ------
    SolverError
        If no start converged.
    """
    solve_options = dict(solve_options)
    solve_options.pop("raise_on_failure", None)
    solve_options.pop("guess", None)
    best, records = None, []
    for i, seed in enumerate(seeds):
        rng = np.random.default_rng(seed)
        T = None if not T_guesses else T_guesses[i % len(T_guesses)]
        g = Guess.geodesic(ocp, T=T, rng=rng, noise=noise)
        variant = dict(ipopt_variants[i % len(ipopt_variants)]) if ipopt_variants else {}
        first_options = dict(solve_options)
        if variant:
            first_options["ipopt_options"] = {**(solve_options.get("ipopt_options") or {}),
                                              **variant}
        first = solve(ocp, method or Collocation(), guess=g, raise_on_failure=False,
                      **first_options)
        s, path = first, [first]
        if first.status.ok and refine_with:
            s, rest = coarse_to_fine(ocp, list(refine_with), guess=first,
                                     raise_on_failure=False, **solve_options)
            path += rest
        records.append({
            "seed": int(seed), "status": s.status.name, "objective": s.objective, "T": s.T,
            "iterations": [p.cost["iterations"] for p in path],
            "solve_seconds": float(sum(p.cost["solve_seconds"] for p in path)),
            "coarse_objective": path[0].objective,
            "ipopt_variant": variant,
        })
        if describe is not None and s.status.ok:
            records[-1].update(describe(s))
        if s.status.ok and (best is None or s.objective < best.objective):
            best = s
    if best is None:
        raise SolverError(f"OCP {ocp.name!r}: none of {len(seeds)} starts converged",
                          status=records[-1]["status"] if records else "")
    return best, records


def coarse_to_fine(
    ocp: OCP,
    methods: Sequence[Method],
    *,
    guess: Guess | OCPSolution | None = None,
    **solve_options: Any,
) -> tuple[OCPSolution, list[OCPSolution]]:
    """Solve with each transcription in turn, each warm-started by the previous solution.

    A coarse transcription is cheap per iteration and absorbs most of the iterations from a
    poor guess; the fine one then converges in a few. Stops at the first failure.

    Parameters
    ----------
    ocp : OCP
        The problem.
    methods : sequence of Collocation or MultipleShooting
        From coarse to fine.
    guess : Guess or OCPSolution, optional
        Guess of the first.
    **solve_options
        Passed to :func:`solve`.

    Returns
    -------
    (OCPSolution, list of OCPSolution)
        The last solution reached and all of them.
    """
    if not methods:
        raise ParameterError("methods must hold at least one transcription")
    path: list[OCPSolution] = []
    current = guess
    raise_on_failure = solve_options.pop("raise_on_failure", True)
    for m in methods:
        s = solve(ocp, m, guess=current, raise_on_failure=raise_on_failure, **solve_options)
        path.append(s)
        if not s.status.ok:
            break
        current = s
    return path[-1], path


def refine(solution: OCPSolution, method: Method, **solve_options: Any) -> OCPSolution:
    """Solve ``solution.ocp`` with another (finer) transcription, warm-started by ``solution``.

    Parameters
    ----------
    solution : OCPSolution
        A coarse solution.
    method : Collocation or MultipleShooting
        The new transcription.
    **solve_options
        Passed to :func:`solve`.
    """
    solve_options.setdefault("handling", solution.handling)
    solve_options.setdefault("graph", solution.graph)
    return solve(solution.ocp, method, guess=solution.guess(), **solve_options)


def continuation(
    ocp: OCP,
    method: Method | None = None,
    *,
    steps: Sequence[dict[str, Any]],
    guess: Guess | OCPSolution | None = None,
    **solve_options: Any,
) -> tuple[OCPSolution, list[OCPSolution]]:
    """Solve a sequence of problems differing in bounds or horizon, each warm-starting the next.

    Parameters
    ----------
    ocp : OCP
        The problem of the last step is ``ocp.with_bounds(**steps[-1])``.
    method : Collocation or MultipleShooting, optional
        One transcription for all steps (built once: bounds are data).
    steps : sequence of dict
        Keyword arguments of :meth:`OCP.with_bounds` (``u_lower``, ``u_upper``, ``T``),
        from an easy problem to the hard one.
    guess : Guess or OCPSolution, optional
        Guess of the first step.
    **solve_options
        Passed to :func:`solve`.

    Returns
    -------
    (OCPSolution, list of OCPSolution)
        The last solution and all of them.
    """
    if not steps:
        raise ParameterError("steps must hold at least one dict of bounds")
    sols: list[OCPSolution] = []
    current = guess
    for st in steps:
        problem = ocp.with_bounds(**st)
        s = solve(problem, method, guess=current, **solve_options)
        sols.append(s)
        current = s
    return sols[-1], sols
