"""The ``export-c`` subcommand of the ``workbench`` command line.

``workbench export-c --list`` names the exportable controllers;
``workbench export-c NAME --out DIR [--binding B] [--opt O] [--verify N] [--bench]`` writes
``NAME.c``, ``NAME.h``, ``main.c``, ``bench.c`` and a ``Makefile`` to ``DIR`` after
compiling them with ``-std=c99 -Wall -Wextra -Werror`` and (by default) checking the
compiled code against casadi's evaluation on 10^4 seeded states. Errors are one clear line
on stderr (a compiler failure adds the compiler's own message) and a non-zero exit status:
2 for bad input, 1 for a failed compilation or verification.

:func:`add_export_c_parser` registers the subcommand on the ``workbench`` parser;
``python -m workbench.app.export_cli`` runs it alone.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from workbench.codegen.spec import MAX_SAMPLES
from workbench.core.errors import ParameterError, WorkbenchError
from workbench.core.files import refuse_descriptor
from workbench.core.validate import count

__all__ = ["add_export_c_parser", "main", "run_export_c"]

TOLERANCE = 1e-12
"""Largest accepted relative deviation of the compiled code from casadi's evaluation."""


def add_export_c_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``export-c`` on the ``workbench`` command's subparsers.

    Parameters
    ----------
    subparsers : argparse subparsers action
        From ``parser.add_subparsers(...)``; the handler is set as ``func`` (it returns
        the exit status).

    Returns
    -------
    argparse.ArgumentParser
        The ``export-c`` parser.
    """
    p = subparsers.add_parser(
        "export-c",
        help="export a controller as self-contained C99 code (see --list)",
        description="Export a controller of the workbench as C99 source and header, an "
        "example main.c and a Makefile, compiled with -std=c99 -Wall -Wextra -Werror and "
        "checked against casadi's evaluation.",
    )
    p.add_argument("name", nargs="?", metavar="NAME",
                   help="controller to export (see --list); the chain takes its number of "
                        "links in the name, e.g. chain_lqr_n5")
    p.add_argument("--list", action="store_true", help="list the exportable controllers")
    p.add_argument("--out", metavar="DIR", help="output directory (created if missing)")
    p.add_argument("--binding", default="frozen",
                   choices=["frozen", "parameters", "parameters-and-gains"],
                   help="frozen: model parameters and gains are constants of the code; "
                        "parameters: model parameters passed at run time; "
                        "parameters-and-gains: both passed at run time (default: frozen)")
    p.add_argument("--opt", default="O2", choices=["O2", "O3", "O3-native"],
                   help="optimisation of the check build (default: O2)")
    p.add_argument("--cc", default="gcc", metavar="COMPILER",
                   help="C compiler of the check build (default: gcc)")
    p.add_argument("--verify", type=int, default=10_000, metavar="N",
                   help="compare the compiled code with casadi on N seeded states "
                        f"(default: 10000; 0 skips; at most {MAX_SAMPLES})")
    p.add_argument("--bench", action="store_true",
                   help="also print the median nanoseconds per call, measured in C")
    p.set_defaults(func=run_export_c)
    return p


def _exports():  # imported on use: listing the parser builds no controller
    from workbench.app import catalogue

    return catalogue


def _fail(message: str, status: int) -> int:
    print(f"error: {message}", file=sys.stderr)
    return status


def run_export_c(args: argparse.Namespace) -> int:
    """Handle ``export-c``; return the exit status (0 ok, 2 bad input, 1 failure)."""
    from workbench import codegen

    exports = _exports()
    if args.list:
        if args.name or args.out:
            return _fail("export-c --list takes no NAME or --out", 2)
        for name, summary in exports.describe():
            print(f"{name:<30} {summary}")
        return 0
    if not args.name:
        return _fail("export-c needs a controller NAME (see 'workbench export-c --list')", 2)
    if not args.out:
        return _fail("export-c needs --out DIR (the output directory)", 2)
    try:  # bounded before anything is built or drawn
        count("--verify", args.verify, minimum=0, maximum=MAX_SAMPLES, error=ParameterError)
    except ParameterError as exc:
        return _fail(f"{exc} (seeded states compared with casadi; 0 skips the check)", 2)
    try:  # /dev/fd/N, /proc/PID/fd/N: a descriptor's name, not a folder (as every writer)
        refuse_descriptor(args.out, name="--out", error=ParameterError, folder=True)
    except ParameterError as exc:
        return _fail(str(exc), 2)
    try:
        controller = exports.build(args.name)
        binding = codegen.Binding(args.binding)
        res = codegen.export_c(controller, args.out, binding=binding,
                               optimization=codegen.Optimization(args.opt), compiler=args.cc)
    except codegen.CompileError as exc:
        return _fail(str(exc), 1)
    except WorkbenchError as exc:
        return _fail(str(exc), 2)
    src = res.compiled.sources
    print(f"exported {controller.name} ({binding.value}; {src.n_instructions} casadi "
          f"instructions; hash {res.compiled.hash[:16]}) to {args.out}:")
    for f in res.files:
        print(f"  {f}")
    if args.verify:
        states = controller.sample_states(args.verify, seed=0)
        worst = max(float(codegen.agreement(controller, res.compiled, states, binding=binding,
                                            through=via).max()) for via in codegen.Through)
        ok = worst <= TOLERANCE
        print(f"verified on {args.verify} seeded states: max relative deviation from "
              f"casadi {worst:.3g} ({'ok' if ok else 'FAILED'}, tolerance {TOLERANCE:g})")
        if not ok:
            return _fail(f"compiled {controller.name} deviates from casadi by {worst:.3g} "
                         f"> {TOLERANCE:g}", 1)
    if args.bench:
        try:
            b = codegen.bench_c(res.compiled)
        except codegen.CompileError as exc:
            return _fail(str(exc), 1)
        print(f"C benchmark ({args.opt}): median {b.median_ns:.2f} ns per call "
              f"(min {b.min_ns:.2f}, max {b.max_ns:.2f}; {b.batches} batches of {b.calls})")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``export-c`` alone (as ``python -m workbench.app.export_cli``)."""
    parser = argparse.ArgumentParser(prog="workbench")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    add_export_c_parser(sub)
    args = parser.parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
