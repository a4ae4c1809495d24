r"""A small LaTeX-math reader that writes MathML (for HTML) and Typst math (for PDF).

The models carry their equations as LaTeX strings, and sympy's ``latex`` printer writes
the symbolic vector fields as LaTeX. Neither a browser nor Typst reads LaTeX, and the
report must render without network access (no MathJax). The subset of
LaTeX math that those strings use -- letters, numbers, operators, Greek letters, ``^``
and ``_``, ``\frac``, ``\sqrt``, accents (``\dot``, ``\ddot``, ``\hat``, ...),
``\text``, ``\mathrm``, named functions, spacing, ``\left ... \right`` and matrix
environments -- is read into a small tree, which this module prints as presentation
MathML (which Chromium renders natively) or as Typst math.

The reader is :mod:`workbench.app.report.latexparse`. Anything outside the subset raises
:class:`LatexError`; the report then shows the LaTeX source verbatim instead (and says
so), rather than a wrong formula.
"""

from __future__ import annotations

import html

from workbench.app.report.latexparse import (
    ACCENTS,
    SPACES,
    Accent,
    Fenced,
    Frac,
    Func,
    Ident,
    LatexError,
    Matrix,
    Node,
    Num,
    Op,
    Row,
    Scripts,
    Space,
    Sqrt,
    Style,
    Text,
    parse,
)

__all__ = ["LatexError", "parse", "to_mathml", "to_typst"]

# characters with a meaning in Typst math, written escaped
_TYPST_ESCAPE = {c: "\\" + c for c in "/,;()[]{}&#$_^\\\"@<>*"}


# ----------------------------------------------------------------------------------------
# MathML


def _ml(node: Node) -> str:  # noqa: C901 - one branch per node kind
    e = html.escape
    if isinstance(node, Row):
        if len(node.items) == 1:
            return _ml(node.items[0])
        return "<mrow>" + "".join(_ml(n) for n in node.items) + "</mrow>"
    if isinstance(node, Ident):
        if node.upright and len(node.text) == 1:
            return f'<mi mathvariant="normal">{e(node.text)}</mi>'
        return f"<mi>{e(node.text)}</mi>"
    if isinstance(node, Num):
        return f"<mn>{e(node.text)}</mn>"
    if isinstance(node, Op):
        text = "−" if node.text == "-" else node.text
        return f'<mo largeop="true">{e(text)}</mo>' if node.big else f"<mo>{e(text)}</mo>"
    if isinstance(node, Text):
        return f"<mtext>{e(node.text)}</mtext>"
    if isinstance(node, Space):
        return f'<mspace width="{SPACES[node.name][0]}"/>'
    if isinstance(node, Frac):
        return f"<mfrac>{_ml(node.num)}{_ml(node.den)}</mfrac>"
    if isinstance(node, Sqrt):
        return f"<msqrt>{_ml(node.body)}</msqrt>"
    if isinstance(node, Accent):
        mark = ACCENTS[node.kind][0]
        # no accent="true": with it, Chromium draws U+02D9 nearly invisibly in text fonts
        return f"<mover>{_ml(node.base)}<mo>{e(mark)}</mo></mover>"
    if isinstance(node, Style):
        weight = "font-weight:bold" if node.kind == "bold" else "font-style:normal"
        return f'<mrow style="{weight}">{_ml(node.body)}</mrow>'
    if isinstance(node, Func):
        return f"<mi>{e(node.name)}</mi><mo>&#x2061;</mo>"
    if isinstance(node, Scripts):
        base = _ml(node.base)
        if node.sub is not None and node.sup is not None:
            return f"<msubsup>{base}{_ml(node.sub)}{_ml(node.sup)}</msubsup>"
        if node.sub is not None:
            return f"<msub>{base}{_ml(node.sub)}</msub>"
        return f"<msup>{base}{_ml(node.sup)}</msup>"  # type: ignore[arg-type]
    if isinstance(node, Fenced):
        left = f"<mo>{e(node.open)}</mo>" if node.open else ""
        right = f"<mo>{e(node.close)}</mo>" if node.close else ""
        return f"<mrow>{left}{_ml(node.body)}{right}</mrow>"
    if isinstance(node, Matrix):
        rows = "".join(
            "<mtr>" + "".join(f"<mtd>{_ml(c)}</mtd>" for c in row) + "</mtr>" for row in node.rows
        )
        table = f"<mtable>{rows}</mtable>"
        if node.open or node.close:
            return f"<mrow><mo>{e(node.open)}</mo>{table}<mo>{e(node.close)}</mo></mrow>"
        return table
    raise LatexError(f"no MathML for {node!r}")  # pragma: no cover


