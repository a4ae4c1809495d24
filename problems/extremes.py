"""Numerical extremes: what the workbench does at the edges of its domain.

The workbench is pushed to where numerical methods break: a pendulum almost balanced on
its pivot, an inertia with a condition number of 10^8, spins of a thousand radians per
second, orbits next to a separatrix, horizons of 10^5 s, continuation next to the
singular points of Proposition 9, chains of 20 and 50 links, swing-ups with hardly enough
force or time, and bad input. Every case either gives a result whose error estimate is
within its stated tolerance, or fails with a documented error that says why; none does
anything else.
"""

from __future__ import annotations

import numpy as np

from problems._extremes import (
    bad_inputs,
    continuation,
    fast_and_slow,
    ill_conditioned,
    large_chains,
    near_balanced,
    optimisation,
)
from workbench.study import CORRECT, Cases, Panel, Result, line_figure

TITLE = ("Numerical extremes: near balance, ill-conditioned inertia, fast and slow motion, "
         "singular continuation, large chains, bad input")


def solve(*, quick: bool = False) -> Result:
    """Run every case.

    Parameters
    ----------
    quick : bool
        Shorter horizons (10^3 s instead of 10^5 s), no n = 50 chain, fewer scales.

    Returns
    -------
    Result
        ``values`` holds one table (list of rows) per group and ``outcomes`` (counts).

    Notes
    -----
    Every case runs one public entry point at an extreme and is tabulated with what the
    workbench did, the outcome, the error estimate and the cost (the case machinery is
    :class:`workbench.study.Cases`; the groups are in ``problems/_extremes/``). The outcome
    is ``correct`` when the result carries an error (against a closed form, a reference
    run, or the method's own estimate) at or below the stated tolerance, ``clear failure``
    for a documented :class:`~workbench.core.errors.WorkbenchError` whose message says what
    failed (or a count of failures turned into such a message), and ``DEFECT`` for
    anything else; the tests require that no case is a defect.

    Groups: the near-balanced pendulum (|rho| from 1e-2 to 0; equilibria, spectra
    (3.22)-(3.28) and LQR); ill-conditioned inertia (cond J to 1e8) and nearly equal
    principal moments beside Prop. 9 case 7(a); fast and slow motion (spin 1e3 rad/s
    against the sleeping top's closed form, periods near the separatrix, horizons of 10^5 s
    for the geometric integrators); continuation near the singular values alpha = 0 and
    1/J_i of Prop. 9; large chains (n = 20, and n = 50 when not quick), each in a forked
    process whose peak resident memory is reset at its start, so that the memory a case
    adds is its own; the swing-up optimisation at
    nearly infeasible bounds and very short and very long horizons (Ipopt's status, and
    the transcription's local defect against CVODES); a sample of bad inputs.
    """
    res = Result("extremes", TITLE, quick=quick)
    cases = Cases()
    scales = [1e-2, 1e-6, 1e-10, 0.0] if quick else [1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 0.0]
    conds = [1e2, 1e8] if quick else [1e2, 1e4, 1e6, 1e8]
    with res.timed("near-balanced pendulum"):
        near_balanced(cases, res, scales)
    with res.timed("ill-conditioned inertia"):
        ill_conditioned(cases, res, conds, quick=quick)
    with res.timed("fast and slow motion"):
        fast_and_slow(cases, res, quick=quick)
    with res.timed("continuation near singular points"):
        continuation(cases, res, quick=quick)
    with res.timed("large chains"):
        large_chains(cases, res, quick=quick)
    with res.timed("optimisation"):
        optimisation(cases, res, quick=quick)
    with res.timed("bad input"):
        bad_inputs(cases)
    res.values = {**cases.groups, "outcomes": cases.outcomes()}
    res.figure("errors", _figure(cases), caption=(
        "Every case that gave a result, by group: its error estimate as a fraction of the "
        "tolerance it is held to (left; below 1 is correct), and the wall time of every "
        "case including the ones that failed clearly (right)."))
    res.notes.append("outcome 'correct': the error (against the closed form, a reference run "
                     "or the method's own estimate) is within the stated tolerance; 'clear "
                     "failure': a documented WorkbenchError with its message; DEFECT would be "
                     "anything else (none is allowed)")
    res.notes.append("each case builds its own models (dozens); their build logs are not "
                     "collected here, the cost column is each case's wall time including builds")
    return res.finish()


def _figure(cases: Cases):  # noqa: ANN202
    ratio, cost, start = {}, {}, 0
    for group, rows in cases.groups.items():
        idx = np.arange(start, start + len(rows))
        start += len(rows)
        cost[group] = (idx, [r["cost [s]"] for r in rows])
        ok = [(i, max(r["error"] / r["tolerance"], 1e-17)) for i, r in zip(idx, rows)
              if r["outcome"] == CORRECT and r["tolerance"]]
        if ok:
            ratio[group] = tuple(zip(*ok))
    return line_figure([
        Panel("error / tolerance of each correct case", ratio, xlabel="case",
              yscale="log", marker="o", linestyle=""),
        Panel("cost of each case", cost, xlabel="case", ylabel="wall time [s]",
              yscale="log", marker="o", linestyle="")], legend="below")


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
