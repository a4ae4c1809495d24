"""What the report typesets from a model itself, through sympy's printers.

Two things are derived from the :class:`~workbench.core._model.Model` object, not typed:

* the **parameter table**: each declared parameter's name, shape, description (with its
  unit) and value, the value printed by sympy (``sympy.Matrix`` for vectors and matrices)
  as LaTeX and as presentation MathML;
* the **vector field** ``xdot = f(x, u, p)`` of a small SX model, read from the casadi
  expression graph of the already built function ``f`` (its algorithm, instruction by
  instruction) into sympy, and printed component by component. Parameters stay symbols
  when the printed component is short; otherwise the component is printed with the
  model's parameter values substituted (rounded to 4 digits), and if it is still too long
  it is left out with its size. MX models (the chain on a cart, whose graph
  holds a numerical linear solve) are not converted.

Nothing is built here: the vector field is read only if the problem already built
``f`` (so the model's build log still shows exactly what the problem required).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp
from sympy.printing.mathml import mathml

from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.linear.symbolic import casadi_to_sympy as _graph_to_sympy

__all__ = [
    "SymbolicError",
    "casadi_to_sympy",
    "state_symbols",
    "parameter_symbols",
    "ParameterRow",
    "FieldRow",
    "parameter_rows",
    "vector_field_rows",
    "MAX_NODES",
    "MAX_SIZE",
    "MAX_CONVERT",
    "MAX_LATEX",
]

MAX_NODES = 400
"""Largest ``f`` (in casadi nodes) that is read into sympy."""

MAX_SIZE = 45
"""Largest sympy expression (tree nodes) of one component that is typeset."""

MAX_CONVERT = 600
"""Largest component that is tried again with the parameter values substituted."""

MAX_LATEX = 300
"""Longest LaTeX of one component that is typeset (longer ones are summarised)."""


class SymbolicError(ValueError):
    """A casadi graph holds an operation that has no sympy counterpart here."""


def _number(value: float) -> sp.Expr:
    if float(value).is_integer() and abs(value) < 1e15:
        return sp.Integer(int(value))
    if float(2 * value).is_integer():
        return sp.Rational(int(2 * value), 2)
    return sp.Float(value, 15)


def casadi_to_sympy(fn: ca.Function, inputs: list[list[sp.Expr]]) -> list[list[sp.Expr]]:
    """Evaluate an SX casadi.Function on sympy arguments by walking its algorithm.

    Parameters
    ----------
    fn : casadi.Function
        An SX function (``fn.is_a("SXFunction")``).
    inputs : list of list of sympy expressions
        One list per input, with one entry per nonzero of that input.

    Returns
    -------
    list of list of sympy expressions
        One list per output, one entry per nonzero.

    Raises
    ------
    SymbolicError
        If ``fn`` is not an SX function or holds an unsupported operation.
    """
    try:
        return _graph_to_sympy(fn, inputs)
    except ModelError as exc:  # the engine's reader; the report keeps its own error type
        raise SymbolicError(str(exc)) from exc


def state_symbols(model: Model) -> list[sp.Symbol]:
    """One sympy symbol per stored state coordinate, named after its factor.

    SO(3) factors (stored column-major) give ``R_ij``; other factors ``name_k`` (1-based).
    """
    syms: list[sp.Symbol] = []
    for name, factor in model.manifold.factors:
        n = factor.ambient_dim
        if factor.kind == "SO3":
            syms += [sp.Symbol(f"{name}_{k % 3 + 1}{k // 3 + 1}") for k in range(9)]
        elif n == 1:
            syms.append(sp.Symbol(name))
        else:
            syms += [sp.Symbol(f"{name}_{k + 1}") for k in range(n)]
    return syms


def parameter_symbols(model: Model) -> list[sp.Symbol]:
    """One sympy symbol per stored parameter scalar (matrices row-major: ``J_ij``)."""
    syms: list[sp.Symbol] = []
    for par in model.parameters:
        if not par.shape:
            syms.append(sp.Symbol(par.name))
        elif len(par.shape) == 1:
            syms += [sp.Symbol(f"{par.name}_{k + 1}") for k in range(par.shape[0])]
        else:
            r, c = par.shape
            syms += [sp.Symbol(f"{par.name}_{i + 1}{j + 1}") for i in range(r) for j in range(c)]
    return syms


def _size(expr: sp.Expr, limit: int) -> int:
    """Nodes of a sympy expression tree, counted up to ``limit + 1``."""
    n = 0
    for _ in sp.preorder_traversal(expr):
        n += 1
        if n > limit:
            break
    return n


def _printed(expr: Any) -> tuple[str, str]:
    """LaTeX and presentation MathML of a sympy object (MathML wrapped in ``<math>``)."""
    tex = sp.latex(expr)
    ml = mathml(expr, printer="presentation")
    return tex, f'<math xmlns="http://www.w3.org/1998/Math/MathML" display="inline">{ml}</math>'


@dataclass
class ParameterRow:
    """One parameter of a model as typeset in the report."""

    name: str
    shape: str
    description: str
    latex: str
    mathml: str
    value: list[Any] | float


def parameter_rows(model: Model) -> list[ParameterRow]:
    """The model's parameters with their values printed by sympy.

    Parameters
    ----------
    model : Model

    Returns
    -------
    list of ParameterRow
    """
    rows = []
    for par in model.parameters:
        val = np.asarray(model.values[par.name], dtype=float)
        obj = sp.Float(float(val), 6) if not par.shape else sp.Matrix(val.tolist()).applyfunc(
            lambda v: sp.Float(v, 6) if not float(v).is_integer() else sp.Integer(int(v))
        )
        if not par.shape and float(val).is_integer():
            obj = sp.Integer(int(val))
        tex, ml = _printed(obj)
        rows.append(ParameterRow(par.name, "x".join(map(str, par.shape)) or "scalar",
                                 par.description, tex, ml, val.tolist()))
    return rows


@dataclass
class FieldRow:
    """One component of the vector field as typeset in the report.

    Attributes
    ----------
    name : str
        The state coordinate (plain text, e.g. ``omega_1``).
    lhs : str
        LaTeX of the state coordinate's time derivative.
    latex : str
        LaTeX of the right-hand side ("" when not typeset).
    mathml : str
        MathML of the right-hand side, printed by sympy ("" when not typeset).
    form : str
        ``"symbolic"`` (parameters as symbols), ``"numeric"`` (parameter values
        substituted) or ``"omitted"``.
    size : int
        Size of the sympy expression (tree nodes, counted up to :data:`MAX_CONVERT` + 1).
    """

    name: str
    lhs: str
    latex: str
    mathml: str
    form: str
    size: int


@dataclass
class FieldSheet:
    """The typeset vector field of a model, or why it is not shown."""

    rows: list[FieldRow] = field(default_factory=list)
    note: str = ""


def vector_field_rows(model: Model) -> FieldSheet:
    """Read the model's built ``f`` into sympy and print it component by component.

    Parameters
    ----------
    model : Model
        A model; only an SX model whose ``f`` is already built and has at most
        :data:`MAX_NODES` nodes is converted.

    Returns
    -------
    FieldSheet
        The rows, or an empty list with a note saying why.
    """
    if model.symbolic != "SX":
        return FieldSheet(note="MX graph (holds numerical sub-solves); not converted to sympy.")
    if f"{model.name}.f" not in model.build_log.names():
        return FieldSheet(note="f was not built by this problem; nothing to typeset.")
    fn = model.function("f")  # cached: builds nothing
    if fn.n_nodes() > MAX_NODES:
        return FieldSheet(note=f"f has {fn.n_nodes()} nodes (> {MAX_NODES}); not typeset.")
    xs, ps = state_symbols(model), parameter_symbols(model)
    us = [sp.Symbol(f"u_{k + 1}") for k in range(model.n_inputs)]
    try:
        (xdot,) = casadi_to_sympy(fn, [xs, us, ps])
    except SymbolicError as exc:
        return FieldSheet(note=str(exc))
    values = dict(zip(ps, (_number(v) if float(v).is_integer() else sp.Float(v, 4)
                           for v in model.p)))
    rows = []
    for sym, rhs in zip(xs, xdot):
        base, _, sub = sp.latex(sym).partition("_")
        lhs = r"\dot{" + base + "}" + (f"_{sub}" if sub else "")
        size = _size(rhs, MAX_CONVERT)
        form, expr = "symbolic", rhs
        if size > MAX_SIZE and size <= MAX_CONVERT:
            form, expr = "numeric", sp.expand(rhs.xreplace(values)).evalf(4)
        tex = sp.latex(expr) if _size(expr, MAX_SIZE) <= MAX_SIZE else ""
        if not tex or len(tex) > MAX_LATEX:
            rows.append(FieldRow(str(sym), lhs, "", "", "omitted", size))
            continue
        rows.append(FieldRow(str(sym), lhs, tex, _printed(expr)[1], form, size))
    return FieldSheet(rows=rows)
