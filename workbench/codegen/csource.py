"""C99 sources of an exportable controller: casadi's generated code plus a documented API.

:func:`generate` produces, for one controller and one :class:`Binding`:

* ``NAME.c``: casadi's generated code for the function ``NAME`` (SX, so straight-line
  code on stack scalars) followed by the thin wrapper ``NAME_step`` / ``NAME_step_r``;
  casadi's template functions take parameters they do not use (``iw``, ``w``, ``mem``),
  so every function definition of the generated code gets ``(void)`` casts of its
  parameters: the file then compiles warning-free under ``-std=c99 -Wall -Wextra
  -Werror`` without suppressing any warning;
* ``NAME.h``: the inputs, outputs, units, the run-time vector layout, the work-array
  sizes, the singular region, and the declarations (casadi's low-level interface
  included);
* ``main.c`` (an example at the paper's initial condition), ``bench.c`` (median
  nanoseconds per call, measured in C with ``clock_gettime``) and a ``Makefile``.

Nothing here allocates on the heap: the step function uses a static workspace
(``NAME_step``, not reentrant) or one the caller provides (``NAME_step_r``).
"""

from __future__ import annotations

import hashlib
import re
import tempfile
import textwrap
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from workbench.codegen.spec import Binding, Entry, ExportableController
from workbench.core.validate import choice

__all__ = ["CSources", "BENCH_STATES", "generate", "void_unused_parameters"]

BENCH_STATES = 16
"""Number of states the C benchmark cycles through (a power of two: indexed by a mask)."""

CFLAGS_WARN = ("-std=c99", "-Wall", "-Wextra", "-Werror")
"""Warning flags every compilation uses (warnings are errors)."""

_DEF = re.compile(r"^(?!\s)(?!#)[^;=()]*\b\w+\s*\(([^()]*)\)\s*\{\s*$")


@dataclass(frozen=True)
class CSources:
    """The generated sources of one controller export.

    Attributes
    ----------
    name : str
        The C prefix (the controller's export name).
    binding : Binding
        What is frozen and what is a run-time input.
    files : dict of str to str
        File name -> text: ``NAME.c``, ``NAME.h``, ``main.c``, ``bench.c``, ``Makefile``.
    nx, n_p, nu : int
        Sizes of the state, of the run-time vector and of the output.
    work : dict of str to int
        casadi's work sizes ``sz_arg``, ``sz_res``, ``sz_iw``, ``sz_w``.
    n_instructions : int
        Instructions of the exported casadi function (a proxy for its flop count).
    with_jacobian : bool
        Whether ``jac_NAME`` (the Jacobian, for implicit integrators) is included.
    digest : str
        SHA-256 of all files: the hash of the exported function and its wrapper.

    Notes
    -----
    :attr:`products` are the files the generated Makefile builds (and ``make clean``
    removes).
    """

    name: str
    binding: Binding
    files: dict[str, str]
    nx: int
    n_p: int
    nu: int
    work: dict[str, int]
    n_instructions: int
    with_jacobian: bool
    digest: str

    def __str__(self) -> str:
        """File names and sizes, never the sources themselves."""
        files = ", ".join(f"{k} ({len(v) / 1024:.1f} kB)" for k, v in self.files.items())
        return (f"C sources of {self.name} ({self.binding.value}): x {self.nx}, p {self.n_p}, "
                f"u {self.nu}; {self.n_instructions} instructions; files {files}")

    __repr__ = __str__

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"

    @property
    def products(self) -> tuple[str, ...]:
        """What the generated Makefile builds and ``make clean`` removes."""
        N = self.name
        return (f"{N}.o", f"lib{N}.a", f"lib{N}.so", "example", "bench")


def void_unused_parameters(code: str) -> str:
    """Add ``(void)param;`` to every function definition of casadi's generated code.

    A definition is a line at column 0 ending in ``{`` with one parameter list (casadi
    writes every definition so); casting a used parameter to void is harmless.
    """
    out = []
    for line in code.splitlines():
        out.append(line)
        m = _DEF.match(line)
        if m and m.group(1).strip() not in ("", "void"):
            names = [re.findall(r"\w+", a)[-1] for a in m.group(1).split(",")]
            out.append("  " + " ".join(f"(void){n};" for n in names))
    return "\n".join(out) + "\n"


def _c_number(v: float) -> str:
    v = float(v)
    if not np.isfinite(v):
        raise ValueError(f"cannot write the non-finite number {v!r} into C source")
    return repr(v)


def _c_array(values: np.ndarray, per_line: int = 4, indent: str = "    ") -> str:
    vals = [_c_number(v) for v in np.ravel(values)] or ["0.0"]
    rows = [", ".join(vals[i:i + per_line]) for i in range(0, len(vals), per_line)]
    return (",\n" + indent).join(rows)


