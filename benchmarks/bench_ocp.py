"""Swing-up OCPs: median Ipopt solve times against a same-run baseline (building excluded).

Targets of issue 8 (2 shared cores): the spherical cart reference case at N = 40 under
0.5 s (a widely used peer needs about 5 s), the double cart under 5 s, the 3D pendulum
under 2 s. For each scene and each variant (graph SX or MX, ambient or Lie group
handling) the script prints the build time (once; excluded from the solve times), and the
median over repeats of:

* ``cold``: one solve at the target N from the scene's deterministic guess;
* ``cascade``: the same guess solved at coarse N and refined to the target N (the sum of
  the solve times: the strategy :func:`workbench.control.ocp.coarse_to_fine`);
* ``warm``: a re-solve from the converged primal-dual solution (continuation steps).

with the iterations, the cost reached and the status, and the ratio of each median to the
baseline variant of the same run (the first of each scene: the model's own MX graph,
ambient coordinates; for the double, whose ambient solves crawl, MX Lie group). CPU
seconds are printed beside wall seconds: other engineers share the cores. The double's
guess (the surrogate single link, see the problem) is computed before timing; N = 20 is
too coarse for the double to be a cascade level (local defects of order 10).

Multistart on all cores (issue 17; target: the best known minimum 4.2351 of the cart
reference case in < 3 s wall on 2 cores): the old way, 12 seeded geodesic starts N = 10 ->
20 -> 40 (:func:`workbench.control.ocp.multistart`, forked workers), against two pumping
guesses (3 and 4 reversals over T = 2 s, :func:`~workbench.control.ocp.study.pumping_guess`)
N = 20 -> 40 in one forked pool (:func:`~workbench.control.ocp.study.parallel_starts`),
run to the end and stopped at the best known cost (the stop is reported), timed in turn
round after round: medians of wall seconds and of CPU seconds (this process and its
workers), the best cost and how many starts reached it, the ratio to the old way, the load
average. Transcriptions and Ipopt instances are built once before timing (their seconds
are printed: a first call pays them).

Usage: python benchmarks/bench_ocp.py [--quick] [--multistart-only]
"""

from __future__ import annotations

import os
import resource
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import table  # noqa: E402

from problems import swingup_3d_pendulum as p3d  # noqa: E402
from problems import swingup_double_spherical_cart as dbl  # noqa: E402
from problems import swingup_spherical_cart as cart  # noqa: E402
from workbench.control.ocp import (  # noqa: E402
    Collocation,
    Guess,
    ManifoldHandling,
    coarse_to_fine,
    multistart,
    solve,
    transcribe,
)
from workbench.control.ocp.study import parallel_starts, pumping_guess  # noqa: E402
from workbench.core import Symbolic  # noqa: E402

BEST_KNOWN = 4.2351
"""Best known local minimum of the cart reference case (docs/science.md: four swings)."""

A, L = ManifoldHandling.AMBIENT, ManifoldHandling.LIE_GROUP


def _median(values):
    return statistics.median(values) if values else float("nan")


