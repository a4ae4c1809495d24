"""CVODES: its options explicit (multistep family, corrector, step bounds), its runs checked.

CVODES is adaptive: it sees the field only at the states of its steps, and its error
estimate compares a predictor with a corrector built from those values. A feature of the
field narrower than a step (a potential wall, a pulse of forcing) that lies between two
steps is never seen: where the field is (to round-off) constant on both sides of it, the
error estimate is zero and the step grows until it jumps the feature; the answer is then
wrong with no warning from CVODES. ``max_step`` (casadi's ``max_step_size``) bounds the
step; it is the remedy, with a value below the feature's width. There is no hidden default
cap: without ``max_step`` the step is unbounded. :class:`RunCheck` checks a finished run at
its output states (growth, the manifold, the invariants the closed loop keeps against what
the tolerances allow) and refuses what CVODES' error estimate let through.
"""

from __future__ import annotations

from enum import Enum
from typing import Any

import numpy as np

from workbench.core.errors import ModelError, WorkbenchError
from workbench.core.validate import choice, count, positive, relative_tolerance, tolerance
from workbench.simulation.integrators.common import MAX_FIXED_STEPS

__all__ = ["Multistep", "Corrector", "CvodesCheck", "RunCheck", "cvodes_options",
           "check_max_steps", "check_max_step", "check_rtol", "AGAIN_STEPS", "MAX_STEPS",
           "AGAIN_RTOL", "RTOL_MAX"]

RTOL_MAX = 1e-3
"""Largest accepted CVODES ``rtol``. SUNDIALS' guide on tolerances: "we do not recommend
using reltol larger than 1e-3". Measured: the pendulum over 20 s at ``rtol = atol = 1e-3``
is already 3.2 away from the converged run (its unit vector moves by 2 at most) with an
energy drift of 13 % of its scale; at 1 the drift is 815 and at 1e3 the unit vector has
length 4e17. A relative tolerance of 1 or more accepts any answer."""

MAX_STEPS = 10**8
"""Largest accepted CVODES ``max_steps`` (internal steps per output interval): 1e8 steps of
a small model take minutes (the 3D pendulum runs about 3e5 steps/s), the same bound as the
fixed-step methods' total (``integrators.common.MAX_FIXED_STEPS``). Without it a run of
``t = [0, 1e9]`` with ``max_steps = 10**18`` would go on for hours before saying anything."""


class Multistep(str, Enum):
    """Linear multistep family of CVODES.

    Attributes
    ----------
    ADAMS
        Adams-Moulton, orders 1-12: the efficient choice for non-stiff dynamics such as the
        uncontrolled pendulums (at rtol = atol = 1e-12 over 100 s of the 3D pendulum it
        conserves E and h about 100 times better than BDF with 4 times fewer evaluations).
    BDF
        Backward differentiation formulas, orders 1-5: for stiff closed loops (high gains).
    """

    ADAMS = "adams"
    BDF = "bdf"


class Corrector(str, Enum):
    """How CVODES solves each step's implicit corrector equation.

    Attributes
    ----------
    FUNCTIONAL
        Fixed-point iteration: no Jacobian of the field is formed or factorised. SUNDIALS'
        choice for non-stiff problems with Adams, and the default with
        :attr:`Multistep.ADAMS`: 7.3x less CPU time on the 20-link chain (2 s at rtol 1e-8,
        the same number of steps, error 2.6e-7 against Newton's 1.4e-7) and 15x on the
        50-link one (``benchmarks/bench_corrector.py``).
    NEWTON
        Newton's method with the field's Jacobian (dense, computed and factorised when
        CVODES decides): needed for stiff problems, the default with :attr:`Multistep.BDF`.

    Neither changes the accuracy CVODES is asked for (``rtol``, ``atol``); a stiff problem
    under FUNCTIONAL takes many small steps (or fails with ``max_steps``), the remedy being
    ``multistep="bdf"``.
    """

    FUNCTIONAL = "functional"
    NEWTON = "newton"


