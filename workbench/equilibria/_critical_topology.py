"""Mod-2 Betti numbers of configuration spaces and critical sets, and the Morse-Bott check.

A smooth function ``V`` on a closed manifold ``Q`` whose critical set is a disjoint union of
closed submanifolds ``C``, each nondegenerate in its normal directions (Morse-Bott), with
index ``lambda_C`` (the number of negative eigenvalues of the Hessian on the normal space),
satisfies the Morse-Bott inequalities (Bott 1954, "Nondegenerate critical manifolds",
Ann. of Math. 60, 248-261; with coefficients in the field Z/2 no orientability of the
negative bundles is needed):

    M(t) - P_Q(t) = (1 + t) R(t),   R with nonnegative coefficients,
    M(t) = sum_C t^lambda_C P_C(t),

where ``P_X(t) = sum_k b_k(X; Z/2) t^k`` is the mod-2 Poincare polynomial. At ``t = 1``:
the sum of the mod-2 Betti numbers of the critical sets is at least that of ``Q``; at
``t = -1``: the alternating sum equals the Euler characteristic. A function with
``M = P_Q`` is *perfect*; the height functions of gravity on the workbench's chains and
pendulums are (see the tests).

The polynomials used (coefficients ``b_0, b_1, ...``):

========================  ==================  ================================================
space                     ``P(t)``            source
========================  ==================  ================================================
point                     ``1``
R^k (contractible)        ``1``
S^1                       ``1 + t``
S^2                       ``1 + t^2``
SO(3) = RP^3              ``1 + t + t^2 + t^3``  ``H^*(RP^n; Z/2) = Z/2[a]/(a^(n+1))``
                                                 (Hatcher, Algebraic Topology, 2002, Thm 3.12)
torus T^d (a circle: d=1) ``(1 + t)^d``        Kunneth
products                  the product          Kunneth formula over a field (Hatcher Thm 3.15)
========================  ==================  ================================================

so the Betti sums are: point 1, circle 2, 2-torus 4, S^1 2, S^2 2, SO(3) 4, R^k 1, and a
product multiplies them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from workbench.core.manifolds import S1, S2, SO3, ProductManifold, Rn

__all__ = [
    "FACTOR_POLYNOMIALS",
    "MorseBottCheck",
    "factor_polynomial",
    "manifold_polynomial",
    "torus_polynomial",
    "polynomial_product",
    "morse_bott_check",
    "topology_name",
]

FACTOR_POLYNOMIALS: dict[str, tuple[int, ...]] = {
    "Rn": (1,),
    "S1": (1, 1),
    "S2": (1, 0, 1),
    "SO3": (1, 1, 1, 1),
}
"""Mod-2 Poincare polynomials (Betti numbers ``b_0, b_1, ...``) of the configuration factors:
R^k is contractible; S^1 and S^2 are spheres; SO(3) is RP^3 (module docstring)."""


def polynomial_product(a: Sequence[int], b: Sequence[int]) -> tuple[int, ...]:
    """Product of two polynomials given by their coefficients (Kunneth over a field).

    Parameters
    ----------
    a, b : sequence of int
        Coefficients, constant term first.

    Returns
    -------
    tuple of int
    """
    return tuple(int(v) for v in np.convolve(np.asarray(a, dtype=np.int64),
                                             np.asarray(b, dtype=np.int64)))


def factor_polynomial(factor: object) -> tuple[int, ...]:
    """The mod-2 Poincare polynomial of one configuration factor (S1, S2, SO3, Rn).

    Parameters
    ----------
    factor : Factor
        A manifold factor of :mod:`workbench.core.manifolds`.

    Returns
    -------
    tuple of int

    Raises
    ------
    TypeError
        For a factor kind without an entry (TS2 is a state, not a configuration).
    """
    for kind, cls in (("S1", S1), ("S2", S2), ("SO3", SO3), ("Rn", Rn)):
        if isinstance(factor, cls):
            return FACTOR_POLYNOMIALS[kind]
    raise TypeError(f"no Betti numbers tabulated for factor {factor!r}; configuration "
                    f"factors are S1, S2, SO3 and Rn")


def manifold_polynomial(manifold: ProductManifold) -> tuple[int, ...]:
    """The mod-2 Poincare polynomial of a product of configuration factors."""
    out: tuple[int, ...] = (1,)
    for _, f in manifold.factors:
        out = polynomial_product(out, factor_polynomial(f))
    return out


def torus_polynomial(d: int) -> tuple[int, ...]:
    """``(1 + t)^d``, the mod-2 Poincare polynomial of the torus T^d (a point for d = 0)."""
    out: tuple[int, ...] = (1,)
    for _ in range(int(d)):
        out = polynomial_product(out, (1, 1))
    return out


def topology_name(compact: int, translations: int) -> str:
    """``"point"``, ``"circle"``, ``"2-torus"``, ``"circle x R^2"``, ... of an orbit."""
    parts = []
    if compact == 1:
        parts.append("circle")
    elif compact > 1:
        parts.append(f"{compact}-torus")
    if translations:
        parts.append(f"R^{translations}")
    return " x ".join(parts) if parts else "point"


def _shift(p: Sequence[int], k: int) -> tuple[int, ...]:
    return (0,) * k + tuple(p)


def _add(a: Sequence[int], b: Sequence[int]) -> list[int]:
    n = max(len(a), len(b))
    return [(a[i] if i < len(a) else 0) + (b[i] if i < len(b) else 0) for i in range(n)]


def _trim(p: Sequence[int]) -> tuple[int, ...]:
    out = list(p)
    while len(out) > 1 and out[-1] == 0:
        out.pop()
    return tuple(out)


def _divide_by_one_plus_t(d: Sequence[int]) -> tuple[tuple[int, ...], bool]:
    """``R`` with ``d = (1 + t) R`` (synthetic division), and whether it is exact."""
    d = list(_trim(d))
    if len(d) == 1:
        return (0,), d[0] == 0
    r = [d[0]]
    for c in d[1:-1]:
        r.append(c - r[-1])
    return tuple(r), d[-1] - r[-1] == 0


@dataclass(frozen=True)
class MorseBottCheck:
    """The Morse-Bott inequalities for a list of critical sets (module docstring).

    Attributes
    ----------
    manifold : tuple of int
        ``P_Q``: the mod-2 Betti numbers of the configuration space.
    critical : tuple of int
        ``M(t) = sum_C t^index P_C(t)``.
    remainder : tuple of int
        ``R(t) = (M - P_Q) / (1 + t)`` when ``1 + t`` divides ``M - P_Q`` (else empty).
    betti_sum_manifold, betti_sum_critical : int
        ``P_Q(1)`` and ``M(1)``.
    holds : bool
        ``M - P_Q = (1 + t) R`` with ``R >= 0``: the strong Morse-Bott inequalities (and so
        the Euler characteristic and ``M(1) >= P_Q(1)``).
    perfect : bool
        ``M = P_Q``.
    message : str
        The comparison in words.
    """

    manifold: tuple[int, ...]
    critical: tuple[int, ...]
    remainder: tuple[int, ...]
    betti_sum_manifold: int
    betti_sum_critical: int
    holds: bool
    perfect: bool
    message: str

    def summary(self) -> dict[str, object]:
        """Plain data."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def morse_bott_check(manifold: tuple[int, ...],
                     sets: Sequence[tuple[int, Sequence[int]]]) -> MorseBottCheck:
    """Compare the critical sets with the configuration space (Morse-Bott inequalities).

    Parameters
    ----------
    manifold : tuple of int
        ``P_Q`` (e.g. :func:`manifold_polynomial`).
    sets : sequence of (int, sequence of int)
        ``(index, P_C)`` of each critical set.

    Returns
    -------
    MorseBottCheck
    """
    M: list[int] = [0]
    for index, poly in sets:
        M = _add(M, _shift(poly, int(index)))
    M = list(_trim(M))
    P = _trim(manifold)
    diff = _add(M, [-v for v in P])
    R, divisible = _divide_by_one_plus_t(diff)
    R = R if divisible else ()
    holds = divisible and all(r >= 0 for r in R)
    perfect = tuple(M) == tuple(P)
    sm, sp = int(sum(M)), int(sum(P))
    if perfect:
        msg = (f"perfect: the critical sets' mod-2 Poincare polynomial equals the "
               f"configuration space's, {list(P)} (Betti sums {sm} = {sp})")
    elif holds:
        msg = (f"the Morse-Bott inequalities hold: M - P = (1 + t) R with R = {list(R)} >= 0 "
               f"(Betti sums {sm} >= {sp}); the function is not perfect")
    elif sm < sp:
        msg = (f"the Morse-Bott inequalities FAIL: the critical sets' Betti sum {sm} is below "
               f"the configuration space's {sp}: critical sets were missed")
    else:
        msg = (f"the Morse-Bott inequalities FAIL: M = {list(M)}, P = {list(P)}: M - P is "
               + ("not divisible by 1 + t (Euler characteristic differs)" if not divisible
                  else f"(1 + t) R with R = {list(R)} not >= 0")
               + ": sets were missed or an index is wrong")
    return MorseBottCheck(tuple(P), tuple(M), R, sp, sm, bool(holds), bool(perfect), msg)
