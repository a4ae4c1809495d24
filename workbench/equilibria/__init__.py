"""Equilibria: Newton on manifolds, equilibrium search, branches and continuation."""

from __future__ import annotations

from workbench.equilibria._branch import (
    Branch,
    BranchSwitch,
    EndReason,
    PointKind,
    SpecialPoint,
    StepControl,
)
from workbench.equilibria._continuation import (
    continue_branch,
    correct_point,
    locate_on_branch,
    switch_branch,
)
from workbench.equilibria._equilibria import (
    Equilibrium,
    EquilibriumSet,
    enumerate_equilibria,
    find_equilibrium,
)
from workbench.equilibria._roots import (
    Root,
    RootStatus,
    ZeroProblem,
    newton_on_manifold,
)

__all__ = [
    "Branch",
    "BranchSwitch",
    "EndReason",
    "Equilibrium",
    "EquilibriumSet",
    "PointKind",
    "Root",
    "RootStatus",
    "SpecialPoint",
    "StepControl",
    "ZeroProblem",
    "continue_branch",
    "correct_point",
    "enumerate_equilibria",
    "find_equilibrium",
    "locate_on_branch",
    "newton_on_manifold",
    "switch_branch",
]
