"""Work-precision measurement: accuracy against cost, and long-time behaviour.

:func:`work_precision` runs a model from one initial state over one horizon with a set of
methods, each swept over its accuracy knob (an :class:`AccuracySweep`: cvodes' ``rtol``, the
step of the fixed-step methods), and measures for every run the error at the final time
against a high-accuracy reference, the energy error and the constraint residual over the
run, against wall time and vector-field evaluations. The reference is the first of a few
independent high-accuracy runs; their spread is its error estimate, reported with it.
The result gives the work-precision table, the fastest method for a requested accuracy,
convergence orders fitted from error against step size (beside each method's theoretical
order) and the work-precision diagram.

:func:`long_time` runs each method once over a long horizon and measures how the energy
error and the constraint residual evolve: their maxima early and late in the run and the
exponent of the growth of the energy error's envelope (about 0 when it stays bounded,
about 1 for a linear drift).

Errors are absolute max-norms over the stored (ambient) state; energy errors are relative
to the initial energy.
"""

from workbench.simulation.accuracy.long_time import LongRun, LongTime, long_time
from workbench.simulation.accuracy.sweep import AccuracySweep, Knob, RunStatus
from workbench.simulation.accuracy.work_precision import (
    Cost,
    Reference,
    Run,
    WorkPrecision,
    default_reference,
    work_precision,
)

__all__ = [
    "Knob",
    "Cost",
    "AccuracySweep",
    "Run",
    "RunStatus",
    "Reference",
    "WorkPrecision",
    "LongRun",
    "LongTime",
    "default_reference",
    "work_precision",
    "long_time",
]
