"""Exact identity tests of casadi graphs on the state manifold, in modular arithmetic.

Whether a symmetry holds is a yes-or-no question: ``dJ/dt`` (or the bracket of the field
with the group's generator) is zero *as a function* on the state manifold, or it is not.
Evaluating it in floating point at sampled states can only say "small where we looked" (a
narrow bump between the samples is never seen). Here the graph is evaluated *exactly*, in
the fields of integers modulo several large primes ``q`` (:func:`primes`), at random
points of the manifold with rational coordinates:

* every float in the graph (constants, parameter values) is a dyadic rational
  ``m 2^e``, exact modulo ``q``; ``+ - * /`` are exact there. The derivation multiplies
  the system's constants together as it differentiates (``0.5 * 0.7 * 0.9``), each product
  rounded once folded, in whatever order the chain rule met them, so an identity of the
  mechanics would fail by those roundings: :func:`unfolded` derives the equations again
  with every non-integer constant of the declaration made a parameter (one per value),
  valued at that very float, so nothing is folded and each constant is exact;
* the manifold's points come from rational parametrisations that satisfy its equations
  exactly: ``(1 - t^2, 2t) / (1 + t^2)`` on S^1, the inverse stereographic projection on
  S^2 (with ``omega = q x w`` tangent), the Cayley transform on SO(3);
* ``sin a`` and ``cos a`` of one argument become a random point of the circle, a square
  root a variable ``s`` with ``s^2 = a`` (every sign is tried), any other operation
  (``exp``, ``fmax``, a comparison) an independent random value of its arguments.

If the graph is a rational function ``R`` of the state and of those values, and ``R``
vanishes on the whole variety they span, then the original expression vanishes on the
manifold, whatever the true values of the operations were. A "zero" verdict requires
``R`` to vanish at every random point modulo *every* prime. It is wrong only if

* ``R`` is nonzero but its reduction modulo each prime is the zero function: every
  coefficient of its numerator (an integer once the dyadic denominators are cleared) is
  divisible by the product of the primes, about ``2^121``. The primes are chosen so that
  2 has multiplicative order above :data:`ORDER_BOUND` modulo each: two floats of the
  double range (exponents -1074 to 1023) never share a residue because of their exponents
  alone (modulo the Mersenne prime ``2^61 - 1``, ``2^61 = 1``: ``1 - 2^-61`` would be
  zero, and a narrow bump scaled by it a "symmetry"). A coefficient built from several
  constants can still be such a multiple: for constants unrelated to the primes, with
  chance about ``2^-121`` per coefficient; the primes are fixed by the seed, so
  constants crafted against them are not excluded;
* or ``R`` reduced modulo a prime is nonzero and vanishes at every random point drawn for
  that prime: below ``(d / 2^60)^points`` for degree ``d`` (Schwartz-Zippel; ~1e-15 per
  point for ``d = 1000``).

A nonzero value modulo a prime proves the expression nonzero only when no such stand-in
value entered it (a purely rational graph); otherwise the verdict is undecided, and the
caller's evidence stays sampled.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
from enum import StrEnum
from fractions import Fraction
from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._equations import Derivation, Ingredients
from workbench.mechanics._factors import RnFactor, S1Factor, S2Factor, SO3Factor
from workbench.mechanics._forces import Load

__all__ = ["Verdict", "identically_zero", "unfolded", "manifold_point", "primes",
           "MAX_INSTRUCTIONS", "MAX_ROOTS", "POINTS", "PRIMES", "ORDER_BOUND"]

PRIMES = 2
"""Independent primes modulo which a graph must vanish."""

ORDER_BOUND = 2200
"""``2^k != 1`` modulo each prime for ``1 <= k <= ORDER_BOUND``: above the span of the
double exponents (-1074 to 1023, and 53 bits of mantissa), so distinct powers of two of
the double range have distinct residues."""

_PRIME_BITS = 61
"""The primes lie in ``[2^60, 2^61)`` (products of two residues fit Python's fast path)."""

_MILLER_RABIN_BASES = (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37)
"""Witnesses deciding primality deterministically for every ``n < 3.3e24``."""

MAX_INSTRUCTIONS = 300_000
"""Larger graphs are not walked (the verdict is undecided)."""

MAX_ROOTS = 4
"""Square roots of distinct radicands per point whose signs are all tried (``2^4`` walks);
more leave the verdict undecided."""

POINTS = 2
"""Random points of the manifold at which a graph must vanish."""

_RESAMPLE = 40
"""Draws of a point before giving up (a pole or a radicand without a root modulo the prime)."""


class Verdict(StrEnum):
    """What the modular evaluation established about one output.

    Attributes
    ----------
    ZERO
        Identically zero on the state manifold (a proof, see the module docstring).
    NONZERO
        Not identically zero: a rational graph nonzero at a point of the manifold.
    UNDECIDED
        Nonzero with stand-in values, or the graph could not be walked.
    """

    ZERO = "zero"
    NONZERO = "nonzero"
    UNDECIDED = "undecided"


class _Resample(Exception):
    """A pole or a radicand that is not a square modulo the prime at this point."""


class _Branch(Exception):
    """A square root whose sign is not chosen yet."""

    def __init__(self, key: int) -> None:
        self.key = key


class _Unsupported(Exception):
    """An instruction the walk cannot read (a call, a non-finite constant)."""


def _is_prime(n: int) -> bool:
    """Deterministic Miller-Rabin primality of ``n < 3.3e24`` (the candidates: ``< 2^61``)."""
    if n < 2:
        return False
    for b in _MILLER_RABIN_BASES:
        if n % b == 0:
            return n == b
    d, r = n - 1, 0
    while d % 2 == 0:
        d, r = d // 2, r + 1
    for b in _MILLER_RABIN_BASES:
        x = pow(b, d, n)
        if x in (1, n - 1):
            continue
        for _ in range(r - 1):
            x = x * x % n
            if x == n - 1:
                break
        else:
            return False
    return True


def _two_has_large_order(q: int) -> bool:
    """``2^k != 1 (mod q)`` for every ``1 <= k <= ORDER_BOUND``."""
    x = 1
    for _ in range(ORDER_BOUND):
        x = 2 * x % q
        if x == 1:
            return False
    return True


@functools.lru_cache(maxsize=16)
def primes(seed: int = 0, count: int = PRIMES) -> tuple[int, ...]:
    """The moduli of the exact evaluation: ``count`` distinct primes of 61 bits.

    Each is the first prime ``q = 3 (mod 4)`` (a square root is one power, ``1 + t^2 !=
    0``) after a random integer of ``[2^60, 2^61)`` drawn from ``seed``, modulo which 2
    has multiplicative order above :data:`ORDER_BOUND` (never a Mersenne prime).

    Parameters
    ----------
    seed : int
        Seed of the draws (the same seed, the same primes).
    count : int
        How many.

    Returns
    -------
    tuple of int
    """
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x9E3779B9]))
    found: list[int] = []
    while len(found) < count:
        q = int(rng.integers(1 << (_PRIME_BITS - 1), 1 << _PRIME_BITS))
        q += (3 - q) % 4
        while q in found or not (_is_prime(q) and _two_has_large_order(q)):
            q += 4
        if q < 1 << _PRIME_BITS:
            found.append(q)
    return tuple(found)


