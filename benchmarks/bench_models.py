"""Model build and evaluation cost (issue 2).

For the chain pendulum on a cart with n = 1, 2, 5, 10, 20 links: graph build time, Jacobian
build time, node counts, and the time per right-hand-side evaluation from Python, both
through a plain casadi call and through the workbench's buffered Evaluator. Baseline in
the same run: the plain casadi call (Python argument conversion) of the same function.
For the 3D pendulum: the time of a 10 s simulation at rtol = 1e-10 (Adams and BDF).

Targets: n = 20 builds with its Jacobian in under 2 s; n = 10 evaluates in under 50 us per
call from Python.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import median_time, table  # noqa: E402

from models import pendulum3d as p3  # noqa: E402
from models.chain_cart import chain_cart  # noqa: E402
from workbench.core import Evaluator
from workbench.simulation import simulate


def chain_rows(ns=(1, 2, 5, 10, 20)) -> list[dict]:
    rows = []
    for n in ns:
        builds, jacs = [], []
        for _ in range(3):  # fresh models: build times are medians of 3 builds
            t0 = time.perf_counter()
            model = chain_cart(n)
            f = model.function("f")
            builds.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            fx = model.function("f_x")
            jacs.append(time.perf_counter() - t0)
        x = model.manifold.random_point(np.random.default_rng(0))
        u = np.zeros(2)
        plain = median_time(lambda: f(x, u, model.p), number=200)
        ev = Evaluator(f)
        fast = median_time(lambda: ev(x, u, model.p), number=2000)
        rows.append({
            "n": n,
            "f nodes": f.n_nodes(),
            "f_x nodes": fx.n_nodes(),
            "build [ms]": f"{1e3 * np.median(builds):.1f}",
            "jac build [ms]": f"{1e3 * np.median(jacs):.1f}",
            "build+jac [s]": f"{np.median(builds) + np.median(jacs):.3f}",
            "eval plain [us]": f"{1e6 * plain:.1f}",
            "eval buffered [us]": f"{1e6 * fast:.1f}",
            "speed-up vs plain": f"{plain / fast:.1f}x",
        })
    return rows


def pendulum_rows() -> list[dict]:
    model = p3.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0, 0, 0.3])
    x0 = model.state(R=np.eye(3), omega=np.ones(3))
    t = np.linspace(0, 10, 101)
    rows = []
    base = None
    for ms in ("bdf", "adams"):
        sec = median_time(lambda ms=ms: simulate(model, x0, t, rtol=1e-10, atol=1e-10,
                                                 multistep=ms), repeat=5)
        tr = simulate(model, x0, t, rtol=1e-10, atol=1e-10, multistep=ms)
        base = base or sec
        rows.append({
            "multistep": ms,
            "median [ms]": f"{1e3 * sec:.1f}",
            "ratio vs bdf": f"{sec / base:.2f}",
            "rhs evals": tr.cost["rhs_evaluations"],
            "rel energy drift": f"{tr.diagnostics['invariant_drift']['energy']['max_rel']:.1e}",
        })
    return rows


def main() -> None:
    print("Chain pendulum on a cart: build and evaluation (medians)")
    rows = chain_rows()
    print(table(rows, list(rows[0])))
    n20 = next(r for r in rows if r["n"] == 20)
    n10 = next(r for r in rows if r["n"] == 10)
    print(f"target n=20 build+jacobian < 2 s: {n20['build+jac [s]']} s")
    print(f"target n=10 evaluation < 50 us from Python: buffered {n10['eval buffered [us]']} us"
          f" (plain casadi call {n10['eval plain [us]']} us)")
    print()
    print("3D pendulum, 10 s simulation at rtol = atol = 1e-10 (cvodes), medians of 5")
    prow = pendulum_rows()
    print(table(prow, list(prow[0])))


if __name__ == "__main__":
    main()
