"""The geometric pendulum workbench.

Coordinate-free models as casadi graphs, and the analyses derived from them.
"""

from workbench.errors import (
    ManifoldError,
    ModelError,
    ParameterError,
    SolverError,
    WorkbenchError,
)
from workbench.manifolds import S1, S2, SO3, TS2, ProductManifold, Rn, hat, so3_exp, so3_log, vee
from workbench.model import BuildLog, Evaluator, Model, Parameter
from workbench.simulate import Method, Trajectory, simulate

__all__ = [
    "BuildLog",
    "Evaluator",
    "ManifoldError",
    "Method",
    "Model",
    "ModelError",
    "Parameter",
    "ParameterError",
    "ProductManifold",
    "Rn",
    "S1",
    "S2",
    "SO3",
    "SolverError",
    "TS2",
    "Trajectory",
    "WorkbenchError",
    "hat",
    "simulate",
    "so3_exp",
    "so3_log",
    "vee",
]
