"""The ``workbench`` command line.

``workbench list`` names the problems; ``workbench run NAME [--quick] [--json PATH]`` runs
one (or ``all``) and prints its results. Errors are one clear line on stderr with a
non-zero exit status.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from workbench.errors import WorkbenchError
from workbench.result import Result, format_result, to_jsonable

__all__ = ["main", "run_script"]


class CLIError(Exception):
    """A user error on the command line: printed as one line, exit status 2."""


def _problems():  # imported lazily: the engine does not depend on the problem catalogue
    import problems

    return problems


def _writable_json(path: str) -> Path:
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise CLIError(f"--json: directory {str(parent)!r} does not exist")
    if p.exists() and p.is_dir():
        raise CLIError(f"--json: {path!r} is a directory, expected a file path")
    try:
        with open(p.with_name(p.name + ".probe"), "w"):
            pass
        p.with_name(p.name + ".probe").unlink()
    except OSError as exc:
        raise CLIError(f"--json: cannot write to {path!r} ({exc.strerror})") from exc
    return p


def _run(args: argparse.Namespace) -> int:
    problems = _problems()
    targets = problems.names() if args.name == "all" else [args.name]
    if args.name != "all" and args.name not in problems.names():
        raise CLIError(
            f"unknown problem {args.name!r}; run 'workbench list' (known: "
            f"{', '.join(problems.names())})"
        )
    out = _writable_json(args.json) if args.json else None
    results: list[Result] = []
    for i, name in enumerate(targets):
        if len(targets) > 1:
            print(f"[{i + 1}/{len(targets)}] {name} ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        result = problems.load(name).solve(quick=args.quick)
        result.timings.setdefault("total", time.perf_counter() - t0)
        print(format_result(result), flush=True)
        results.append(result)
    if out is not None:
        data = results[0].as_dict() if len(results) == 1 and args.name != "all" else {
            r.name: r.as_dict() for r in results
        }
        tmp = out.with_name(out.name + ".partial")
        tmp.write_text(json.dumps(to_jsonable(data), indent=2, allow_nan=False))
        tmp.replace(out)
        print(f"wrote {out}", file=sys.stderr)
    bad = [r.name for r in results if not r.ok]
    if bad:
        print(f"error: comparisons out of tolerance in: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


def _list(args: argparse.Namespace) -> int:
    problems = _problems()
    for name in problems.names():
        print(f"{name:<34} {problems.title(name)}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (also used by the tests)."""
    parser = argparse.ArgumentParser(
        prog="workbench",
        description="Geometric pendulum workbench: run the papers' problems.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p_list = sub.add_parser("list", help="list the problems with one-line descriptions")
    p_list.set_defaults(func=_list)
    p_run = sub.add_parser("run", help="run one problem (or 'all') and print its results")
    p_run.add_argument("name", help="problem name (see 'workbench list'), or 'all'")
    p_run.add_argument("--quick", action="store_true", help="smaller sizes, for a fast check")
    p_run.add_argument("--json", metavar="PATH", help="also write the values as JSON")
    p_run.set_defaults(func=_run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except CLIError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except WorkbenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def run_script(solve: Callable[..., Result]) -> None:
    """Body of ``if __name__ == "__main__"`` in a problem module: run and print it."""
    parser = argparse.ArgumentParser(description="Run this problem and print its results.")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json", metavar="PATH")
    args = parser.parse_args()
    result = solve(quick=args.quick)
    print(format_result(result))
    if args.json:
        result.write_json(_writable_json(args.json))
    sys.exit(0 if result.ok else 1)


if __name__ == "__main__":
    sys.exit(main())
