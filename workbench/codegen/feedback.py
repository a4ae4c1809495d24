"""Your own feedback as C in one call: :func:`export_feedback`.

The papers' controllers carry hand-written documentation for their headers
(:class:`ExportableController`); a feedback designed in a session — an LQR gain turned into
a geometric feedback, a PD law written as a casadi graph — needs only the model it controls:
the header's state entries are the model's factors, its output the model's input, the
test states are random points of the model's manifold (and the example state).
"""

from __future__ import annotations

import os

import casadi as ca
import numpy as np

from workbench.codegen.api import ExportResult, export_c
from workbench.codegen.spec import Binding, Entry, ExportableController
from workbench.core import Model, ModelError, validate
from workbench.core.manifolds import S1, Factor

__all__ = ["feedback_controller", "export_feedback"]


def _entry_text(name: str, factor: Factor) -> str:
    """A state entry in the header: the factor's kind; an S1 factor says it is an angle."""
    if isinstance(factor, S1):
        return (f"S^1 factor {name!r}: an angle on S^1 stored as (cos, sin), a unit 2-vector "
                "(see the model's conventions for its zero and sense)")
    return f"{type(factor).__name__} factor {name!r} (see the model's conventions)"


def feedback_controller(
    model: Model,
    function: ca.Function,
    *,
    name: str,
    title: str,
    example_state: np.ndarray,
    example_note: str = "the equilibrium the feedback stabilises",
) -> ExportableController:
    """Describe a feedback ``u = k(x, p)`` of ``model`` for export, from the model alone.

    Parameters
    ----------
    model : Model
        The controlled model (its factors document the state, its input the output).
    function : casadi.Function
        ``(x, p) -> u`` with ``x`` the model's stored state and ``p`` its parameters, e.g.
        ``lqr(...).feedback()``.
    name : str
        Export name, a C identifier.
    title : str
        One line for the header (free text: it is escaped in the generated files).
    example_state : array-like, shape=(nx,)
        A state on the model's manifold (checked).
    example_note : str
        Where the example state comes from.

    Returns
    -------
    ExportableController

    Raises
    ------
    ModelError
        ``function`` does not map ``(x, p)`` of the model's sizes to ``u`` of its input size.
    """
    if not isinstance(function, ca.Function):
        raise ModelError(f"function must be a casadi.Function (x, p) -> u; got "
                         f"{type(function).__name__}")
    nx, nu = model.manifold.ambient_dim, model.n_inputs
    shapes = [function.size_in(0), function.size_in(1) if function.n_in() > 1 else None,
              function.size_out(0)]
    if function.n_in() != 2 or shapes != [(nx, 1), (model.n_params, 1), (nu, 1)]:
        raise ModelError(
            f"function must map x ({nx}) and p ({model.n_params}) to u ({nu}); got inputs "
            f"{[function.size_in(i) for i in range(function.n_in())]} and output "
            f"{function.size_out(0)}")
    x_ex = model.check_state(example_state, name="example_state")
    entries = tuple(Entry(n, model.manifold.slices[n].stop - model.manifold.slices[n].start,
                          _entry_text(n, f)) for n, f in model.manifold.factors)

    def sampler(rng: np.random.Generator, n: int) -> np.ndarray:
        pts = [model.manifold.random_point(rng) for _ in range(max(int(n) - 1, 0))]
        return np.array([x_ex, *pts])[: int(n)]

    return ExportableController(
        name=validate.identifier("name", name),
        title=validate.single_line("title", title),
        model=model, function=function, gains={}, gain_entries=(),
        law=lambda ctx, gains: function(ctx.x, ctx.p),
        state_entries=entries,
        output=Entry("u", nu, model.input_description or "the model's input"),
        example_state=x_ex, example_note=example_note, singular="none declared",
        sampler=sampler,
    )


def export_feedback(
    model: Model,
    function: ca.Function,
    out_dir: str | os.PathLike,
    *,
    name: str,
    title: str,
    example_state: np.ndarray,
    binding: Binding = Binding.FROZEN,
) -> ExportResult:
    """Export a feedback of ``model`` as checked C99 in one call.

    Parameters
    ----------
    model, function, name, title, example_state
        As in :func:`feedback_controller`.
    out_dir : path-like
        Output directory (created if missing; nothing is written if the check build fails).
    binding : Binding
        ``FROZEN`` folds the parameter values into the code; ``PARAMETERS`` makes them a
        run-time vector.

    Returns
    -------
    ExportResult
        The files written and the compiled library (compare it with
        :func:`workbench.codegen.agreement`).
    """
    controller = feedback_controller(model, function, name=name, title=title,
                                     example_state=example_state)
    return export_c(controller, out_dir, binding=binding)