def measure(ocp, ladder, guess, graph, handling, repeat, *, max_iter=500):
    """Build, then time cold, cascade and warm solves (medians)."""
    fine = ladder[-1]
    tr, _ = transcribe(ocp, fine, handling=handling, graph=graph)
    build = tr.build_seconds
    for m in ladder[:-1]:
        transcribe(ocp, m, handling=handling, graph=graph)
    cold, cold_cpu, casc, warm = [], [], [], []
    sol = s = None
    for _ in range(repeat):
        s = solve(ocp, fine, guess=guess, graph=graph, handling=handling,
                  raise_on_failure=False, max_iter=max_iter)
        cold.append(s.cost["solve_seconds"])
        cold_cpu.append(s.cost["solve_cpu_seconds"])
        last, path = coarse_to_fine(ocp, ladder, guess=guess, graph=graph, handling=handling,
                                    raise_on_failure=False, max_iter=max_iter)
        casc.append(sum(p.cost["solve_seconds"] for p in path))
        sol = last if last.status.ok else (s if s.status.ok else sol)
        if sol is not None:
            w = solve(ocp, fine, guess=sol, graph=graph, handling=handling,
                      raise_on_failure=False, max_iter=max_iter)
            warm.append(w.cost["solve_seconds"])
    return {
        "variant": f"{graph.value.upper()} {handling.value}",
        "build s": f"{build:.2f}",
        "cold s": f"{_median(cold):.3f}", "cold cpu s": f"{_median(cold_cpu):.3f}",
        "cold it": s.cost["iterations"], "cold status": s.status.name,
        "cold cost": f"{s.objective:.5g}",
        "cascade s": f"{_median(casc):.3f}",
        "cascade it": "+".join(str(p.cost["iterations"]) for p in path),
        "cascade cost": f"{last.objective:.5g}" if last.status.ok else last.status.name,
        "warm s": f"{_median(warm):.3f}",
        "_cold": _median(cold), "_casc": _median(casc), "_warm": _median(warm),
    }


def scene(name, ocp, ladder, guess, variants, baseline, repeat, target, **kw):
    rows = [measure(ocp, ladder, guess, g, h, repeat, **kw) for g, h in variants]
    base = next(r for r, v in zip(rows, variants, strict=True) if v == baseline)
    for r in rows:
        r["scene"] = name
        r["ratio cold"] = f"{r['_cold'] / base['_cold']:.2f}"
        r["ratio casc"] = f"{r['_casc'] / base['_casc']:.2f}"
        best = min(r["_cold"], r["_casc"])
        r["target"] = f"{'met' if best < target else 'MISSED'} (< {target:g} s)"
    return rows


def _cpu() -> float:
    """CPU seconds of this process and of its finished children (the forked workers)."""
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + ch.ru_utime + ch.ru_stime


def multistart_rows(repeat: int) -> list[dict]:
    """The old multistart against the pumping starts in one pool, timed in turn."""
    ocp = cart.problem()
    workers = os.cpu_count() or 1
    t0 = time.perf_counter()
    old_ladder = [Collocation(N=n) for n in (10, 20, 40)]
    for m in old_ladder:
        transcribe(ocp, m)
    print(f"builds N = 10, 20, 40: {time.perf_counter() - t0:.1f} s (once, before timing)")
    guesses = [pumping_guess(ocp, half_swings=k, T=2.0) for k in (3, 4)]
    ladder = [Collocation(N=20), Collocation(N=40)]
    runs = {
        "old: 12 geodesic starts 10->20->40": lambda: multistart(
            ocp, old_ladder[0], seeds=range(12), T_guesses=cart.T_GUESSES,
            refine_with=old_ladder[1:], max_iter=150, workers=workers),
        "2 pumping starts 20->40": lambda: parallel_starts(
            ocp, guesses, ladder, workers=workers, max_iter=150),
        f"2 pumping starts 20->40, stop at {BEST_KNOWN}": lambda: parallel_starts(
            ocp, guesses, ladder, workers=workers, max_iter=150, stop_below=BEST_KNOWN,
            rel_tol=1e-4),
    }
    t0 = time.perf_counter()
    _, _, first = runs["2 pumping starts 20->40"]()  # Ipopt instances of these options
    print(f"first pumping run (creates the Ipopt instances): build "
          f"{first['build_seconds']:.1f} s + pool {first['wall_seconds']:.2f} s")
    samples: dict[str, list] = {k: [] for k in runs}
    for _ in range(repeat):
        for name, fn in runs.items():
            w0, c0 = time.perf_counter(), _cpu()
            out = fn()
            samples[name].append((time.perf_counter() - w0, _cpu() - c0, out,
                                  os.getloadavg()[0]))
    rows = []
    base_wall = statistics.median(s[0] for s in samples[next(iter(runs))])
    for name, ss in samples.items():
        wall = statistics.median(s[0] for s in ss)
        cpu = statistics.median(s[1] for s in ss)
        best, rec = ss[-1][2][0], ss[-1][2][1]
        summ = ss[-1][2][2] if len(ss[-1][2]) > 2 else {}
        ran = summ.get("finished", len(rec))
        rows.append({
            "multistart": name, "wall s": f"{wall:.2f}", "cpu s": f"{cpu:.2f}",
            "vs old (wall)": f"{base_wall / wall:.1f}x", "best": f"{best.objective:.4f}",
            "starts run": f"{ran}/{len(rec)}",
            "reached best": sum(r.get("reached_best", False) for r in rec),
            "target": f"{'met' if wall < 3 and best.objective <= BEST_KNOWN + 1e-4 else 'MISSED'}"
                      f" (< 3 s to {BEST_KNOWN})",
            "load": "/".join(f"{s[3]:.1f}" for s in ss)})
    return rows


