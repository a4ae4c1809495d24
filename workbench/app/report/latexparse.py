r"""Reading LaTeX math into a small formula tree (the subset the report needs).

The subset: letters, numbers, operators, Greek letters, ``^`` and ``_``, ``\frac``,
``\sqrt``, accents (``\dot``, ``\ddot``, ``\hat``, ...), ``\text``, ``\mathrm``, named
functions, spacing, ``\left ... \right`` and matrix environments. Anything else raises
:class:`LatexError`. The printers are in :mod:`workbench.app.report.latexmath`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["LatexError", "parse", "Node", "Row", "Ident", "Num", "Op", "Text", "Space",
           "Frac", "Sqrt", "Accent", "Style", "Func", "Scripts", "Fenced", "Matrix",
           "ACCENTS", "SPACES"]


class LatexError(ValueError):
    """The LaTeX string uses a construct this reader does not support."""


# ----------------------------------------------------------------------------------------
# tables

GREEK = {
    "alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "epsilon": "ϵ",
    "varepsilon": "ε", "zeta": "ζ", "eta": "η", "theta": "θ", "vartheta": "ϑ",
    "iota": "ι", "kappa": "κ", "lambda": "λ", "mu": "μ", "nu": "ν", "xi": "ξ", "pi": "π",
    "rho": "ρ", "sigma": "σ", "tau": "τ", "upsilon": "υ", "phi": "ϕ", "varphi": "φ",
    "chi": "χ", "psi": "ψ", "omega": "ω", "Gamma": "Γ", "Delta": "Δ", "Theta": "Θ",
    "Lambda": "Λ", "Xi": "Ξ", "Pi": "Π", "Sigma": "Σ", "Upsilon": "Υ", "Phi": "Φ",
    "Psi": "Ψ", "Omega": "Ω", "ell": "ℓ", "infty": "∞", "partial": "∂", "nabla": "∇",
    "hbar": "ℏ",
}
OPERATORS = {
    "times": "×", "cdot": "·", "pm": "±", "mp": "∓", "ne": "≠", "neq": "≠", "ge": "≥",
    "geq": "≥", "le": "≤", "leq": "≤", "approx": "≈", "equiv": "≡", "sim": "∼",
    "to": "→", "rightarrow": "→", "leftarrow": "←", "mapsto": "↦", "in": "∈",
    "subset": "⊂", "cap": "∩", "cup": "∪", "wedge": "∧", "otimes": "⊗", "circ": "∘",
    "ldots": "…", "dots": "…", "cdots": "⋯", "|": "‖", "Vert": "‖", "vert": "|",
    "langle": "⟨", "rangle": "⟩", "{": "{", "}": "}", "setminus": "∖", "perp": "⊥",
    "top": "⊤", "ast": "∗", "star": "⋆", "prime": "′", "forall": "∀", "exists": "∃",
    "lbrace": "{", "rbrace": "}", "lvert": "|", "rvert": "|", "lVert": "‖", "rVert": "‖",
}
BIG_OPERATORS = {"sum": "∑", "int": "∫", "prod": "∏", "oint": "∮"}
FUNCTIONS = {
    "sin", "cos", "tan", "cot", "sec", "csc", "sinh", "cosh", "tanh", "arcsin", "arccos",
    "arctan", "exp", "log", "ln", "max", "min", "det", "tr", "sup", "inf", "arg", "lim",
    "dim", "ker", "sgn", "sign",
}
ACCENTS = {  # name: (MathML mark, Typst function)
    "dot": ("˙", "dot"),
    "ddot": ("¨", "dot.double"),
    "hat": ("^", "hat"),
    "widehat": ("^", "hat"),
    "tilde": ("˜", "tilde"),
    "widetilde": ("˜", "tilde"),
    "bar": ("¯", "overline"),
    "overline": ("¯", "overline"),
    "vec": ("→", "arrow"),
}
SPACES = {  # name: (MathML width, Typst space)
    ",": ("0.1667em", "thin"),
    ":": ("0.2222em", "med"),
    ">": ("0.2222em", "med"),
    ";": ("0.2778em", "thick"),
    " ": ("0.25em", "thin"),
    "quad": ("1em", "quad"),
    "qquad": ("2em", "wide"),
    "!": None,
}
STYLES = {"mathbf": "bold", "boldsymbol": "bold", "mathit": "italic", "mathcal": "cal",
          "mathbb": "bb"}
TEXTS = {"text", "textrm", "mbox", "textit"}
UPRIGHT = {"mathrm", "operatorname", "textup"}
MATRICES = {"matrix": ("", ""), "bmatrix": ("[", "]"), "pmatrix": ("(", ")"),
            "vmatrix": ("|", "|"), "Bmatrix": ("{", "}")}
ASCII_OPS = set("+-=<>/,;:!|()[].'*?")



# ----------------------------------------------------------------------------------------
# tree


@dataclass
class Node:
    """Base of the formula tree."""


@dataclass
class Row(Node):
    """A horizontal sequence."""

    items: list[Node] = field(default_factory=list)


@dataclass
class Ident(Node):
    """An identifier: a letter, a Greek letter, or an upright name (``upright``)."""

    text: str
    upright: bool = False


@dataclass
class Num(Node):
    """A number."""

    text: str


@dataclass
class Op(Node):
    """An operator or delimiter character; ``big`` for sums and integrals."""

    text: str
    big: bool = False


@dataclass
class Text(Node):
    r"""Upright text (``\text{...}``)."""

    text: str


@dataclass
class Space(Node):
    """Horizontal space, named as in :data:`SPACES`."""

    name: str


@dataclass
class Frac(Node):
    """A fraction."""

    num: Node
    den: Node


@dataclass
class Sqrt(Node):
    """A square root."""

    body: Node


@dataclass
class Accent(Node):
    r"""An accent over a base (``\dot x``)."""

    kind: str
    base: Node


@dataclass
class Style(Node):
    """A font style (bold, calligraphic, ...)."""

    kind: str
    body: Node


@dataclass
class Func(Node):
    r"""A named function (``\sin``, ``\operatorname{tr}``)."""

    name: str


@dataclass
class Scripts(Node):
    """A base with a subscript and/or a superscript."""

    base: Node
    sub: Node | None = None
    sup: Node | None = None


@dataclass
class Fenced(Node):
    r"""``\left X body \right Y`` (an empty delimiter is ``""``)."""

    open: str
    close: str
    body: Node


@dataclass
class Matrix(Node):
    """A matrix environment: rows of cells, with its own delimiters."""

    rows: list[list[Node]]
    open: str = ""
    close: str = ""


# ----------------------------------------------------------------------------------------
# reader


def _tokens(src: str) -> tuple[list[tuple[str, str]], list[int]]:
    """Tokens ``(kind, value)`` and their start offsets in ``src``."""
    out: list[tuple[str, str]] = []
    pos: list[int] = []
    i, n = 0, len(src)
    while i < n:
        c = src[i]
        start = i
        if c == "\\":
            j = i + 1
            if j < n and src[j].isalpha():
                while j < n and src[j].isalpha():
                    j += 1
                out.append(("cmd", src[i + 1 : j]))
                i = j
            elif j < n:
                out.append(("cmd", src[j]))
                i = j + 1
            else:
                raise LatexError("a lone backslash ends the formula")
        elif c.isspace():
            i += 1
            continue
        elif c in "{}^_&~":
            out.append(("sym", c))
            i += 1
        elif c.isdigit():
            j = i
            while j < n and (src[j].isdigit() or (src[j] == "." and j + 1 < n
                                                   and src[j + 1].isdigit())):
                j += 1
            out.append(("num", src[i:j]))
            i = j
        elif c.isalpha():
            out.append(("letter", c))
            i += 1
        else:
            out.append(("char", c))
            i += 1
        pos.append(start)
    return out, pos


class _Reader:
    def __init__(self, src: str) -> None:
        self.src = src
        self.toks, self.pos = _tokens(src)
        self.i = 0

    def peek(self) -> tuple[str, str] | None:
        return self.toks[self.i] if self.i < len(self.toks) else None

    def take(self) -> tuple[str, str]:
        tok = self.peek()
        if tok is None:
            raise LatexError(f"formula ends too early: {self.src!r}")
        self.i += 1
        return tok

    def row(self, stop: tuple[tuple[str, str], ...] = ()) -> Row:
        items: list[Node] = []
        while True:
            tok = self.peek()
            if tok is None or tok in stop:
                return Row(items)
            if tok == ("sym", "}"):
                raise LatexError(f"unbalanced '}}' in {self.src!r}")
            if tok in (("sym", "^"), ("sym", "_")):
                base = items.pop() if items else Row([])
                items.append(self.scripts(base))
                continue
            node = self.atom()
            if node is not None:
                items.append(node)

    def scripts(self, base: Node) -> Scripts:
        node = base if isinstance(base, Scripts) else Scripts(base)
        while self.peek() in (("sym", "^"), ("sym", "_")):
            kind = self.take()[1]
            arg = self.argument()
            if kind == "^":
                if node.sup is not None:
                    raise LatexError(f"double superscript in {self.src!r}")
                node.sup = arg
            else:
                if node.sub is not None:
                    raise LatexError(f"double subscript in {self.src!r}")
                node.sub = arg
        return node

    def group(self) -> Row:
        if self.take() != ("sym", "{"):
            raise LatexError(f"expected '{{' in {self.src!r}")
        body = self.row(stop=(("sym", "}"),))
        if self.peek() != ("sym", "}"):
            raise LatexError(f"missing '}}' in {self.src!r}")
        self.take()
        return body

    def raw_group(self) -> str:
        r"""The literal text of the next ``{...}`` group (for ``\text``); skips it."""
        if self.peek() != ("sym", "{"):
            raise LatexError(f"expected '{{' in {self.src!r}")
        start = self.pos[self.i]
        depth, j = 0, start
        while j < len(self.src):
            if self.src[j] == "{" and self.src[j - 1] != "\\":
                depth += 1
            elif self.src[j] == "}" and self.src[j - 1] != "\\":
                depth -= 1
                if depth == 0:
                    break
            j += 1
        else:
            raise LatexError(f"missing '}}' in {self.src!r}")
        while self.i < len(self.toks) and self.pos[self.i] <= j:
            self.i += 1
        return self.src[start + 1 : j]

    def argument(self) -> Node:
        tok = self.peek()
        if tok == ("sym", "{"):
            return self.group()
        if tok is None:
            raise LatexError(f"missing argument at the end of {self.src!r}")
        if tok[0] == "num":  # x^23 means x^{2}3
            start = self.pos[self.i]
            self.take()
            if len(tok[1]) > 1:
                self.toks.insert(self.i, ("num", tok[1][1:]))
                self.pos.insert(self.i, start + 1)
            return Num(tok[1][0])
        node = self.atom()
        if node is None:
            raise LatexError(f"missing argument in {self.src!r}")
        return node

    def delimiter(self) -> str:
        kind, val = self.take()
        if kind == "char" and val in "()[]|.":
            return "" if val == "." else val
        if kind == "cmd" and val in OPERATORS:
            return OPERATORS[val]
        raise LatexError(f"unsupported delimiter {val!r} after \\left/\\right in {self.src!r}")

    def atom(self) -> Node | None:  # noqa: C901 - a flat dispatch on token kinds
        kind, val = self.take()
        if kind == "sym":
            if val == "{":
                self.i -= 1
                return self.group()
            if val == "~":
                return Space(" ")
            raise LatexError(f"unexpected {val!r} in {self.src!r}")
        if kind == "letter":
            return Ident(val)
        if kind == "num":
            return Num(val)
        if kind == "char":
            if val in ASCII_OPS:
                return Op(val)
            raise LatexError(f"unsupported character {val!r} in {self.src!r}")
        # commands
        if val in GREEK:
            return Ident(GREEK[val])
        if val in OPERATORS:
            return Op(OPERATORS[val])
        if val in BIG_OPERATORS:
            return Op(BIG_OPERATORS[val], big=True)
        if val in FUNCTIONS:
            return Func(val)
        if val in SPACES:
            return Space(val) if SPACES[val] else None
        if val in ACCENTS:
            return Accent(val, self.argument())
        if val in ("frac", "tfrac", "dfrac"):
            return Frac(self.argument(), self.argument())
        if val == "sqrt":
            if self.peek() == ("char", "["):
                raise LatexError(f"\\sqrt[n] is not supported ({self.src!r})")
            return Sqrt(self.argument())
        if val in TEXTS:
            return Text(self.raw_group())
        if val in UPRIGHT:
            name = self.raw_group().strip()
            return Func(name) if val == "operatorname" else Ident(name, upright=True)
        if val in STYLES:
            return Style(STYLES[val], self.argument())
        if val == "left":
            opening = self.delimiter()
            body = self.row(stop=(("cmd", "right"),))
            if self.peek() != ("cmd", "right"):
                raise LatexError(f"\\left without \\right in {self.src!r}")
            self.take()
            return Fenced(opening, self.delimiter(), body)
        if val == "begin":
            return self.matrix()
        raise LatexError(f"unsupported LaTeX command \\{val} in {self.src!r}")

    def matrix(self) -> Matrix:
        env = self.raw_group().strip()
        if env not in MATRICES:
            raise LatexError(f"unsupported environment {env!r} in {self.src!r}")
        rows: list[list[Node]] = [[]]
        stops = (("sym", "&"), ("cmd", "\\"), ("cmd", "end"))
        while True:
            rows[-1].append(self.row(stop=stops))
            tok = self.take()
            if tok == ("sym", "&"):
                continue
            if tok == ("cmd", "\\"):
                rows.append([])
                continue
            if self.raw_group().strip() != env:
                raise LatexError(f"\\begin{{{env}}} closed by another \\end in {self.src!r}")
            break
        if rows and rows[-1] == [Row([])]:
            rows.pop()
        opening, closing = MATRICES[env]
        return Matrix(rows, opening, closing)


def parse(latex: str) -> Row:
    """Read a LaTeX math string into a formula tree.

    Parameters
    ----------
    latex : str
        Math-mode LaTeX (no ``$``).

    Returns
    -------
    Row

    Raises
    ------
    LatexError
        If the string uses a construct outside the supported subset.
    """
    reader = _Reader(latex)
    tree = reader.row()
    if reader.peek() is not None:
        raise LatexError(f"unbalanced '}}' in {latex!r}")
    return tree
