"""One-step integration of a model with a constant input (re-simulation, sampled feedback).

:func:`workbench.simulation.simulate` integrates ``x' = f(x, k(x))`` for a feedback ``k``
of the state; an open-loop or sampled-data control is constant (or, with a first-order
hold, linear) on each interval instead. A
:class:`Stepper` builds one CVODES integrator with the input and the step length as
parameters (time scaled to ``[0, 1]``), so a trajectory of ``N`` intervals costs one build
and ``N`` calls. It uses the same CVODES tolerances, multistep family and corrector as
``simulate`` (Adams with functional iteration by default: the model is integrated open
loop over a sample, where it is not stiff); the tests check the two agree.
"""

from __future__ import annotations

import time

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import ParameterError, SolverError
from workbench.core.types import ArrayLike, Vector
from workbench.simulation import Corrector, Multistep, cvodes_options

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
    multistep : Multistep or str
        ``"adams"`` (default; non-stiff) or ``"bdf"`` (stiff), as in ``simulate``.
    corrector : Corrector or str, optional
        ``"functional"`` (default with Adams: no Jacobian) or ``"newton"`` (default with
        BDF), as in ``simulate``. casadi's defaults, BDF with Newton, cost more on these
        non-stiff models (``benchmarks/bench_corrector.py`` times both on the double cart).
    """

    def __init__(self, model: Model, *, rtol: float = 1e-10, atol: float = 1e-10,
                 max_steps: int = 100_000, multistep: Multistep | str = Multistep.ADAMS,
                 corrector: Corrector | str | None = None) -> None:
        opts = cvodes_options(multistep=multistep, corrector=corrector, rtol=rtol, atol=atol,
                              max_steps=max_steps, error=ParameterError)
        self.model = model
        t0 = time.perf_counter()
        S = model.sym
        x = S.sym("x", model.manifold.ambient_dim)
        u, h = S.sym("u", model.n_inputs), S.sym("h")
        p = S.sym("p", model.n_params)
        ode = h * model.function("f")(x, u, p)
        self._F = ca.integrator(
            f"step_{model.name}", "cvodes", {"x": x, "p": ca.vertcat(u, h, p), "ode": ode},
            0.0, 1.0, opts,
        )
        self.build_seconds = time.perf_counter() - t0
        self._p = model.p
        self._opts = opts
        self._F_linear: ca.Function | None = None

    def _linear(self) -> ca.Function:
        """The integrator with the input linear in time (first-order hold), built once."""
        if self._F_linear is None:
            model = self.model
            S = model.sym
            x, s = S.sym("x", model.manifold.ambient_dim), S.sym("s")
            u0, u1 = S.sym("u0", model.n_inputs), S.sym("u1", model.n_inputs)
            h, p = S.sym("h"), S.sym("p", model.n_params)
            ode = h * model.function("f")(x, u0 + s * (u1 - u0), p)
            self._F_linear = ca.integrator(
                f"step_foh_{model.name}", "cvodes",
                {"x": x, "t": s, "p": ca.vertcat(u0, u1, h, p), "ode": ode}, 0.0, 1.0,
                self._opts)
        return self._F_linear

    def step(self, x: ArrayLike, u: ArrayLike, h: float, *,
             u_end: ArrayLike | None = None) -> Vector:
        """Integrate from ``x`` over ``h`` seconds with the constant input ``u``.

        Parameters
        ----------
        x : array-like, shape=(ambient_dim,)
            Start.
        u : array-like, shape=(n_inputs,)
            Input (at the start, with ``u_end``).
        h : float
            Step length [s].
        u_end : array-like, shape=(n_inputs,), optional
            Input at the end: the input is then linear in time from ``u`` to ``u_end``
            (first-order hold).

        Raises
        ------
        SolverError
            If CVODES fails.
        """
        try:
            if u_end is None:
                F, pv = self._F, np.r_[np.ravel(u), h, self._p]
            else:
                F, pv = self._linear(), np.r_[np.ravel(u), np.ravel(u_end), h, self._p]
            res = F(x0=np.asarray(x, float), p=pv)
        except RuntimeError as exc:
            raise SolverError(
                f"cvodes failed on a step of {h:g} s of {self.model.name}: "
                f"{str(exc).splitlines()[-1] if str(exc) else exc!r}",
                status=str(F.stats().get("return_status", "integrator error")),
            ) from exc
        out = np.asarray(res["xf"], float).ravel()
        if not np.all(np.isfinite(out)):
            raise SolverError(f"cvodes produced non-finite states for {self.model.name}",
                              status="non-finite")
        return out
