"""Run a problem module as a script: ``python -m problems.NAME [--quick] [--json PATH]``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from workbench.core.errors import WorkbenchError
from workbench.study._result import Result, format_result

__all__ = ["run_script"]


def run_script(solve: Callable[..., Result], argv: Sequence[str] | None = None) -> None:
    """Body of ``if __name__ == "__main__"`` in a problem module: run, print, exit.

    Parameters
    ----------
    solve : callable
        The problem's ``solve(*, quick=False) -> Result``.
    argv : sequence of str, optional
        The arguments (default: ``sys.argv[1:]``): ``--quick`` and ``--json PATH``.

    Notes
    -----
    Exits with status 0 when every comparison holds, 1 when one does not, and 2 (one line
    on stderr) when the JSON cannot be written.
    """
    parser = argparse.ArgumentParser(description="Run this problem and print its results.")
    parser.add_argument("--quick", action="store_true", help="the problem's quick mode")
    parser.add_argument("--json", metavar="PATH", help="also write the result as JSON")
    args = parser.parse_args(argv)
    result = solve(quick=args.quick)
    print(format_result(result))
    if args.json is not None:
        try:
            result.write_json(args.json)
        except (OSError, WorkbenchError) as exc:
            print(f"error: --json: {exc}", file=sys.stderr)
            sys.exit(2)
    sys.exit(0 if result.ok else 1)
