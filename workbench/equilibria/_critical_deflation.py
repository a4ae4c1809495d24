"""The deflation stage of the critical-point search, and how it ended.

The homotopy's paths can fold, so deflated Newton (:func:`._critical_search.deflate`) looks
for the critical sets they missed, from independent random starts drawn from the uniform
(Haar) measure on the compact factors and a standard normal on R^k. From each start the
deflated solves go on, each deflating what the last one found, until one fails or finds a
known point (at most ``deflation_rounds`` solves).

**When to stop.** Nothing proves that every critical set was found: the Morse-Bott
inequalities cannot see a missing pair of sets whose indices differ by one (such a pair
adds ``t^k (1 + t)`` to both sides). The search therefore keeps drawing starts while new
sets keep appearing, and ends when ``patience`` starts *in a row* found no new set, with

    patience = max(deflation_starts, PATIENCE_PER_SET * (n_sets + dim))

(``n_sets`` the critical sets found so far, ``dim`` the manifold's dimension), or when the
budget ``max_deflation_starts`` is spent. While the Morse-Bott inequalities fail, sets are
known to be missing and the patience is ``MISSING_FACTOR`` (4) times longer.

While no new set is found the deflated system does not change (but for further points of
sets already known), so the starts of such a run are independent trials of one experiment;
after ``m`` of them that all failed, the probability ``p`` that a random start finds a new
set is below ``1 - 0.05^(1/m)`` (about ``3 / m``, the "rule of three") with 95 %
confidence. With ``m >= 3 (n_sets + dim) >= 3 (n_sets + 1)``, a missing set that attracts
as many starts as an average found set (a share ``1 / (n_sets + 1)``) would have been found
with probability at least ``1 - e^-3 = 95 %``. A set whose basin is much smaller can still
be missed: the bound is reported, not a proof.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from workbench.core.types import Vector
from workbench.equilibria._critical_search import Homotopy, deflate

__all__ = ["PATIENCE_PER_SET", "MISSING_FACTOR", "CONFIDENCE", "SearchEnd", "deflation_stage",
           "patience", "rate_bound"]

PATIENCE_PER_SET = 3
"""Starts in a row without a new set, per set found and per dimension, that end the search
(module docstring: 3 per set is the rule of three at 95 % for a set with an average basin)."""

MISSING_FACTOR = 4
"""The patience is this many times longer while the Morse-Bott inequalities fail."""

CONFIDENCE = 0.95
"""Confidence of :attr:`SearchEnd.new_rate_bound`."""


def patience(deflation_starts: int, n_sets: int, dim: int) -> int:
    """Starts in a row without a new set that end the deflation (module docstring).

    Parameters
    ----------
    deflation_starts : int
        The least patience; 0 turns the deflation off (the patience is then 0).
    n_sets : int
        Critical sets found so far.
    dim : int
        The manifold's dimension.

    Returns
    -------
    int
    """
    if deflation_starts == 0:
        return 0
    return max(deflation_starts, PATIENCE_PER_SET * (n_sets + dim))


def rate_bound(fruitless: int) -> float:
    """Upper bound (at :data:`CONFIDENCE`) on the chance that a start finds a new set.

    After ``fruitless`` independent starts that all failed: ``1 - (1 - CONFIDENCE)^(1/m)``
    (1.0 when ``m = 0``: nothing is known).
    """
    return 1.0 - (1.0 - CONFIDENCE) ** (1.0 / fruitless) if fruitless > 0 else 1.0


@dataclass(frozen=True)
class SearchEnd:
    """How the search for critical sets ended: what it can and cannot vouch for.

    Attributes
    ----------
    starts : int
        Deflation starts made.
    budget : int
        ``max_deflation_starts``: the most starts allowed.
    last_new : int
        The start (counted from 1, as in the sets' ``found_by``) at which the last new set
        was found by deflation; 0 when deflation found none (every set came from the
        homotopy).
    fruitless : int
        Starts after ``last_new``, in a row, that found no new set.
    patience : int
        Starts in a row without a new set that end the search, for the sets found at the
        end (:func:`patience`, times ``MISSING_FACTOR`` while the Morse-Bott inequalities
        fail); 0 when deflation was off.
    settled : bool
        ``fruitless >= patience > 0``: the search stopped because new sets stopped
        appearing, not because the budget ran out (or deflation was off).
    new_rate_bound : float
        With 95 % confidence, a further random start finds a new set with probability below
        this (:func:`rate_bound` of ``fruitless``; 1.0 when nothing bounds it).
    message : str
        The above in words.
    """

    starts: int
    budget: int
    last_new: int
    fruitless: int
    patience: int
    settled: bool
    new_rate_bound: float
    message: str

    def summary(self) -> dict[str, object]:
        """Plain data."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def _end(starts: int, budget: int, last_new: int, pat: int, longer: bool) -> SearchEnd:
    fruitless = starts - last_new
    settled = pat > 0 and fruitless >= pat
    bound = rate_bound(fruitless)
    where = (f"the last new set was found at deflation start {last_new} of {starts}"
             if last_new else f"deflation found no new set in {starts} starts")
    if pat == 0:
        msg = ("deflation was off (deflation_starts = 0): only the homotopy's paths were "
               "followed, nothing looked for the sets they missed")
    elif settled:
        why = f", {MISSING_FACTOR} times longer as sets are missing" if longer else ""
        msg = (f"{where}; the {fruitless} starts after it found nothing new (patience "
               f"{pat}{why}), so a random start finds a new set with probability below "
               f"{bound:.2g} ({CONFIDENCE:.0%} confidence); sets with smaller basins can "
               "still be missing")
    else:
        msg = (f"{where}: the budget of {budget} starts (max_deflation_starts) ran out "
               f"{fruitless} starts after it, short of the patience {pat}, so new sets may "
               "still have been appearing and more may be missing: raise "
               "max_deflation_starts")
    return SearchEnd(starts, budget, last_new, fruitless, pat, settled, bound, msg)


def deflation_stage(hom: Homotopy, known: list[Vector], add: Callable[[Vector, str], bool],
                    *, n_sets: Callable[[], int], failing: Callable[[], bool], seed: int,
                    deflation_starts: int, deflation_rounds: int, budget: int, tol: float,
                    max_iterations: int, point_tol: float,
                    at_start: Callable[[Vector, str], None] | None = None,
                    ) -> tuple[dict[str, int], SearchEnd]:
    """Deflated Newton from random starts until new sets stop appearing (module docstring).

    Parameters
    ----------
    hom : Homotopy
        Its gauge-fixed system at ``t = 1`` is deflated.
    known : list of ndarray
        The known solutions; ``add`` appends to it.
    add : callable
        ``add(point, how) -> bool``: classify and record a solution; True for a new set.
    n_sets : callable
        The number of critical sets found so far.
    failing : callable
        Whether the Morse-Bott inequalities fail for the sets found so far (the patience
        is then ``MISSING_FACTOR`` times longer).
    seed : int
        Of the starts (the stream ``[seed, 1]``).
    deflation_starts, deflation_rounds, budget : int
        The least patience (0: off), solves per start, and ``max_deflation_starts``.
    tol : float
        Absolute residual tolerance of the solves.
    max_iterations : int
        Newton iterations per solve.
    point_tol : float
        Max-norm distance under which a solution is a known one.
    at_start : callable, optional
        ``at_start(c0, where)``, called at each start before its solves (it may raise: the
        check that the forces at rest are the potential's).

    Returns
    -------
    (dict, SearchEnd)
        ``{"starts", "solves", "found"}`` and how the search ended.
    """
    man = hom.manifold
    rng = np.random.default_rng([seed, 1])
    starts = solves = found = last_new = 0
    seen: dict[int, bool] = {}  # failing() by the number of sets (it changes with them only)

    def in_force() -> tuple[int, bool]:
        n = n_sets()
        longer = seen[n] if n in seen else seen.setdefault(n, failing())
        pat = patience(deflation_starts, n, man.dim)
        return pat * MISSING_FACTOR if longer else pat, longer

    while deflation_starts and starts < budget:
        if starts - last_new >= in_force()[0]:
            break
        c0 = man.random_point(rng)
        starts += 1
        if at_start is not None:
            at_start(c0, f"seeded deflation start {starts}")
        for _ in range(deflation_rounds):
            root = deflate(hom, known, c0, tol=tol, max_iterations=max_iterations)
            solves += 1
            if not root.ok or any(float(np.max(np.abs(root.x - q))) <= point_tol
                                  for q in known):
                break
            if add(root.x, f"deflation from seeded start {starts}"):
                found += 1
                last_new = starts
    end = _end(starts, budget, last_new, *in_force())
    return {"starts": starts, "solves": solves, "found": found}, end
