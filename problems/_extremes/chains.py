"""Extremes, large chains: n = 20 and 50 links, each in its own process (the memory it adds)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from workbench.core.errors import SolverError
from workbench.study import Cases, Check, Result, peak_memory_mb, reset_peak_memory, run_isolated


def chain_case(n: int, horizon: float) -> dict[str, Any]:
    """Build, linearise, PBH, LQR and simulate the n-link chain; times and memory.

    It resets the peak RSS of the process it runs in, so ``added_rss_mb`` (peak minus
    start) is what this case needed beyond what the process had loaded (nan where
    Linux's ``/proc`` cannot reset the peak): run it in a process of its own, as
    :func:`large_chains` does (a forked one, :func:`workbench.study.run_isolated`), or
    the caller's own peak is lost.
    """
    try:
        rss0 = reset_peak_memory()
    except OSError:
        rss0 = float("nan")
    from models.chain_cart import chain_cart
    from models.chain_cart_reference import equilibrium, lqr_weights
    from workbench import lqr, pbh, simulate
    from workbench.linear import linearize, mechanical_order

    stages: dict[str, float] = {}
    t0 = time.perf_counter()
    model = chain_cart(n)
    model.function("f")
    stages["build f"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    model.function("f_x")
    model.function("f_u")
    stages["build Jacobians"] = time.perf_counter() - t0
    x_e = equilibrium(n, (1.0,) * n)
    t0 = time.perf_counter()
    lin = linearize(model, x_e)
    stages["linearize"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    test = pbh(lin)
    stages["pbh"] = time.perf_counter() - t0
    pos, vel = mechanical_order(model, {"x": "v"})
    t0 = time.perf_counter()
    design = lqr(lin.permuted(pos + vel), *lqr_weights(n))
    stages["lqr"] = time.perf_counter() - t0
    dx = 1e-3 * np.random.default_rng(n).standard_normal(model.manifold.dim)
    x0 = model.manifold.retract(x_e, dx)
    t0 = time.perf_counter()
    tr = simulate(model, x0, np.linspace(0.0, horizon, 21), rtol=1e-8, atol=1e-10)
    stages["simulate"] = time.perf_counter() - t0
    finite = bool(np.all(np.isfinite(lin.A)) and np.all(np.isfinite(design.K))
                  and np.all(np.isfinite(tr.x)))
    return {"n": n, "horizon": horizon, "stages": stages, "dim": lin.dim,
            "controllable": test.controllable, "pbh_margin": test.margin,
            "riccati_residual": design.riccati_residual,
            "max_closed_loop_real": float(design.closed_loop_eigenvalues.real.max()),
            "energy_drift": tr.diagnostics["invariant_drift"]["energy"]["max_rel"],
            "constraint": max(tr.diagnostics["constraint_residual"].values()),
            "steps": tr.cost["steps"], "finite": finite,
            "added_rss_mb": peak_memory_mb() - rss0 if np.isfinite(rss0) else rss0}


def large_chains(cases: Cases, res: Result, *, quick: bool) -> None:
    """Chains of n = 20 (and 50 unless quick) links: build, linearise, PBH, LQR, simulate 2 s."""
    group = "large_chains"
    for n in ((20,) if quick else (20, 50)):
        def run(n: int = n) -> Check:
            out = run_isolated(chain_case, n, 2.0, fresh=False)
            err = max(out["riccati_residual"], out["energy_drift"], out["constraint"])
            st = out["stages"]
            if not (out["finite"] and out["controllable"]):
                raise SolverError(f"chain n = {n}: finite {out['finite']}, controllable "
                                  f"{out['controllable']}", status="chain")
            return Check(
                f"dim {out['dim']}: build f {st['build f']:.2f} s, Jacobians "
                f"{st['build Jacobians']:.2f} s, linearize {st['linearize']:.2f} s, pbh "
                f"{st['pbh']:.2f} s (margin {out['pbh_margin']:.1e}), lqr {st['lqr']:.2f} s "
                f"(max Re {out['max_closed_loop_real']:.3g}), simulate 2 s "
                f"{st['simulate']:.2f} s ({out['steps']} steps); all finite", err,
                "max(Riccati residual, energy drift, constraint residual)", 1e-8,
                {"memory added [MB]": out["added_rss_mb"]})

        cases.run(group, f"chain n = {n}", run)