def cvodes_options(*, multistep: Multistep | str = Multistep.ADAMS,
                   corrector: Corrector | str | None = None, rtol: float, atol: float,
                   max_steps: int | None = None, max_step: float | None = None,
                   error: type[WorkbenchError] = ModelError) -> dict[str, Any]:
    """CVODES options with the multistep family and corrector explicit.

    Parameters
    ----------
    multistep : Multistep or str
        ``"adams"`` (non-stiff) or ``"bdf"`` (stiff).
    corrector : Corrector or str, optional
        ``"functional"`` or ``"newton"``; default functional with Adams, Newton with BDF.
    rtol : float
        Relative tolerance in ``(0, RTOL_MAX]`` (:func:`check_rtol`).
    atol : float
        Absolute tolerance: a positive finite number.
    max_steps : int, optional
        CVODES' limit on internal steps per output interval, an integer in ``[1,
        MAX_STEPS]`` (casadi's default when None).
    max_step : float, optional
        Largest internal step (casadi's ``max_step_size``), positive and finite; None:
        unbounded.
    error : type of Exception
        Raised for an unknown ``multistep`` or ``corrector``, a bad tolerance,
        ``max_steps`` or ``max_step``, naming the argument.

    Returns
    -------
    dict
        The options for ``casadi.integrator(..., "cvodes", ...)``.
    """
    rtol = check_rtol(rtol, error=error)
    atol = tolerance("atol", atol, error=error)
    if max_steps is not None:
        max_steps = check_max_steps(max_steps, error=error)
    max_step = check_max_step(max_step, error=error)
    multistep = choice(Multistep, multistep, "multistep", error=error)
    if corrector is None:
        corrector = Corrector.FUNCTIONAL if multistep is Multistep.ADAMS else Corrector.NEWTON
    corrector = choice(Corrector, corrector, "corrector", error=error)
    opts: dict[str, Any] = {"abstol": atol, "reltol": rtol,
                            "linear_multistep_method": multistep.value,
                            "nonlinear_solver_iteration": corrector.value}
    if max_steps is not None:
        opts["max_num_steps"] = max_steps
    if max_step is not None:
        opts["max_step_size"] = max_step
    return opts


def check_rtol(rtol: object, *, error: type[WorkbenchError] = ModelError) -> float:
    """CVODES' ``rtol`` as a float in ``(0, RTOL_MAX]``.

    Parameters
    ----------
    rtol : float
        The relative tolerance.
    error : type of Exception
        Raised for a value that is not such a number, naming the argument and the bound.

    Returns
    -------
    float
    """
    return relative_tolerance(
        "rtol", rtol, maximum=RTOL_MAX, error=error,
        why=f"CVODES' local relative error per step; SUNDIALS advises against more than "
            f"{RTOL_MAX:g}, where the answer is already off by the size of the state (1 or "
            f"more accepts any answer)")


def check_max_step(max_step: object, *, interval: float | None = None,
                   max_steps: int | None = None, horizon: float | None = None,
                   error: type[WorkbenchError] = ModelError) -> float | None:
    """CVODES' ``max_step`` as a positive finite float, checked before anything runs.

    Parameters
    ----------
    max_step : float or None
        The largest internal step (None: unbounded, returned as is).
    interval : float, optional
        The longest output interval: with ``max_steps``, ``interval / max_step`` steps
        must fit in ``max_steps`` (else the run would fail after spending them).
    max_steps : int, optional
        CVODES' limit on internal steps per output interval.
    horizon : float, optional
        The whole run's length: ``horizon / max_step``, the fewest steps the run takes,
        must be at most :data:`MAX_TOTAL_STEPS`.
    error : type of Exception
        Raised for a bad value, naming the argument.

    Returns
    -------
    float or None
    """
    if max_step is None:
        return None
    v = positive("max_step", max_step, error=error)
    if horizon is not None and horizon / v > MAX_TOTAL_STEPS:
        raise error(
            f"max_step = {v:g} needs at least {horizon / v:.3g} steps over the horizon "
            f"({horizon:g}), more than {MAX_TOTAL_STEPS:.0e} (a run of that many steps of a "
            f"small model takes minutes; the fixed-step methods have the same bound); "
            f"pass a larger max_step or a shorter horizon")
    if interval is not None and max_steps is not None and interval / v > max_steps:
        raise error(
            f"max_step = {v:g} needs at least {interval / v:.3g} steps for the longest "
            f"output interval ({interval:g}), more than max_steps = {max_steps} (the limit "
            f"per output interval); raise max_steps, output at more times t, or pass a "
            f"larger max_step")
    return v


def check_max_steps(max_steps: object, *, error: type[WorkbenchError] = ModelError) -> int:
    """CVODES' ``max_steps`` as an int in ``[1, MAX_STEPS]``, checked before anything runs.

    Parameters
    ----------
    max_steps : int
        Internal steps per output interval.
    error : type of Exception
        Raised for a value that is not such an integer, naming the argument and the bound.

    Returns
    -------
    int
    """
    if (isinstance(max_steps, (int, np.integer)) and not isinstance(max_steps, bool)
            and max_steps > MAX_STEPS):
        raise error(
            f"max_steps must be an integer >= 1 and <= {MAX_STEPS:.0e}; got {max_steps}: it "
            f"bounds CVODES' internal steps per output interval, and {MAX_STEPS:.0e} steps of "
            f"a small model already take minutes. For a long horizon output at more times t "
            f"(the limit is per output interval), or shorten the horizon")
    return count("max_steps", max_steps, maximum=MAX_STEPS, error=error)


MAX_TOTAL_STEPS = MAX_FIXED_STEPS
"""The fewest steps a run with ``max_step`` may be held to: ``horizon / max_step`` (the
fixed-step methods' bound on their steps)."""


# the checks of a finished run (implemented in _cvodes_check, part of this module's API)
from workbench.simulation._cvodes_check import (  # noqa: E402
    AGAIN_RTOL,
    AGAIN_STEPS,
    CvodesCheck,
    RunCheck,
)
