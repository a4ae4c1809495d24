"""Exported C controllers: nanoseconds per call, measured in C, against casadi from Python.

For every exportable controller (and the chain with n = 1, 2, 5, 10 links) and the
bindings frozen / parameters / parameters-and-gains: the median over 501 batches of the
mean time per call (20 000 calls a batch) of ``NAME_step`` compiled with -O2, measured in
C by the generated bench.c (cycling through 16 stored states), against the same function
called from Python in the same run, both as a plain casadi call (``f(x, p)``, numpy in,
DM out) and through the workbench's buffered ``Evaluator``. The flop count is casadi's
instruction count.

Targets (issue 9): the saturated feedback (about 30 operations) under 20 ns; the n = 5
chain feedback (state chart plus a 2 x 24 gain) under 150 ns.

Usage: python benchmarks/bench_codegen.py [--native] [--quick]
(--native adds -O3 -march=native builds; --quick fewer batches).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import median_time, table  # noqa: E402

from models import exports  # noqa: E402
from workbench import codegen  # noqa: E402
from workbench.codegen import Binding, Optimization  # noqa: E402
from workbench.core import Evaluator

MAIN = ["saturated_velocity_feedback", "s2_pd", "so3_pd", "cart_nonlinear", "chain_lqr_n5"]
CHAINS = ["chain_lqr_n1", "chain_lqr_n2", "chain_lqr_n10"]


def row(c, binding: Binding, opt: Optimization, batches: int) -> dict:
    lib = codegen.compile_controller(c, binding=binding, optimization=opt)
    b = codegen.bench_c(lib, calls=20_000, batches=batches)
    f = c.function_for(binding)
    x = c.example_state
    args = [x] + ([c.runtime_values(binding)] if f.n_in() == 2 else [])
    plain = median_time(lambda: f(*args), repeat=7, number=2000)
    ev = Evaluator(f)
    buffered = median_time(lambda: ev(*args), repeat=7, number=5000)
    return {
        "controller": c.name,
        "binding": binding.value,
        "opt": opt.value,
        "instr": f.n_instructions(),
        "C median [ns]": f"{b.median_ns:.1f}",
        "C min [ns]": f"{b.min_ns:.1f}",
        "casadi call [ns]": f"{1e9 * plain:.0f}",
        "Evaluator [ns]": f"{1e9 * buffered:.0f}",
        "casadi/C": f"{1e9 * plain / b.median_ns:.0f}x",
        "Evaluator/C": f"{1e9 * buffered / b.median_ns:.0f}x",
        "_median": b.median_ns,
    }


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    batches = 51 if "--quick" in argv else 501
    opts = [Optimization.O2] + ([Optimization.NATIVE] if "--native" in argv else [])
    print(f"cache: {codegen.cache_root()}")
    rows = []
    for name in MAIN:
        c = exports.build(name)
        for binding in Binding:
            for opt in opts:
                rows.append(row(c, binding, opt, batches))
    for name in CHAINS:
        c = exports.build(name)
        for opt in opts:
            rows.append(row(c, Binding.FROZEN, opt, batches))
    cols = [k for k in rows[0] if not k.startswith("_")]
    print("Nanoseconds per call: compiled C (median of batches, measured in C) vs casadi "
          "from Python (same function, same run)")
    print(table(rows, cols))

    def best(name: str) -> float:
        return min(r["_median"] for r in rows if r["controller"] == name
                   and r["binding"] == "frozen" and r["opt"] == "O2")

    sat, chain5 = best("saturated_velocity_feedback"), best("chain_lqr_n5")
    print(f"target saturated feedback < 20 ns (frozen, -O2): {sat:.1f} ns "
          f"({'met' if sat < 20 else 'NOT met'})")
    print(f"target chain n = 5 feedback < 150 ns (frozen, -O2): {chain5:.1f} ns "
          f"({'met' if chain5 < 150 else 'NOT met'})")
    loaded = np.mean([float(r["C median [ns]"]) / float(r["C min [ns]"]) for r in rows])
    print(f"mean median/min ratio of the C timings: {loaded:.2f} (near 1 on a quiet machine; "
          f"the machine is shared, so medians carry scheduling noise)")


if __name__ == "__main__":
    main()