def to_mathml(latex: str, *, display: bool = True) -> str:
    """Presentation MathML of a LaTeX math string.

    Parameters
    ----------
    latex : str
        Math-mode LaTeX.
    display : bool
        Block (``display="block"``) or inline math.

    Returns
    -------
    str
        A ``<math>`` element, with the LaTeX source as its ``alttext``.

    Raises
    ------
    LatexError
        If the string uses an unsupported construct.
    """
    body = _ml(parse(latex))
    mode = "block" if display else "inline"
    alt = html.escape(latex, quote=True)
    return (
        f'<math xmlns="http://www.w3.org/1998/Math/MathML" display="{mode}" alttext="{alt}">'
        f"{body}</math>"
    )


# ----------------------------------------------------------------------------------------
# Typst


def _ty_char(text: str) -> str:
    return "".join(_TYPST_ESCAPE.get(c, c) for c in text)


def _ty_str(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _ty(node: Node) -> str:  # noqa: C901 - one branch per node kind
    if isinstance(node, Row):
        return " ".join(_ty(n) for n in node.items) if node.items else '""'
    if isinstance(node, Ident):
        if len(node.text) == 1 and not node.upright:
            return _ty_char(node.text)
        return f"upright({_ty_str(node.text)})" if len(node.text) == 1 else _ty_str(node.text)
    if isinstance(node, Num):
        return node.text
    if isinstance(node, Op):
        return _ty_char(node.text)
    if isinstance(node, Text):
        return _ty_str(node.text)
    if isinstance(node, Space):
        return SPACES[node.name][1]
    if isinstance(node, Frac):
        return f"frac({_ty(node.num)}, {_ty(node.den)})"
    if isinstance(node, Sqrt):
        return f"sqrt({_ty(node.body)})"
    if isinstance(node, Accent):
        return f"{ACCENTS[node.kind][1]}({_ty(node.base)})"
    if isinstance(node, Style):
        return f"{node.kind}({_ty(node.body)})"
    if isinstance(node, Func):
        return f"op({_ty_str(node.name)})"
    if isinstance(node, Scripts):
        parts = [_ty(node.base)]
        if node.sub is not None:
            parts.append(f"b: {_ty(node.sub)}")
        if node.sup is not None:
            parts.append(f"t: {_ty(node.sup)}")
        return "attach(" + ", ".join(parts) + ")"
    if isinstance(node, Fenced):
        body = _ty(node.body)
        if node.open and node.close:
            return f"lr({_ty_char(node.open)} {body} {_ty_char(node.close)})"
        return f"{_ty_char(node.open)} {body} {_ty_char(node.close)}"
    if isinstance(node, Matrix):
        rows = "; ".join(", ".join(_ty(c) for c in row) for row in node.rows)
        if node.open:
            return f"lr({_ty_char(node.open)} mat(delim: #none, {rows}) {_ty_char(node.close)})"
        return f"mat(delim: #none, {rows})"
    raise LatexError(f"no Typst for {node!r}")  # pragma: no cover


def to_typst(latex: str) -> str:
    """Typst math (the inside of ``$ ... $``) for a LaTeX math string.

    Parameters
    ----------
    latex : str
        Math-mode LaTeX.

    Returns
    -------
    str

    Raises
    ------
    LatexError
        If the string uses an unsupported construct.
    """
    return _ty(parse(latex))
