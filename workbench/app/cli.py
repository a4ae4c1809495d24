"""The ``workbench`` command line.

``workbench list`` names the problems; ``workbench run NAME [--quick] [--json PATH]`` runs
one (or ``all``) and prints its results (``--json -``: the JSON on standard output, the
printed results on stderr); ``workbench report [NAMES...] [--quick] [--html]
[--pdf] [--out DIR]`` writes the HTML and/or PDF report; ``workbench bench [NAMES...]
[--list]`` runs the scripts in ``benchmarks/``; ``workbench export-c NAME --out DIR``
exports a controller as C99 (:mod:`workbench.app.export_cli`). Errors are one clear line on
stderr with a non-zero exit status (2 for bad input; 1 when a problem failed or a
comparison is out of tolerance).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import os
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import NoReturn

from workbench.app.export_cli import add_export_c_parser
from workbench.core.errors import WorkbenchError
from workbench.core.files import writable_dir, writable_file, write_atomic
from workbench.core.validate import output_path
from workbench.study._result import PROGRESS_ENV, Result, format_result, to_jsonable

__all__ = ["main", "build_parser", "benchmark_scripts"]


BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
"""Directory of the benchmark scripts (``bench_*.py``, each with a ``main()``)."""


class CLIError(Exception):
    """A user error on the command line: printed as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line on stderr (exit status 2)."""

    def error(self, message: str) -> NoReturn:
        """Print ``prog: error: message (see --help)`` and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _problems():  # imported lazily: the engine does not depend on the problem catalogue
    from workbench.app import registry as problems

    return problems


STDOUT = "-"
"""``--json -``: the JSON goes to standard output (and the printed results to stderr)."""


def _writable_json(path: str) -> Path | None:
    """``--json PATH`` checked before any problem runs, without writing anything.

    Returns None for ``-`` (standard output, written as a stream, never replaced).
    """
    if path == STDOUT:
        return None
    p = output_path("--json", path, error=CLIError)
    # a directory, FIFO, socket or device (or a link to one) is refused, and so is a name
    # of an open descriptor (/dev/stdout, /dev/fd/N, /proc/PID/fd/N): behind it may be the
    # shell's redirect target (>> log), which a replacement would wipe; a link is written
    # through, so its target's folder is the one that must be writable
    target = writable_file(p, name="--json", error=CLIError,
                           hint=f"for standard output use '--json {STDOUT}'")
    writable_dir(target.parent, name="--json", error=CLIError)
    return p


def _write_stdout(text: str) -> None:
    """Write ``text`` to file descriptor 1 as a stream: appended, nothing truncated.

    Whatever the shell opened (a terminal, a pipe, ``> file``, ``>> log``) is written
    to through the descriptor, so ``>>``'s appending is kept.
    """
    sys.stdout.flush()
    view = memoryview(text.encode("utf-8"))
    while view:
        view = view[os.write(1, view):]


@contextlib.contextmanager
def _stdout_to_stderr() -> Iterator[None]:
    """While problems run for ``--json -``, whatever they print goes to stderr.

    Both Python's ``sys.stdout`` and file descriptor 1 (where compiled solvers print)
    point at stderr, so standard output carries the JSON alone.
    """
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        with contextlib.suppress(OSError, ValueError):
            sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1; got {text!r}")
    return value


def _jobs(text: str) -> int:
    """``--jobs N``: a whole number from 1 to the report's bound (checked before any work)."""
    from workbench.app.report.runner import MAX_JOBS  # the report's modules load on use

    value = _positive_int(text)
    if value > MAX_JOBS:
        raise argparse.ArgumentTypeError(
            f"expected a whole number from 1 to {MAX_JOBS} (problems run at the same time; "
            f"at most one process per problem is used); got {text!r}")
    return value


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive number; got {text!r}")
    return value


@contextlib.contextmanager
def _progress_to_stderr() -> Iterator[None]:
    """While problems run here, their ``progress(...)`` lines go to stderr as text."""
    before = os.environ.get(PROGRESS_ENV)
    os.environ.setdefault(PROGRESS_ENV, "-")
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(PROGRESS_ENV, None)


