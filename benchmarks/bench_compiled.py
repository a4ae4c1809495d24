"""Compiled right-hand side of the chain on a cart (issue 17): microseconds per state.

For the chain with n = 5 and n = 10 links (``models.chain_cart.chain_cart(n)``, whatever
it returns today): the right-hand side ``f(x, u, p)`` on 1000 seeded states per call,

* baseline: one call per state through the workbench's buffered ``Evaluator`` (casadi's
  virtual machine, LAPACK LU for the accelerations) -- the issue's 9.7 / 24 us;
* ``BatchEvaluator`` through casadi's virtual machine (``Function.map``, serial);
* ``BatchEvaluator`` compiled to C (``-O2``), with each replacement of the LAPACK solve
  that casadi cannot generate: ``dense_ldl`` (straight-line LDL^T, mass matrices),
  ``ldl`` and ``qr`` (casadi's sparse factorisations); and ``dense_ldl`` at
  ``-O3 -march=native`` (fused multiply-adds: last-bit differences),

and the lane-vectorised batch (``parallelization="lanes"``: every instruction of the
straight-line code on 2 states at ``-O2``, the x86-64 baseline's SSE2, or 4 at
``-O3 -march=native``, AVX2; see ``workbench/codegen/lanes.py``), all timed in turn,
round after round, in CPU time (medians), with the build cost of each compiled variant
(generation + compiler wall seconds; 0 compiler seconds when found in the cache) printed
beside it and the agreement with the baseline. On a loaded machine every
CPU time grows (shared caches and cores), so each row also gives its speed-up over the
baseline of the same run, and the estimate for the issue's quiet-machine baseline (9.7 /
24 us, measured on the chain before the mechanics rewrite) divided by that speed-up.
Then ``simulate`` (rk, fixed step) with and without the compiled right-hand side.

Target: compiled batch < 2 us per state at n = 5 and n = 10.

Usage: python benchmarks/bench_compiled.py [--quick] [--cvodes] [--before]
(--quick: dense_ldl only (serial, lanes, native lanes), fewer rounds; --cvodes adds a
CVODES run, whose compiled Jacobian is a long build; --before also measures the chain as
written before the mechanics layer derived it, ``models/chain_cart.py`` of commit 94f3b89~1,
read with ``git show``).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import interleaved_cpu, table  # noqa: E402

from models.chain_cart import chain_cart  # noqa: E402
from workbench.codegen import Optimization  # noqa: E402
from workbench.codegen.functions import (  # noqa: E402
    BatchEvaluator,
    CompileOptions,
    LinearSolver,
    Parallelization,
)
from workbench.core import Evaluator  # noqa: E402
from workbench.simulation import simulate  # noqa: E402

N_STATES = 1000
QUIET_BASELINE_US = {5: 9.7, 10: 24.0}
"""The issue's Evaluator times per call on a quiet machine (issue 17)."""


BEFORE = "94f3b89~1"
"""The last commit whose chain_cart wrote its equations by hand (SX assembly + LU)."""


def chain_before():
    """``chain_cart`` of :data:`BEFORE`, loaded from ``git show`` into a temporary module."""
    root = Path(__file__).resolve().parents[1]
    text = subprocess.run(["git", "show", f"{BEFORE}:models/chain_cart.py"], cwd=root,
                          capture_output=True, text=True, check=True).stdout
    path = Path(tempfile.mkdtemp(prefix="chain-before-")) / "chain_cart_before.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("chain_cart_before", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.chain_cart


