"""Lane-vectorised C for a batch of states: one SX algorithm run on ``width`` states at once.

casadi's ``Function.map`` compiles to a loop that calls the straight-line code of one
state ``n`` times: every operation of the algorithm is a scalar instruction. Here the
algorithm of an SX function (its instructions, in casadi's order, on casadi's work
vector) is written once more in C with every work variable a vector of ``width`` doubles
(the GCC/clang ``vector_size`` extension): each instruction then computes ``width``
states, and the compiler maps the vectors onto the SIMD registers the target allows
(two doubles with the x86-64 baseline at ``-O2``, four with ``-march=native`` on AVX2).
Arithmetic (``+ - * /``, negation, squares) is vector arithmetic; every other operation
(``sqrt``, trigonometric functions, comparisons, ``fmin``/``fmax``, ...) is the same C
expression as casadi's code generator writes, lane by lane. The operations and their
order are casadi's, so the results equal the virtual machine's bit for bit unless the
flags allow contracting ``a*b + c`` into fused multiply-adds (``-march=native``).

The library has casadi's external interface (loaded with :func:`casadi.external`): the
inputs and outputs of the batch are those of ``Function.map(n)`` (one column per state;
shared inputs once). States beyond a multiple of ``width`` run in a padded block whose
extra lanes repeat the last state and are not written back.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import casadi as ca

from workbench.core.errors import ModelError

__all__ = ["lanes_source", "LANE_WIDTH"]

LANE_WIDTH = 4
"""Default states per vector: one AVX2 register of doubles (two SSE2 registers)."""

_VECTOR = {"OP_ADD": "{x} + {y}", "OP_SUB": "{x} - {y}", "OP_MUL": "{x} * {y}",
           "OP_DIV": "{x} / {y}", "OP_NEG": "-{x}", "OP_SQ": "{x} * {x}",
           "OP_TWICE": "{x} + {x}", "OP_ASSIGN": "{x}", "OP_INV": "1. / {x}"}
"""Operations written as vector arithmetic (GCC/clang vector extension)."""

_LANE = {"OP_SQRT": "sqrt({x})", "OP_EXP": "exp({x})", "OP_LOG": "log({x})",
         "OP_POW": "pow({x}, {y})", "OP_CONSTPOW": "pow({x}, {y})",
         "OP_SIN": "sin({x})", "OP_COS": "cos({x})", "OP_TAN": "tan({x})",
         "OP_ASIN": "asin({x})", "OP_ACOS": "acos({x})", "OP_ATAN": "atan({x})",
         "OP_ATAN2": "atan2({x}, {y})", "OP_SINH": "sinh({x})", "OP_COSH": "cosh({x})",
         "OP_TANH": "tanh({x})", "OP_ASINH": "asinh({x})", "OP_ACOSH": "acosh({x})",
         "OP_ATANH": "atanh({x})", "OP_ERF": "erf({x})", "OP_FABS": "fabs({x})",
         "OP_FLOOR": "floor({x})", "OP_CEIL": "ceil({x})", "OP_FMOD": "fmod({x}, {y})",
         "OP_FMIN": "fmin({x}, {y})", "OP_FMAX": "fmax({x}, {y})",
         "OP_COPYSIGN": "copysign({x}, {y})", "OP_HYPOT": "hypot({x}, {y})",
         "OP_LOG1P": "log1p({x})", "OP_EXPM1": "expm1({x})",
         "OP_SIGN": "({x} < 0 ? -1. : {x} > 0 ? 1. : {x})",
         "OP_LT": "({x} < {y})", "OP_LE": "({x} <= {y})", "OP_EQ": "({x} == {y})",
         "OP_NE": "({x} != {y})", "OP_NOT": "(!{x})", "OP_AND": "({x} && {y})",
         "OP_OR": "({x} || {y})", "OP_IF_ELSE_ZERO": "({x} ? {y} : 0.)"}
"""Operations written lane by lane, as casadi's code generator writes them."""


