"""Validation shared by the papers' feedback laws and Lyapunov functions (private).

Gains are checked against the papers' conditions and models against what a law needs;
failures raise :class:`~workbench.core.errors.ParameterError` or
:class:`~workbench.core.errors.ModelError` naming the argument, the condition and the value.
"""

from __future__ import annotations

import numpy as np

from workbench.core import Model, spd3, validate
from workbench.core.errors import ModelError, ParameterError
from workbench.core.types import ArrayLike

E3 = np.array([0.0, 0.0, 1.0])


def positive_scalar(value: float, name: str, condition: str) -> float:
    """Return ``value`` as a positive finite float, or raise ``ParameterError``.

    A thin use of :func:`workbench.core.validate.positive` (bool, str, complex refused).
    """
    try:
        return validate.positive(name, value)
    except ParameterError as exc:
        raise ParameterError(f"{name} must be positive (a positive number, finite; "
                             f"{condition}); got {value!r}") from exc


def spd_matrix(value: ArrayLike, name: str, condition: str) -> np.ndarray:
    """Return ``value`` as a symmetric positive definite 3x3 array, or raise ``ParameterError``."""
    a = validate.array(f"{name} (a 3x3 matrix; {condition})", value, shape=(3, 3))
    msg = spd3(a)
    if msg:
        raise ParameterError(f"{name} {msg.replace('; got', f' ({condition}); got', 1)}")
    return a


def require_model(model: Model, who: str, *, factors: dict[str, type] | None = None,
             params: tuple[str, ...] = (), inputs: int | None = None) -> None:
    """Check that ``model`` has the state factors, parameters and inputs a law needs."""
    man, have = model.manifold, [p.name for p in model.parameters]
    for name, kind in (factors or {}).items():
        if name not in man.names or not isinstance(man.factor(name), kind):
            raise ModelError(f"{who} needs a model with a {kind.__name__} state factor "
                             f"{name!r}; model {model.name!r} has factors {man.names} "
                             f"({man.describe()})")
    missing = [n for n in params if n not in have]
    if missing:
        raise ModelError(f"{who} uses the model parameters {list(params)}; model "
                         f"{model.name!r} lacks {missing} (has {have})")
    if inputs is not None and model.n_inputs != inputs:
        raise ModelError(f"{who} returns {inputs} inputs; model {model.name!r} has "
                         f"{model.n_inputs} inputs")
