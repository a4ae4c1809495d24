"""The warm report (issue 18: < 20 s when nothing changed): where its time goes.

A warm ``workbench report`` runs no problem: it hashes each problem's dependencies, loads
the cached outcomes, assembles the document and writes HTML and PDF. This benchmark
times those stages on the outcomes already in the cache (run ``workbench report [--quick]``
first; problems without a cached outcome are left out and named), stage after stage,
round after round (CPU-time medians of the same run, so a busy spell of the shared machine
falls on every stage alike), and prints the wall time of one whole warm build.

Target: the whole warm report < 20 s (``workbench report`` prints its own total time and
peak memory at the end as well).

Usage: python benchmarks/bench_report.py [--quick] [--rounds N] [--cache DIR]
"""

from __future__ import annotations

import argparse
import io
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _timing import interleaved_cpu, table  # noqa: E402

from workbench.app import registry  # noqa: E402
from workbench.app.report import DEFAULT_CACHE, Format, build_report, document, run_all  # noqa: E402
from workbench.app.report import cache as report_cache  # noqa: E402
from workbench.app.report.html import render_html  # noqa: E402
from workbench.app.report.pdf import render_pdf  # noqa: E402


def cached_names(cache_dir: Path, quick: bool) -> tuple[list[str], list[str]]:
    """Problems with a cached outcome for today's sources, and those without."""
    have, missing = [], []
    for name in registry.names():
        key = report_cache.problem_key(report_cache.module_file(registry.load(name)),
                                       quick=quick)
        ok = key and report_cache.load(cache_dir, name, quick=quick, key=key) is not None
        (have if ok else missing).append(name)
    return have, missing


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the quick report's cache")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--cache", type=Path, default=DEFAULT_CACHE)
    args = parser.parse_args(argv)
    names, missing = cached_names(args.cache, args.quick)
    print(f"{len(names)} problems cached ({'quick' if args.quick else 'full'} mode)"
          + (f"; not cached, left out: {', '.join(missing)}" if missing else ""))
    if not names:
        print("nothing cached: run 'workbench report" + (" --quick" if args.quick else "")
              + "' first")
        return 1
    state: dict[str, object] = {}

    def lookup() -> None:
        outs, stats = run_all(names, quick=args.quick, catalogue=registry, progress=False,
                              cache_dir=args.cache)
        assert stats.ran == 0, "a problem ran: the cache is not warm"
        state["outs"], state["stats"] = outs, stats

    def assemble() -> None:
        state["doc"] = document(state["outs"], quick=args.quick, seconds=0.0,  # type: ignore
                                modules={n: registry.load(n) for n in names})

    def html() -> None:
        state["html"] = render_html(state["doc"])  # type: ignore[arg-type]

    def pdf() -> None:
        state["pdf"] = render_pdf(state["doc"])  # type: ignore[arg-type]

    cpu = interleaved_cpu({"hash keys + load cache": lookup, "assemble document": assemble,
                           "HTML": html, "PDF (typst)": pdf}, rounds=args.rounds)
    rows = [{"stage": k, "CPU median [s]": f"{v:.2f}"} for k, v in cpu.items()]
    print(table(rows, ["stage", "CPU median [s]"]))
    print(f"HTML {len(state['html']) / 1e6:.1f} MB, PDF {len(state['pdf']) / 1e6:.1f} MB "
          f"(typst runs in this process; its CPU time is counted)")
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        rep = build_report(names, quick=args.quick, formats=[Format.HTML, Format.PDF],
                           out_dir=out, cache_dir=args.cache, stream=io.StringIO())
        wall = time.perf_counter() - t0
    print(f"one whole warm report: {wall:.1f} s wall (target < 20 s); stages "
          + ", ".join(f"{k} {v:.1f} s" for k, v in rep.seconds.items()))
    print(f"peak resident memory of this process: "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
