"""The case groups of the extremes study (:mod:`problems.extremes`), one module each.

Each group is a function ``group(cases, res, ...)`` that runs its cases through a
:class:`workbench.study.Cases` table and records the comparisons with closed forms in the
:class:`workbench.study.Result`. The tests (tests/extremes/) import the same definitions.
"""

from __future__ import annotations

from problems._extremes.bad_input import bad_inputs
from problems._extremes.balance import near_balanced
from problems._extremes.chains import chain_case, large_chains
from problems._extremes.continuation import continuation
from problems._extremes.inertia import ill_conditioned, nearly_equal
from problems._extremes.motion import fast_and_slow
from problems._extremes.optimisation import optimisation

__all__ = ["bad_inputs", "chain_case", "continuation", "fast_and_slow", "ill_conditioned",
           "large_chains", "near_balanced", "nearly_equal", "optimisation"]
