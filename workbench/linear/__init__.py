"""Linear analysis: linearisation (tangent and ambient), eigenstructure, PBH/Kalman, LQR."""

from __future__ import annotations

from workbench.linear._ambient import (
    EQUILIBRIUM_TOL,
    AmbientLinearization,
    closed_loop_jacobians,
    linearize_ambient,
)
from workbench.linear._controllability import (
    PBH_TOL,
    KalmanResult,
    ModeTest,
    PBHResult,
    SecondOrderForm,
    kalman_rank,
    pbh,
    pbh_second_order,
    second_order_form,
)
from workbench.linear._eigen import (
    Eigenstructure,
    Stability,
    Subspace,
    default_tol,
    eigenstructure,
)
from workbench.linear._linearize import (
    LinearizationCost,
    LinearModel,
    linearize,
    mechanical_order,
    tangent_labels,
)
from workbench.linear._lqr import (
    LQRCost,
    LQRResult,
    Requirement,
    geometric_feedback,
    lqr,
    riccati_residual,
)
from workbench.linear._symmetry import SymmetryDirections, symmetry_directions
from workbench.linear.symbolic import (
    SymbolicLinearization,
    casadi_to_sympy,
    default_parameter_symbols,
    exact_number,
    symbolic_linearization,
)

__all__ = [
    "SymmetryDirections",
    "symmetry_directions",
    "AmbientLinearization",
    "EQUILIBRIUM_TOL",
    "Eigenstructure",
    "KalmanResult",
    "LQRResult",
    "LinearModel",
    "ModeTest",
    "PBHResult",
    "PBH_TOL",
    "Requirement",
    "SecondOrderForm",
    "Stability",
    "Subspace",
    "SymbolicLinearization",
    "casadi_to_sympy",
    "closed_loop_jacobians",
    "default_parameter_symbols",
    "default_tol",
    "eigenstructure",
    "exact_number",
    "geometric_feedback",
    "kalman_rank",
    "linearize",
    "linearize_ambient",
    "lqr",
    "mechanical_order",
    "pbh",
    "pbh_second_order",
    "riccati_residual",
    "second_order_form",
    "symbolic_linearization",
    "tangent_labels",
    "LQRCost",
    "LinearizationCost",
]