def _c_double(c: float) -> str:
    """A double constant as C99 source: ``INFINITY``, ``-INFINITY``, ``NAN`` (math.h)."""
    if math.isnan(c):
        return "NAN"
    if math.isinf(c):
        return "INFINITY" if c > 0 else "-INFINITY"
    return repr(c)


def _table() -> dict[int, tuple[str, str]]:
    out = {}
    for kind, ops in (("vector", _VECTOR), ("lane", _LANE)):
        for name, expr in ops.items():
            if hasattr(ca, name):  # an operation this casadi does not have never occurs
                out[int(getattr(ca, name))] = (kind, expr)
    return out


def _dense_vectors(fn: ca.Function) -> None:
    for kind, count, sp in (("input", fn.n_in(), fn.sparsity_in),
                            ("output", fn.n_out(), fn.sparsity_out)):
        for i in range(count):
            s = sp(i)
            if not (s.is_dense() and s.size2() == 1):
                raise ModelError(f"{fn.name()}: lane-vectorised C needs dense column "
                                 f"vectors; {kind} {i} has shape {s.size()} with "
                                 f"{s.nnz()} nonzeros")


def lanes_source(fn: ca.Function, n: int, *, name: str, shared: Sequence[str] = (),
                 width: int = LANE_WIDTH) -> str:
    """C source of ``fn`` evaluated on ``n`` states, ``width`` states per instruction.

    Parameters
    ----------
    fn : casadi.Function
        An SX function of one state with dense column-vector inputs and outputs.
    n : int
        States per call.
    name : str
        The C entry point (and casadi external name).
    shared : sequence of str
        Inputs given once for all states (as in :func:`workbench.codegen.batch_function`).
    width : int
        States per vector, a power of two.

    Returns
    -------
    str
        Self-contained C with casadi's external interface.

    Raises
    ------
    ModelError
        ``fn`` is not an SX function, has a non-vector input or output, or an operation
        this writer does not know (named: use the serial batch instead).
    """
    if not isinstance(fn, ca.Function) or not fn.is_a("SXFunction"):
        raise ModelError(f"lane-vectorised C needs an SX function (straight-line code); got "
                         f"{fn.class_name() if isinstance(fn, ca.Function) else type(fn)}")
    if isinstance(width, bool) or not isinstance(width, int) or width < 1 or \
            width & (width - 1):
        raise ModelError(f"width must be a power of two (1, 2, 4, 8, ...; a vector of "
                         f"doubles); got {width!r}")
    _dense_vectors(fn)
    ops = _table()
    op_names = {int(getattr(ca, a)): a for a in dir(ca) if a.startswith("OP_")}
    is_shared = [fn.name_in(i) in shared for i in range(fn.n_in())]
    nin, nout = fn.n_in(), fn.n_out()
    lines = []
    for k in range(fn.n_instructions()):
        op = int(fn.instruction_id(k))
        i_in, i_out = fn.instruction_input(k), fn.instruction_output(k)
        if op == ca.OP_CONST:
            c = float(fn.instruction_constant(k))
            lines.append(f"  w{i_out[0]} = zero + {_c_double(c)};")
        elif op == ca.OP_INPUT:
            a, j = i_in
            lines.append(f"  w{i_out[0]} = in{a}[{j}];")
        elif op == ca.OP_OUTPUT:
            a, j = i_out
            lines.append(f"  out{a}[{j}] = w{i_in[0]};")
        elif op in ops:
            kind, expr = ops[op]
            args = {"x": f"w{i_in[0]}", "y": f"w{i_in[1]}" if len(i_in) > 1 else ""}
            if kind == "vector":
                lines.append(f"  w{i_out[0]} = {expr.format(**args)};")
            else:
                lane = {k2: f"{v}[l]" for k2, v in args.items() if v}
                lines.append(f"  for (l = 0; l < W; ++l) t[l] = {expr.format(**lane)}; "
                             f"w{i_out[0]} = t;")
        else:
            raise ModelError(f"{fn.name()}: operation {op_names.get(op, op)} has no lane-"
                             f"vectorised C here; use the serial batch")
    sz_in = [fn.nnz_in(i) for i in range(nin)]
    sz_out = [fn.nnz_out(i) for i in range(nout)]
    sp = [f"static const casadi_int sp_in{i}[3] = {{{sz_in[i]}, {1 if is_shared[i] else n}, 1}};"
          for i in range(nin)]
    sp += [f"static const casadi_int sp_out{i}[3] = {{{sz_out[i]}, {n}, 1}};"
           for i in range(nout)]
    gather = []
    for i in range(nin):
        if is_shared[i]:
            gather.append(f"  for (j = 0; j < {sz_in[i]}; ++j) in{i}[j] = zero + "
                          f"(arg[{i}] ? arg[{i}][j] : 0.);")
        else:
            gather.append(f"  for (j = 0; j < {sz_in[i]}; ++j) for (l = 0; l < W; ++l) "
                          f"in{i}[j][l] = arg[{i}] ? arg[{i}][(s0 + (l < m ? l : m - 1)) * "
                          f"{sz_in[i]} + j] : 0.;")
    scatter = [f"  if (res[{i}]) for (j = 0; j < {sz_out[i]}; ++j) for (l = 0; l < m; ++l) "
               f"res[{i}][(s0 + l) * {sz_out[i]} + j] = out{i}[j][l];" for i in range(nout)]
    decl = [f"  wb_v in{i}[{max(sz_in[i], 1)}];" for i in range(nin)]
    decl += [f"  wb_v out{i}[{max(sz_out[i], 1)}];" for i in range(nout)]
    switch_in = "\n".join(f"    case {i}: return sp_in{i};" for i in range(nin))
    switch_out = "\n".join(f"    case {i}: return sp_out{i};" for i in range(nout))
    body = "\n".join(lines)
    names = [f"w{k}" for k in range(fn.sz_w())]
    work = "\n".join(f"  wb_v {', '.join(names[k:k + 12])};" for k in range(0, len(names), 12))
    return f"""/* {name}: {fn.name()} on {n} states, {width} per instruction (workbench lanes) */
#include <math.h>

typedef double casadi_real;
typedef long long int casadi_int;
#define W {width}
typedef double wb_v __attribute__((vector_size({8 * width})));

{chr(10).join(sp)}

static void block(const casadi_real **arg, casadi_real **res, casadi_int s0,
                  casadi_int m) {{
  const wb_v zero = {{0}};
{work}
  wb_v t;
  casadi_int j;
  int l;
{chr(10).join(decl)}
{chr(10).join(gather)}
{body}
{chr(10).join(scatter)}
  (void)t; (void)l; (void)j;
}}

int {name}(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w,
           int mem) {{
  casadi_int s0;
  (void)iw; (void)w; (void)mem;
  for (s0 = 0; s0 < {n}; s0 += W)
    block(arg, res, s0, {n} - s0 < W ? {n} - s0 : W);
  return 0;
}}

casadi_int {name}_n_in(void) {{ return {nin}; }}
casadi_int {name}_n_out(void) {{ return {nout}; }}

const casadi_int *{name}_sparsity_in(casadi_int i) {{
  switch (i) {{
{switch_in}
    default: return 0;
  }}
}}

const casadi_int *{name}_sparsity_out(casadi_int i) {{
  switch (i) {{
{switch_out}
    default: return 0;
  }}
}}

int {name}_work(casadi_int *sz_arg, casadi_int *sz_res, casadi_int *sz_iw,
                casadi_int *sz_w) {{
  if (sz_arg) *sz_arg = {nin};
  if (sz_res) *sz_res = {nout};
  if (sz_iw) *sz_iw = 0;
  if (sz_w) *sz_w = 0;
  return 0;
}}
"""
