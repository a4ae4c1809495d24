"""The compiled right-hand side of :func:`workbench.simulation._simulate.simulate`.

``simulate(..., compilation="c")`` puts a call of the compiled library (from the codegen
cache) in place of the right-hand side's graph; this module keeps the libraries of this
process so that a repeated simulation does not generate the code again to hash it.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import casadi as ca

from workbench.codegen.functions import CompiledFunction, CompileOptions, compile_function
from workbench.core._model import Model
from workbench.core.errors import ModelError

__all__ = ["compiled_ode"]

_COMPILED: dict[tuple, tuple] = {}
"""Compiled right-hand sides of this process by (f, controller, sign, options): a repeated
simulation skips the code generation that the content hash of the disk cache needs."""


def compiled_ode(model: Model, xs: Any, ps: Any, ode: Any, options: CompileOptions | None,
                 *, jacobian: bool, key: tuple) -> tuple[Any, CompiledFunction]:
    """The right-hand side ``ode(xs, ps)`` as a call of its compiled library."""
    opts = CompileOptions() if options is None else options
    if not isinstance(opts, CompileOptions):
        raise ModelError(f"compile_options must be a CompileOptions; got "
                         f"{type(opts).__name__}")
    memo = (*(id(k) for k in key[:2]), key[2], jacobian, repr(opts))
    if memo in _COMPILED:  # the entry holds f and the controller, so their ids stay theirs
        compiled, ext = _COMPILED[memo][-2:]
        return ext(xs, ps), dataclasses.replace(compiled, cached=True, generate_seconds=0.0,
                                                compile_seconds=0.0)
    name = "rhs_" + "".join(c if c.isalnum() else "_" for c in model.name)
    fn = ca.Function(name, [xs, ps], [ode], ["x", "p"], ["xdot"])
    compiled = compile_function(fn, with_jacobian=jacobian, **opts.keywords())
    ext = compiled.function()
    if len(_COMPILED) >= 32:
        _COMPILED.pop(next(iter(_COMPILED)))
    _COMPILED[memo] = (*key[:2], compiled, ext)
    return ext(xs, ps), compiled
