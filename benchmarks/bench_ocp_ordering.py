"""MUMPS's ordering in the OCP's default Ipopt options: CPU and the optimum reached, per problem.

The ordering (``mumps_pivot_order``) changes no equation, but it changes the pivots, hence
the inertia corrections and the path Ipopt takes: both the cost per iteration and the
minimum a solve ends in. Each swing-up below is solved by the default call,
``solve(ocp, method)`` (the Auto strategy, every attempt counted), with METIS (5) and with
MUMPS's automatic choice (7), interleaved round by round; the table prints the CPU
medians, the iterations, the cost reached and the ratio. The load average is printed: the
machine is shared.

Measured once (load 2.0, 2 cores): METIS as fast or faster on 6 of 8 cases (the automatic
ordering takes 1.0-5x its CPU, the acrobot's 5x for a cheaper minimum, 36.6 against 67.1);
the automatic ordering wins on the double cartpole, 1.55x at N = 80 and 13x at N = 120,
where METIS's run takes 243 iterations at 92 ms. METIS stays the default.

Usage: python benchmarks/bench_ocp_ordering.py [--quick] [--repeat K]
"""

from __future__ import annotations

import os
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import quick_repeat_arguments, table  # noqa: E402

ORDERINGS = {"METIS (5)": 5, "automatic (7)": 7}


def cases(quick: bool) -> dict:
    """Name -> (OCP, transcription, guess or None): the default calls of the swing-ups."""
    from problems import swingup_acrobot as acro
    from problems import swingup_double_cartpole as dcp
    from problems import swingup_drake_reference as drake
    from problems import swingup_furuta as fur
    from problems import swingup_rail_pendulum as rail
    from problems import swingup_spherical_cart as cart
    from workbench.control.ocp import Collocation

    out = {"drake origin (HS 40, Drake's guess)": (drake.problem(), drake.METHOD, "drake"),
           "drake free (HS 40, Drake's guess)": (drake.problem(cart_free=True), drake.METHOD,
                                                 "drake"),
           "spherical cart (N = 40)": (cart.problem(), Collocation(N=40), None),
           "furuta 0.01 N m (N = 60)": (fur.problem(), Collocation(N=60), None),
           "rail pendulum (N = 60)": (rail.problem(), rail.METHOD, None)}
    if not quick:
        out["acrobot (N = 70)"] = (acro.problem(), Collocation(N=70), None)
        out["double cartpole (N = 80)"] = (dcp.problem(), Collocation(N=80), None)
        out["double cartpole (N = 100)"] = (dcp.problem(), Collocation(N=100), None)
        out["double cartpole (N = 120)"] = (dcp.problem(), Collocation(N=120), None)
    return out


def run(ocp, method, guess, ordering: int) -> dict:
    """One default solve with ``ordering`` as MUMPS's ordering."""
    from problems import swingup_drake_reference as drake
    from workbench.control.ocp import solve as solve_module_function

    solve_mod = sys.modules["workbench.control.ocp.solve"]  # the package's `solve` is the

    solve_mod.MUMPS_ORDERING = ordering  # function, which shadows the module's name
    g = drake.drake_guess(ocp) if guess == "drake" else None
    s = solve_module_function(ocp, method, guess=g, raise_on_failure=False)
    return {"cpu": s.cost.get("strategy_cpu_seconds", s.cost["solve_cpu_seconds"]),
            "iterations": sum(a["iterations"] for a in s.attempts), "cost": s.objective,
            "status": s.status.name, "attempts": len(s.attempts)}


def main(argv: list[str] | None = None) -> None:
    a = quick_repeat_arguments(__doc__, "the five fastest cases, one round", argv or [],
                               repeat=3)
    repeat = 1 if a.quick else a.repeat
    rows = []
    for name, (ocp, method, guess) in cases(a.quick).items():
        for o in ORDERINGS.values():  # builds and first solves, untimed
            run(ocp, method, guess, o)
        samples = {k: [] for k in ORDERINGS}
        for _ in range(repeat):
            for k, o in ORDERINGS.items():
                samples[k].append(run(ocp, method, guess, o))
        row = {"case": name}
        med = {}
        for k, runs in samples.items():
            med[k] = statistics.median(r["cpu"] for r in runs)
            last = runs[-1]
            row[f"{k} cpu s"] = f"{med[k]:.2f}"
            row[f"{k} it"] = last["iterations"]
            row[f"{k} cost"] = f"{last['cost']:.4f} {last['status'][:4]}"
        a5, a7 = (med[k] for k in ORDERINGS)
        row["cpu 5/7"] = f"{a5 / a7:.2f}"
        rows.append(row)
    sys.modules["workbench.control.ocp.solve"].MUMPS_ORDERING = 5
    cols = ["case"] + [f"{k} {c}" for k in ORDERINGS for c in ("cpu s", "it", "cost")]
    print(table(rows, cols + ["cpu 5/7"]))
    print(f"(CPU medians of {repeat} interleaved rounds of the default solve, every attempt of "
          f"its strategy counted, builds excluded; a different cost is a different local "
          f"minimum; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main(sys.argv[1:])
