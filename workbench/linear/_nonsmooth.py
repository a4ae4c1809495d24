"""Where a model's graph is not differentiable: kinks and switches at a point.

A linearisation is the derivative of the field at a point; where the graph takes
``fabs``, ``fmax``, ``fmin``, ``sign``, ``floor``, ``ceil``, ``fmod``, ``remainder``,
``copysign`` or ``atan2`` at its kink, or compares two equal numbers (``<``, ``<=``,
``==``, ``!=``: an ``if_else`` on its switching surface), automatic differentiation
returns one of the one-sided derivatives (``d|x|/dx = sign(0) = 0``) and the eigenvalues
of that one-sided matrix say nothing about the point: a potential ``k |x|`` linearised at
its kink has ``A = [[0, 1], [0, 0]]`` whatever ``k``. :func:`kinks` finds such operations.

The graph is walked once per function (SX instructions, and the functions an MX graph
calls, with the numeric inputs of each call); the arguments of the watched operations are
then evaluated at the point. Only operations that reach an output count: a kink inside the
branch of an ``if_else`` that is not taken, or under a comparison that is not at its
switching point (``if_else(|x| < r, ...)`` with ``x = 0``), changes nothing nearby. An
argument is at its kink when it is within ``tol * max(1, |operands|)`` of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

__all__ = ["Kink", "kinks", "field_function"]

UNARY = {ca.OP_FABS: "fabs", ca.OP_SIGN: "sign", ca.OP_FLOOR: "floor", ca.OP_CEIL: "ceil"}
BINARY = {ca.OP_FMAX: "fmax", ca.OP_FMIN: "fmin", ca.OP_FMOD: "fmod",
          ca.OP_REMAINDER: "remainder", ca.OP_COPYSIGN: "copysign", ca.OP_ATAN2: "atan2",
          ca.OP_LT: "<", ca.OP_LE: "<=", ca.OP_EQ: "==", ca.OP_NE: "!="}
COMPARISONS = {ca.OP_LT, ca.OP_LE, ca.OP_EQ, ca.OP_NE}
LOGIC = {ca.OP_NOT, ca.OP_AND, ca.OP_OR}
CONSTANT_PIECES = COMPARISONS | {ca.OP_FLOOR, ca.OP_CEIL, ca.OP_SIGN}
"""Outputs constant between their jumps: what feeds them does not change the field nearby."""

WATCHED = set(UNARY) | set(BINARY) | LOGIC | {ca.OP_IF_ELSE_ZERO}


@dataclass(frozen=True)
class Kink:
    """An operation at its kink or switching point.

    Attributes
    ----------
    operation : str
        ``"fabs"``, ``"fmax"``, ``"<"``, ``"if_else"`` ...
    arguments : tuple of float
        Its arguments' values at the point.
    gap : float
        Distance of the arguments from the kink (``|a|``, ``|a - b|``, ...).
    function : str
        The casadi function it is in (``f``, or one that ``f`` calls).
    expression : str
        The operation's expression, shortened.
    """

    operation: str
    arguments: tuple[float, ...]
    gap: float
    function: str
    expression: str

    def describe(self) -> str:
        """One line: the operation, its arguments, where."""
        args = ", ".join(f"{a:.6g}" for a in self.arguments)
        return (f"{self.operation}({args}) in function {self.function!r} (distance "
                f"{self.gap:.3g} from its kink; {self.expression})")


def _gap(op: int, a: float, b: float | None) -> tuple[float, float] | None:
    """``(distance from the kink, scale)`` of one watched operation, or None if smooth there."""
    if op in (ca.OP_FABS, ca.OP_SIGN):
        return abs(a), max(1.0, abs(a))
    if op in (ca.OP_FLOOR, ca.OP_CEIL):
        return abs(a - np.rint(a)), max(1.0, abs(a))
    assert b is not None
    scale = max(1.0, abs(a), abs(b))
    if op in (ca.OP_FMAX, ca.OP_FMIN) or op in COMPARISONS:
        return abs(a - b), scale
    if op in (ca.OP_FMOD, ca.OP_REMAINDER):
        if b == 0:
            return 0.0, scale
        r = a / b
        # fmod jumps where a/b is an integer; remainder (round to nearest) where it is a half
        at = np.rint(r) if op == ca.OP_FMOD else np.floor(r) + 0.5
        return abs(b) * abs(r - at), scale
    if op == ca.OP_COPYSIGN:
        return (abs(b), scale) if a != 0 else None
    if op == ca.OP_ATAN2:  # a = y, b = x: the branch cut y = 0, x < 0, and the origin
        return (abs(a), scale) if b < 0 else (float(np.hypot(a, b)), scale)
    return None


class _SXPlan:
    """One SX function's watched operations and the producers of every instruction."""

    def __init__(self, fn: ca.Function) -> None:
        self.fn = fn
        n = fn.n_instructions()
        ids = [fn.instruction_id(k) for k in range(n)]
        self.watched = [k for k in range(n) if ids[k] in WATCHED]
        if not self.watched:
            return
        writer: dict[int, int] = {}
        producers: list[tuple[int, ...]] = [()] * n
        for k in range(n):
            op = ids[k]
            if op not in (ca.OP_INPUT, ca.OP_CONST):
                regs = fn.instruction_input(k)
                producers[k] = tuple(writer[r] for r in (regs[:1] if op == ca.OP_OUTPUT
                                                         else regs))
            if op != ca.OP_OUTPUT:
                writer[fn.instruction_output(k)[0]] = k
        self.ids, self.producers = ids, producers
        exprs, inputs = fn.instructions_sx(), fn.sx_in()

        def expr(j: int) -> ca.SX:  # instructions_sx has NaN in place of the inputs
            if ids[j] == ca.OP_INPUT:
                i, nz = fn.instruction_input(j)
                return inputs[i].nz[nz]
            return exprs[j]

        # the values needed: the watched operations' arguments (and if_else conditions)
        self.need = sorted({j for k in self.watched for j in producers[k]})
        self.values = ca.Function("kink_arguments", inputs,
                                  [ca.vertcat(*[expr(j) for j in self.need])])
        self.text = {k: str(exprs[k]) for k in self.watched}
        self.static = None if any(ids[k] == ca.OP_IF_ELSE_ZERO for k in self.watched) \
            else self._live(None)

    def _live(self, value: Any) -> list[bool]:
        """Which instructions reach an output (through the branches taken, with ``value``)."""
        ids, producers = self.ids, self.producers
        live = [False] * len(ids)
        for k in range(len(ids) - 1, -1, -1):
            if ids[k] == ca.OP_OUTPUT:
                live[k] = True
            if not live[k] or ids[k] in CONSTANT_PIECES:
                continue
            if ids[k] == ca.OP_IF_ELSE_ZERO:
                c, v = producers[k]
                live[c] = True
                if value(c) != 0:
                    live[v] = True
                continue
            for j in producers[k]:
                live[j] = True
        return live

    def kinks(self, args: list[Any], tol: float) -> list[Kink]:
        if not self.watched:
            return []
        vals = np.asarray(self.values(*args), dtype=float).ravel()
        at = dict(zip(self.need, vals))
        live = self.static if self.static is not None else self._live(at.__getitem__)
        out = []
        for k in self.watched:
            if not live[k]:
                continue
            op, ps = self.ids[k], self.producers[k]
            if op == ca.OP_IF_ELSE_ZERO or op in LOGIC:
                # a numeric condition (not a comparison) switches where it is zero
                conds = ps[:1] if op == ca.OP_IF_ELSE_ZERO else ps
                for c in conds:
                    if self.ids[c] in COMPARISONS | LOGIC | {ca.OP_CONST}:
                        continue
                    if abs(at[c]) <= tol:
                        out.append(self._kink(k, "if_else" if op == ca.OP_IF_ELSE_ZERO
                                              else "logic", (at[c],), abs(at[c])))
                continue
            a = at[ps[0]]
            b = at[ps[1]] if len(ps) > 1 else None
            found = _gap(op, a, b)
            if found is not None and found[0] <= tol * found[1]:
                name = UNARY.get(op) or BINARY[op]
                out.append(self._kink(k, name, (a,) if b is None else (a, b), found[0]))
        return out

    def _kink(self, k: int, name: str, args: tuple[float, ...], gap: float) -> Kink:
        text = self.text[k]
        return Kink(name, tuple(float(a) for a in args), float(gap), self.fn.name(),
                    text if len(text) <= 100 else text[:97] + "...")


