"""Global dynamics: invariant manifolds of saddles, Poincare maps, FTLE, geometric phase."""

from __future__ import annotations

from workbench.global_dynamics._ftle import (
    FTLECost,
    LyapunovEstimate,
    lyapunov_exponent,
)
from workbench.global_dynamics._invariant_manifolds import (
    VECTORISED_METHODS,
    InvariantManifold,
    invariant_manifold,
    stable_manifold,
    unstable_manifold,
)
from workbench.global_dynamics._manifold_validation import (
    Validation,
    ValidationCost,
    compare_per_point,
    validate,
)
from workbench.global_dynamics._phase import (
    PhaseCheck,
    PhaseCost,
    cone_integral,
    first_self_intersection,
    geometric_phase_check,
    holonomy_angle,
    wrap_angle,
)
from workbench.global_dynamics._poincare import (
    OrbitCost,
    OrbitStatus,
    PoincareOrbit,
    poincare_map,
)
from workbench.global_dynamics._sections import (
    Direction,
    Section,
    stabilized_field,
    turning_section,
    turning_section_state,
)
from workbench.global_dynamics._seeds import (
    ball_points,
    batch_evaluate,
    chart_increments,
    direction_spread,
    distances,
    equilibrium_distance,
    rounding_bound,
    seed_report,
    sphere_directions,
)

__all__ = [
    "Direction",
    "FTLECost",
    "InvariantManifold",
    "LyapunovEstimate",
    "OrbitCost",
    "OrbitStatus",
    "PhaseCheck",
    "PoincareOrbit",
    "Section",
    "VECTORISED_METHODS",
    "Validation",
    "ball_points",
    "batch_evaluate",
    "chart_increments",
    "compare_per_point",
    "cone_integral",
    "direction_spread",
    "distances",
    "equilibrium_distance",
    "first_self_intersection",
    "geometric_phase_check",
    "holonomy_angle",
    "invariant_manifold",
    "lyapunov_exponent",
    "poincare_map",
    "rounding_bound",
    "seed_report",
    "sphere_directions",
    "stabilized_field",
    "stable_manifold",
    "turning_section",
    "turning_section_state",
    "unstable_manifold",
    "validate",
    "wrap_angle",
    "PhaseCost",
    "ValidationCost",
]
