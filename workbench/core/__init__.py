"""The core of the engine: manifolds, models, evaluators, validation, errors, status."""

from __future__ import annotations

from workbench.core._evaluator import (
    DenseEvaluator,
    Evaluator,
)
from workbench.core._feedback import (
    feedback_function,
)
from workbench.core._model import (
    RESERVED_NAMES,
    BuildLog,
    BuildRecord,
    Context,
    Model,
    Parameter,
    Symbolic,
    finite,
    nonnegative,
    positive,
    spd3,
)
from workbench.core._solve import solve_spd
from workbench.core.errors import (
    ManifoldError,
    ModelError,
    ParameterError,
    SolverError,
    WorkbenchError,
)
from workbench.core.manifolds import (
    DEFAULT_TOL,
    S1,
    S2,
    SO3,
    TS2,
    Factor,
    ProductManifold,
    Rn,
    hat,
    so3_exp,
    so3_log,
    sphere_basis,
    vee,
)
from workbench.core.status import (
    Record,
    SolverResult,
    StatusEnum,
    StatusResult,
)
from workbench.core.types import (
    Expr,
    Matrix,
    Vector,
)
from workbench.core.validate import (
    choice,
    count,
)

__all__ = [
    "BuildLog",
    "BuildRecord",
    "Context",
    "DEFAULT_TOL",
    "DenseEvaluator",
    "Evaluator",
    "Expr",
    "Factor",
    "ManifoldError",
    "Matrix",
    "Model",
    "RESERVED_NAMES",
    "ModelError",
    "Parameter",
    "ParameterError",
    "ProductManifold",
    "Record",
    "Rn",
    "S1",
    "S2",
    "SO3",
    "SolverError",
    "SolverResult",
    "StatusEnum",
    "StatusResult",
    "Symbolic",
    "TS2",
    "Vector",
    "WorkbenchError",
    "choice",
    "count",
    "feedback_function",
    "finite",
    "hat",
    "nonnegative",
    "positive",
    "so3_exp",
    "so3_log",
    "solve_spd",
    "spd3",
    "sphere_basis",
    "vee",
]
