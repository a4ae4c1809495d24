"""The geometric pendulum workbench.

Coordinate-free models as casadi graphs, and the analyses derived from them.
"""

from workbench.continuation import StepControl, continue_branch
from workbench.controllability import kalman_rank, pbh, pbh_second_order, second_order_form
from workbench.eigen import Eigenstructure, Stability, Subspace, eigenstructure
from workbench.equilibria import enumerate_equilibria, find_equilibrium
from workbench.errors import (
    ManifoldError,
    ModelError,
    ParameterError,
    SolverError,
    WorkbenchError,
)
from workbench.invariant_manifolds import (
    InvariantManifold,
    invariant_manifold,
    stable_manifold,
    unstable_manifold,
)
from workbench.linearize import LinearModel, linearize, linearize_ambient
from workbench.lqr import LQRResult, geometric_feedback, lqr
from workbench.manifolds import S1, S2, SO3, TS2, ProductManifold, Rn, hat, so3_exp, so3_log, vee
from workbench.model import BuildLog, Evaluator, Model, Parameter, Symbolic
from workbench.ocp import (
    OCP,
    Collocation,
    ManifoldHandling,
    MultipleShooting,
    OCPSolution,
    OCPStatus,
    TargetPoint,
    TargetSet,
)
from workbench.ocp import solve as solve_ocp
from workbench.phase import geometric_phase_check
from workbench.poincare import PoincareOrbit, Section, poincare_map, turning_section
from workbench.relative_families import at_alpha, trace_relative_equilibria
from workbench.simulate import Method, Multistep, Trajectory, simulate
from workbench.sweep import SweepResult, grid, sweep
from workbench.tvlqr import TVLQR, tvlqr, tvlqr_along

__all__ = [
    "OCP",
    "Collocation",
    "ManifoldHandling",
    "MultipleShooting",
    "OCPSolution",
    "OCPStatus",
    "TVLQR",
    "TargetPoint",
    "TargetSet",
    "solve_ocp",
    "tvlqr",
    "tvlqr_along",
    "InvariantManifold",
    "invariant_manifold",
    "stable_manifold",
    "unstable_manifold",
    "PoincareOrbit",
    "Section",
    "SweepResult",
    "geometric_phase_check",
    "grid",
    "poincare_map",
    "sweep",
    "turning_section",
    "StepControl",
    "at_alpha",
    "continue_branch",
    "enumerate_equilibria",
    "find_equilibrium",
    "trace_relative_equilibria",
    "BuildLog",
    "Eigenstructure",
    "Evaluator",
    "LQRResult",
    "LinearModel",
    "Multistep",
    "Stability",
    "Subspace",
    "eigenstructure",
    "geometric_feedback",
    "kalman_rank",
    "linearize",
    "linearize_ambient",
    "lqr",
    "pbh",
    "pbh_second_order",
    "second_order_form",
    "ManifoldError",
    "Method",
    "Model",
    "ModelError",
    "Parameter",
    "Symbolic",
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
