"""What define-and-solve studies are made of: Result and comparisons, figures, the script runner."""

from __future__ import annotations

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
    to_jsonable,
)
from workbench.study._script import run_script

__all__ = [
    "run_script",
    "Comparison",
    "MAX_SEGMENTS",
    "Result",
    "ResultStatus",
    "body_axis_curves",
    "decimate",
    "format_result",
    "mark_directions",
    "s2_manifold_figure",
    "so3_manifold_figure",
    "sphere_axes",
    "sphere_curves",
    "to_jsonable",
]
