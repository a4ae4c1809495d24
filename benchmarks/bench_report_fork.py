"""What the report's forked problems inherit: frozen objects and preloaded modules.

Issue 18 (the cold quick report, < 60 s on 2 cores): ``workbench report`` runs each
problem in a process forked from its own, after loading what the problems would each load
(:data:`workbench.app.report.runner.PRELOAD`). Two things make a child cheaper:

- ``gc.freeze()`` before each fork: the ~170k objects a child inherits are never garbage
  for it, but without the freeze its collector walks them at every full collection (and
  writes to each object's header, so the child copies every page it touches);
- the preload of ``sympy.tensor.tensor`` (imported by sympy at its first sum of certain
  terms, which every model sheet makes), ``sympy.physics.mechanics`` (the Kane references
  of 4 problems) and ``workbench.mechanics``, besides python-control, scipy.stats and PIL.

The baseline is the runner without the freeze and with the previous preload (python-control,
scipy.stats, PIL). Each variant runs as a fresh command (what it preloads stays loaded), in
turn, round by round (interleaved), on the problems given (default: the 13 smallest, where
a child's fixed costs weigh most), one problem at a time (``--jobs 1``), no cache. Printed:
CPU-second medians of the whole command (parent and children) and of the children alone, the
ratio to the baseline, and the load average (the 2 cores are shared).

Usage: python benchmarks/bench_report_fork.py [--rounds N] [NAME ...]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _timing import table  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent

SMALL = ("s2_pd_eigenstructure", "pendulum3d_linearization", "chain_linearization",
         "so3_pd_eigenstructure", "mechanics_paper_models", "so3_pd_closed_loop",
         "pendulum3d_invariants", "chain_lqr", "velocity_feedback_hanging",
         "inverted_manifold_velocity_feedback", "chain_equilibria",
         "velocity_feedback_linearization", "pendulum3d_cart")
"""The 13 problems of under 3 s each in quick mode."""

BASELINE_PRELOAD = ("control", "scipy.stats", "PIL.Image")

CHILD = """
import sys, types
sys.path.insert(0, {root!r})
from workbench.app import registry
from workbench.app.report import runner
if {baseline!r}:
    runner.PRELOAD = {preload!r}
    runner.gc = types.SimpleNamespace(freeze=lambda: None, unfreeze=lambda: None)
outcomes, stats = runner.run_all({names!r}, quick=True, catalogue=registry, jobs=1,
                                 progress=False)
bad = [o.name for o in outcomes if o.status.value not in ("ok", "out of tolerance")]
if bad:
    raise SystemExit(f"failed: {{bad}}")
print(stats.cpu_seconds)
"""


def one(names: list[str], *, baseline: bool) -> tuple[float, float]:
    """CPU seconds of one report run: (whole command, its problems' processes)."""
    code = CHILD.format(root=str(ROOT), baseline=baseline, preload=BASELINE_PRELOAD,
                        names=names)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as tmp:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             cwd=tmp, env=os.environ | {"OPENBLAS_NUM_THREADS": "1"})
    if out.returncode:
        raise SystemExit(f"report run failed:\n{out.stderr[-2000:]}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    whole = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return whole, float(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("names", nargs="*", default=list(SMALL))
    args = parser.parse_args(argv)
    samples: dict[str, list[tuple[float, float]]] = {"baseline": [], "now": []}
    for r in range(args.rounds):
        order = ("baseline", "now") if r % 2 == 0 else ("now", "baseline")
        for variant in order:
            samples[variant].append(one(args.names, baseline=variant == "baseline"))
    base_whole = statistics.median(s[0] for s in samples["baseline"])
    base_kids = statistics.median(s[1] for s in samples["baseline"])
    rows = []
    for variant, s in samples.items():
        whole = statistics.median(x[0] for x in s)
        kids = statistics.median(x[1] for x in s)
        rows.append({"variant": variant, "command CPU [s]": f"{whole:.2f}",
                     "ratio": f"{whole / base_whole:.3f}",
                     "problems' CPU [s]": f"{kids:.2f}", "ratio ": f"{kids / base_kids:.3f}"})
    print(f"{len(args.names)} problems, quick, one at a time; medians of {args.rounds} "
          f"interleaved rounds; load average {os.getloadavg()[0]:.2f}")
    print(table(rows, ["variant", "command CPU [s]", "ratio", "problems' CPU [s]", "ratio "]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
