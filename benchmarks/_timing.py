"""Timing helpers for the benchmarks: medians of repeated runs, never single times."""

from __future__ import annotations

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
