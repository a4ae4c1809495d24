"""One-step integration of a model with a constant input (re-simulation, sampled feedback).

:func:`workbench.simulation._simulate.simulate` integrates ``x' = f(x, k(x))`` for a feedback ``k`` of
the state; an open-loop or sampled-data control is constant on each interval instead. A
:class:`Stepper` builds one CVODES integrator with the input and the step length as
parameters (time scaled to ``[0, 1]``), so a trajectory of ``N`` intervals costs one build
and ``N`` calls. It uses the same CVODES tolerances as ``simulate``; the tests check the two
agree.
"""

from __future__ import annotations

import time

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import ParameterError, SolverError
from workbench.core.types import ArrayLike, Vector

__all__ = ["Stepper"]


class Stepper:
    """``x(t + h)`` from ``x(t)`` under a constant input, by CVODES.

    Parameters
    ----------
    model : Model
        The model.
    rtol, atol : float
        CVODES tolerances.
    max_steps : int
        CVODES' limit on internal steps per call.
    """

    def __init__(self, model: Model, *, rtol: float = 1e-10, atol: float = 1e-10,
                 max_steps: int = 100_000) -> None:
        for name, val in (("rtol", rtol), ("atol", atol)):
            if not (np.isfinite(val) and val > 0):
                raise ParameterError(f"{name} must be positive and finite; got {val!r}")
        self.model = model
        t0 = time.perf_counter()
        S = model.sym
        x = S.sym("x", model.manifold.ambient_dim)
        u, h = S.sym("u", model.n_inputs), S.sym("h")
        p = S.sym("p", model.n_params)
        ode = h * model.function("f")(x, u, p)
        self._F = ca.integrator(
            f"step_{model.name}", "cvodes", {"x": x, "p": ca.vertcat(u, h, p), "ode": ode},
            0.0, 1.0, {"abstol": atol, "reltol": rtol, "max_num_steps": int(max_steps)},
        )
        self.build_seconds = time.perf_counter() - t0
        self._p = model.p

    def step(self, x: ArrayLike, u: ArrayLike, h: float) -> Vector:
        """Integrate from ``x`` over ``h`` seconds with the constant input ``u``.

        Raises
        ------
        SolverError
            If CVODES fails.
        """
        try:
            res = self._F(x0=np.asarray(x, float), p=np.r_[np.ravel(u), h, self._p])
        except RuntimeError as exc:
            raise SolverError(
                f"cvodes failed on a step of {h:g} s of {self.model.name}: "
                f"{str(exc).splitlines()[-1] if str(exc) else exc!r}",
                status=str(self._F.stats().get("return_status", "integrator error")),
            ) from exc
        out = np.asarray(res["xf"], float).ravel()
        if not np.all(np.isfinite(out)):
            raise SolverError(f"cvodes produced non-finite states for {self.model.name}",
                              status="non-finite")
        return out
