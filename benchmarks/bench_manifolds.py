"""Growing stable manifolds: 1000 trajectories, 10 s backward (issue target: < 20 s).

Scenes: the inverted spherical pendulum under PD (paper 002 Sec. II, step 0.002 s, the
paper's) and the saddle exp(pi e2^) of PD on SO(3) (Sec. III, step 0.002 s). For each, the
vectorised growth (workbench.global_dynamics._invariant_manifolds: all points per casadi
call) with the geometric method of the paper and with RKMK4, compiled (jit), on 1 and 2
threads, and the first one in casadi's virtual machine. Baseline, same run: the same method
and step run point by point through workbench.simulation._simulate (compiled), measured on
a subset and scaled to 1000 points. Printed: median wall seconds of the stepping (and of
the whole call, with linearisation, seeds, diagnostics), microseconds per point-step, and
the ratio to the baseline. Compilation is done before timing.

Usage: python benchmarks/bench_manifolds.py [--quick]
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import table  # noqa: E402

from models import controllers as ctl  # noqa: E402
from models import pendulum3d as p3  # noqa: E402
from models.spherical import spherical_pendulum  # noqa: E402
from workbench.core.manifolds import SO3  # noqa: E402
from workbench.global_dynamics import stable_manifold
from workbench.simulation import Method, simulate

HORIZON, STEP, OUTPUT = 10.0, 0.002, 0.05


def grow(model, x_e, k, n, method, *, jit, threads):
    t0 = time.perf_counter()
    W = stable_manifold(model, x_e, controller=k, delta=1e-6, n_points=n, horizon=HORIZON,
                        step=STEP, output_step=OUTPUT, method=method, jit=jit,
                        threads=threads)
    return W.cost["wall_seconds"], time.perf_counter() - t0, W


def per_point(model, W, method, n_sub):
    """Seconds for ``n_sub`` seeds through simulate (compiled), scaled to all points."""
    grid = -W.t
    simulate(model, W.seeds[0], grid[:3], controller=W.controller, method=method, step=STEP,
             jit=True)
    t0 = time.perf_counter()
    for x0 in W.seeds[:n_sub]:
        simulate(model, x0, grid, controller=W.controller, method=method, step=STEP, jit=True)
    return (time.perf_counter() - t0) * W.n_points / n_sub


def scene(name, model, x_e, k, method, n, repeat, n_sub):
    grow(model, x_e, k, 4, method, jit=True, threads=1)  # compile
    grow(model, x_e, k, 4, Method.RKMK4, jit=True, threads=1)
    base_runs, rows = [], []
    _, _, W = grow(model, x_e, k, n, method, jit=True, threads=1)
    for _ in range(repeat):
        base_runs.append(per_point(model, W, method, n_sub))
    base = statistics.median(base_runs)
    point_steps = n * round(HORIZON / STEP)
    rows.append({"scene": name, "variant": f"per-point simulate {method.value} jit "
                 f"(baseline, {n_sub} pts scaled)", "step s": f"{base:.2f}", "total s": "",
                 "us/pt-step": f"{base / point_steps * 1e6:.2f}", "ratio": "1.00"})
    variants = [(f"vectorised {method.value} jit", method, True, 1),
                (f"vectorised {method.value} jit, 2 threads", method, True, 2),
                ("vectorised rkmk4 jit", Method.RKMK4, True, 1),
                ("vectorised rkmk4 jit, 2 threads", Method.RKMK4, True, 2),
                (f"vectorised {method.value} (virtual machine)", method, False, 1)]
    for label, meth, jit, threads in variants:
        reps = 1 if not jit else repeat
        runs = [grow(model, x_e, k, n, meth, jit=jit, threads=threads)[:2] for _ in range(reps)]
        wall = statistics.median(r[0] for r in runs)
        total = statistics.median(r[1] for r in runs)
        rows.append({"scene": name, "variant": label, "step s": f"{wall:.2f}",
                     "total s": f"{total:.2f}",
                     "us/pt-step": f"{wall / point_steps * 1e6:.2f}",
                     "ratio": f"{wall / base:.3f}"})
    return rows


def main() -> None:
    quick = "--quick" in sys.argv
    n, repeat, n_sub = (200, 1, 4) if quick else (1000, 3, 10)
    sph = spherical_pendulum()
    e3 = np.array([0.0, 0.0, 1.0])
    rows = scene("S^2 PD, (-e3, 0)", sph, np.r_[-e3, 0, 0, 0], ctl.s2_pd(sph, e3, k_q=1.0, k_w=1.0),
                 Method.S2_VARIATIONAL, n, repeat, n_sub)
    body = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.3])
    k = ctl.so3_pd(body, np.eye(3), k_R=1.0, k_Omega=1.0, G=[0.9, 1.0, 1.1])
    R_e = np.diag([-1.0, 1.0, -1.0])
    rows += scene("SO(3) PD, exp(pi e2^)", body, np.r_[SO3.flat(R_e), 0, 0, 0], k,
                  Method.LGVI, n, repeat, n_sub)
    print(table(rows, ["scene", "variant", "step s", "total s", "us/pt-step", "ratio"]))
    print(f"({n} trajectories, {HORIZON:g} s backward, step {STEP:g} s; medians of {repeat} "
          f"runs; ratio = stepping time / per-point baseline of the same run; 'total' adds "
          f"linearisation, seeds and diagnostics; target < 20 s on 2 cores)")


if __name__ == "__main__":
    main()
