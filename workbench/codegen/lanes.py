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

The width is bounded before any code is written (:func:`check_lane_width`): at most
:data:`MAX_LANE_WIDTH`, the function's instructions times the width at most
:data:`LANE_BUDGET` (the compiler's time and memory grow faster than that product), and
the vectors of one block's frame (casadi's work vector, the inputs and the outputs, each
``width`` doubles wide, on the caller's stack) at most :data:`STACK_BUDGET` bytes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import casadi as ca

from workbench.core.errors import ModelError
from workbench.core.validate import count

__all__ = ["lanes_source", "check_lane_width", "max_lane_width", "max_states", "LANE_WIDTH",
           "MAX_LANE_WIDTH", "LANE_BUDGET", "STACK_BUDGET", "MAX_BATCH_ENTRIES"]

LANE_WIDTH = 4
"""Default states per vector: one AVX2 register of doubles (two SSE2 registers)."""

MAX_LANE_WIDTH = 8
"""Widest lanes: the widest SIMD register of doubles (AVX-512, SVE-512). Wider vectors are
split by the compiler into as many registers (no faster), while its time and memory grow
faster than the width: the chain on a cart with two links (755 instructions) compiled at
``-O2`` in 0.6 s at width 8, 6 s at 32 and 91 s with 1 GB at 128."""

LANE_BUDGET = 2 ** 17
"""Largest instructions x width of a lane-vectorised function (gcc at ``-O2``: 3581
instructions at width 8, 28 648, took 6 s and 0.2 GB; at width 16, 57 296, 14.5 s and
0.45 GB)."""

STACK_BUDGET = 2 ** 20
"""Largest frame of one block [bytes]: the work, input and output vectors live on the
caller's stack (8 MiB for the main thread on Linux, often less for other threads)."""

MAX_BATCH_ENTRIES = 2 ** 24
"""Largest number of doubles one call of a batch holds: the inputs and outputs of all its
states (128 MiB); more states go in several calls. casadi builds a batch in time linear
in its size: 4 * 10^6 states of a function of 2 inputs and 2 outputs (the bound) took
1.4 s to build and 1.1 s per call through casadi's virtual machine."""

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
    for kind, total, sp in (("input", fn.n_in(), fn.sparsity_in),
                            ("output", fn.n_out(), fn.sparsity_out)):
        for i in range(total):
            s = sp(i)
            if not (s.is_dense() and s.size2() == 1):
                raise ModelError(f"{fn.name()}: lane-vectorised C needs dense column "
                                 f"vectors; {kind} {i} has shape {s.size()} with "
                                 f"{s.nnz()} nonzeros")


def max_states(fn: ca.Function, shared: Sequence[str] = ()) -> int:
    """Most states one call of a batch of ``fn`` may take (:data:`MAX_BATCH_ENTRIES`).

    Parameters
    ----------
    fn : casadi.Function
        The function of one state.
    shared : sequence of str
        Inputs given once for all states.

    Returns
    -------
    int
        ``(MAX_BATCH_ENTRIES - shared entries) // entries per state``, at least 1.
    """
    once = sum(fn.nnz_in(i) for i in range(fn.n_in()) if fn.name_in(i) in shared)
    per_state = sum(fn.nnz_in(i) for i in range(fn.n_in()) if fn.name_in(i) not in shared)
    per_state += sum(fn.nnz_out(i) for i in range(fn.n_out()))
    return max(1, (MAX_BATCH_ENTRIES - once) // max(per_state, 1))


def _check_states(fn: ca.Function, n: object, shared: Sequence[str]) -> int:
    """``n`` as a number of states of one call of ``fn``, bounded by :func:`max_states`."""
    limit = max_states(fn, shared)
    try:
        return count("n", n, maximum=limit, error=ModelError)
    except ModelError as exc:
        raise ModelError(f"{exc} (states per call of {fn.name()}: the inputs and outputs of "
                         f"one call hold at most MAX_BATCH_ENTRIES = {MAX_BATCH_ENTRIES} "
                         "doubles, 128 MiB; split larger sets into several calls)") from None


def _width_value(width: object) -> int:
    """``width`` checked without the function: a power of two up to MAX_LANE_WIDTH."""
    if isinstance(width, bool) or not isinstance(width, int) or width < 1 or \
            width & (width - 1) or width > MAX_LANE_WIDTH:
        raise ModelError(f"width must be a power of two (1, 2, 4 or {MAX_LANE_WIDTH}: a "
                         f"vector of doubles, at most the widest SIMD register, "
                         f"MAX_LANE_WIDTH = {MAX_LANE_WIDTH}); got {width!r}")
    return width


def _frame_vectors(fn: ca.Function) -> int:
    """Vectors on one block's stack: casadi's work, the inputs, the outputs, two more."""
    return (fn.sz_w() + sum(max(fn.nnz_in(i), 1) for i in range(fn.n_in()))
            + sum(max(fn.nnz_out(i), 1) for i in range(fn.n_out())) + 2)


def _too_wide(fn: ca.Function, width: int) -> str:
    """Why ``width`` lanes of ``fn`` exceed the bounds ("" if they do not)."""
    ops, frame = fn.n_instructions() * width, 8 * width * _frame_vectors(fn)
    if ops > LANE_BUDGET:
        return (f"{fn.n_instructions()} instructions x {width} lanes = {ops} > LANE_BUDGET = "
                f"{LANE_BUDGET} (the compiler's time and memory grow with it)")
    if frame > STACK_BUDGET:
        return (f"its frame of {_frame_vectors(fn)} vectors of {width} doubles is {frame} "
                f"bytes > STACK_BUDGET = {STACK_BUDGET} bytes of stack")
    return ""


def max_lane_width(fn: ca.Function) -> int:
    """The widest lanes allowed for ``fn`` (0 if even one lane exceeds the bounds).

    Parameters
    ----------
    fn : casadi.Function
        An SX function of one state.

    Returns
    -------
    int
        The largest power of two ``w <= MAX_LANE_WIDTH`` with ``fn.n_instructions() * w
        <= LANE_BUDGET`` and a frame of at most ``STACK_BUDGET`` bytes; 0 if none.
    """
    w = MAX_LANE_WIDTH
    while w >= 1 and _too_wide(fn, w):
        w //= 2
    return w


def check_lane_width(fn: ca.Function, width: object) -> int:
    """``width`` lanes of ``fn``, checked against the bounds before any code is written.

    Parameters
    ----------
    fn : casadi.Function
        An SX function of one state.
    width : int
        States per vector.

    Returns
    -------
    int
        ``width``.

    Raises
    ------
    ModelError
        ``width`` is not a power of two up to :data:`MAX_LANE_WIDTH`, or ``fn`` at this
        width exceeds :data:`LANE_BUDGET` or :data:`STACK_BUDGET` (the message names the
        bound and the widest width allowed).
    """
    width = _width_value(width)
    why = _too_wide(fn, width)
    if why:
        widest = max_lane_width(fn)
        hint = (f"the widest allowed for it is {widest}" if widest else
                "no width fits: use parallelization='serial'")
        raise ModelError(f"width {width} is too wide for lane-vectorised C of {fn.name()}: "
                         f"{why}; {hint}")
    return width


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
        States per vector, a power of two within the bounds of :func:`check_lane_width`.

    Returns
    -------
    str
        Self-contained C with casadi's external interface.

    Raises
    ------
    ModelError
        ``fn`` is not an SX function, has a non-vector input or output, or an operation
        this writer does not know (named: use the serial batch instead); ``width`` or
        ``n`` is out of its bounds (:func:`check_lane_width`, :func:`max_states`).
    """
    if not isinstance(fn, ca.Function) or not fn.is_a("SXFunction"):
        raise ModelError(f"lane-vectorised C needs an SX function (straight-line code); got "
                         f"{fn.class_name() if isinstance(fn, ca.Function) else type(fn)}")
    _dense_vectors(fn)
    n = _check_states(fn, n, shared)
    width = check_lane_width(fn, width)
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