def comment_text(text: object) -> str:
    """Free text made safe for a C comment and a Makefile comment line.

    Every run of whitespace or control characters (a newline would end a Makefile comment
    and start a recipe line) becomes one space; ``*/`` (would end the C comment and
    inject code) and ``/*`` (``-Wcomment`` is an error under ``-Werror``) get a space
    between their characters; a trailing backslash (continues a Makefile comment onto
    the next line) is dropped. Nothing else changes.

    Parameters
    ----------
    text : object
        The text (``str(text)`` for anything else).

    Returns
    -------
    str
        One line.
    """
    s = re.sub(r"[\s\x00-\x1f\x7f]+", " ", str(text))
    while "*/" in s or "/*" in s:
        s = s.replace("*/", "* /").replace("/*", "/ *")
    return s.rstrip("\\ ")


def _layout(entries: tuple[Entry, ...], var: str) -> list[str]:
    lines, k = [], 0
    for e in entries:
        span = f"{var}[{k}]" if e.size == 1 else f"{var}[{k}..{k + e.size - 1}]"
        lines += textwrap.wrap(f"{span:<14} {e.name}: {comment_text(e.description)}", 96,
                               initial_indent=" *   ", subsequent_indent=" *" + " " * 18,
                               break_on_hyphens=False)
        k += e.size
    return lines or [f" *   (empty: {var} is unused and may be NULL)"]


def _casadi_code(fn: ca.Function, with_jacobian: bool) -> tuple[str, str]:
    """The generated (.c, .h) text for ``fn`` (and its Jacobian)."""
    name = fn.name()
    with tempfile.TemporaryDirectory(prefix="workbench-cg-") as tmp:
        cg = ca.CodeGenerator(f"{name}.c", {"with_header": True, "casadi_real": "double",
                                             "casadi_int": "long long int"})
        cg.add(fn)
        if with_jacobian:
            cg.add(fn.jacobian())
        cg.generate(tmp + "/")
        return (Path(tmp, f"{name}.c").read_text(), Path(tmp, f"{name}.h").read_text())


def _header_body(casadi_h: str) -> str:
    """The declarations of casadi's header without its leading comment."""
    return casadi_h[casadi_h.index("*/") + 2:].strip() if "*/" in casadi_h else casadi_h


def _header(c: ExportableController, fn: ca.Function, binding: Binding, casadi_h: str,
            with_jacobian: bool) -> str:
    N, n = c.name, c.name.upper()
    rt = c.runtime_entries(binding)
    n_p = sum(e.size for e in rt)
    work = {"arg": fn.sz_arg(), "res": fn.sz_res(), "iw": fn.sz_iw(), "w": fn.sz_w()}
    binding_text = {
        Binding.FROZEN: "FROZEN: model parameters and gains are constants of this code; "
                        "p is unused (pass NULL).",
        Binding.PARAMETERS: "PARAMETERS: the model parameters are the run-time vector p; "
                            "the gains are constants of this code.",
        Binding.PARAMETERS_AND_GAINS: "PARAMETERS_AND_GAINS: p holds the model parameters "
                                      "then the gains; the gains are NOT checked against "
                                      "the paper's conditions here.",
    }[binding]
    def para(text: str) -> list[str]:
        return textwrap.wrap(text, 96, initial_indent=" * ", subsequent_indent=" * ",
                             break_on_hyphens=False)

    doc = [
        *textwrap.wrap(f"{N}.h -- {comment_text(c.title)}.", 96, initial_indent="/* ",
                       subsequent_indent=" * ", break_on_hyphens=False),
        " *",
        *para(f"Exported by workbench.codegen (casadi {ca.__version__}) from the "
              f"workbench's controller {c.function.name()!r} of the model "
              f"{comment_text(c.model.name)!r}: {comment_text(c.model.description)}."),
        " *",
        *para(f"Binding {binding_text}"),
        " *",
        f" *   int {N}_step(const double *x, const double *p, double *u);",
        " *",
        f" * Input x[{n}_NX = {c.nx}]: the model's stored ambient state",
        *_layout(c.state_entries, "x"),
        f" * Input p[{n}_NP = {n_p}]: run-time parameters (flattened row-major)",
        *_layout(rt, "p"),
        f" * Output u[{n}_NU = {c.nu}]: {comment_text(c.output.description)}",
        " *",
        *para(f"Singular or saturated region: {comment_text(c.singular)}."),
        " *",
        *para(f"Work arrays ({N}_SZ_* below; casadi's {N}_work reports the same): "
              f"{work['arg']} input pointers, {work['res']} output pointers, {work['iw']} "
              f"integers, {work['w']} reals. Nothing here allocates on the heap: {N}_step "
              f"uses a static {N}_workspace (not reentrant, not thread-safe); {N}_step_r "
              f"uses one the caller provides. Both return 0 on success."),
    ]
    if with_jacobian:
        doc += [" *", *para(f"Also contains jac_{N}, the Jacobian of {N} (for implicit "
                            f"integrators).")]
    doc.append(" */")
    return "\n".join([
        *doc,
        f"#ifndef {n}_H",
        f"#define {n}_H",
        "",
        "/* casadi's low-level interface */",
        _header_body(casadi_h),
        "",
        "#ifdef __cplusplus",
        'extern "C" {',
        "#endif",
        "",
        f"#define {n}_NX {c.nx}",
        f"#define {n}_NP {n_p}",
        f"#define {n}_NU {c.nu}",
        "",
        f"/** Work arrays of {N}: a caller-owned, fixed-size workspace. */",
        "typedef struct {",
        f"  const double *arg[{N}_SZ_ARG];",
        f"  double *res[{N}_SZ_RES];",
        f"  long long int iw[{N}_SZ_IW > 0 ? {N}_SZ_IW : 1];",
        f"  double w[{N}_SZ_W > 0 ? {N}_SZ_W : 1];",
        f"}} {N}_workspace;",
        "",
        "/** u = k(x, p) with a static workspace (not reentrant). Returns 0 on success. */",
        f"int {N}_step(const double *x, const double *p, double *u);",
        "",
        "/** u = k(x, p) with the caller's workspace (reentrant). Returns 0 on success. */",
        f"int {N}_step_r(const double *x, const double *p, double *u, {N}_workspace *work);",
        "",
        "#ifdef __cplusplus",
        "}",
        "#endif",
        "",
        f"#endif /* {n}_H */",
        "",
    ])