class _MXPlan:
    """One MX function: its elementwise watched operations and the functions it calls."""

    def __init__(self, fn: ca.Function) -> None:
        self.fn = fn
        inputs = fn.mx_in()
        self.calls: list[tuple[ca.Function, ca.Function]] = []
        self.ops: list[tuple[int, ca.Function, str]] = []
        for k in range(fn.n_instructions()):
            op = fn.instruction_id(k)
            if op == ca.OP_CALL:
                e = fn.instruction_MX(k)
                deps = [e.dep(i) for i in range(e.n_dep())]
                self.calls.append((e.which_function(),
                                   ca.Function("call_inputs", inputs, deps)))
            elif op in UNARY or op in BINARY:
                e = fn.instruction_MX(k)
                deps = [ca.densify(e.dep(i)) for i in range(e.n_dep())]
                self.ops.append((op, ca.Function("op_inputs", inputs, deps),
                                 str(e)[:100]))

    def kinks(self, args: list[Any], tol: float) -> list[Kink]:
        out = []
        for op, inputs, text in self.ops:
            vals = inputs(*args)
            vals = [vals] if isinstance(vals, ca.DM) else list(vals)
            a = np.asarray(vals[0], dtype=float).ravel()
            b = np.asarray(vals[1], dtype=float).ravel() if len(vals) > 1 else None
            if b is not None and a.size != b.size:  # a scalar against a matrix
                a, b = np.broadcast_arrays(a, b)
            for i in range(a.size):
                found = _gap(op, float(a[i]), None if b is None else float(b[i]))
                if found is not None and found[0] <= tol * found[1]:
                    args_i = (float(a[i]),) if b is None else (float(a[i]), float(b[i]))
                    out.append(Kink(UNARY.get(op) or BINARY[op], args_i, found[0],
                                    self.fn.name(), text))
        for callee, inputs in self.calls:
            vals = inputs(*args)
            vals = [vals] if isinstance(vals, ca.DM) else list(vals)
            out += _plan(callee).kinks(vals, tol)
        return out


