"""Timing helpers for the benchmarks: medians of repeated runs, never single times."""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable


def median_time(fn: Callable[[], object], *, repeat: int = 7, number: int = 1) -> float:
    """Median over ``repeat`` runs of the mean time of ``number`` calls of ``fn`` [s]."""
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        samples.append((time.perf_counter() - t0) / number)
    return statistics.median(samples)


def table(rows: list[dict], columns: list[str]) -> str:
    """Plain-text table of dict rows."""
    widths = {c: max(len(c), *(len(str(r[c])) for r in rows)) for c in columns}
    head = "  ".join(f"{c:>{widths[c]}}" for c in columns)
    body = ["  ".join(f"{r[c]!s:>{widths[c]}}" for c in columns) for r in rows]
    return "\n".join([head, *body])


def interleaved_cpu(fns: dict[str, Callable[[], object]], *, rounds: int = 15,
                    number: int = 1) -> dict[str, float]:
    """CPU-time medians [s per call] of several functions timed in turn, round by round.

    Each round times ``number`` calls of every function one after the other (CPU time of
    the process, ``time.process_time``), so a busy spell of the shared machine falls on
    all of them alike; the median over ``rounds`` rounds is returned per name.
    """
    samples: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(rounds):
        for k, fn in fns.items():
            t0 = time.process_time()
            for _ in range(number):
                fn()
            samples[k].append((time.process_time() - t0) / number)
    return {k: statistics.median(v) for k, v in samples.items()}


def quick_repeat_arguments(doc: str, quick_help: str, argv: list[str], *,
                           repeat: int = 5) -> argparse.Namespace:
    """``--quick`` and ``--repeat K`` (an integer >= 1) of a benchmark script.

    ``doc``'s first line is the description; ``argv`` is ``sys.argv[1:]`` when the script
    runs as ``__main__`` and ``[]`` otherwise (the defaults, when ``workbench bench`` imports it).
    """
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=quick_help)
    ap.add_argument("--repeat", type=int, default=repeat)
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error(f"--repeat must be an integer >= 1; got {a.repeat}")
    return a