def _source(c: ExportableController, fn: ca.Function, casadi_c: str) -> str:
    N = c.name
    code = void_unused_parameters(casadi_c)
    end = code.index("*/") + 2 if code.startswith("/*") else 0
    set_p = "  work->arg[1] = p;\n" if fn.n_in() == 2 else "  (void)p;\n"
    return "".join([
        code[:end],
        f'\n\n#include "{N}.h"\n',
        code[end:],
        "\n/* --- workbench wrapper: no heap allocation --- */\n\n",
        f"int {N}_step_r(const double *x, const double *p, double *u, "
        f"{N}_workspace *work) {{\n",
        "  work->arg[0] = x;\n",
        set_p,
        "  work->res[0] = u;\n",
        f"  return {N}(work->arg, work->res, work->iw, work->w, 0);\n",
        "}\n\n",
        f"static {N}_workspace {N}_static_workspace;\n\n",
        f"int {N}_step(const double *x, const double *p, double *u) {{\n",
        f"  return {N}_step_r(x, p, u, &{N}_static_workspace);\n",
        "}\n",
    ])


def _main(c: ExportableController, binding: Binding) -> str:
    N, n = c.name, c.name.upper()
    p = c.runtime_values(binding)
    names = ", ".join(f'"{e.name}"' for e in c.state_entries)
    return f"""/* main.c -- example: {N} at {comment_text(c.example_note)}. */
#include <stdio.h>

#include "{N}.h"

int main(void) {{
  /* stored state: {names} */
  static const double x[{n}_NX] = {{
    {_c_array(c.example_state)}
  }};
  /* run-time vector p (see {N}.h){"; empty for this binding" if p.size == 0 else ""} */
  static const double p[{n}_NP > 0 ? {n}_NP : 1] = {{
    {_c_array(p)}
  }};
  double u[{n}_NU];
  int i;
  int status = {N}_step(x, p, u);
  if (status != 0) {{
    fprintf(stderr, "{N}_step failed with status %d\\n", status);
    return 1;
  }}
  for (i = 0; i < {n}_NU; ++i) printf("u[%d] = %.17g\\n", i, u[i]);
  return 0;
}}
"""


