"""Compiling a step function to C (``jit=True`` of the geometric integrators).

:func:`compile_step` compiles an SX step once per process (kept by the sha256 of its
serialisation); :func:`jit_function` compiles any casadi function through casadi's shell
compiler in a private temporary directory removed as soon as the library is loaded.
"""

from __future__ import annotations

import hashlib
import shutil
import tempfile

import casadi as ca

from workbench.core.errors import ModelError, SolverError

__all__ = ["compile_step", "jit_function"]


_COMPILED: dict[str, ca.Function] = {}
_COMPILED_MAX = 32  # compiled step functions kept, by the sha256 of their serialisation


def compile_step(fn: ca.Function) -> ca.Function:
    """Just-in-time compile a step function to C (``gcc -O2`` through casadi's shell).

    The result is kept per process by the sha256 of the step's serialisation, so the same
    graph is compiled once however many simulations use it.

    Parameters
    ----------
    fn : casadi.Function
        An SX step function.

    Returns
    -------
    casadi.Function
        The same function, compiled.

    Raises
    ------
    SolverError
        If the compiler fails (its message is included).
    """
    if not fn.is_a("SXFunction"):
        raise ModelError(
            f"jit=True compiles scalar (SX) step functions; {fn.name()!r} is "
            f"{fn.class_name()} (an MX model); run it with jit=False"
        )
    # the same graph (by its serialisation) is compiled once per process: a study that
    # simulates one model several times with jit (extremes: three lgvi runs) paid gcc
    # for each, 0.3-0.5 s
    try:
        key = hashlib.sha256(fn.serialize().encode()).hexdigest()
    except RuntimeError:  # a function casadi cannot serialise: compiled, not remembered
        key = None
    hit = _COMPILED.get(key) if key else None
    if hit is not None:
        return hit
    ins = fn.sx_in()
    out = jit_function(f"{fn.name()}_jit", ins, fn.call(ins), fn.name_in(), fn.name_out(),
                       what=repr(fn.name()))
    if key is None:
        return out
    if len(_COMPILED) >= _COMPILED_MAX:
        _COMPILED.pop(next(iter(_COMPILED)))
    _COMPILED[key] = out
    return out


def jit_function(name: str, ins: list, outs: list, names_in: list[str] | None = None,
                 names_out: list[str] | None = None, *, what: str = "") -> ca.Function:
    """A casadi function compiled to C (``gcc -O2`` through casadi's shell compiler).

    The C source, object and shared library go to a private temporary directory that is
    removed as soon as the library is loaded: nothing is left behind, however the process
    ends (forked children exit without running destructors, which left casadi's own
    temporary files in the system's temporary directory).

    Parameters
    ----------
    name : str
        Name of the function.
    ins, outs : list of casadi.SX or list of casadi.MX
        Its inputs and outputs.
    names_in, names_out : list of str, optional
        Their names.
    what : str
        What is compiled, for the error message (default: ``name``).

    Returns
    -------
    casadi.Function

    Raises
    ------
    SolverError
        If the compiler fails (its message is included).
    """
    work = tempfile.mkdtemp(prefix="workbench-jit-")
    opts = {"jit": True, "compiler": "shell", "jit_name": "jit", "jit_temp_suffix": False,
            "jit_cleanup": False,  # the directory is removed below, not by casadi
            "jit_options": {"flags": ["-O2"], "directory": work, "cleanup": False}}
    try:
        if names_in is None:
            return ca.Function(name, ins, outs, opts)
        return ca.Function(name, ins, outs, names_in, names_out, opts)
    except RuntimeError as exc:
        raise SolverError(
            f"jit compilation of {what or name!r} failed: "
            f"{str(exc).strip().splitlines()[-1]}", status="compiler error") from exc
    finally:
        shutil.rmtree(work, ignore_errors=True)