def states(model, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = np.array([model.manifold.random_point(rng) for _ in range(n)])
    return X, rng.normal(size=(n, model.n_inputs))


def rhs_rows(n_links: int, variants: list[tuple[LinearSolver, Optimization, Parallelization]],
             rounds: int, build=chain_cart, label: str = "") -> list[dict]:
    model = build(n_links)
    f = model.function("f")
    X, U = states(model, N_STATES, seed=n_links)
    one = Evaluator(f)
    vm = BatchEvaluator(f, N_STATES, shared=("p",))
    ref = vm(X, U, model.p)
    compiled = {}
    for s, opt, par in variants:
        name = s.value if opt is Optimization.O2 else f"{s.value} {opt.value}"
        name += " lanes" if par is Parallelization.LANES else ""
        compiled[name] = BatchEvaluator(f, N_STATES, shared=("p",), compilation="c",
                                         linear_solver=s, optimization=opt,
                                         parallelization=par)
    k = 50  # single calls per sample of the baseline

    def baseline():
        for i in range(k):
            one(X[i], U[i], model.p)

    fns = {"evaluator": baseline, "vm batch": lambda: vm(X, U, model.p)}
    fns.update({s: (lambda e=e: e(X, U, model.p)) for s, e in compiled.items()})
    med = interleaved_cpu(fns, rounds=rounds)
    per_state = {"evaluator": med["evaluator"] / k,
                 **{name: med[name] / N_STATES for name in fns if name != "evaluator"}}
    base = per_state["evaluator"]
    rows = []
    for name, t in per_state.items():
        e = compiled.get(name)
        err = "-" if e is None else \
            f"{np.max(np.abs(e(X, U, model.p) - ref)) / np.max(np.abs(ref)):.1e}"
        rows.append({
            "n": f"{n_links}{label}", "evaluation": name if e is None else f"compiled C, {name}",
            "us/state": f"{1e6 * t:.3f}", "speed-up": f"{base / t:.1f}x",
            "quiet est. [us]": f"{QUIET_BASELINE_US[n_links] * t / base:.2f}",
            "build [s]": "-" if e is None else f"{e.compiled.build_seconds:.1f}"
                         + (" (cached)" if e.compiled.cached else ""),
            "rel. diff": err, "_t": t, "_name": name})
    return rows


def simulate_rows(n_links: int, cvodes: bool, rounds: int) -> list[dict]:
    model = chain_cart(n_links)
    X, _ = states(model, 1, seed=100 + n_links)
    x0 = X[0]
    x0[2:4] = 0.0
    t = np.linspace(0.0, 1.0, 11)
    cases = {"rk": {"method": "rk", "step": 1e-3}}
    if cvodes:
        cases["cvodes"] = {"method": "cvodes", "rtol": 1e-10, "atol": 1e-10}
    opts = CompileOptions(linear_solver=LinearSolver.DENSE_LDL)
    rows = []
    for label, kw in cases.items():
        first = simulate(model, x0, t, compilation="c", compile_options=opts, **kw)
        runs = {}
        med = interleaved_cpu({
            "casadi": lambda kw=kw: runs.__setitem__("casadi", simulate(model, x0, t, **kw)),
            "compiled": lambda kw=kw: runs.__setitem__(
                "compiled", simulate(model, x0, t, compilation="c", compile_options=opts,
                                     **kw))}, rounds=rounds)
        c = first.cost["compile"]
        rows.append({
            "n": n_links, "method": label, "casadi CPU [s]": f"{med['casadi']:.3f}",
            "compiled CPU [s]": f"{med['compiled']:.3f}",
            "speed-up": f"{med['casadi'] / med['compiled']:.1f}x",
            "build [s]": f"{c['generate_seconds'] + c['compile_seconds']:.1f}"
                         + (" (cached)" if c["cached"] else ""),
            "max |dx|": f"{np.max(np.abs(runs['casadi'].x - runs['compiled'].x)):.1e}"})
    return rows


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    quick = "--quick" in argv
    o2, native, ldl = Optimization.O2, Optimization.NATIVE, LinearSolver.DENSE_LDL
    serial, lanes = Parallelization.SERIAL, Parallelization.LANES
    variants = [(ldl, o2, serial), (ldl, o2, lanes), (ldl, native, lanes)]
    if not quick:
        variants += [(s, o2, serial) for s in LinearSolver if s is not ldl]
        variants += [(ldl, native, serial)]
    rounds = 5 if quick else 15
    rows = [r for n in (5, 10) for r in rhs_rows(n, variants, rounds)]
    if "--before" in argv:
        old = chain_before()
        rows += [r for n in (5, 10) for r in rhs_rows(n, variants, rounds, old, " before")]
    print(f"Chain on a cart, right-hand side on {N_STATES} states: CPU-time medians per state "
          f"({rounds} rounds, in turn); build = generation + compiler wall seconds")
    print(table(rows, [k for k in rows[0] if not k.startswith("_")]))
    for n in (5, 10):
        best = min((r for r in rows if r["n"] == str(n) and r["build [s]"] != "-"),
                   key=lambda r: r["_t"])
        us = 1e6 * best["_t"]
        est = float(best["quiet est. [us]"])
        print(f"target n = {n}: < 2 us per state compiled: {us:.2f} us measured here "
              f"({best['_name']}; {'met' if us < 2 else 'NOT met'} at this load), "
              f"{est:.2f} us estimated on the issue's quiet baseline "
              f"({'met' if est < 2 else 'NOT met'})")
    sims = [r for n in (5, 10) for r in simulate_rows(n, "--cvodes" in argv, 3)]
    print("simulate over 1 s, casadi vs compiled right-hand side (dense_ldl), CPU-time "
          "medians of 3 runs in turn")
    print(table(sims, list(sims[0])))
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
