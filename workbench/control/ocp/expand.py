r"""Scalar (SX) versions of a model's functions, with linear solves made symbolic.

Ipopt with exact Hessians is fastest on SX graphs: every derivative is a flat scalar
expression that casadi differentiates, simplifies and evaluates without the overhead of
matrix-valued nodes. ``casadi.Function.expand`` produces one for most MX graphs, but not for
a graph that contains a numeric linear solve (the chain model's ``casadi.solve(A, b,
"lapacklu")``): a numeric factorisation has no scalar expression. :func:`sx_function`
replays the MX algorithm instruction by instruction on SX symbols and replaces each linear
solve ``A \\ b`` by a symbolic solve of the same matrix (casadi's QR, or L D L^T when the
model declares its solves symmetric positive definite, as mass matrices are), so the result
is the same mathematical function (one graph, no re-typed equations), only evaluated
differently. The size of the symbolic solve grows like ``n^3`` in the matrix dimension:
fine for the 5x5 and 8x8 systems of the one- and two-link carts, measured for both in
``benchmarks/bench_ocp.py``.
"""

from __future__ import annotations

import casadi as ca

from workbench.core import solve_spd
from workbench.core.errors import ModelError

__all__ = ["sx_function"]

_UNSUPPORTED = "cannot be replayed on SX"


def sx_function(fn: ca.Function, *, name: str | None = None,
                spd: bool = False) -> ca.Function:
    """An SX function equal to ``fn``, with numeric linear solves made symbolic.

    Parameters
    ----------
    fn : casadi.Function
        An SX function (returned unchanged) or an MX function. MX graphs are first expanded
        by casadi; if that fails because of a linear-solve node, the graph is replayed
        instruction by instruction (inputs, outputs, nonzero selections, calls of SX-able
        functions, linear solves, elementwise operations, matrix products, concatenations).
    name : str, optional
        Name of the new function (default: ``fn``'s name with ``_sx``).
    spd : bool
        Every linear solve in ``fn`` has a symmetric positive definite matrix (the caller's
        guarantee, e.g. :attr:`workbench.core.Model.spd_solves`): written as L D L^T
        (:func:`workbench.core.solve_spd`) instead of QR.

    Returns
    -------
    casadi.Function
        Same inputs and outputs (names and sparsity), an SX graph.

    Raises
    ------
    ModelError
        If the graph contains an operation that cannot be replayed on SX.
    """
    if fn.is_a("SXFunction"):
        return fn
    new_name = name or f"{fn.name()}_sx"
    try:
        return fn.expand(new_name)
    except RuntimeError:
        pass
    ins = [ca.SX.sym(fn.name_in(i), fn.sparsity_in(i)) for i in range(fn.n_in())]
    outs = [ca.SX.zeros(fn.sparsity_out(i)) for i in range(fn.n_out())]
    work: dict[int, ca.SX] = {}
    for k in range(fn.n_instructions()):
        op = fn.instruction_id(k)
        node = fn.instruction_MX(k)
        i_in, i_out = fn.instruction_input(k), fn.instruction_output(k)
        if op in (ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST, ca.OP_PARAMETER):
            _io(fn, op, node, i_in, i_out, work, ins, outs)
        elif op == ca.OP_GETNONZEROS:
            work[i_out[0]] = _get_nonzeros(fn, node, work[i_in[0]])
        elif op == ca.OP_CALL:
            sub = sx_function(node.which_function(), spd=spd)
            res = sub.call([work[i] for i in i_in])
            for j, r in zip(i_out, res):
                if j >= 0:
                    work[j] = r
        else:
            work[i_out[0]] = _operation(fn, op, node, [work[i] for i in i_in], spd)
    return ca.Function(
        new_name, ins, outs,
        [fn.name_in(i) for i in range(fn.n_in())],
        [fn.name_out(i) for i in range(fn.n_out())],
        {"cse": True},
    )


def _io(fn: ca.Function, op: int, node: ca.MX, i_in: list, i_out: list, work: dict,
        ins: list, outs: list) -> None:
    """Inputs, outputs and constants of the replay (updates ``work`` and ``outs``)."""
    if op == ca.OP_INPUT:
        info = node.info()
        nz = ca.vec(ins[info["ind"]])[info["offset"]: info["offset"] + node.nnz()]
        work[i_out[0]] = _reshape(nz, node.sparsity())
    elif op == ca.OP_OUTPUT:
        info = node.info()
        val = ca.vec(work[i_in[0]])
        flat = ca.vec(outs[info["ind"]])
        flat[info["offset"]: info["offset"] + val.numel()] = val
        outs[info["ind"]] = _reshape(flat, fn.sparsity_out(info["ind"]))
    elif op == ca.OP_CONST:
        work[i_out[0]] = ca.SX(ca.evalf(node))
    else:
        raise ModelError(f"graph of {fn.name()!r} has a free parameter node; {_UNSUPPORTED}")


def _get_nonzeros(fn: ca.Function, node: ca.MX, value: ca.SX) -> ca.SX:
    src = ca.vec(value)
    info = node.info()
    if "slice" in info:
        s = info["slice"]
        idx = list(range(s["start"], s["stop"], s["step"]))
    elif "nz" in info:
        idx = list(info["nz"])
    else:
        raise ModelError(f"nonzero selection {info} in {fn.name()!r}; {_UNSUPPORTED}")
    return _reshape(src[idx], node.sparsity())


def _operation(fn: ca.Function, op: int, node: ca.MX, args: list, spd: bool) -> ca.SX:
    """One arithmetic or structural operation of the replay, on SX arguments."""
    if op == ca.OP_SOLVE:
        b, A = args[0], args[1]
        A = A.T if node.info().get("tr", False) else A
        return solve_spd(A, b) if spd else ca.solve(A, b)
    if op == ca.OP_MTIMES:
        return args[0] + ca.mtimes(args[1], args[2])
    if op == ca.OP_VERTCAT:
        return ca.vertcat(*args)
    if op == ca.OP_HORZCAT:
        return ca.horzcat(*args)
    if op == ca.OP_TRANSPOSE:
        return args[0].T
    if op == ca.OP_RESHAPE:
        return _reshape(ca.vec(args[0]), node.sparsity())
    if len(args) in (1, 2) and _elementwise(op):
        return (ca.SX.unary(op, args[0]) if len(args) == 1
                else ca.SX.binary(op, args[0], args[1]))
    raise ModelError(f"operation {node} (op code {op}) in {fn.name()!r}; {_UNSUPPORTED}")


def _reshape(v: ca.SX, sp: ca.Sparsity) -> ca.SX:
    if sp.is_dense():
        return ca.reshape(v, sp.size1(), sp.size2())
    return ca.SX(sp, v)


_ELEMENTWISE = {
    getattr(ca, n) for n in (
        "OP_ADD", "OP_SUB", "OP_MUL", "OP_DIV", "OP_NEG", "OP_EXP", "OP_LOG", "OP_POW",
        "OP_CONSTPOW", "OP_SQRT", "OP_SQ", "OP_TWICE", "OP_SIN", "OP_COS", "OP_TAN",
        "OP_ASIN", "OP_ACOS", "OP_ATAN", "OP_ATAN2", "OP_FABS", "OP_SIGN", "OP_FMIN",
        "OP_FMAX", "OP_INV", "OP_TANH", "OP_SINH", "OP_COSH", "OP_IF_ELSE_ZERO", "OP_LT",
        "OP_LE", "OP_EQ", "OP_NE", "OP_NOT", "OP_AND", "OP_OR",
    ) if hasattr(ca, n)
}


def _elementwise(op: int) -> bool:
    return op in _ELEMENTWISE
