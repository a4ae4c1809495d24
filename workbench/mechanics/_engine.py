"""The engine names the mechanics layer uses, imported in one place.

The layer depends only on the core room (manifolds, models, errors); keeping the imports
here means a move of the core touches one file.
"""

from __future__ import annotations

from workbench.core import (
    RESERVED_NAMES,
    S1,
    SO3,
    TS2,
    Context,
    Model,
    ModelError,
    Parameter,
    ParameterError,
    ProductManifold,
    Rn,
    Symbolic,
    finite,
    hat,
    nonnegative,
    positive,
    solve_spd,
    sphere_basis,
    vee,
)
from workbench.core.validate import MAX_DIM

__all__ = [
    "MAX_DIM",
    "RESERVED_NAMES",
    "Context",
    "Model",
    "ModelError",
    "Parameter",
    "ParameterError",
    "ProductManifold",
    "Rn",
    "S1",
    "SO3",
    "TS2",
    "Symbolic",
    "finite",
    "hat",
    "nonnegative",
    "positive",
    "solve_spd",
    "sphere_basis",
    "vee",
]