def _run(args: argparse.Namespace) -> int:
    problems = _problems()
    targets = problems.names() if args.name == "all" else [args.name]
    if args.name != "all" and args.name not in problems.names():
        raise CLIError(
            f"unknown problem {args.name!r}; run 'workbench list' (known: "
            f"{', '.join(problems.names())})"
        )
    out = _writable_json(args.json) if args.json is not None else None
    to_stdout = args.json == STDOUT
    results: list[Result] = []
    with _progress_to_stderr(), \
            (_stdout_to_stderr() if to_stdout else contextlib.nullcontext()):
        for i, name in enumerate(targets):
            if len(targets) > 1:
                print(f"[{i + 1}/{len(targets)}] {name} ...", file=sys.stderr, flush=True)
            t0 = time.perf_counter()
            result = problems.load(name).solve(quick=args.quick)
            result.timings.setdefault("total", time.perf_counter() - t0)
            print(format_result(result), flush=True)
            results.append(result)
    if args.json is not None:
        data = results[0].as_dict() if len(results) == 1 and args.name != "all" else {
            r.name: r.as_dict() for r in results
        }
        text = json.dumps(to_jsonable(data), indent=2, allow_nan=False)
        if out is None:
            _write_stdout(text + "\n")
        else:
            write_atomic(out, text, name="--json")
            print(f"wrote {out}", file=sys.stderr)
    bad = [r.name for r in results if not r.ok]
    if bad:
        print(f"error: comparisons out of tolerance in: {', '.join(bad)}", file=sys.stderr)
        return 1
    return 0


def _list(args: argparse.Namespace) -> int:
    problems = _problems()
    if getattr(args, "markdown", False):
        print("| name | reproduces |\n|---|---|")
        for name in problems.names():
            print(f"| `{name}` | {problems.title(name)} |")
        return 0
    for name in problems.names():
        print(f"{name:<34} {problems.title(name)}")
    return 0


def _report(args: argparse.Namespace) -> int:
    from workbench.app.report import DEFAULT_CACHE, DEFAULT_OUT, Format, build_report

    formats = [f for f, on in ((Format.HTML, args.html), (Format.PDF, args.pdf)) if on]
    if not formats:
        formats = [Format.HTML, Format.PDF]
    cache = None if args.no_cache else (args.cache or DEFAULT_CACHE)
    rep = build_report(args.names or None, quick=args.quick, formats=formats,
                       out_dir=DEFAULT_OUT if args.out is None else output_path(
                           "--out", args.out, error=CLIError),
                       progress=not args.no_progress,
                       jobs=args.jobs, timeout=args.timeout, cache_dir=cache,
                       rerun=args.rerun, memory_mb=args.memory)
    for fmt_, path in rep.paths.items():
        print(f"wrote {path} ({path.stat().st_size / 1024:.0f} kB, {fmt_.value})")
    print(rep.summary_line())
    if rep.failed:
        print(f"error: problems failed or timed out (shown in the report): "
              f"{', '.join(rep.failed)}", file=sys.stderr)
    if rep.out_of_tolerance:
        print("error: comparisons out of tolerance in: " + ", ".join(rep.out_of_tolerance),
              file=sys.stderr)
    return 0 if rep.ok else 1


def benchmark_scripts(directory: Path | None = None) -> dict[str, Path]:
    """The benchmark scripts by name (``bench_models.py`` is ``models``)."""
    directory = BENCHMARKS if directory is None else directory
    if not directory.is_dir():
        return {}
    return {p.stem.removeprefix("bench_"): p for p in sorted(directory.glob("bench_*.py"))}


