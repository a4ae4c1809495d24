"""Structure-preserving fixed-step integrators, built from a model's casadi graph.

* :func:`lgvi`: Lie group variational integrator on TSO(3) (rigid body, 3D pendulum);
* :func:`s2_variational`: variational integrator on S^2 (spherical pendulum);
* :func:`mechanics_variational`: variational integrator of any model made by
  :mod:`workbench.mechanics` on R^k, SO(3) and S^2 factors (the 3D pendulum, the double 3D
  pendulum, the pendulum on a cart), from its Lagrangian;
* :func:`rkmk4`: explicit Runge-Kutta-Munthe-Kaas method of order 4 for any model on
  R^n, S1, S2, SO3 and TS2 factors.

Each returns a :class:`DiscreteFlow` (the discrete flow map ``Phi_h``: one step as a
casadi.Function, cached in the model's build log) that :func:`integrate` runs forward or
backward in time; they are first-class methods of
:func:`workbench.simulation._simulate.simulate` (``Method.LGVI``,
``Method.S2_VARIATIONAL``, ``Method.RKMK4``, ``Method.MECHANICS_VARIATIONAL``). The
casadi-backed methods (cvodes, rk, collocation) live in :mod:`workbench.simulation._simulate`.
"""

from workbench.simulation.integrators.common import (
    CHUNK,
    NEWTON_MAX_ITER,
    NEWTON_TOL,
    DiscreteFlow,
    Integration,
    IntegrationCost,
    integrate,
)
from workbench.simulation.integrators.lgvi import lgvi
from workbench.simulation.integrators.mechanics_variational import mechanics_variational
from workbench.simulation.integrators.rkmk import rkmk4
from workbench.simulation.integrators.s2_variational import s2_variational

__all__ = [
    "CHUNK",
    "NEWTON_MAX_ITER",
    "NEWTON_TOL",
    "Integration",
    "IntegrationCost",
    "DiscreteFlow",
    "integrate",
    "lgvi",
    "mechanics_variational",
    "rkmk4",
    "s2_variational",
]
