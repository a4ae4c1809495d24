"""Strategies for nonconvex OCPs: seeded starts, coarse-to-fine refinement, homotopy.

The swing-ups have many local minima (they differ in the number of swings) and a poor
guess can leave Ipopt far from any. :func:`multistart` solves from seeded geodesic guesses
and keeps the cheapest; :func:`coarse_to_fine` lets a cheap coarse transcription absorb
the iterations from a poor guess before a fine one converges in a few; :func:`refine`
warm-starts another transcription from a solution; :func:`homotopy` walks a sequence of
bounds or horizons, each solve warm-starting the next on one build (a parameter
continuation; the name keeps "continuation" for the branches of
:mod:`workbench.equilibria`).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from workbench.control.ocp.auto import Direct
from workbench.control.ocp.guess import Guess
from workbench.control.ocp.problem import OCP
from workbench.control.ocp.solve import (
    DEFAULT_HANDLING,
    OCPSolution,
    OCPStatus,
    _ipopt_options,
    solve,
    transcribe,
)
from workbench.control.ocp.transcription import (
    Collocation,
    TranscriptionMethod,
)
from workbench.core import validate
from workbench.core._model import Symbolic
from workbench.core.errors import ParameterError, SolverError

__all__ = ["multistart", "coarse_to_fine", "refine", "homotopy"]


def _direct(ocp: OCP, method: TranscriptionMethod | None, **options: Any) -> OCPSolution:
    """:func:`solve` with ``strategy=Direct()`` unless one is given.

    These strategies make their own guesses (or take the caller's): each of their solves is
    one Ipopt solve from that guess, as the strategy's record of it says.
    """
    options.setdefault("strategy", Direct())
    return solve(ocp, method, **options)


def multistart(
    ocp: OCP,
    method: TranscriptionMethod | None = None,
    *,
    seeds: Sequence[int] = tuple(range(8)),
    noise: float = 0.1,
    T_guesses: Sequence[float] | None = None,
    refine_with: Sequence[TranscriptionMethod] = (),
    refine_best: int | None = None,
    describe: Callable[[OCPSolution], dict[str, Any]] | None = None,
    ipopt_variants: Sequence[dict[str, Any]] = ({},),
    workers: int = 1,
    starts: str = "seeded",
    executor: Any = None,
    build: Callable[[], OCP] | None = None,
    **solve_options: Any,
) -> tuple[OCPSolution, list[dict[str, Any]]]:
    """Solve from several starts and keep the best: seeded geodesics, or the structured ones.

    Parameters
    ----------
    ocp : OCP
        The problem.
    method : Collocation, MultipleShooting or HermiteSimpson, optional
        The transcription of the starts (built once for all; a coarse one is cheap).
    seeds : sequence of int
        One start per seed (``starts="seeded"``).
    noise : float
        Control noise of the guesses (relative to the bounds' half-range).
    T_guesses : sequence of float, optional
        Final-time guesses, cycled over the seeds (default: the middle of the range).
    refine_with : sequence of transcriptions
        Each converged start is refined through these transcriptions in turn (each
        warm-started by the previous one, see :func:`coarse_to_fine`); the best is chosen
        after refinement.
    refine_best : int, optional
        Refine only this many converged starts, those of least cost on the coarse
        transcription (default: every converged start). A speed-for-robustness knob: a
        coarse transcription can rank two minima the other way round from the fine one,
        so the best refined minimum may be missed; each record says whether its start was
        refined and keeps its coarse cost (``coarse_objective``) to measure the trade.
    describe : callable, optional
        ``describe(solution) -> dict`` of further fields for each converged start's record
        (e.g. a classification of the local minimum).
    ipopt_variants : sequence of dict
        Ipopt options cycled over the starts (e.g. ``{"mu_oracle": "probing"}``): on a
        rugged landscape the barrier strategy decides which minimum a start falls into as
        much as the guess does. The refinements use the default options.
    workers : int
        Processes solving the starts in parallel (1: in this process). The transcriptions
        are built here first and inherited by forked workers (no rebuild, nothing
        pickled but numbers); each worker returns its records and the primal-dual vector
        of its end point, and the best is re-solved here from that vector (a warm start
        of the same transcription: a few iterations) to give a complete solution. With
        ``refine_best`` the refinements run here, one after the other.
    starts : str
        ``"seeded"`` (default): seeded geodesic guesses (random great circles, control
        noise), one per seed. ``"structured"``: the default strategy's deterministic starts
        (:func:`~workbench.control.ocp.initial.structured_guesses`: the energy-pumping
        start, the direct path, paths with reversals), one start each; ``seeds``, ``noise``
        and ``T_guesses`` then do not apply. Each start is one Ipopt solve from its guess
        (``strategy=Direct()`` unless ``solve_options`` name another), in the handling of
        ``solve_options`` (default ``PROJECTED``): not :class:`Auto`'s relaxation and
        continuation, so a start the default strategy would rescue may fail here.
    executor : dask.distributed.Client or concurrent.futures.Executor, optional
        Run the starts there instead of forked workers (as :func:`workbench.sweep` does).
        An OCP holds casadi graphs and the user's cost functions, which do not pickle: a
        worker receives ``build`` instead, calls it once, and builds its transcriptions
        itself; it returns numbers only, and each converged end point is re-solved here (a
        warm start: a few iterations) before ``describe`` sees it. A dask worker runs its
        linear algebra on one thread (its nanny sets ``OMP_NUM_THREADS=1``): a long solve
        can end at another minimum than it does here.
    build : callable, optional
        With ``executor``: a picklable function of no argument returning ``ocp`` (a
        module-level function, or ``functools.partial`` of one); checked here to give the
        same problem (model, start, target, bounds, horizon).
    **solve_options
        Passed to :func:`solve` (``raise_on_failure`` is forced off for the starts).

    Returns
    -------
    (OCPSolution, list of dict)
        The converged solution of least cost, and one record per start: ``seed``,
        ``status``, ``objective``, ``T``, ``iterations`` (one entry per solve),
        ``solve_seconds`` (all its solves), ``coarse_objective``, ``ipopt_variant``,
        ``refined`` (whether it went through ``refine_with``), ``reached_best``, and the
        fields of ``describe``.

    Raises
    ------
    SolverError
        If no start converged (with ``refine_best``: if no refined start converged).
    """
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1; got {workers!r}")
    if starts not in ("seeded", "structured"):
        raise ParameterError(f"starts must be 'seeded' or 'structured'; got {starts!r}")
    if starts == "seeded":
        seeds = list(seeds) if isinstance(seeds, (list, tuple, range)) else seeds
        if not isinstance(seeds, list) or not seeds or not all(
                isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
                and v >= 0 for v in seeds) or len(seeds) > validate.MAX_DIM:
            raise ParameterError(f"seeds must be a non-empty sequence of integers >= 0 (at "
                                 f"most {validate.MAX_DIM}); got {seeds!r}")
    if executor is not None:
        _check_build(ocp, build)
        if workers != 1:
            raise ParameterError("workers applies to forked workers; with an executor, size "
                                 "the executor yourself")
    elif build is not None:
        raise ParameterError("build is what an executor's workers call; got build without "
                             "executor")
    if refine_best is not None and (isinstance(refine_best, bool) or not isinstance(
            refine_best, (int, np.integer)) or refine_best < 1):
        raise ParameterError(f"refine_best must be None or an integer >= 1; got "
                             f"{refine_best!r}")
    if refine_best is not None and not refine_with:
        raise ParameterError("refine_best chooses which starts go through refine_with; "
                             "got refine_best without refine_with")
    later = list(refine_with) if refine_best is not None else []
    if "guess" in solve_options:
        raise ParameterError("multistart makes its own guesses (seeded geodesics); got a "
                             "guess= (solve from it with solve(), or refine it with "
                             "coarse_to_fine())")
    solve_options = dict(solve_options)
    solve_options.pop("raise_on_failure", None)
    labels = (list(seeds) if starts == "seeded" else
              [g.name for g in _structured(ocp)])
    job = {"ocp": ocp, "method": method or Collocation(), "noise": noise, "seeds": labels,
           "starts": starts, "T_guesses": T_guesses, "describe": describe,
           "refine_with": [] if later else list(refine_with),
           "variants": list(ipopt_variants), "options": solve_options,
           "refine_later": bool(later)}
    if executor is not None:
        done = _remote_starts(job, executor, build)
    elif workers == 1 or len(job["seeds"]) < 2:
        done = [_one_start(job, i) for i in range(len(job["seeds"]))]
    else:
        done = _parallel_starts(job, int(workers))
    if later:  # refine the best refine_best coarse starts only, here
        done = _refine_best(ocp, job, done, later, int(refine_best), solve_options)
    records = [d[0] for d in done]
    # the starts that are judged: refined ones (every start without refine_with)
    counted = [i for i, r in enumerate(records) if r["refined"] or not refine_with]
    ok = [(records[i]["objective"], i) for i in counted
          if records[i]["status"] in ("SUCCESS", "ACCEPTABLE")]
    if not ok:
        what = (f"none of the {len(counted)} refined starts (the cheapest of the "
                f"converged coarse ones) converged" if later and counted else
                f"none of {len(records)} starts converged")
        raise SolverError(f"OCP {ocp.name!r}: {what}", status=records[
            counted[-1] if counted else -1]["status"] if records else "")
    i_best = min(ok)[1]
    best = done[i_best][1]
    if not isinstance(best, OCPSolution):  # a vector from a worker: complete it here
        best = _complete(ocp, best, solve_options)
    best_cost = records[i_best]["objective"]
    judged = set(counted)
    for i, r in enumerate(records):
        r["reached_best"] = bool(r["status"] in ("SUCCESS", "ACCEPTABLE") and i in judged
                                 and abs(r["objective"] - best_cost) <= 1e-6 * max(1, best_cost))
    return best, records


def _refine_best(ocp: OCP, job: dict[str, Any], done: list[tuple], methods: list,
                 k: int, options: dict[str, Any]) -> list[tuple]:
    """Refine the ``k`` converged coarse starts of least cost; mark every record."""
    ranked = sorted((r["objective"], i) for i, (r, _) in enumerate(done)
                    if r["status"] in ("SUCCESS", "ACCEPTABLE"))
    chosen = {i for _, i in ranked[:k]}
    out = []
    for i, (record, first) in enumerate(done):
        record["refined"] = i in chosen
        ok = record["status"] in ("SUCCESS", "ACCEPTABLE")
        if ok and not isinstance(first, OCPSolution):  # a vector from a worker: re-solved
            first = _complete(ocp, first, options)  # here from it (a few iterations)
            ok = first.status.ok
        s = first
        if i in chosen:
            s, path = coarse_to_fine(ocp, methods, guess=first, raise_on_failure=False,
                                     **options)
            record.update({
                "status": s.status.name, "objective": s.objective, "T": s.T,
                "iterations": record["iterations"] + [p.cost["iterations"] for p in path],
                "solve_seconds": record["solve_seconds"] + float(
                    sum(p.cost["solve_seconds"] for p in path))})
            ok = s.status.ok
        if job["describe"] is not None and ok:  # a converged minimum, refined or coarse
            record.update(job["describe"](s))
        out.append((record, s))
    return out


_JOB: dict[str, Any] = {}
"""The multistart job of the parent, inherited by forked workers (never pickled)."""


def _structured(ocp: OCP) -> list[Any]:
    """The structured starts of ``ocp`` (made once per problem, cached on it).

    The cache is shared with the problem's :meth:`~OCP.with_bounds` copies, whose starts
    differ (the inputs' bounds and the horizon shape them): it is keyed by both.
    """
    from workbench.control.ocp.initial import structured_guesses

    key = ("structured_guesses", tuple(ocp.u_lower), tuple(ocp.u_upper), ocp.T_range)
    if key not in ocp._cache:
        ocp._cache[key] = structured_guesses(ocp)
    return ocp._cache[key]


def _one_start(job: dict[str, Any], i: int) -> tuple[dict[str, Any], OCPSolution | None]:
    """Start ``i`` of a multistart job: guess, solve, refine; its record and end point."""
    ocp, seed = job["ocp"], job["seeds"][i]
    if job.get("starts") == "structured":
        g = _structured(ocp)[i].guess
    else:
        rng = np.random.default_rng(seed)
        T = None if not job["T_guesses"] else job["T_guesses"][i % len(job["T_guesses"])]
        g = Guess.geodesic(ocp, T=T, rng=rng, noise=job["noise"])
    variant = dict(job["variants"][i % len(job["variants"])]) if job["variants"] else {}
    options = job["options"]
    first_options = dict(options)
    if job["refine_with"] or job["refine_later"]:  # a coarse start is a means: judged
        # after its refinement
        first_options.setdefault("defect_tol", None)
    if variant:
        first_options["ipopt_options"] = {**(options.get("ipopt_options") or {}), **variant}
    first = _direct(ocp, job["method"], guess=g, raise_on_failure=False, **first_options)
    s, path = first, [first]
    if first.status.ok and job["refine_with"]:
        s, rest = coarse_to_fine(ocp, job["refine_with"], guess=first, raise_on_failure=False,
                                 **options)
        path += rest
    record = {
        "seed": seed if isinstance(seed, str) else int(seed), "status": s.status.name,
        "objective": s.objective, "T": s.T,
        "iterations": [p.cost["iterations"] for p in path],
        "solve_seconds": float(sum(p.cost["solve_seconds"] for p in path)),
        "coarse_objective": path[0].objective,
        "ipopt_variant": variant,
        "refined": bool(job["refine_with"]) and first.status.ok,
    }
    if job["describe"] is not None and s.status.ok and not job["refine_later"]:
        record.update(job["describe"](s))  # refined later: described by _refine_best
    return record, s


def _worker_start(i: int) -> tuple[dict[str, Any], tuple]:
    """Run start ``i`` of the inherited job; return numbers only."""
    record, s = _one_start(_JOB, i)
    return record, (s.method, s.w, s.lam_x, s.lam_g)


def _parallel_starts(job: dict[str, Any], workers: int) -> list[tuple]:
    """Solve the starts in forked processes (transcriptions built here first)."""
    from workbench.simulation import OnError, StartMethod, sweep

    handling = job["options"].get("handling") or DEFAULT_HANDLING
    graph = job["options"].get("graph", Symbolic.SX)
    opts = job["options"]
    defaults = inspect.signature(solve).parameters
    ipopt = _ipopt_options(*(opts.get(k, defaults[k].default)
                             for k in ("tol", "max_iter", "print_level", "ipopt_options")))
    for m in [job["method"], *job["refine_with"]]:  # and their Ipopt instances: a worker
        tr, _ = transcribe(job["ocp"], m, handling=handling, graph=graph)  # would make its own
        tr.solver(ipopt, opts.get("compiled"))
        for variant in job["variants"]:
            if variant and m is job["method"]:
                tr.solver({**ipopt, **variant}, opts.get("compiled"))
    _JOB.clear()
    _JOB.update(job)
    try:
        out = sweep(_worker_start, [{"i": i} for i in range(len(job["seeds"]))],
                    workers=min(workers, len(job["seeds"])), start_method=StartMethod.FORK,
                    on_error=OnError.RAISE, progress=False, desc="multistart")
    finally:
        _JOB.clear()
    return [tuple(v) for v in out.values()]


_BUILT: dict[bytes, OCP] = {}
"""Problems a worker built from ``build`` functions (one per function, kept for its life)."""


def _check_build(ocp: OCP, build: Any) -> None:
    """``build`` must be picklable and give ``ocp``'s problem (checked on its data)."""
    import pickle

    if build is None or not callable(build):
        raise ParameterError(f"build must be a function of no argument returning the OCP (an "
                             f"executor's workers call it); got {build!r}")
    try:
        pickle.dumps(build)
    except Exception as exc:  # noqa: BLE001 - any pickling failure is the caller's to fix
        raise ParameterError(f"build must be picklable (a module-level function or a "
                             f"functools.partial of one, not a lambda or closure); got "
                             f"{build!r} ({exc})") from exc
    other = build()
    same = (isinstance(other, OCP) and other.model.name == ocp.model.name
            and np.array_equal(other.x0, ocp.x0)
            and np.array_equal(other.target.witness, ocp.target.witness)
            and np.array_equal(other.u_lower, ocp.u_lower)
            and np.array_equal(other.u_upper, ocp.u_upper) and other.T_range == ocp.T_range
            and np.array_equal(other.model.p, ocp.model.p))
    if not same:
        raise ParameterError("build() must return the same problem as ocp (model, parameters, "
                             "x0, target, bounds, horizon); it returned another")


def _remote_start(build: Callable[[], OCP], i: int, spec: dict[str, Any]
                  ) -> tuple[dict[str, Any], tuple]:
    """Start ``i`` on an executor's worker: the problem built there once; numbers back."""
    import pickle

    key = pickle.dumps(build)
    if key not in _BUILT:
        _BUILT[key] = build()
    record, s = _one_start({**spec, "ocp": _BUILT[key], "describe": None}, i)
    return record, (s.method, s.w, s.lam_x, s.lam_g)


def _remote_starts(job: dict[str, Any], executor: Any, build: Callable[[], OCP]
                   ) -> list[tuple]:
    """Every start on ``executor``; ``describe`` applied here to each converged end point."""
    from workbench.simulation import OnError, sweep

    spec = {k: v for k, v in job.items() if k not in ("ocp", "describe")}
    out = sweep(_remote_start, [{"build": build, "i": i, "spec": spec}
                                for i in range(len(job["seeds"]))],
                executor=executor, on_error=OnError.RAISE, progress=False, desc="multistart")
    done = [tuple(v) for v in out.values()]
    if job["describe"] is not None and not job["refine_later"]:
        for i, (record, point) in enumerate(done):
            if record["status"] in ("SUCCESS", "ACCEPTABLE"):  # describe a real solution:
                s = _complete(job["ocp"], point, job["options"])  # re-solved here from the
                if s.status.ok:  # worker's end point (a warm start: a few iterations)
                    record.update(job["describe"](s))
                    done[i] = (record, s)
    return done


def _complete(ocp: OCP, point: tuple, options: dict[str, Any]) -> OCPSolution:
    """The solution at a worker's end point ``(method, w, lam_x, lam_g)``, re-solved here.

    A warm start of the same transcription from a converged point: Ipopt confirms it in a
    few iterations and the result carries everything a solution has (cost, errors, local
    defect), not only the vector.
    """
    m, w, lam_x, lam_g = point
    return _direct(ocp, m, guess=_warm(ocp, m, w, lam_x, lam_g, options),
                   raise_on_failure=False, **options)


def _warm(ocp: OCP, method: TranscriptionMethod, w: np.ndarray, lam_x: np.ndarray,
          lam_g: np.ndarray, options: dict[str, Any]) -> OCPSolution:
    """A primal-dual point of a transcription as a solution object, only to warm-start from.

    Its status, cost and errors are not measured (a worker's numbers): never returned or
    described, only passed as ``guess=`` to a solve (see :func:`_complete`).
    """
    handling = options.get("handling") or DEFAULT_HANDLING
    graph = options.get("graph", Symbolic.SX)
    tr, _ = transcribe(ocp, method, handling=handling, graph=graph)
    X, U, T = tr.unpack(w)
    return OCPSolution(status=OCPStatus.NOT_SOLVED, ipopt_status="(a worker's end point)",
                       objective=float("nan"),
                       T=T, t=tr.times(T), x=X, u=U, method=method, handling=handling,
                       graph=graph, cost={}, error={}, ocp=ocp, w=w, lam_x=lam_x,
                       lam_g=lam_g)


def coarse_to_fine(
    ocp: OCP,
    methods: Sequence[TranscriptionMethod],
    *,
    guess: Guess | OCPSolution | None = None,
    **solve_options: Any,
) -> tuple[OCPSolution, list[OCPSolution]]:
    """Solve with each transcription in turn, each warm-started by the previous solution.

    A coarse transcription is cheap per iteration and absorbs most of the iterations from a
    poor guess; the fine one then converges in a few. Stops at the first failure. The local
    defect is judged on the last transcription only (``defect_tol=None`` on the coarse
    ones unless given): a coarse level is a guess for the next, not a result.

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
    for k, m in enumerate(methods):
        options = dict(solve_options)
        if k < len(methods) - 1:  # coarse levels are a means: the last one is judged
            options.setdefault("defect_tol", None)
        s = _direct(ocp, m, guess=current, raise_on_failure=raise_on_failure, **options)
        path.append(s)
        if not s.status.ok:
            break
        current = s
    return path[-1], path


def refine(solution: OCPSolution, method: TranscriptionMethod, **solve_options: Any) -> OCPSolution:
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
    return _direct(solution.ocp, method, guess=solution.guess(), **solve_options)


def homotopy(
    ocp: OCP,
    method: TranscriptionMethod | None = None,
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
        s = _direct(problem, method, guess=current, **solve_options)
        sols.append(s)
        current = s
    return sols[-1], sols
