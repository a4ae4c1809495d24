"""Drake's swing-up, posed identically in Drake and in the workbench: CPU medians and ratios.

The problem: a spherical pendulum on a cart, tip mass 0.1 kg on a massless link of 0.1 m,
cart 0.5 kg moving in the horizontal plane under a horizontal force ``u`` in R^2,
g = 9.81. 41 knots with equal intervals, cost ``integral u'u dt`` (the trapezoid over the
knots) ``+ T``, ``|u_i| <= 10 N``, ``T in [0.5, 3] s``; from hanging at rest with the cart
at the origin to upright at rest, with the cart back at the origin (``origin``) or anywhere
(``free``). Initial guess: ``u = 0`` and the straight swing (the state interpolated
linearly in Drake's coordinates, a great circle in ours) over ``T = 1.5 s``.

Drake's side (when ``pydrake`` is installed; ``pip install
'geometric-pendulum-workbench[peers]'``) is ``problems/_drake_peer.py``, written as Drake's
docs write one: a MultibodyPlant (two prismatic joints for the cart, a UniversalJoint for
the pendulum: two angles, Drake has no S^2), ``pydrake.planning.DirectCollocation``
(Hermite-Simpson, first-order-hold controls, trapezoidal running cost) with
``AddEqualTimeIntervalsConstraints``, ``AddDurationBounds``, bounding boxes on the inputs
and the boundary states, solved by Drake's ``IpoptSolver`` with its default options (a
limited-memory Hessian: Drake gives Ipopt no second derivatives; SPRAL). It is timed twice
per round: with Ipopt's output file (the iteration count is read from it) and with no
options at all, to show the log costs nothing. CPU seconds are ``time.process_time``
around ``Solve`` (building the program excluded).

The workbench's side is its default call, ``solve(ocp, HermiteSimpson(N=40),
guess=<Drake's guess>)``: every solve of the default strategy counted (an ambient
relaxation, then the projected NLP warm-started from it, whose nodes are on TS^2 to
1e-10), building excluded as on Drake's side; and the same call compiled (``Compiled()``).
A ratio is printed only where the workbench's cost is at most Drake's (else the table
says which is lower). Both sides run interleaved round by round and the medians of the
CPU times are compared. Without Drake, the figures recorded in ``problems/_drake_peer.py``
are printed, labelled as recorded. This script installs nothing.

Also measured: the workbench's own reference swing-up (``swingup_spherical_cart``) from
the defaults, multistart of its 12 seeded starts in processes on all cores, and the
compiled NLP (``Compiled()``: build seconds against solve seconds) on the reduced 3D
pendulum. The load average is printed: the machine is shared.

The compiled NLP of Drake's problem (per-interval derivatives: several MB of C, about a
minute of gcc -O1 once, then cached by hash) is timed beside the uncompiled one;
``--no-compiled`` skips it.

Usage: python benchmarks/bench_drake_swingup.py [--quick] [--repeat K] [--drake-only]
[--no-compiled]
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import table  # noqa: E402

from problems import _drake_peer as peer  # noqa: E402

TARGET_RATIO = 10.0
TARGET_COMPILED = 30.0


# workbench -----------------------------------------------------------------------------


def workbench_problem(*, cart_free: bool):
    """The same problem on the workbench: (OCP, transcription, guess, solve options)."""
    from problems import swingup_drake_reference as ref

    return ref.problem(cart_free=cart_free), ref.METHOD, ref.drake_guess, ref.SOLVE_OPTIONS


def workbench_solve(setup, compiled=None) -> dict:
    """The workbench's default solve of the problem from Drake's guess (builds cached).

    Its CPU seconds are those of every solve its default strategy made (an ambient
    relaxation, then the on-manifold polish: ``cost["strategy_cpu_seconds"]``), building
    excluded as on Drake's side. With ``compiled`` (a
    :class:`~workbench.control.ocp.Compiled`), the NLP's functions run from a C library
    compiled once (its one-off cost is in ``cost["compile"]``).
    """
    from workbench.control.ocp import solve

    ocp, method, guess, options = setup
    s = solve(ocp, method, guess=guess(ocp), raise_on_failure=False, compiled=compiled,
              **options)
    return {"side": "workbench", "cpu": s.cost["strategy_cpu_seconds"],
            "iterations": "+".join(str(a["iterations"]) for a in s.attempts),
            "cost": s.objective, "ok": s.status.ok, "status": s.status.name,
            "residual": s.error["manifold_residual"], "gauge": s.gauge,
            "compile": (s.cost.get("compile") or {})}


def _median(rows, key):
    return statistics.median(r[key] for r in rows)


def _ratio(drake: dict, ours_cpu: float, ours_cost: float) -> str:
    """Drake's CPU over ours, quoted only for a cost at most Drake's (else which is lower)."""
    if ours_cost <= drake["cost"] * (1 + 1e-9):
        return f"{drake['cpu'] / ours_cpu:.1f}"
    return f"none (cost {ours_cost:.6f} > Drake's {drake['cost']:.6f})"


def main() -> None:
    quick = "--quick" in sys.argv
    repeat = 1 if quick else 3
    if "--repeat" in sys.argv:
        repeat = int(sys.argv[sys.argv.index("--repeat") + 1])
    from workbench.control.ocp import Compiled

    compiled = None if "--no-compiled" in sys.argv else Compiled()
    have_drake = peer.drake_available()
    plant = peer.drake_plant() if have_drake else None
    rows = []
    for case in ("origin", "free"):
        free = case == "free"
        setup = workbench_problem(cart_free=free)
        if compiled is not None:  # generate and compile once (cached by hash), untimed
            first = workbench_solve(setup, compiled)["compile"]
        workbench_solve(setup)  # the transcriptions' builds, untimed (Drake's build is too)
        drake_runs, bare, ours, comp = [], [], [], []
        for _ in range(repeat):  # interleaved: drake, drake bare, ours, ours compiled, ...
            if have_drake:
                drake_runs.append(peer.drake_solve(plant, cart_free=free))
                bare.append(peer.drake_solve(plant, cart_free=free, count_iterations=False))
            ours.append(workbench_solve(setup))
            if compiled is not None:
                comp.append(workbench_solve(setup, compiled))
        if have_drake:
            d = {"cpu": _median(drake_runs, "cpu"), "bare": _median(bare, "cpu"),
                 **{k: drake_runs[-1][k] for k in ("iterations", "cost", "status")},
                 "source": "measured"}
        else:
            rec = peer.RECORDED[case]
            d = {"cpu": rec["cpu_seconds"], "bare": float("nan"), "cost": rec["cost"],
                 "iterations": rec["iterations"], "status": "n/a",
                 "source": "RECORDED (problems/_drake_peer.py)"}
        w_cpu = _median(ours, "cpu")
        row = {
            "case": f"cart {case}", "drake": d["source"],
            "drake cpu s": f"{d['cpu']:.3f}", "drake (no options) cpu s": f"{d['bare']:.3f}",
            "drake it": d["iterations"], "drake cost": f"{d['cost']:.6f}",
            "ours cpu s": f"{w_cpu:.3f}", "ours it": ours[-1]["iterations"],
            "ours cost": f"{ours[-1]['cost']:.6f}", "ours status": ours[-1]["status"],
            "node residual": f"{ours[-1]['residual']:.1e}",
            "ratio (cpu)": _ratio(d, w_cpu, ours[-1]["cost"]),
        }
        ok = row["ratio (cpu)"][0].isdigit() and float(row["ratio (cpu)"]) >= TARGET_RATIO
        row["target"] = f"{'met' if ok else 'MISSED'} (>= {TARGET_RATIO:g}x)"
        if comp:
            c_cpu = _median(comp, "cpu")
            c_ratio = _ratio(d, c_cpu, comp[-1]["cost"])
            c_ok = c_ratio[0].isdigit() and float(c_ratio) >= TARGET_COMPILED
            row.update({
                "compiled cpu s": f"{c_cpu:.3f}", "compiled it": comp[-1]["iterations"],
                "compiled cost": f"{comp[-1]['cost']:.6f}", "ratio compiled": c_ratio,
                "target compiled": f"{'met' if c_ok else 'MISSED'} (>= {TARGET_COMPILED:g}x)",
                "compile s (once)": f"{first.get('compile_seconds', 0.0):.0f}"
                                    f"{' (cached)' if first.get('cached') else ''}, "
                                    f"{first.get('source_mb', 0.0):.1f} MB C"})
        rows.append(row)
    if not have_drake:
        print("drake not installed: Drake's figures below are RECORDED (problems/_drake_peer.py),"
              " not measured in this run (pip install 'geometric-pendulum-workbench[peers]')")
    print(table(rows, ["case", "drake", "drake cpu s", "drake (no options) cpu s", "drake it",
                       "drake cost", "ours cpu s", "ours it", "ours cost", "ours status",
                       "node residual", "ratio (cpu)", "target"]))
    if any("compiled cpu s" in r for r in rows):
        print("the same default solves with the NLP compiled (Compiled(): gcc -O1, cached by "
              "hash; the compile is a one-off build cost, excluded like Drake's program build):")
        print(table(rows, ["case", "drake cpu s", "compiled cpu s", "compiled it",
                           "compiled cost", "ratio compiled", "target compiled",
                           "compile s (once)"]))
    print(f"(CPU-time medians of {repeat} interleaved runs; ours: every attempt of the default "
          f"strategy (iterations per attempt, relaxation + polish); building excluded on both "
          f"sides; a ratio only where our cost is at most Drake's; load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; gauge: {ours[-1]['gauge']})")
    if "--drake-only" not in sys.argv:
        others()


def others() -> None:
    """The reference swing-up's iterations, multistart on all cores, the compiled NLP."""
    from problems import swingup_spherical_cart as cart
    from workbench.control.ocp import (
        Collocation,
        Compiled,
        Direct,
        Guess,
        HermiteSimpson,
        multistart,
        solve,
        transcribe,
    )
    from workbench.control.ocp.study import effort_time_ocp

    ocp = cart.problem()
    s = solve(ocp, Collocation(N=40), raise_on_failure=False)
    print(f"reference swing-up, the defaults, Legendre N = 40: {s.status.name}, "
          f"{len(s.attempts)} solves, {sum(a['iterations'] for a in s.attempts)} iterations, "
          f"cost {s.objective:.4f}, CPU {s.cost['strategy_cpu_seconds']:.2f} s; {s.gauge}")
    ladder = [Collocation(N=n) for n in (10, 20, 40)]
    for m in ladder:  # built once before timing: the workers inherit the builds
        transcribe(ocp, m)
    workers = os.cpu_count() or 1
    t0 = time.perf_counter()
    best, rec = multistart(ocp, ladder[0], seeds=range(12), T_guesses=cart.T_GUESSES,
                           refine_with=ladder[1:], max_iter=150, workers=workers)
    wall = time.perf_counter() - t0
    n = sum(r["reached_best"] for r in rec)
    print(f"multistart, 12 starts N = 10 -> 20 -> 40 on {workers} processes: {wall:.2f} s wall "
          f"(target < 3 s on 2 cores; builds excluded), best {best.objective:.4f} reached by "
          f"{n} of 12 (best known 4.2351), load {os.getloadavg()[0]:.1f}")
    from models import pendulum3d as p3

    body = p3.reduced(J=np.diag([0.13, 0.28, 0.17]), rho=[0, 0, 0.3], m=1.0, g=9.81)
    e3 = np.eye(3)[2]
    pend = effort_time_ocp(body, np.r_[e3, 0.0, 0.0, 0.0], np.r_[-e3, 0.0, 0.0, 0.0],
                           u_max=3.0, T=(0.5, 3.0), name="bench_compiled")
    g = Guess.geodesic(pend, T=1.5, rng=np.random.default_rng(3), noise=0.3)
    for comp in (None, Compiled()):
        t0 = time.perf_counter()
        first = solve(pend, HermiteSimpson(N=60), guess=g, compiled=comp,
                      strategy=Direct(), raise_on_failure=False)
        build = time.perf_counter() - t0 - first.cost["solve_seconds"]
        cpu = statistics.median(
            solve(pend, HermiteSimpson(N=60), guess=g, compiled=comp, strategy=Direct(),
                  raise_on_failure=False).cost["solve_cpu_seconds"] for _ in range(3))
        info = first.cost["compile"] or {}
        print(f"3D pendulum (reduced), HS N = 60, {'compiled' if comp else 'casadi VM'}: "
              f"build+first-call overhead {build:.2f} s"
              + (f" (generate {info['generate_seconds']:.2f} s, compile "
                 f"{info['compile_seconds']:.2f} s, {info['source_mb']:.1f} MB of C, cached "
                 f"{info['cached']})" if info else "")
              + f", solve CPU median {cpu:.3f} s, {first.cost['iterations']} iterations, "
                f"cost {first.objective:.5f}")


if __name__ == "__main__":
    main()
