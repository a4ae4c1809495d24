"""Extremes, bad input: a sample of bad calls and their messages.

The full table is tests/extremes/test_extreme_bad_input.py.
"""

from __future__ import annotations

import numpy as np

from models import pendulum3d as p3
from problems._extremes.common import J_CYL, RHO_CYL
from workbench.core.manifolds import SO3
from workbench.study import Cases


def bad_inputs(cases: Cases) -> None:
    """A few bad calls and the messages they give."""
    from models.chain_cart import chain_cart
    from workbench import linearize, lqr, simulate, so3_log

    full = p3.full(J=J_CYL, rho=RHO_CYL)
    x0 = full.state(R=np.eye(3), omega=np.zeros(3))
    sample = {
        "J with a negative eigenvalue": lambda: p3.full(J=np.diag([1.0, 1.0, -1.0]),
                                                        rho=RHO_CYL),
        "rho with NaN": lambda: p3.full(J=J_CYL, rho=[np.nan, 0.0, 0.0]),
        "mass 0": lambda: p3.full(J=J_CYL, rho=RHO_CYL, m=0.0),
        "chain with 1.5 links": lambda: chain_cart(1.5),
        "initial attitude 2 I": lambda: simulate(full, np.r_[2 * np.eye(3).ravel(), 0, 0, 0],
                                                 [0, 1]),
        "output times not monotone": lambda: simulate(full, x0, [0.0, 2.0, 1.0]),
        "unknown method": lambda: simulate(full, x0, [0, 1], method="euler"),
        "log of a reflection": lambda: so3_log(np.diag([1.0, 1.0, -1.0])),
        "linearise off equilibrium": lambda: linearize(
            full, full.state(R=np.eye(3), omega=[1.0, 0, 0])),
        "LQR of an uncontrollable pair": lambda: lqr(np.eye(2), np.eye(2), np.eye(1),
                                                     B=np.array([[1.0], [0.0]])),
        "unknown parameter": lambda: full.with_parameters(mass=2.0),
        "off-manifold state to SO3().check": lambda: SO3().check(np.ones((3, 3))),
    }
    for name, call in sample.items():
        cases.run("bad_input", name, call, expect_failure=True)