def main() -> None:
    quick = "--quick" in sys.argv
    if "--multistart-only" in sys.argv:
        rows = multistart_rows(1 if quick else 3)
        print(table(rows, list(rows[0])))
        print(f"(medians of {1 if quick else 3} rounds in turn; wall and CPU seconds of each "
              f"call, builds excluded; {os.cpu_count()} cores; load average per round)")
        return
    repeat = 1 if quick else 3
    cols = ["scene", "variant", "build s", "cold s", "cold cpu s", "cold it", "cold status",
            "cold cost", "cascade s", "cascade it", "cascade cost", "warm s", "ratio cold",
            "ratio casc", "target"]
    rows = []

    # 1. spherical cart, reference case, N = 40, deterministic geodesic guess
    ocp = cart.problem()
    ladder = [Collocation(N=n) for n in (10, 20, 40)]
    variants = [(Symbolic.MX, A), (Symbolic.SX, A), (Symbolic.SX, L)]
    variants += [] if quick else [(Symbolic.MX, L)]
    rows += scene("cart n=1, N=40", ocp, ladder, Guess.geodesic(ocp), variants, (Symbolic.MX, A),
                  repeat, 0.5)

    # 2. 3D pendulum, reduced, minimum effort, N = 60, seeded geodesic guess
    red, full = p3d.problems("effort")
    g = Guess.geodesic(red, rng=np.random.default_rng(3), noise=0.3)
    variants = [(Symbolic.MX, A), (Symbolic.SX, A), (Symbolic.SX, L)]
    rows += scene("3D pendulum reduced, N=60", red, [Collocation(N=30), Collocation(N=60)], g,
                  variants, (Symbolic.MX, A), repeat, 2.0)
    if not quick:
        s = solve(red, Collocation(N=60), guess=g)
        rows += scene("3D pendulum full (lifted), N=60", full, [Collocation(N=60)],
                      p3d.lift(s, full), [(Symbolic.MX, A), (Symbolic.SX, A), (Symbolic.SX, L)],
                      (Symbolic.MX, A), repeat, 2.0)

    # 3. double cart, N = 40, guess lifted from the surrogate single link (setup not timed)
    ocp2, sur = dbl.problem(), dbl.surrogate()
    single, _ = multistart(sur, Collocation(N=10), seeds=[2], T_guesses=dbl.T_GUESSES[2:3],
                           refine_with=[Collocation(N=20), Collocation(N=40)], max_iter=150)
    variants = [(Symbolic.MX, L)] + ([] if quick else [(Symbolic.MX, A), (Symbolic.SX, L)])
    rows += scene("double cart n=2, N=40", ocp2, [Collocation(N=40)],
                  dbl.lift(single, ocp2), variants, (Symbolic.MX, L), repeat, 5.0, max_iter=300)

    print(table(rows, cols))
    ms = multistart_rows(repeat)
    print(table(ms, list(ms[0])))
    print(f"(medians of {repeat} runs; wall seconds of Ipopt's solve, building excluded; "
          "'cascade' = solve at coarse N then refine, summed; ratios against the first "
          "variant of each scene, the model's own MX graph)")


if __name__ == "__main__":
    main()