def _bench(args: argparse.Namespace) -> int:
    scripts = benchmark_scripts()
    if args.list:
        for name, path in scripts.items():
            print(f"{name:<24} {path}")
        return 0
    if not scripts:
        raise CLIError(f"no benchmark scripts (bench_*.py) in {BENCHMARKS}")
    names = [n.removeprefix("bench_") for n in args.names] or list(scripts)
    unknown = [n for n in names if n not in scripts]
    if unknown:
        raise CLIError(f"unknown benchmark(s) {', '.join(map(repr, unknown))}; known: "
                       f"{', '.join(scripts)}")
    failed = []
    for i, name in enumerate(names):
        print(f"[{i + 1}/{len(names)}] benchmark {name} ...", file=sys.stderr, flush=True)
        print(f"=== {name}", flush=True)
        if _run_benchmark(name, scripts[name]) != 0:
            failed.append(name)
        print(flush=True)
    if failed:
        print(f"error: benchmarks failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


def _run_benchmark(name: str, path: Path) -> int:
    """Import a benchmark script and call its ``main()``; return its exit status."""
    saved_argv, saved_path = sys.argv, list(sys.path)
    sys.argv = [str(path)]
    sys.path.insert(0, str(path.parent))
    try:
        spec = importlib.util.spec_from_file_location(f"_bench_{path.stem}", path)
        mod = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
        spec.loader.exec_module(mod)  # type: ignore[union-attr]
        if not callable(getattr(mod, "main", None)):
            print(f"error: benchmark {name} ({path.name}) has no main()", file=sys.stderr)
            return 1
        status = mod.main()
        return int(status) if isinstance(status, int) else 0
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except Exception as exc:  # noqa: BLE001 - one failing benchmark does not stop the rest
        print(f"error: benchmark {name} raised {type(exc).__name__}: {exc}",
              file=sys.stderr)
        return 1
    finally:
        sys.argv = saved_argv
        with contextlib.suppress(ValueError):
            sys.path[:] = saved_path


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (also used by the tests)."""
    parser = _Parser(
        prog="workbench",
        description="Geometric pendulum workbench: run the papers' problems.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=_Parser)
    p_list = sub.add_parser("list", help="list the problems with one-line descriptions")
    p_list.add_argument("--markdown", action="store_true",
                        help="print the list as a Markdown table of names and one-line "
                             "descriptions")
    p_list.set_defaults(func=_list)
    p_run = sub.add_parser("run", help="run one problem (or 'all') and print its results")
    p_run.add_argument("name", help="problem name (see 'workbench list'), or 'all'")
    p_run.add_argument("--quick", action="store_true", help="smaller sizes, for a fast check")
    p_run.add_argument("--json", metavar="PATH",
                       help="also write the values as JSON to the file PATH (replaced "
                       "whole); '-' writes them to standard output, and the printed "
                       "results to stderr. A name of an open descriptor (/dev/stdout, "
                       "/dev/fd/N) is refused")
    p_run.set_defaults(func=_run)
    p_rep = sub.add_parser(
        "report", help="run problems and write their HTML and/or PDF report",
        description="Run the problems (all, or NAMES) and write one report: a self-contained "
        "HTML file and/or a PDF, in DIR. Problems run in parallel processes, each with a time "
        "limit, and are re-used from the cache when nothing they depend on changed. A problem "
        "that fails or times out appears in the report with its error, and is cached like the "
        "others (--rerun runs it again; a time-out also runs again under a larger --timeout). "
        "Ends with the total "
        "time and peak memory. Exit status 1 if a problem failed or a comparison is out of "
        "tolerance.",
    )
    p_rep.add_argument("names", nargs="*", metavar="NAME",
                       help="problems to include (default: all; see 'workbench list')")
    p_rep.add_argument("--quick", action="store_true", help="run the problems in quick mode")
    p_rep.add_argument("--html", action="store_true", help="write HTML (default: HTML and PDF)")
    p_rep.add_argument("--pdf", action="store_true", help="write PDF (default: HTML and PDF)")
    p_rep.add_argument("--out", metavar="DIR", default=None,
                       help="output directory (default: reports/out/ of the repository)")
    p_rep.add_argument("--no-progress", action="store_true",
                       help="do not show per-problem progress on stderr")
    p_rep.add_argument("--jobs", type=_jobs, default=None, metavar="N",
                       help="problems run at the same time (default: the number of cores; "
                       "at most one process per problem to run, and 256)")
    p_rep.add_argument("--timeout", type=_positive_float, default=None, metavar="SECONDS",
                       help="time limit of one problem in CPU seconds (default 600 quick, "
                       "1200 full); also stopped after 3 times as long in wall time")
    p_rep.add_argument("--cache", metavar="DIR", default=None,
                       help="cache of the problems' results (default: reports/out/cache/); "
                       "a problem is re-used when nothing it depends on changed")
    p_rep.add_argument("--no-cache", action="store_true",
                       help="run every problem and cache nothing")
    p_rep.add_argument("--memory", type=_positive_float, default=None, metavar="MB",
                       help="run problems at the same time only while their peak memories "
                       "(of their last runs) add up to at most MB (default 1300)")
    p_rep.add_argument("--rerun", action="append", metavar="NAME", default=None,
                       help="run NAME again even if its result is cached (repeatable); "
                       "'failed': every cached failure and time-out; 'all': every problem "
                       "(results are cached again)")
    p_rep.set_defaults(func=_report)
    p_bench = sub.add_parser(
        "bench", help="run the benchmark scripts and print their output",
        description="Run the scripts benchmarks/bench_*.py (all, or NAMES), each through its "
        "main(), and print what they print.",
    )
    p_bench.add_argument("names", nargs="*", metavar="NAME",
                         help="benchmarks to run (default: all; see --list)")
    p_bench.add_argument("--list", action="store_true", help="name the benchmarks and stop")
    p_bench.set_defaults(func=_bench)
    add_export_c_parser(sub)
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
    except OSError as exc:  # e.g. a full disk while writing: one line, nothing partial
        print(f"error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "),
              file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("error: interrupted; nothing partial was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
