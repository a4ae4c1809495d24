"""Run a problem module as a script: ``python -m problems.NAME [--quick] [--json PATH]``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from workbench.core.errors import WorkbenchError
from workbench.core.files import writable_dir, writable_file
from workbench.core.validate import output_path
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
    on stderr) when the JSON cannot be written; a ``--json`` path that cannot be written (a
    missing folder, a directory, a device, an open descriptor's name such as
    ``/dev/stdout``) is refused before the problem runs.
    """
    parser = argparse.ArgumentParser(description="Run this problem and print its results.")
    parser.add_argument("--quick", action="store_true", help="the problem's quick mode")
    parser.add_argument("--json", metavar="PATH", help="also write the result as JSON")
    args = parser.parse_args(argv)
    if args.json is not None:
        try:  # checked before the problem runs, without writing anything
            target = writable_file(output_path("--json", args.json), name="--json")
            writable_dir(target.parent, name="--json")
        except (OSError, WorkbenchError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            sys.exit(2)
    result = solve(quick=args.quick)
    print(format_result(result))
    if args.json is not None:
        try:
            result.write_json(args.json)
        except (OSError, WorkbenchError) as exc:
            print(f"error: --json: {exc}", file=sys.stderr)
            sys.exit(2)
    sys.exit(0 if result.ok else 1)
