"""What define-and-solve studies are made of: Result and comparisons, figures, the script runner."""

from __future__ import annotations

from workbench.study._cases import CLEAR, CORRECT, DEFECT, Cases, Check, run_isolated
from workbench.study._compare import (
    SpectrumMatch,
    compare_counts,
    compare_lyapunov,
    compare_rows,
    compare_spectrum,
    compare_stability,
    decay_rate,
    match_spectrum,
    sign_pattern,
)
from workbench.study._figures import Panel, line_figure, spectrum_figure
from workbench.study._integrators import (
    check_work_precision,
    compare_constraint,
    compare_energy_growth,
    integrator_sweeps,
    long_time_periods,
    orders_figure,
    per_step_costs,
    slowest_period,
)
from workbench.study._manifold_measures import so3_axis_observations, stop_summary
from workbench.study._measures import (
    angle_travelled,
    axis_shares,
    body_axis_angle,
    circle_defect,
    cover_counts,
    great_circle_defect,
    rotation_cover_fraction,
)
from workbench.study._plots import (
    MAX_SEGMENTS,
    body_axis_curves,
    decimate,
    mark_directions,
    s2_manifold_figure,
    so3_manifold_figure,
    sphere_axes,
    sphere_curves,
)
from workbench.study._result import (
    Comparison,
    Result,
    ResultStatus,
    format_result,
    progress,
    to_jsonable,
)
from workbench.study._script import run_script

__all__ = [
    "run_script",
    "rotation_cover_fraction",
    "CLEAR",
    "CORRECT",
    "DEFECT",
    "Cases",
    "Check",
    "run_isolated",
    "Panel",
    "SpectrumMatch",
    "compare_counts",
    "compare_lyapunov",
    "compare_rows",
    "compare_spectrum",
    "compare_stability",
    "decay_rate",
    "line_figure",
    "match_spectrum",
    "sign_pattern",
    "spectrum_figure",
    "Comparison",
    "MAX_SEGMENTS",
    "Result",
    "progress",
    "ResultStatus",
    "angle_travelled",
    "axis_shares",
    "body_axis_angle",
    "body_axis_curves",
    "circle_defect",
    "cover_counts",
    "decimate",
    "format_result",
    "great_circle_defect",
    "mark_directions",
    "s2_manifold_figure",
    "so3_manifold_figure",
    "sphere_axes",
    "sphere_curves",
    "to_jsonable",
    "check_work_precision",
    "compare_constraint",
    "compare_energy_growth",
    "integrator_sweeps",
    "long_time_periods",
    "orders_figure",
    "per_step_costs",
    "slowest_period",
    "so3_axis_observations",
    "stop_summary",
]
