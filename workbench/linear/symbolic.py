"""Symbolic linearisations of small models: sympy forms read from the casadi graph.

The Jacobians ``df/dx`` and ``df/du`` of an SX model (optionally with a controller composed
in) are built by casadi's automatic differentiation at a numeric equilibrium ``x_e`` with
the parameters left symbolic; the resulting casadi expression graph is then *read* into
sympy instruction by instruction (:func:`casadi_to_sympy`), with each parameter replaced
by the sympy expression the caller chooses (a symbol, a number, or e.g. ``0`` to impose a
diagonal inertia). Nothing is retyped: the sympy matrices are the graph's derivatives.
Tangent coordinates are those of the numeric linearisation (``A = pinv(N) df/dx N`` with
``N`` converted to exact numbers where its entries are simple rationals).

:class:`SymbolicLinearization` then gives the characteristic polynomial ``det(s I - A)``,
its factorisation over the rationals in the parameters, and closed loops ``A - B K`` for
a symbolic gain ``K``: e.g. paper 001 Remark 2,
``(s^2 + d1 s + m g l1)(s^2 + d2 s + m g l2)(s + d3)`` with ``d_i = k_i / J_i`` and
``m g l_i = m g rho / J_i`` for ``J = diag(J1, J2, J3)``, ``rho = rho e3``.

Only SX models are read (the MX chain model holds a numeric linear solve, which has no
scalar expression); graphs are limited in size by ``max_nodes``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import casadi as ca
import numpy as np
import sympy as sp

from workbench.core._model import Model
from workbench.core.errors import ModelError, ParameterError
from workbench.core.types import ArrayLike
from workbench.linear._linearize import linearize

__all__ = [
    "SymbolicLinearization",
    "symbolic_linearization",
    "casadi_to_sympy",
    "exact_number",
    "default_parameter_symbols",
]

_UNARY: dict[int, Callable[[Any], Any]] = {
    ca.OP_NEG: lambda a: -a, ca.OP_SQ: lambda a: a**2, ca.OP_TWICE: lambda a: 2 * a,
    ca.OP_SQRT: sp.sqrt, ca.OP_INV: lambda a: 1 / a, ca.OP_SIN: sp.sin, ca.OP_COS: sp.cos,
    ca.OP_TAN: sp.tan, ca.OP_ASIN: sp.asin, ca.OP_ACOS: sp.acos, ca.OP_ATAN: sp.atan,
    ca.OP_EXP: sp.exp, ca.OP_LOG: sp.log, ca.OP_FABS: sp.Abs, ca.OP_SIGN: sp.sign,
    ca.OP_SINH: sp.sinh, ca.OP_COSH: sp.cosh, ca.OP_TANH: sp.tanh, ca.OP_ASSIGN: lambda a: a,
}
_BINARY: dict[int, Callable[[Any, Any], Any]] = {
    ca.OP_ADD: lambda a, b: a + b, ca.OP_SUB: lambda a, b: a - b,
    ca.OP_MUL: lambda a, b: a * b, ca.OP_DIV: lambda a, b: a / b,
    ca.OP_POW: lambda a, b: a**b, ca.OP_CONSTPOW: lambda a, b: a**b,
    ca.OP_ATAN2: sp.atan2, ca.OP_HYPOT: lambda a, b: sp.sqrt(a**2 + b**2),
    ca.OP_FMIN: sp.Min, ca.OP_FMAX: sp.Max,
}


def exact_number(value: float, *, max_denominator: int = 10_000) -> sp.Expr:
    """A float as an exact sympy Rational when it is one to rounding, else a Float.

    Parameters
    ----------
    value : float
        The number.
    max_denominator : int
        Largest denominator tried.

    Returns
    -------
    sympy.Rational or sympy.Float
    """
    v = float(value)
    if not np.isfinite(v):
        raise ParameterError(f"value must be a finite number to be made exact; got {value!r}")
    fr = Fraction(v).limit_denominator(max_denominator)
    if abs(float(fr) - v) <= 4 * np.finfo(float).eps * max(1.0, abs(v)):
        return sp.Rational(fr.numerator, fr.denominator)
    return sp.Float(v, 17)


def casadi_to_sympy(fn: ca.Function, inputs: list[list[Any]]) -> list[list[sp.Expr]]:
    """Evaluate an SX ``casadi.Function`` on sympy arguments by walking its algorithm.

    Parameters
    ----------
    fn : casadi.Function
        An SX function.
    inputs : list of list
        Per input, one sympy expression per nonzero.

    Returns
    -------
    list of list of sympy expressions
        Per output, one expression per nonzero (column-major, casadi's order).

    Raises
    ------
    ModelError
        Not an SX function, wrong input sizes, or an operation without a sympy form.
    """
    if not fn.is_a("SXFunction"):
        raise ModelError(f"{fn.name()} is not an SX function; only SX graphs are read")
    for k, arg in enumerate(inputs):
        if len(arg) != fn.nnz_in(k):
            raise ModelError(f"input {k} of {fn.name()} has {fn.nnz_in(k)} nonzeros; got "
                             f"{len(arg)}")
    work: dict[int, Any] = {}
    out = [[sp.Integer(0)] * fn.nnz_out(k) for k in range(fn.n_out())]
    for k in range(fn.n_instructions()):
        op = fn.instruction_id(k)
        ins, outs = fn.instruction_input(k), fn.instruction_output(k)
        if op == ca.OP_INPUT:
            work[outs[0]] = inputs[ins[0]][ins[1]]
        elif op == ca.OP_OUTPUT:
            out[outs[0]][outs[1]] = work[ins[0]]
        elif op == ca.OP_CONST:
            work[outs[0]] = exact_number(fn.instruction_constant(k))
        elif op in _UNARY:
            work[outs[0]] = _UNARY[op](work[ins[0]])
        elif op in _BINARY:
            work[outs[0]] = _BINARY[op](work[ins[0]], work[ins[1]])
        else:
            raise ModelError(f"casadi operation {op} in {fn.name()} has no sympy form here")
    return out


def default_parameter_symbols(model: Model) -> dict[str, Any]:
    """One positive real sympy symbol per parameter scalar (``J_11``, ``rho_3``, ``m``)."""
    out: dict[str, Any] = {}
    for par in model.parameters:
        if not par.shape:
            out[par.name] = sp.Symbol(par.name, real=True)
        elif len(par.shape) == 1:
            out[par.name] = sp.Matrix([sp.Symbol(f"{par.name}_{k + 1}", real=True)
                                       for k in range(par.shape[0])])
        else:
            r, c = par.shape
            out[par.name] = sp.Matrix(r, c, lambda i, j, n=par.name: sp.Symbol(
                f"{n}_{i + 1}{j + 1}", real=True))
    return out


def _parameter_vector(model: Model, parameters: Mapping[str, Any] | None) -> list[sp.Expr]:
    """Flatten the caller's sympy parameters in the model's storage order (matrices by row)."""
    given = dict(parameters or {})
    unknown = [k for k in given if k not in model.parameter_slices]
    if unknown:
        raise ParameterError(
            f"unknown parameter(s) {unknown} for model {model.name!r}; known: "
            f"{[p.name for p in model.parameters]}"
        )
    defaults = default_parameter_symbols(model)
    flat: list[sp.Expr] = []
    for par in model.parameters:
        val = given.get(par.name, defaults[par.name])
        arr = sp.Matrix(val) if not isinstance(val, (sp.Expr, int, float)) else None
        if not par.shape:
            if arr is not None:
                raise ParameterError(f"parameter {par.name!r} is a scalar; got {val!r}")
            flat.append(sp.sympify(val))
            continue
        shape = (arr.shape[0], arr.shape[1]) if arr is not None else ()
        want = par.shape if len(par.shape) == 2 else (par.shape[0], 1)
        if shape != want and not (len(par.shape) == 1 and shape == (1, par.shape[0])):
            raise ParameterError(
                f"parameter {par.name!r} must have shape {par.shape}; got {shape or 'scalar'}"
            )
        flat += list(arr)  # sympy iterates row by row: the storage order (row-major)
    return flat


@dataclass
class SymbolicLinearization:
    """``z-dot = A z + B du`` with sympy entries in the parameters.

    Attributes
    ----------
    A : sympy.Matrix, shape=(dim, dim)
    B : sympy.Matrix, shape=(dim, n_inputs)
    s : sympy.Symbol
        The Laplace variable of :meth:`charpoly`.
    parameters : dict
        The sympy values used for the model's parameters.
    labels : list of str
        Tangent coordinate names.
    """

    A: sp.Matrix
    B: sp.Matrix
    s: sp.Symbol
    parameters: dict[str, Any]
    labels: list[str] = field(default_factory=list)

    def closed_loop(self, K: Any) -> SymbolicLinearization:
        """Return the system with ``du = -K z`` applied (``A - B K``; ``B`` kept).

        Parameters
        ----------
        K : sympy.Matrix or array-like, shape=(n_inputs, dim)
            Gain (may hold symbols).

        Returns
        -------
        SymbolicLinearization
        """
        Km = sp.Matrix(K)
        if Km.shape != (self.B.shape[1], self.A.shape[0]):
            raise ParameterError(
                f"K must have shape ({self.B.shape[1]}, {self.A.shape[0]}); got {Km.shape}"
            )
        return SymbolicLinearization(sp.simplify(self.A - self.B * Km), self.B, self.s,
                                     self.parameters, self.labels)

    def charpoly(self) -> sp.Expr:
        """Return ``det(s I - A)`` as a rational expression in ``s`` and the parameters."""
        return sp.together(sp.expand(self.A.charpoly(self.s).as_expr()))

    def factored(self) -> sp.Expr:
        """Return the characteristic polynomial factored over the rationals."""
        return sp.factor(self.charpoly())

    def evaluate(self, values: Mapping[str, ArrayLike]) -> tuple[np.ndarray, np.ndarray]:
        """Return numeric ``A`` and ``B`` for numeric values of the symbols (by name)."""
        subs = {sym: float(np.asarray(values[str(sym)]))
                for sym in self.A.free_symbols | self.B.free_symbols if str(sym) in values}
        missing = sorted(str(s) for s in (self.A.free_symbols | self.B.free_symbols)
                         if str(s) not in values)
        if missing:
            raise ParameterError(f"values needed for the symbols {missing}")
        return (np.array(self.A.subs(subs).evalf(), dtype=float),
                np.array(self.B.subs(subs).evalf(), dtype=float))


def symbolic_linearization(
    model: Model,
    x_e: ArrayLike,
    u_e: ArrayLike | None = None,
    *,
    parameters: Mapping[str, Any] | None = None,
    controller: ca.Function | None = None,
    max_nodes: int = 5000,
    s: sp.Symbol | None = None,
) -> SymbolicLinearization:
    """Linearise an SX model at ``x_e`` with sympy parameters, read from its casadi graph.

    Parameters
    ----------
    model : Model
        An SX model (small).
    x_e : array-like, shape=(ambient_dim,)
        The equilibrium (numeric; checked to be one with the model's current parameter
        values, as :func:`~workbench.linear._linearize.linearize` does).
    u_e : array-like, shape=(n_inputs,), optional
        Input at the equilibrium.
    parameters : mapping of str to sympy expressions, optional
        Per parameter name, a sympy expression of its shape (a scalar, a vector, a matrix)
        made of symbols and numbers; parameters not given get one real symbol per scalar
        (:func:`default_parameter_symbols`).
    controller : casadi.Function, optional
        An SX feedback ``u = k(x, p)`` composed into the field (its gains are numbers).
    max_nodes : int
        Largest Jacobian graph read into sympy.
    s : sympy.Symbol, optional
        Laplace variable (default ``s``).

    Returns
    -------
    SymbolicLinearization

    Raises
    ------
    ModelError
        An MX model, a graph larger than ``max_nodes``, or ``x_e`` not an equilibrium.
    ParameterError
        Unknown parameter names or wrong shapes.
    """
    if model.symbolic != "SX":
        raise ModelError(
            f"symbolic_linearization reads SX graphs only; model {model.name!r} is built "
            f"with MX (a numeric linear solve has no scalar expression)"
        )
    lin = linearize(model, x_e, u_e, controller=controller)
    p_vals = _parameter_vector(model, parameters)
    f = model.function("f")
    p = ca.SX.sym("p", model.n_params)
    u = ca.SX.sym("u", model.n_inputs)
    x = ca.SX.sym("x", model.manifold.ambient_dim)
    if controller is not None:
        k = controller(x) if controller.n_in() == 1 else controller(x, p)
        xdot = f(x, k + u, p)
    else:
        xdot = f(x, u, p)
    jx = ca.substitute(ca.jacobian(xdot, x), ca.vertcat(x, u),
                       ca.vertcat(ca.DM(lin.x_e), ca.DM(lin.u_e)))
    ju = ca.substitute(ca.jacobian(xdot, u), ca.vertcat(x, u),
                       ca.vertcat(ca.DM(lin.x_e), ca.DM(lin.u_e)))
    fn = ca.Function("symbolic_jacobians", [p], [ca.densify(jx), ca.densify(ju)])
    if fn.n_nodes() > max_nodes:
        raise ModelError(
            f"the Jacobian graph of {model.name!r} has {fn.n_nodes()} nodes > max_nodes "
            f"{max_nodes}; symbolic forms are for small models"
        )
    jx_s, ju_s = casadi_to_sympy(fn, [p_vals])
    n_amb = model.manifold.ambient_dim
    Jx = sp.Matrix(n_amb, n_amb, lambda i, j: jx_s[j * n_amb + i])
    Ju = sp.Matrix(n_amb, model.n_inputs, lambda i, j: ju_s[j * n_amb + i])
    N = sp.Matrix(lin.basis.shape[0], lin.basis.shape[1],
                  lambda i, j: exact_number(lin.basis[i, j]))
    L = (N.T * N).inv() * N.T
    A = (L * Jx * N).applyfunc(sp.simplify)
    B = (L * Ju).applyfunc(sp.simplify)
    return SymbolicLinearization(A, B, s or sp.Symbol("s"), dict(parameters or {}),
                                 list(lin.labels))
