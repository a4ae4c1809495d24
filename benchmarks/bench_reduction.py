"""CPU cost of the derived reduced models of the 3D pendulum against the full and transcribed.

Models (paper 000's elliptic cylinder and an axisymmetric top): the full model on TSO(3)
(``models.pendulum3d.full``, derived), the Lagrange-Poincare and Routh models derived from
it by ``workbench.mechanics.reduce``, and the transcribed ones (``models.pendulum3d.reduced``
and ``routh``). Per scene every model integrates the same motion unforced with CVODES
(Adams, rtol = atol = 1e-10, the scene's horizon), timed in turn round by round
(CPU time of the process, medians over rounds); printed: the graph size of ``f`` (nodes),
the CPU time inside the field per evaluation (CVODES' own ``t_proc_daeF`` over its
evaluations), the steps and evaluations of the run, the CPU time per step and per
simulated second, each with its ratio to the full model's, and the load average. The
target: the derived models at least as cheap per step as the full model.

Usage: ``python benchmarks/bench_reduction.py [--quick] [--repeat 7]``.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import quick_repeat_arguments, table  # noqa: E402

from models import pendulum3d as p3  # noqa: E402
from workbench import mechanics, so3_exp  # noqa: E402
from workbench.simulation import closed_loop_function, cvodes_options  # noqa: E402

PAPER = {"J": np.diag([0.4486, 0.3943, 0.0772]), "rho": np.array([-0.014, 0.1044, 0.4989]),
         "m": 1.0, "g": 9.81}
TOP = {"J": np.diag([0.28, 0.28, 0.13]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
       "g": 9.81}
RTOL = 1e-10


def _flow(model, horizon: float):
    loop = closed_loop_function(model, None)
    x = ca.SX.sym("x", model.manifold.ambient_dim)
    p = ca.SX.sym("p", model.n_params)
    return ca.integrator(f"bench_{model.name}", "cvodes",
                         {"x": x, "p": p, "ode": loop(x, p)[0]}, 0.0, horizon,
                         cvodes_options(rtol=RTOL, atol=RTOL, max_steps=10**7))


def _levels(body: dict, x_full: np.ndarray) -> dict[str, tuple]:
    """``name -> (model, initial state)`` for one body and one full state."""
    full = p3.full(**body)
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")
    mu = lp.momentum_of(x_full)
    ro = mechanics.reduce(full, "h", momentum=mu, breaking_inputs="hold_zero")
    r = lp.state_from_full(x_full)
    g, w = r[:3], r[3:]
    w_routh = -(w - (w @ g) * g)  # the mechanics TS2 convention: Gamma-dot = w x Gamma
    return {"full": (full, x_full),
            "LP derived": (lp.model, r),
            "LP transcribed": (p3.reduced(**body), r),
            "Routh derived": (ro.model, ro.state_from_full(x_full)),
            "Routh transcribed": (p3.routh(**body, mu=mu), np.r_[g, np.cross(w_routh, g)])}


def _scenes(quick: bool) -> dict[str, tuple[dict, np.ndarray, float]]:
    T = 5.0 if quick else 20.0
    lp_paper = mechanics.reduce(p3.full(**PAPER), "h", kind="lagrange_poincare")
    lp_top = mechanics.reduce(p3.full(**TOP), "h", kind="lagrange_poincare")
    down = PAPER["rho"] / np.linalg.norm(PAPER["rho"])

    def at(lp, direction, tilt, omega):
        gam = np.asarray(so3_exp(np.asarray(tilt, dtype=float)), dtype=float) @ direction
        return lp.full_state(np.r_[gam, omega])

    return {"000 body tumbling": (PAPER, at(lp_paper, down, [0.8, 0, 0], [0.5, -0.3, 1.0]), T),
            "000 body near hanging": (PAPER, at(lp_paper, down, [2e-3, 1e-3, 0], [0, 0, 0]), T),
            "top at 30 rad/s": (TOP, at(lp_top, np.r_[0.0, 0.0, 1.0], [0.6, 0, 0],
                                        [0.0, 0.3, 30.0]), T)}


def _timed(flows: dict, rounds: int) -> dict[str, dict[str, float]]:
    """Medians over interleaved rounds: CPU of a run, CPU inside the field, and the counts."""
    samples: dict[str, dict[str, list]] = {k: {"cpu": [], "rhs": []} for k in flows}
    stats: dict[str, dict] = {}
    for _ in range(rounds):
        for k, (F, x, p) in flows.items():
            t0 = time.process_time()
            F(x0=x, p=p)
            samples[k]["cpu"].append(time.process_time() - t0)
            st = F.stats()
            samples[k]["rhs"].append(st["t_proc_daeF"] / max(st["nfevals"], 1))
            stats[k] = st
    return {k: {"cpu": statistics.median(v["cpu"]), "rhs": statistics.median(v["rhs"]),
                "steps": stats[k]["nsteps"], "nfevals": stats[k]["nfevals"]}
            for k, v in samples.items()}


def main(argv: list[str]) -> None:
    """Run the benchmark (module docstring)."""
    args = quick_repeat_arguments(__doc__, "5 s horizons instead of 20 s", argv, repeat=7)
    rows = []
    for scene, (body, x0, T) in _scenes(args.quick).items():
        levels = _levels(body, x0)
        flows = {k: (_flow(m, T), x, m.p) for k, (m, x) in levels.items()}
        res = _timed(flows, args.repeat)
        base = res["full"]
        for k, r in res.items():
            step, base_step = r["cpu"] / r["steps"], base["cpu"] / base["steps"]
            rows.append({"scene": scene, "model": k,
                         "nodes": int(levels[k][0].function("f").n_nodes()),
                         "rhs [ns]": f"{1e9 * r['rhs']:.0f}",
                         "rhs / full": f"{r['rhs'] / base['rhs']:.2f}",
                         "steps": r["steps"], "rhs evals": r["nfevals"],
                         "cpu/step [us]": f"{1e6 * step:.2f}",
                         "step / full": f"{step / base_step:.2f}",
                         "cpu/sim s [ms]": f"{1e3 * r['cpu'] / T:.3f}",
                         "sim s / full": f"{r['cpu'] / base['cpu']:.2f}"})
    print(table(rows, list(rows[0])))
    print(f"CVODES Adams rtol = atol = {RTOL:g}; medians of {args.repeat} interleaved rounds; "
          f"rhs: CPU inside the field per evaluation (CVODES' t_proc_daeF / nfevals); "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main(sys.argv[1:])
