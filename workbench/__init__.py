"""The geometric pendulum workbench.

Coordinate-free models as casadi graphs, and the analyses derived from them. The engine is
grouped into rooms, each a package whose public names are re-exported here:

- :mod:`workbench.core` — manifolds, :class:`Model`, evaluators, validation, errors, status;
- :mod:`workbench.mechanics` — systems from their Lagrangians;
- :mod:`workbench.simulation` — ``simulate``, geometric integrators, accuracy, sweeps;
- :mod:`workbench.linear` — linearisation, eigenstructure, PBH/Kalman, LQR, symbolic forms;
- :mod:`workbench.equilibria` — Newton on manifolds, equilibria, continuation;
- :mod:`workbench.global_dynamics` — invariant manifolds, Poincare maps, FTLE, phase;
- :mod:`workbench.control` — feedback, Lyapunov, domains of attraction, OCP, TVLQR;
- :mod:`workbench.codegen` — controllers exported as C;
- :mod:`workbench.study` — results and figures of define-and-solve studies, and the choice
  of a model's level for a scene (:func:`compare_models`);
- :mod:`workbench.app` — the command line and the report (above the problems; not imported here).
"""

from __future__ import annotations

from workbench import (
    _moved,
    codegen,
    control,
    core,
    equilibria,
    global_dynamics,
    linear,
    simulation,
    study,
)
from workbench.control import (
    OCP,
    TVLQR,
    Auto,
    Collocation,
    Direct,
    HermiteSimpson,
    ManifoldHandling,
    MultipleShooting,
    OCPSolution,
    OCPStatus,
    TargetPoint,
    TargetSet,
    ocp,  # noqa: F401 (the documented alias workbench.ocp)
    solve_ocp,
    tvlqr,
    tvlqr_along,
)
from workbench.core import (
    S1,
    S2,
    SO3,
    TS2,
    BuildLog,
    Evaluator,
    ManifoldError,
    Model,
    ModelError,
    Parameter,
    ParameterError,
    ProductManifold,
    Rn,
    SolverError,
    Symbolic,
    WorkbenchError,
    errors,  # noqa: F401 (the documented alias workbench.errors)
    hat,
    manifolds,  # noqa: F401 (the documented alias workbench.manifolds)
    so3_exp,
    so3_log,
    vee,
)
from workbench.equilibria import (
    ConfigurationFunction,
    CriticalPoints,
    StepControl,
    continue_branch,
    critical_points,
    enumerate_equilibria,
    find_all_equilibria,
    find_equilibrium,
)
from workbench.global_dynamics import (
    InvariantManifold,
    PoincareOrbit,
    Section,
    geometric_phase_check,
    invariant_manifold,
    poincare_map,
    stable_manifold,
    turning_section,
    unstable_manifold,
)
from workbench.linear import (
    Eigenstructure,
    LinearModel,
    LQRResult,
    Stability,
    Subspace,
    eigenstructure,
    geometric_feedback,
    kalman_rank,
    linearize,
    linearize_ambient,
    lqr,
    pbh,
    pbh_second_order,
    second_order_form,
    symbolic,  # noqa: F401 (the documented alias workbench.symbolic)
    symmetry_directions,
)
from workbench.simulation import Method, Multistep, SweepResult, Trajectory, grid, simulate, sweep
from workbench.study import ModelChoice, Scene, compare_models

# The module paths of 0.1.0's flat layout: the documented ones (``workbench.manifolds``,
# ``.errors``, ``.symbolic``, ``.ocp``) stay as silent aliases of their rooms, the others warn
# until 0.3.0, and those that cannot return say where their names went (see _moved.py).
_moved.install()

__all__ = [
    "OCP",
    "S1",
    "S2",
    "SO3",
    "TS2",
    "TVLQR",
    "BuildLog",
    "Auto",
    "Collocation",
    "Direct",
    "ConfigurationFunction",
    "CriticalPoints",
    "Eigenstructure",
    "Evaluator",
    "HermiteSimpson",
    "InvariantManifold",
    "LQRResult",
    "LinearModel",
    "ModelChoice",
    "ManifoldError",
    "ManifoldHandling",
    "Method",
    "Model",
    "ModelError",
    "MultipleShooting",
    "Multistep",
    "OCPSolution",
    "OCPStatus",
    "Parameter",
    "ParameterError",
    "PoincareOrbit",
    "ProductManifold",
    "Rn",
    "Scene",
    "Section",
    "SolverError",
    "Stability",
    "StepControl",
    "Subspace",
    "SweepResult",
    "Symbolic",
    "TargetPoint",
    "TargetSet",
    "Trajectory",
    "WorkbenchError",
    "codegen",
    "compare_models",
    "continue_branch",
    "critical_points",
    "control",
    "core",
    "eigenstructure",
    "enumerate_equilibria",
    "equilibria",
    "find_all_equilibria",
    "find_equilibrium",
    "geometric_feedback",
    "geometric_phase_check",
    "global_dynamics",
    "grid",
    "hat",
    "invariant_manifold",
    "kalman_rank",
    "linear",
    "linearize",
    "linearize_ambient",
    "lqr",
    "pbh",
    "pbh_second_order",
    "poincare_map",
    "second_order_form",
    "symmetry_directions",
    "simulate",
    "simulation",
    "so3_exp",
    "so3_log",
    "solve_ocp",
    "stable_manifold",
    "study",
    "sweep",
    "tvlqr",
    "tvlqr_along",
    "turning_section",
    "unstable_manifold",
    "vee",
]
