"""Tracing the relative equilibria of the elliptic cylinder (paper 000 Sec. 4.3).

All eight branches (families L1-L4, both signs of omega) of the reduced model are traced
by ``trace_relative_equilibria`` (slices at |k| = k_max = 100 for the ends at infinity,
pseudo-arclength continuation with events k = 0, k1 = 0 and the bound |k| = k_max, branch
point detection), with ``max_step`` chosen so that every family has at least 200 points
(L1, L2 about 205; L3, L4, which run from infinity to infinity, about 420). Graph builds
happen before the timing. Reported: median wall time of 5 runs, points, per-point cost,
and the same with the spectral stability at every point (linearisation of the reduced
model, eigenvalues, changes located by bisection).

Baselines in the same run:
* natural-parameter continuation in k of family L2 (Newton on the slice k = const from
  the previous point, the naive method), at the same k values as the traced L2 points;
* one evaluation of the model's f through casadi's Python call (model.rhs), the unit cost.

Target (issue 4): all families at 200 points each in under 2 s (without stability).

Usage: python benchmarks/bench_equilibria.py [--quick]
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import median_time, table  # noqa: E402

from models import pendulum3d as p3  # noqa: E402
from models.relative_equilibria import rotation_problem, slice_zeros  # noqa: E402
from models.relative_families import trace_relative_equilibria  # noqa: E402
from workbench.equilibria import StepControl

BODY = {"J": np.diag([0.4486, 0.3943, 0.0772]), "rho": np.array([-0.0140, 0.1044, 0.4989]),
        "m": 1.0, "g": 9.81}


def cpu_time(fn, *, repeat: int) -> float:  # noqa: ANN001
    """Median process (CPU) time of ``fn`` over ``repeat`` runs [s]: less sensitive than the
    wall time to other processes sharing the cores."""
    samples = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        samples.append(time.process_time() - t0)
    return statistics.median(samples)


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    repeat = 3 if "--quick" in argv else 5
    model = p3.reduced(**BODY)
    control = StepControl(max_step=0.5)
    atlas = trace_relative_equilibria(model, control=control)  # builds every graph
    counts = [len(b) for b in atlas.branches]
    n_points = sum(counts)

    t_trace = median_time(lambda: trace_relative_equilibria(model, control=control,
                                                            with_stability=False),
                          repeat=repeat)
    t_stab = median_time(lambda: trace_relative_equilibria(model, control=control),
                         repeat=max(1, repeat - 2))
    c_trace = cpu_time(lambda: trace_relative_equilibria(model, control=control,
                                                         with_stability=False), repeat=repeat)
    c_stab = cpu_time(lambda: trace_relative_equilibria(model, control=control),
                      repeat=max(1, repeat - 2))

    # baseline 1: natural-parameter continuation in k along L2 (slice Newton)
    l2 = next(b for b, o in zip(atlas.branches, atlas.origins) if o == "hanging +k")
    prob = rotation_problem(model)
    ks = l2.points[1:, 3]

    def natural() -> None:
        g = l2.points[0, :3]
        for k in ks:
            z, _ = slice_zeros(prob, float(k), g[None, :], tol=control.tol)
            g = z[0].y[:3]

    t_nat = median_time(natural, repeat=repeat)
    t_l2 = l2.wall_time
    # baseline 2: one model f evaluation through the casadi Python call
    x = prob.state(l2.points[10])
    t_f = median_time(lambda: model.rhs(x), repeat=7, number=2000)

    rows = [
        {"what": "all 8 branches, no stability", "points": n_points,
         "median [s]": f"{t_trace:.3f}", "per point [us]": f"{1e6 * t_trace / n_points:.0f}",
         "per point / f call": f"{t_trace / n_points / t_f:.0f}x"},
        {"what": "  same, CPU time", "points": n_points,
         "median [s]": f"{c_trace:.3f}", "per point [us]": f"{1e6 * c_trace / n_points:.0f}",
         "per point / f call": "-"},
        {"what": "all 8 branches, with stability", "points": n_points,
         "median [s]": f"{t_stab:.3f}", "per point [us]": f"{1e6 * t_stab / n_points:.0f}",
         "per point / f call": f"{t_stab / n_points / t_f:.0f}x"},
        {"what": "  same, CPU time", "points": n_points,
         "median [s]": f"{c_stab:.3f}", "per point [us]": f"{1e6 * c_stab / n_points:.0f}",
         "per point / f call": "-"},
        {"what": "L2 by pseudo-arclength (in the run above)", "points": len(l2),
         "median [s]": f"{t_l2:.3f}", "per point [us]": f"{1e6 * t_l2 / len(l2):.0f}",
         "per point / f call": f"{t_l2 / len(l2) / t_f:.0f}x"},
        {"what": "L2 by natural parameter k (baseline)", "points": len(ks),
         "median [s]": f"{t_nat:.3f}", "per point [us]": f"{1e6 * t_nat / len(ks):.0f}",
         "per point / f call": f"{t_nat / len(ks) / t_f:.0f}x"},
    ]
    print(table(rows, ["what", "points", "median [s]", "per point [us]",
                       "per point / f call"]))
    print(f"points per branch: {counts} (min {min(counts)})")
    print(f"one f evaluation (casadi call): {1e6 * t_f:.1f} us")
    print(f"load average during the run: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores "
          f"(wall times are inflated when it exceeds the core count; CPU times less so)")
    at_200 = c_trace * 8 * 200 / n_points
    print(f"target: all families at >= 200 points each in < 2 s: wall {t_trace:.2f} s, CPU "
          f"{c_trace:.2f} s for {n_points} points ({'met' if t_trace < 2.0 else 'NOT met'} "
          f"in wall time, {'met' if c_trace < 2.0 else 'NOT met'} in CPU time); CPU time "
          f"scaled to exactly 200 points per branch: {at_200:.2f} s")


if __name__ == "__main__":
    main()