def _bench(c: ExportableController, binding: Binding) -> str:
    N, n = c.name, c.name.upper()
    states = np.vstack([c.example_state, c.sample_states(BENCH_STATES - 1, seed=0)])
    rows = ",\n".join("  {" + _c_array(s, per_line=1000) + "}" for s in states)
    return f"""/* bench.c -- nanoseconds per call of {N}_step, measured in C.
 * Usage: bench [calls_per_batch [batches]]; prints the median, min and max over batches
 * of the mean time per call (cycling through {BENCH_STATES} stored states). */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "{N}.h"

#define NSTATES {BENCH_STATES}
#define MAXBATCH 1001

static const double states[NSTATES][{n}_NX] = {{
{rows}
}};
static const double p[{n}_NP > 0 ? {n}_NP : 1] = {{
  {_c_array(c.runtime_values(binding), per_line=1000)}
}};

static int cmp(const void *a, const void *b) {{
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}}

static double now_ns(void) {{
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return 1e9 * (double)t.tv_sec + (double)t.tv_nsec;
}}

int main(int argc, char **argv) {{
  long calls = argc > 1 ? atol(argv[1]) : 20000;
  int batches = argc > 2 ? atoi(argv[2]) : 501;
  static double per_call[MAXBATCH];
  double u[{n}_NU], t0, sink = 0.0;
  long i;
  int b, status = 0;
  if (calls < 1 || batches < 1 || batches > MAXBATCH) {{
    fprintf(stderr, "usage: %s [calls >= 1 [1 <= batches <= %d]]\\n", argv[0], MAXBATCH);
    return 2;
  }}
  for (i = 0; i < calls; ++i) status |= {N}_step(states[i & (NSTATES - 1)], p, u);
  for (b = 0; b < batches; ++b) {{
    t0 = now_ns();
    for (i = 0; i < calls; ++i) {{
      status |= {N}_step(states[i & (NSTATES - 1)], p, u);
      sink += u[0];
    }}
    per_call[b] = (now_ns() - t0) / (double)calls;
  }}
  qsort(per_call, (size_t)batches, sizeof(double), cmp);
  printf("{N} median_ns=%.4f min_ns=%.4f max_ns=%.4f calls=%ld batches=%d status=%d "
         "checksum=%.6g\\n", per_call[batches / 2], per_call[0], per_call[batches - 1],
         calls, batches, status, sink);
  return status != 0;
}}
"""


def _makefile(c: ExportableController, binding: Binding, digest_note: str) -> str:
    N = c.name
    warn = " ".join(CFLAGS_WARN)
    return f"""# Makefile for {N}: {comment_text(c.title)}.
# Exported by workbench.codegen, binding {binding.name}; {digest_note}.
# make            the static library lib{N}.a and the example program
# make bench      the benchmark (median nanoseconds per call)
# make shared     lib{N}.so
# Override the optimisation with e.g. make OPT="-O3 -march=native".
CC = gcc
OPT = -O2
CFLAGS = {warn} $(OPT)
LDLIBS = -lm

all: lib{N}.a example

{N}.o: {N}.c {N}.h
\t$(CC) $(CFLAGS) -c {N}.c -o $@

lib{N}.a: {N}.o
\t$(AR) rcs $@ {N}.o

lib{N}.so: {N}.c {N}.h
\t$(CC) $(CFLAGS) -fPIC -shared {N}.c -o $@ $(LDLIBS)

shared: lib{N}.so

example: main.c {N}.h lib{N}.a
\t$(CC) $(CFLAGS) main.c lib{N}.a -o $@ $(LDLIBS)

bench: bench.c {N}.h lib{N}.a
\t$(CC) $(CFLAGS) bench.c lib{N}.a -o $@ $(LDLIBS)

clean:
\trm -f {N}.o lib{N}.a lib{N}.so example bench

.PHONY: all shared clean
"""


def generate(controller: ExportableController, *, binding: Binding,
             with_jacobian: bool = False) -> CSources:
    """The C99 sources of a controller for one binding.

    Parameters
    ----------
    controller : ExportableController
        The controller (e.g. from :func:`workbench.app.catalogue.build`).
    binding : Binding
        What is frozen into the code and what is a run-time input.
    with_jacobian : bool
        Also generate ``jac_NAME`` (needed when the compiled library is put inside an
        implicit integrator such as CVODES, which differentiates its right-hand side).

    Returns
    -------
    CSources
    """
    binding = choice(Binding, binding, "binding")
    fn = controller.function_for(binding)
    casadi_c, casadi_h = _casadi_code(fn, bool(with_jacobian))
    N = controller.name
    files = {
        f"{N}.h": _header(controller, fn, binding, casadi_h, bool(with_jacobian)),
        f"{N}.c": _source(controller, fn, casadi_c),
        "main.c": _main(controller, binding),
        "bench.c": _bench(controller, binding),
    }
    h = hashlib.sha256()
    for k in sorted(files):
        h.update(k.encode() + b"\0" + files[k].encode() + b"\0")
    digest = h.hexdigest()
    files["Makefile"] = _makefile(controller, binding, f"source hash {digest[:16]}")
    return CSources(
        name=N, binding=binding, files=files, nx=controller.nx,
        n_p=int(controller.runtime_values(binding).size), nu=controller.nu,
        work={"sz_arg": int(fn.sz_arg()), "sz_res": int(fn.sz_res()),
              "sz_iw": int(fn.sz_iw()), "sz_w": int(fn.sz_w())},
        n_instructions=int(fn.n_instructions()), with_jacobian=bool(with_jacobian),
        digest=digest,
    )
