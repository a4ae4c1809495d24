"""Equilibria: Newton on manifolds, equilibrium search, all critical sets, continuation."""

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
from workbench.equilibria._critical import (
    CriticalPoints,
    CriticalSet,
    CriticalStatus,
    critical_points,
    find_all_equilibria,
)
from workbench.equilibria._critical_deflation import SearchEnd
from workbench.equilibria._critical_function import ConfigurationFunction, potential_function
from workbench.equilibria._critical_topology import MorseBottCheck
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
    "ConfigurationFunction",
    "CriticalPoints",
    "CriticalSet",
    "CriticalStatus",
    "EndReason",
    "Equilibrium",
    "EquilibriumSet",
    "MorseBottCheck",
    "PointKind",
    "Root",
    "RootStatus",
    "SearchEnd",
    "SpecialPoint",
    "StepControl",
    "ZeroProblem",
    "continue_branch",
    "correct_point",
    "critical_points",
    "enumerate_equilibria",
    "find_all_equilibria",
    "find_equilibrium",
    "locate_on_branch",
    "newton_on_manifold",
    "potential_function",
    "switch_branch",
]
