"""The controller in the loop: ``(x, p) -> u`` from a user's feedback, checked once.

Every closed-loop analysis (simulation, the geometric integrators, linearisation, the
ambient form) composes a controller ``u = k(x)`` or ``u = k(x, p)`` with a model through
:func:`feedback_function`, so a controller that does not fit the model is refused with the
same message everywhere.
"""

from __future__ import annotations

import casadi as ca

from workbench.core._model import Model
from workbench.core.errors import ModelError

__all__ = ["feedback_function"]


def feedback_function(model: Model, controller: ca.Function | None) -> ca.Function:
    """``(x, p) -> u`` in the model's symbol class: the controller, or ``u = 0``.

    Parameters
    ----------
    model : Model
        The plant.
    controller : casadi.Function or None
        ``u = k(x)`` or ``u = k(x, p)``, output of size ``model.n_inputs``.

    Returns
    -------
    casadi.Function

    Raises
    ------
    ModelError
        If the controller's inputs or output do not fit the model.
    """
    S = model.sym
    x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
    if controller is None:
        u = S.zeros(model.n_inputs)
    else:
        if not isinstance(controller, ca.Function):
            raise ModelError(
                f"controller must be a casadi.Function u = k(x) or k(x, p); got "
                f"{type(controller).__name__}"
            )
        if controller.n_in() not in (1, 2) or \
                controller.nnz_in(0) != model.manifold.ambient_dim or \
                (controller.n_in() == 2 and controller.nnz_in(1) != model.n_params):
            raise ModelError(
                f"controller must take the state ({model.manifold.ambient_dim} entries) and "
                f"optionally the parameters ({model.n_params}); got inputs of sizes "
                f"{[controller.nnz_in(i) for i in range(controller.n_in())]}"
            )
        if controller.nnz_out(0) != model.n_inputs:
            raise ModelError(
                f"controller must return {model.n_inputs} inputs; got {controller.nnz_out(0)}"
            )
        u = controller(x) if controller.n_in() == 1 else controller(x, p)
    return ca.Function("feedback", [x, p], [ca.vec(u)], ["x", "p"], ["u"])
