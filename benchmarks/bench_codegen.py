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

Issue 17: the exported saturated feedback within 1.2x of the same law written by hand in
C. ``hand_vs_export`` compiles both with the same flags into separate objects, links them
into one program that calls each through the same step signature on the same 16 stored
states, batch after batch in turn (CPU time of the process), and prints both medians and
their ratio, with the load average; it also prints their largest relative difference on
those states (the hand-written law may round differently in the last bit).

Usage: python benchmarks/bench_codegen.py [--native] [--quick] [--hand-only]
(--native adds -O3 -march=native builds; --quick fewer batches; --hand-only runs only the
hand-written comparison).
"""

from __future__ import annotations

import hashlib
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _timing import median_time, table  # noqa: E402

from workbench import codegen  # noqa: E402
from workbench.app import catalogue as exports  # noqa: E402
from workbench.codegen import Binding, Optimization  # noqa: E402
from workbench.codegen.build import build_cached  # noqa: E402
from workbench.codegen.csource import BENCH_STATES, CFLAGS_WARN  # noqa: E402
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


HAND_C = """/* paper 001 (34) written by hand: u = -k P w / (1 + |P w|), P diagonal */
#include <math.h>

int hand_step(const double *x, const double *p, double *u) {
  double a = P0 * x[9], b = P1 * x[10], c = P2 * x[11];
  double s = -K / (1.0 + sqrt(a * a + b * b + c * c));
  (void)p;
  u[0] = s * a;
  u[1] = s * b;
  u[2] = s * c;
  return 0;
}
"""

COMPARE_C = """/* the exported step and the hand-written one, timed in turn (CPU time) */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "NAME.h"

int hand_step(const double *x, const double *p, double *u);
typedef int (*step_t)(const double *, const double *, double *);

static const double states[NSTATES][NAME_UPPER_NX] = {
STATES
};

static int cmp(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static double cpu_ns(void) {
  struct timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return 1e9 * (double)t.tv_sec + (double)t.tv_nsec;
}

int main(int argc, char **argv) {
  step_t f[2] = {NAME_step, hand_step};
  long calls = argc > 1 ? atol(argv[1]) : 20000, i;
  int batches = argc > 2 ? atoi(argv[2]) : 501, b, k, j;
  static double t[2][1001];
  double u[2][3], sink = 0.0, t0, worst = 0.0;
  if (calls < 1 || batches < 1 || batches > 1001) return 2;
  for (i = 0; i < NSTATES; ++i) {
    f[0](states[i], 0, u[0]);
    f[1](states[i], 0, u[1]);
    for (j = 0; j < 3; ++j) {
      double d = fabs(u[0][j] - u[1][j]) / (fabs(u[0][j]) > 0 ? fabs(u[0][j]) : 1.0);
      worst = d > worst ? d : worst;
    }
  }
  for (b = 0; b < batches; ++b) {
    for (k = 0; k < 2; ++k) {
      t0 = cpu_ns();
      for (i = 0; i < calls; ++i) {
        f[k](states[i & (NSTATES - 1)], 0, u[0]);
        sink += u[0][0];
      }
      t[k][b] = (cpu_ns() - t0) / (double)calls;
    }
  }
  qsort(t[0], (size_t)batches, sizeof(double), cmp);
  qsort(t[1], (size_t)batches, sizeof(double), cmp);
  printf("export_ns=%.4f hand_ns=%.4f max_rel_diff=%.3g checksum=%.6g\\n",
         t[0][batches / 2], t[1][batches / 2], worst, sink);
  return 0;
}
"""


def hand_vs_export(opt: Optimization, batches: int) -> dict:
    """Exported saturated feedback against the hand-written law, same flags, in turn."""
    c = exports.build("saturated_velocity_feedback")
    P, k = np.asarray(c.gains["P"]), float(c.gains["k"])
    assert np.count_nonzero(P - np.diag(np.diag(P))) == 0, "the hand-written law takes P diagonal"
    lib = codegen.compile_controller(c, binding=Binding.FROZEN, optimization=opt)
    name = c.name
    states = np.vstack([c.example_state, c.sample_states(BENCH_STATES - 1, seed=0)])
    rows = ",\n".join("  {" + ", ".join(repr(float(v)) for v in s) + "}" for s in states)
    hand = HAND_C
    for key, val in (("P0", P[0, 0]), ("P1", P[1, 1]), ("P2", P[2, 2]), ("K", k)):
        hand = re.sub(rf"\b{key}\b", f"({float(val)!r})", hand)
    compare = (COMPARE_C.replace("NAME_UPPER_NX", f"{name.upper()}_NX")
               .replace("NAME", name).replace("NSTATES", str(BENCH_STATES))
               .replace("STATES", rows))
    files = {f"{name}.c": lib.sources.files[f"{name}.c"],
             f"{name}.h": lib.sources.files[f"{name}.h"], "hand.c": hand,
             "compare.c": compare}
    flags = [*CFLAGS_WARN, *opt.flags]
    cmds = [["gcc", *flags, "-c", f"{name}.c", "-o", f"{name}.o"],
            ["gcc", *flags, "-c", "hand.c", "-o", "hand.o"],
            ["gcc", *flags, "compare.c", f"{name}.o", "hand.o", "-o", "compare", "-lm"]]
    digest = hashlib.sha256(repr(sorted(files.items())).encode()).hexdigest()
    directory, _, _ = build_cached(f"{name}_vs_hand", files, cmds, digest=digest,
                                   compiler="gcc", cache_dir=None, manifest={})
    out = subprocess.run([str(directory / "compare"), "20000", str(batches)],
                         capture_output=True, text=True, check=True).stdout
    vals = {k: float(v) for k, v in re.findall(r"(\w+)=(\S+)", out)}
    return {"opt": opt.value, "export [ns]": f"{vals['export_ns']:.2f}",
            "hand [ns]": f"{vals['hand_ns']:.2f}",
            "export/hand": f"{vals['export_ns'] / vals['hand_ns']:.2f}",
            "max rel diff": f"{vals['max_rel_diff']:.1e}",
            "_ratio": vals["export_ns"] / vals["hand_ns"]}


def print_hand_comparison(opts: list[Optimization], batches: int) -> None:
    """The issue-17 comparison: exported law vs hand-written C, with the load average."""
    rows = [hand_vs_export(opt, batches) for opt in opts]
    print("Saturated feedback (34): exported C vs hand-written C, same flags, timed in turn "
          "(CPU-time medians over batches of 20 000 calls)")
    print(table(rows, [k for k in rows[0] if not k.startswith("_")]))
    ratio = rows[0]["_ratio"]
    print(f"target export/hand <= 1.2 (-O2): {ratio:.2f} "
          f"({'met' if ratio <= 1.2 else 'NOT met'}); load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    batches = 51 if "--quick" in argv else 501
    opts = [Optimization.O2] + ([Optimization.NATIVE] if "--native" in argv else [])
    print_hand_comparison(opts, batches)
    if "--hand-only" in argv:
        return
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
