"""Benchmark: Poincare maps of the 3D pendulum, 5 energy levels x 1000 section crossings.

Target: under 60 s on 2 cores. Measured in one run:

1. the workbench sweep (``workbench.simulation._sweep`` over a 2-process pool,
   ``poincare_map`` on the Routh model, CVODES Adams + RK4-refined crossings), 5 levels x
   N crossings, wall time;
2. single-core per-crossing cost, workbench against the baseline, on the same 5 levels x
   M crossings, median of R repeats: the baseline is scipy ``solve_ivp`` (DOP853, same
   tolerances) on a hand-written numpy right-hand side of (5.7)-(5.9) with the same
   constraint stabilisation, crossings from its event location (``events=``, brentq on
   the dense output); the ratio is baseline / workbench;
3. agreement of the first crossings of the regular orbit (c = 1) between the two.

Run: ``.venv/bin/python benchmarks/bench_poincare.py [--crossings 1000] [--baseline 20]
[--repeats 1]`` (the scipy baseline is slow: keep its crossings few). Both sides
integrate in chunks of 5 s in the single-core comparison, so neither overshoots by much.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from scipy.integrate import solve_ivp

from models import pendulum3d as p3
from workbench.global_dynamics import poincare_map, turning_section
from workbench.simulation import InlineExecutor, grid, sweep

BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
        "g": 9.81}
C_VALUES = (1.0, 3.0, 4.5, 6.0, 10.0)
TOL = 1e-10
GAIN = 10.0


def start(c: float) -> tuple[np.ndarray, float]:
    full = p3.full(**BODY)
    return p3.routh_state_from_full(full, full.state(R=np.eye(3), omega=c * np.ones(3)))


def workbench_orbit(*, c: float, n: int, chunk: float = 25.0) -> np.ndarray:
    x0, mu = start(c)
    orb = poincare_map(p3.routh(**BODY, mu=mu), x0, turning_section(), n_crossings=n,
                       t_max=1e5, rtol=TOL, atol=TOL, stabilization=GAIN, chunk=chunk)
    return np.column_stack([orb.t, orb.x])


def numpy_rhs(mu: float):
    J, rho, m, g = BODY["J"], BODY["rho"], BODY["m"], BODY["g"]
    Jinv, trJ = np.linalg.inv(J), np.trace(J)

    def f(t, x):
        gam, gd = x[:3], x[3:]
        JG = J @ gam
        gJg = gam @ JG
        gxg = np.cross(gd, gam)
        b = JG @ gxg / gJg
        nu = mu / gJg
        c = nu * (trJ - 2 * (JG @ JG) / gJg)
        inner = (np.cross(J @ gxg - b * JG, gxg - b * gam) + nu**2 * np.cross(JG, gam)
                 - m * g * np.cross(gam, rho) - c * gd)
        sigma = b * gd + Jinv @ inner
        gdd = -(gd @ gd) * gam + np.cross(gam, sigma)
        # the same constraint stabilisation: - k H^T (H H^T)^-1 h
        h = np.array([gam @ gam - 1.0, gam @ gd])
        H = np.zeros((2, 6))
        H[0, :3] = 2 * gam
        H[1, :3], H[1, 3:] = gd, gam
        return np.r_[gd, gdd] - GAIN * H.T @ np.linalg.solve(H @ H.T, h)

    return f


def scipy_orbit(*, c: float, n: int, chunk: float = 5.0) -> np.ndarray:
    x0, mu = start(c)
    f = numpy_rhs(mu)

    def event(t, x):
        return x[5]

    t_end, out, x = 0.0, [], x0
    while len(out) < n:
        sol = solve_ivp(f, (t_end, t_end + chunk), x, method="DOP853", rtol=TOL, atol=TOL,
                        events=event)
        for te, xe in zip(sol.t_events[0], sol.y_events[0]):
            if np.cross(xe[:3], xe[3:])[2] > 0 and len(out) < n:
                out.append(np.r_[te, xe])
        t_end, x = sol.t[-1], sol.y[:, -1]
    return np.array(out)


def timed(call, /, *args, **kw) -> tuple[float, object]:
    t0 = time.perf_counter()
    val = call(*args, **kw)
    return time.perf_counter() - t0, val


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--crossings", type=int, default=1000)
    ap.add_argument("--baseline", type=int, default=20,
                    help="crossings per level for the single-core comparison (step 2)")
    ap.add_argument("--repeats", type=int, default=1)
    args = ap.parse_args()

    print(f"== 5 levels x {args.crossings} crossings, workbench sweep on a 2-process pool")
    t_sweep, res = timed(sweep, workbench_orbit,
                         grid(c=list(C_VALUES), n=[args.crossings]), workers=2)
    orbits = res.values()
    for c, o, out in zip(C_VALUES, orbits, res.outcomes):
        print(f"  c = {c:4}: {len(o)} crossings up to t = {o[-1, 0]:8.1f} s in "
              f"{out.seconds:6.2f} s (worker)")
    print(f"  wall {t_sweep:.2f} s (incl. pool start-up), sum of items "
          f"{res.cost['item_seconds']:.2f} s, speed-up {res.cost['item_seconds'] / t_sweep:.2f}"
          f"  -> target < 60 s: {'met' if t_sweep < 60 else 'MISSED'}")

    print(f"== single core, 5 levels x {args.baseline} crossings, median of {args.repeats}")
    wb, sp = [], []
    for _ in range(args.repeats):
        t, _ = timed(sweep, workbench_orbit, grid(c=list(C_VALUES), n=[args.baseline],
                                                  chunk=[5.0]), executor=InlineExecutor())
        wb.append(t)
        t, base = timed(lambda: [scipy_orbit(c=c, n=args.baseline) for c in C_VALUES])
        sp.append(t)
    m_wb, m_sp = statistics.median(wb), statistics.median(sp)
    n_tot = 5 * args.baseline
    print(f"  workbench (casadi cvodes + RK4 refine): {m_wb:7.3f} s = "
          f"{1e3 * m_wb / n_tot:.2f} ms/crossing  (runs {', '.join(f'{v:.2f}' for v in wb)})")
    print(f"  scipy solve_ivp DOP853, numpy rhs:     {m_sp:7.3f} s = "
          f"{1e3 * m_sp / n_tot:.2f} ms/crossing  (runs {', '.join(f'{v:.2f}' for v in sp)})")
    print(f"  ratio scipy / workbench = {m_sp / m_wb:.1f}; scipy extrapolated to "
          f"5 x {args.crossings} crossings on one core: {m_sp / n_tot * 5 * args.crossings:.0f} s")

    reg = orbits[0][: min(20, args.baseline)]
    b = base[0][: len(reg)]
    print(f"== agreement, c = 1, first {len(reg)} crossings: max |dt| = "
          f"{np.max(np.abs(reg[:, 0] - b[:, 0])):.2e} s, max |dGamma| = "
          f"{np.max(np.abs(reg[:, 1:4] - b[:, 1:4])):.2e}, scipy event residual "
          f"{np.max(np.abs(b[:, 6])):.1e}")


if __name__ == "__main__":
    main()