_PLANS: dict[int, tuple[ca.Function, Any]] = {}
_PLANS_SIZE = 128


def _plan(fn: ca.Function) -> Any:
    """The cached plan of ``fn`` (kept with ``fn`` itself, so its id stays unique)."""
    hit = _PLANS.get(id(fn))
    if hit is None or hit[0] is not fn:
        if fn.is_a("SXFunction"):
            plan: Any = _SXPlan(fn)
        elif fn.is_a("MXFunction"):
            plan = _MXPlan(fn)
        else:  # a plugin (linear solver, external code): nothing to walk
            plan = _Opaque()
        if len(_PLANS) >= _PLANS_SIZE:
            _PLANS.pop(next(iter(_PLANS)))
        hit = _PLANS[id(fn)] = (fn, plan)
    return hit[1]


class _Opaque:
    def kinks(self, args: list[Any], tol: float) -> list[Kink]:  # noqa: ARG002
        return []


def field_function(model: Any, controller: ca.Function | None) -> ca.Function:
    """``(x, u, p) -> f(x, k(x, p) + u, p)``: the field linearised (``k = 0`` open loop)."""
    f = model.function("f")
    if controller is None:
        return f
    key = (id(f), id(controller))
    hit = _FIELDS.get(key)
    if hit is None or hit[0] is not f or hit[1] is not controller:
        S = model.sym
        x = S.sym("x", model.manifold.ambient_dim)
        u, p = S.sym("u", model.n_inputs), S.sym("p", model.n_params)
        k = controller(x) if controller.n_in() == 1 else controller(x, p)
        fn = ca.Function("closed_loop_field", [x, u, p], [f(x, k + u, p)], ["x", "u", "p"],
                         ["f"])
        if len(_FIELDS) >= _PLANS_SIZE:
            _FIELDS.pop(next(iter(_FIELDS)))
        # the functions only, never the model: its graphs are released with it
        hit = _FIELDS[key] = (f, controller, fn)
    return hit[2]


_FIELDS: dict[tuple[int, int], tuple[ca.Function, ca.Function, ca.Function]] = {}


def kinks(model: Any, controller: ca.Function | None, x: np.ndarray, u: np.ndarray,
          tol: float) -> list[Kink]:
    """The operations of the (closed-loop) field at their kink at ``(x, u)``.

    Parameters
    ----------
    model : Model
        The model (its current parameter values).
    controller : casadi.Function or None
        A feedback composed into the field.
    x : ndarray, shape=(ambient_dim,)
        The state.
    u : ndarray, shape=(n_inputs,)
        The input (on top of the controller's).
    tol : float
        An argument within ``tol * max(1, |operands|)`` of a kink is at it.

    Returns
    -------
    list of Kink
    """
    fn = field_function(model, controller)
    return _plan(fn).kinks([ca.DM(x), ca.DM(u), ca.DM(model.p)], tol)