def _residue(value: float, q: int) -> int:
    """An exact float as an integer modulo ``q``."""
    if not np.isfinite(value):
        raise _Unsupported(f"a non-finite constant {value!r}")
    fr = Fraction(float(value))
    return fr.numerator % q * pow(fr.denominator % q, q - 2, q) % q


def _inv(a: int, q: int) -> int:
    if a == 0:
        raise _Resample
    return pow(a, q - 2, q)


_OP_NAMES = {getattr(ca, name): name[3:].lower() for name in dir(ca) if name.startswith("OP_")}

_BINARY = {ca.OP_ADD, ca.OP_SUB, ca.OP_MUL, ca.OP_DIV, ca.OP_POW, ca.OP_CONSTPOW}
_RATIONAL_UNARY = {ca.OP_NEG, ca.OP_SQ, ca.OP_TWICE, ca.OP_INV, ca.OP_ASSIGN}


class _Walk:
    """One SX function's instructions, evaluated modulo the prime ``q``."""

    q: int = 0
    """The modulus (set by :meth:`modulo`)."""

    def __init__(self, fn: ca.Function) -> None:
        if not fn.is_a("SXFunction"):
            raise _Unsupported("not an SX function")
        if fn.n_instructions() > MAX_INSTRUCTIONS:
            raise _Unsupported(f"{fn.n_instructions()} instructions")
        self.n_out = [fn.nnz_out(k) for k in range(fn.n_out())]
        self.program = []
        for k in range(fn.n_instructions()):
            op = fn.instruction_id(k)
            ins, outs = fn.instruction_input(k), fn.instruction_output(k)
            const = fn.instruction_constant(k) if op == ca.OP_CONST else None
            if op not in (ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST) and len(ins) not in (1, 2):
                raise _Unsupported(f"casadi operation {op}")
            self.program.append((op, tuple(ins), tuple(outs), const))

    def modulo(self, q: int) -> _Walk:
        """The same instructions with their constants' residues modulo ``q``."""
        walk = copy.copy(self)
        walk.q = q
        walk.program = [(op, ins, outs, None if c is None else (_residue(c, q), c))
                        for op, ins, outs, c in self.program]
        return walk

    def run(self, inputs: list[list[int]], signs: dict[int, int], memo: dict,
            rng: np.random.Generator) -> list[list[tuple[int, bool]]]:
        """Per output nonzero: (value mod ``q``, tainted by a stand-in value)."""
        val: dict[int, int] = {}
        taint: dict[int, bool] = {}
        consts: dict[int, float] = {}
        out = [[(0, False)] * n for n in self.n_out]
        for op, ins, outs, const in self.program:
            if op == ca.OP_OUTPUT:
                out[outs[0]][outs[1]] = (val[ins[0]], taint[ins[0]])
                continue
            o = outs[0]
            consts.pop(o, None)
            if op == ca.OP_INPUT:
                val[o], taint[o] = inputs[ins[0]][ins[1]], False
            elif op == ca.OP_CONST:
                val[o], taint[o] = const[0], False
                consts[o] = const[1]
            elif len(ins) == 2:
                v, t = self._binary(op, val[ins[0]], val[ins[1]], consts.get(ins[1]), signs,
                                    memo, rng)
                val[o], taint[o] = v, t or taint[ins[0]] or taint[ins[1]]
            else:
                v, t = self._unary(op, val[ins[0]], signs, memo, rng)
                val[o], taint[o] = v, t or taint[ins[0]]
        return out

    def _binary(self, op: int, a: int, b: int, e: float | None, signs: dict, memo: dict,
                rng: np.random.Generator) -> tuple[int, bool]:
        """A two-argument operation; ``e`` the second argument's float if a constant."""
        q = self.q
        if op == ca.OP_ADD:
            return (a + b) % q, False
        if op == ca.OP_SUB:
            return (a - b) % q, False
        if op == ca.OP_MUL:
            return a * b % q, False
        if op == ca.OP_DIV:
            return a * _inv(b, q) % q, False
        if op in (ca.OP_POW, ca.OP_CONSTPOW) and e is not None:
            if float(e).is_integer() and abs(e) <= 64:
                return (pow(a, int(e), q) if e >= 0 else pow(_inv(a, q), int(-e), q)), False
            if e == 0.5:
                return self._root(a, signs, q), True
        return _fresh(memo, (op, a, b), rng, q), True

    def _unary(self, op: int, a: int, signs: dict, memo: dict, rng: np.random.Generator
               ) -> tuple[int, bool]:
        q = self.q
        if op == ca.OP_NEG:
            return -a % q, False
        if op == ca.OP_SQ:
            return a * a % q, False
        if op == ca.OP_TWICE:
            return 2 * a % q, False
        if op == ca.OP_INV:
            return _inv(a, q), False
        if op == ca.OP_ASSIGN:
            return a, False
        if op == ca.OP_SQRT:
            return self._root(a, signs, q), True
        if op in (ca.OP_SIN, ca.OP_COS, ca.OP_TAN):
            c, s = self._circle(a, memo, rng, q)
            return (s if op == ca.OP_SIN else c if op == ca.OP_COS else s * _inv(c, q) % q), True
        return _fresh(memo, (op, a), rng, q), True

    @staticmethod
    def _root(a: int, signs: dict[int, int], q: int) -> int:
        if a == 0:
            return 0
        r = pow(a, (q + 1) // 4, q)
        if r * r % q != a:
            raise _Resample
        if a not in signs:
            raise _Branch(a)
        return r if signs[a] > 0 else q - r

    @staticmethod
    def _circle(a: int, memo: dict, rng: np.random.Generator, q: int) -> tuple[int, int]:
        key = ("circle", a)
        if key not in memo:
            t = int(rng.integers(0, q))
            d = _inv(1 + t * t, q)
            memo[key] = ((1 - t * t) * d % q, 2 * t * d % q)
        return memo[key]


def _fresh(memo: dict, key: tuple, rng: np.random.Generator, q: int) -> int:
    """The stand-in value of an operation at its arguments (the same each time)."""
    if key not in memo:
        memo[key] = int(rng.integers(0, q))
    return memo[key]


def _rand(rng: np.random.Generator, n: int, q: int) -> list[int]:
    return [int(v) for v in rng.integers(0, q, n)]


def manifold_point(factors: list, rng: np.random.Generator, q: int) -> list[int]:
    """A random state on the factors' manifold with exact coordinates modulo ``q``.

    Parameters
    ----------
    factors : list of Factor
        In storage order (the layout of ``Derivation.x``).
    rng : numpy.random.Generator
    q : int
        The prime modulus (``q = 3 mod 4``).

    Returns
    -------
    list of int
        The stored state, each entry modulo ``q``.
    """
    x: list[int] = []
    for f in factors:
        if isinstance(f, RnFactor):
            x += _rand(rng, 2 * f.dim, q)
        elif isinstance(f, S1Factor):
            t = _rand(rng, 1, q)[0]
            d = _inv(1 + t * t, q)
            x += [(1 - t * t) * d % q, 2 * t * d % q] + _rand(rng, 1, q)
        elif isinstance(f, S2Factor):
            a, b = _rand(rng, 2, q)
            d = _inv(1 + a * a + b * b, q)
            n = [2 * a * d % q, 2 * b * d % q, (a * a + b * b - 1) * d % q]
            w = _rand(rng, 3, q)
            omega = [(n[1] * w[2] - n[2] * w[1]) % q, (n[2] * w[0] - n[0] * w[2]) % q,
                     (n[0] * w[1] - n[1] * w[0]) % q]
            x += n + omega
        elif isinstance(f, SO3Factor):
            w = _rand(rng, 3, q)
            n2 = sum(v * v for v in w) % q
            d = _inv(1 + n2, q)
            hat = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
            R = [[((1 - n2) * (i == j) + 2 * w[i] * w[j] + 2 * hat[i][j]) * d % q
                  for j in range(3)] for i in range(3)]
            x += [R[k % 3][k // 3] for k in range(9)]  # column-major, as reshape reads it
            x += _rand(rng, 3, q)
        else:  # pragma: no cover - every factor kind is listed above
            raise _Unsupported(f"factor kind {f.kind}")
    return x


def identically_zero(fn: ca.Function, factors: list, p: np.ndarray, *, seed: int = 0,
                     points: int = POINTS) -> tuple[list[Verdict], str]:
    """Whether each output nonzero of ``fn(x, p)`` vanishes identically on the manifold.

    Parameters
    ----------
    fn : casadi.Function
        An SX function of the stored state ``x`` and the parameters ``p``.
    factors : list of Factor
        The factors in storage order.
    p : ndarray
        Parameter values (exact floats: the identity is tested at these values).
    seed : int
        Seed of the primes (:func:`primes`) and of the random points.
    points : int
        Points, per prime, at which every output must vanish.

    Returns
    -------
    verdicts : list of Verdict
        One per nonzero of the outputs, concatenated in output order: ``ZERO`` only if
        zero at every point modulo each of the :data:`PRIMES` primes.
    why : str
        What keeps a verdict from being decided: the graph's operations other than
        ``+ - * /`` and integer powers (square roots, sines, ``exp``, ``fmax``...), or why
        it could not be walked; ``""`` for a rational graph.
    """
    n = sum(fn.nnz_out(k) for k in range(fn.n_out()))
    try:
        walk = _Walk(fn)
        pf = np.asarray(p, dtype=float).ravel()
        fields = [(walk.modulo(q), [_residue(v, q) for v in pf]) for q in primes(seed)]
    except _Unsupported as exc:
        return [Verdict.UNDECIDED] * n, f"its graph cannot be read exactly ({exc})"
    others = sorted({_OP_NAMES.get(op, f"operation {op}") for op, ins, _, _ in walk.program
                     if op not in _RATIONAL_UNARY | _BINARY
                     and op not in (ca.OP_INPUT, ca.OP_OUTPUT, ca.OP_CONST)})
    why = f"its graph holds {', '.join(others)}" if others else ""
    rng = np.random.default_rng(seed)
    zero = [True] * n
    clean_nonzero = [False] * n
    for modular, pv in fields:
        for _ in range(points):
            values = _one_point(modular, factors, pv, rng)
            if values is None:
                return [Verdict.UNDECIDED] * n, (
                    f"no point of the manifold without a pole or an unresolved square root "
                    f"in {_RESAMPLE} draws, or more than {MAX_ROOTS} square roots")
            for branch in values:
                flat = [item for out in branch for item in out]
                for k, (v, tainted) in enumerate(flat):
                    if v != 0:
                        zero[k] = False
                        clean_nonzero[k] |= not tainted
    verdicts = [Verdict.ZERO if z else Verdict.NONZERO if c else Verdict.UNDECIDED
                for z, c in zip(zero, clean_nonzero)]
    return verdicts, why


def _one_point(walk: _Walk, factors: list, pv: list[int], rng: np.random.Generator
               ) -> list | None:
    """Every sign pattern's outputs at one random point, or None after ``_RESAMPLE`` draws."""
    for _ in range(_RESAMPLE):
        try:
            x = manifold_point(factors, rng, walk.q)
        except _Resample:
            continue
        memo: dict[Any, Any] = {}
        pending: list[dict[int, int]] = [{}]
        results: list = []
        try:
            while pending:
                signs = pending.pop()
                try:
                    results.append(walk.run([x, pv], signs, memo, rng))
                except _Branch as br:
                    if len(signs) >= MAX_ROOTS:
                        return None
                    pending += [{**signs, br.key: 1}, {**signs, br.key: -1}]
        except _Resample:
            continue
        return results
    return None


def _lift(exprs: list, table: dict) -> list:
    """``exprs`` rebuilt with every non-integer constant a symbol (one per value).

    ``table`` maps a float to its symbol and is extended. Exponents of powers stay
    constants (an integer power is rational; the walk reads it).
    """
    exprs = [ca.SX(e) for e in exprs]
    flat = [ca.vec(e) for e in exprs]
    syms = ca.symvar(ca.vertcat(*flat)) if flat else []
    fn = ca.Function("unfold", syms, flat)
    work: dict[int, Any] = {}
    outs = [[ca.SX(0)] * fn.nnz_out(k) for k in range(fn.n_out())]

    def arg(slot: int, exponent: bool = False) -> Any:
        v = work[slot]
        if isinstance(v, float):
            if exponent or v.is_integer() or not np.isfinite(v):
                return ca.SX(v)
            if v not in table:
                table[v] = ca.SX.sym(f"k{len(table)}")
            return table[v]
        return v

    for k in range(fn.n_instructions()):
        op = fn.instruction_id(k)
        ins, o = fn.instruction_input(k), fn.instruction_output(k)
        if op == ca.OP_INPUT:
            work[o[0]] = syms[ins[0]]
        elif op == ca.OP_OUTPUT:
            outs[o[0]][o[1]] = arg(ins[0])
        elif op == ca.OP_CONST:
            work[o[0]] = float(fn.instruction_constant(k))
        elif len(ins) == 2:
            power = op in (ca.OP_POW, ca.OP_CONSTPOW)
            work[o[0]] = ca.SX.binary(op, arg(ins[0]), arg(ins[1], power))
        else:
            work[o[0]] = ca.SX.unary(op, arg(ins[0]))
    return [ca.SX(e.sparsity(), ca.vertcat(*nz)) if nz else ca.SX(e.sparsity())
            for e, nz in zip(exprs, outs)]


def unfolded(der: Derivation) -> tuple[Derivation, np.ndarray]:
    """The equations derived again with the declaration's constants as parameters.

    Every non-integer constant of the kinetic energy, the bodies, the potential, the
    loads and the dissipation becomes a parameter (one per distinct value) appended to
    ``der.ing.p``; the derivation then multiplies symbols, not floats, so no product of
    constants is rounded. Evaluated with those parameters at their own float values, it
    is the same system exactly.

    Parameters
    ----------
    der : Derivation
        The derived equations.

    Returns
    -------
    Derivation
        Over the same factors (and symbols), with parameters ``[p, k]``.
    ndarray
        The values of the new parameters ``k``.
    """
    ing, table = der.ing, {}
    bodies = []
    for b in ing.bodies:
        names = [f.name for f in dataclasses.fields(b)
                 if isinstance(getattr(b, f.name), ca.SX)]
        lifted = _lift([getattr(b, n) for n in names], table)
        bodies.append(dataclasses.replace(b, **dict(zip(names, lifted))))
    loads = []
    for ld in ing.loads:
        target, weight = _lift([ld.target, ld.weight], table)
        loads.append(Load(ld.label, target, weight))
    kinetic, potential, dissipation = _lift([ing.kinetic, ing.potential, ing.dissipation],
                                            table)
    k = ca.vertcat(*table.values()) if table else ca.SX(0, 1)
    new = Ingredients(factors=ing.factors, u=ing.u, p=ca.vertcat(ing.p, k), kinetic=kinetic,
                      bodies=bodies, potential=potential, loads=loads,
                      dissipation=dissipation, momenta=ing.momenta)
    return Derivation(new, der.name), np.array(list(table), dtype=float)
