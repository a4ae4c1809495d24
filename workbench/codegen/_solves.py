"""Linear solves casadi cannot write as C, replaced by ones it can (for compiled functions).

casadi writes its ``lapacklu`` and ``lapackqr`` solves as an ``#error`` line in generated
C. :func:`generable` rewrites such a graph with every solve replaced by the explicit
:class:`LinearSolver` (nested MX functions inlined) and says what it replaced; the rest of
the graph is unchanged. Used by :mod:`workbench.codegen.functions`, which re-exports both.
"""

from __future__ import annotations

from enum import Enum

import casadi as ca

from workbench.core._solve import solve_spd
from workbench.core.errors import ModelError
from workbench.core.validate import choice

__all__ = ["LinearSolver", "generable"]


class LinearSolver(str, Enum):
    """Replacement of the linear solves casadi cannot write as C.

    Attributes
    ----------
    QR
        casadi's sparse QR (``"qr"``): any nonsingular matrix.
    LDL
        casadi's sparse LDL^T (``"ldl"``): symmetric matrices only (mass matrices).
    DENSE_LDL
        A dense LDL^T without pivoting written as scalar (SX) operations, so that the
        whole function becomes straight-line C: the fastest, for symmetric positive
        definite matrices only (mass matrices); the matrix is never checked.
    """

    QR = "qr"
    LDL = "ldl"
    DENSE_LDL = "dense_ldl"

    @classmethod
    def _missing_(cls, value: object) -> LinearSolver:
        raise ModelError(f"linear_solver must be one of {[s.value for s in cls]} (or a "
                         f"LinearSolver); got {value!r}")


_HELPER = "wb_generable_solve_"
"""Prefix of the functions that hold the replacement solves (never inlined again)."""


def _targets(outputs: list[ca.MX]) -> tuple[list[ca.MX], list[ca.MX]]:
    """The linear-solve nodes and the outputs of calls to MX functions in a graph."""
    seen: set[int] = set()
    stack, solves, calls = list(outputs), [], []
    while stack:
        e = stack.pop()
        key = e.__hash__()
        if key in seen:
            continue
        seen.add(key)
        if e.is_op(ca.OP_SOLVE):
            solves.append(e)
        elif e.is_output() and e.dep(0).is_op(ca.OP_CALL):
            g = e.dep(0).which_function()
            if g.is_a("MXFunction") and not g.name().startswith(_HELPER):
                calls.append(e)
        stack.extend(e.dep(i) for i in range(e.n_dep()))
    return solves, calls


def _dense_ldl_solve(n: int, m: int) -> ca.Function:
    """``(A, B) -> A^{-1} B`` by L D L^T without pivoting, in scalar operations (SX).

    The symbolic solve is :func:`workbench.core.solve_spd`, the one the SX replay of a
    model with symmetric positive definite solves writes (``sx_function(spd=True)``).
    """
    A, B = ca.SX.sym("A", n, n), ca.SX.sym("B", n, m)
    return ca.Function(f"dense_ldl_solve_{n}x{m}", [A, B], [solve_spd(A, B)])


def _replacement(solver: LinearSolver, n: int, m: int) -> ca.Function:
    """``(A, B) -> A^{-1} B`` with the replacement solver, as a named function."""
    if solver is LinearSolver.DENSE_LDL:
        return _dense_ldl_solve(n, m)
    A, B = ca.MX.sym("A", n, n), ca.MX.sym("B", n, m)
    return ca.Function(f"{_HELPER}{solver.value}_{n}x{m}", [A, B],
                       [ca.solve(A, B, solver.value)])


def generable(fn: ca.Function, linear_solver: LinearSolver | str = LinearSolver.QR
              ) -> tuple[ca.Function, tuple[str, ...]]:
    """``fn`` with every linear solve of its graph replaced by ``linear_solver``.

    Only needed for MX functions whose solves use a plugin casadi cannot write as C; SX
    functions and functions without solves are returned unchanged. Calls of nested MX
    functions are inlined (their values are kept; a custom Jacobian attached to one is
    replaced by automatic differentiation of its inlined graph). With
    :attr:`LinearSolver.DENSE_LDL` the result is expanded to one SX function (straight-line
    code) when the rest of the graph allows it.

    Parameters
    ----------
    fn : casadi.Function
        The function.
    linear_solver : LinearSolver or str
        The replacement (see :class:`LinearSolver`).

    Returns
    -------
    tuple of (casadi.Function, tuple of str)
        The function (same name, inputs and outputs) and a description of each
        replacement.
    """
    solver = choice(LinearSolver, linear_solver, "linear_solver", error=ModelError)
    if not fn.is_a("MXFunction"):
        return fn, ()
    args = fn.mx_in()
    outs = fn.call(args, True, False)
    replaced = []
    for _ in range(100):  # each round inlines one level of nested MX functions
        solves, calls = _targets(outs)
        if not solves and not calls:
            break
        new = [c.dep(0).which_function().call(
            [c.dep(0).dep(k) for k in range(c.dep(0).n_dep())], True, False)[c.which_output()]
            for c in calls]
        for s in solves:
            A = s.dep(1).T if s.info().get("tr", False) else s.dep(1)
            b = s.dep(0)
            replaced.append(f"{A.shape[0]}x{A.shape[1]}")
            new.append(_replacement(solver, A.shape[0], b.shape[1])(A, b))
        outs = ca.graph_substitute(outs, calls + solves, new)
    if not replaced:
        return fn, ()
    out = ca.Function(fn.name(), args, outs, fn.name_in(), fn.name_out())
    if solver is LinearSolver.DENSE_LDL:
        try:
            out = out.expand()
        except RuntimeError:
            pass  # a node that cannot be expanded: keep the MX graph
    return out, (f"{len(replaced)} linear solve(s) ({', '.join(replaced)}) -> "
                 f"{solver.value}",)
