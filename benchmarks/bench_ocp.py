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

Usage: python benchmarks/bench_ocp.py [--quick]
"""

from __future__ import annotations

import statistics
import sys
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
from workbench.core import Symbolic  # noqa: E402

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


def main() -> None:
    quick = "--quick" in sys.argv
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
    print(f"(medians of {repeat} runs; wall seconds of Ipopt's solve, building excluded; "
          "'cascade' = solve at coarse N then refine, summed; ratios against the first "
          "variant of each scene, the model's own MX graph)")


if __name__ == "__main__":
    main()
