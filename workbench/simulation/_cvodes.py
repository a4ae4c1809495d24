"""CVODES' options: the multistep family and the corrector iteration, explicit."""

from __future__ import annotations

from enum import Enum
from typing import Any

import numpy as np

from workbench.core.errors import ModelError, WorkbenchError
from workbench.core.validate import choice, count, tolerance

__all__ = ["Multistep", "Corrector", "cvodes_options", "check_max_steps", "MAX_STEPS"]

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
                   max_steps: int | None = None, error: type[WorkbenchError] = ModelError
                   ) -> dict[str, Any]:
    """CVODES options with the multistep family and corrector explicit.

    Parameters
    ----------
    multistep : Multistep or str
        ``"adams"`` (non-stiff) or ``"bdf"`` (stiff).
    corrector : Corrector or str, optional
        ``"functional"`` or ``"newton"``; default functional with Adams, Newton with BDF.
    rtol, atol : float
        Tolerances: positive finite numbers.
    max_steps : int, optional
        CVODES' limit on internal steps per output interval, an integer in ``[1,
        MAX_STEPS]`` (casadi's default when None).
    error : type of Exception
        Raised for an unknown ``multistep`` or ``corrector``, a bad tolerance or
        ``max_steps``, naming the argument.

    Returns
    -------
    dict
        The options for ``casadi.integrator(..., "cvodes", ...)``.
    """
    rtol = tolerance("rtol", rtol, error=error)
    atol = tolerance("atol", atol, error=error)
    if max_steps is not None:
        max_steps = check_max_steps(max_steps, error=error)
    multistep = choice(Multistep, multistep, "multistep", error=error)
    if corrector is None:
        corrector = Corrector.FUNCTIONAL if multistep is Multistep.ADAMS else Corrector.NEWTON
    corrector = choice(Corrector, corrector, "corrector", error=error)
    opts: dict[str, Any] = {"abstol": atol, "reltol": rtol,
                            "linear_multistep_method": multistep.value,
                            "nonlinear_solver_iteration": corrector.value}
    if max_steps is not None:
        opts["max_num_steps"] = max_steps
    return opts


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
