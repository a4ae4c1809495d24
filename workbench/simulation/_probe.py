"""The functions the stability checks of a fixed-step run evaluate, built once and kept.

:func:`probe_for` gives a :class:`Probe` for a model, a controller, a direction of time
and a step map: the closed-loop field in the direction of integration and its Jacobian
(the model's own ``f_x``, with ``f_u`` and the controller's derivative), the rates of the
invariants along it, and the step map whose Jacobian is built on first use.
:func:`rk4_step` is casadi's ``rk`` step written out, so that ``rk`` has a step map too.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from dataclasses import field as dc_field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._evaluator import DenseEvaluator
from workbench.core._feedback import feedback_function
from workbench.core._model import Model
from workbench.core.errors import SolverError
from workbench.simulation.integrators.common import controller_key

__all__ = ["Probe", "probe_for", "rk4_step", "RESTEP_CHUNK"]

RESTEP_CHUNK = 256
"""Steps evaluated per call when an output interval is stepped again to locate a failure
(:meth:`Probe.walk`)."""


def rk4_step(field: ca.Function, sym: type) -> ca.Function:
    """The classical RK4 step of ``x' = field(x, p)`` (casadi's ``rk``), ``(x, p, h) -> x+``.

    Parameters
    ----------
    field : casadi.Function
        ``(x, p) -> xdot`` (first output used).
    sym : type
        ``casadi.SX`` or ``casadi.MX``.

    Returns
    -------
    casadi.Function
    """
    x, p, h = sym.sym("x", field.nnz_in(0)), sym.sym("p", field.nnz_in(1)), sym.sym("h")

    def f(y: Any) -> Any:
        return field(y, p)[0] if field.n_out() > 1 else field(y, p)

    k1 = f(x)
    k2 = f(x + h / 2 * k1)
    k3 = f(x + h / 2 * k2)
    k4 = f(x + h * k3)
    return ca.Function("rk4_step", [x, p, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)],
                       ["x", "p", "h"], ["x_next"])


@dataclass
class Probe:
    """The functions the checks evaluate, for one model, controller, direction and step.

    Attributes
    ----------
    field : casadi.Function
        ``(x, p) -> (xdot, u)``: the closed-loop field in the direction of integration.
    field_jac : casadi.Function
        ``(x, p) -> A``, its ambient Jacobian (a property: built on first use from the
        model's ``f_x``, so a run whose checks pass without it does not build it).
    step : casadi.Function or None
        The step map ``(x, p, h) -> (x_next, ...)`` (None: none to linearise).
    rates : casadi.Function or None
        ``(x, p) -> (grad I . f, |grad I|, |f|)`` for every invariant (None: none).

    Notes
    -----
    The states between two outputs are not kept by the integrators; when a check fails
    between outputs, :meth:`walk` steps that interval again with the same step map (the
    same arithmetic as the run, up to round-off for casadi's ``rk``) to locate the failure.
    """

    field: ca.Function
    _jac_builder: Callable[[], ca.Function]
    step: ca.Function | None
    rates: ca.Function | None
    _field_jac: ca.Function | None = None
    _step_jac: ca.Function | None = None
    _maps: dict[tuple[str, int], DenseEvaluator] = dc_field(default_factory=dict)

    def mapped(self, name: str, k: int) -> DenseEvaluator:
        """An evaluator of ``field_jac`` or ``rates`` at ``k`` states in one call."""
        hit = self._maps.get((name, k))
        if hit is None:
            fn = getattr(self, name)  # the parameters are shared, not repeated
            hit = self._maps[(name, k)] = DenseEvaluator(
                fn.map(f"{fn.name()}_{k}", "serial", k, [1], []))
        return hit

    def walk(self, x: np.ndarray, p: np.ndarray, h: float, n: int
             ) -> Iterator[np.ndarray]:
        """The states after each of ``n`` steps from ``x``, chunk by chunk.

        Yields arrays of shape ``(m, ambient_dim)`` (``m <= RESTEP_CHUNK``) of consecutive
        states; stops after the chunk where a state is not finite.
        """
        if self.step is None:
            raise SolverError("no step map to re-step")  # a caller's defect
        ev = self._maps.get(("walk", RESTEP_CHUNK))
        if ev is None:
            xs, ps, hs = (ca.MX.sym(k, self.step.nnz_in(i)) for i, k in enumerate("xph"))
            out = self.step.mapaccum(f"{self.step.name()}_walk", RESTEP_CHUNK)(
                xs, ca.repmat(ps, 1, RESTEP_CHUNK), ca.repmat(hs, 1, RESTEP_CHUNK))
            X = out[0] if isinstance(out, (list, tuple)) else out
            ev = self._maps[("walk", RESTEP_CHUNK)] = DenseEvaluator(
                ca.Function("walk", [xs, ps, hs], [X]))
        done, cur = 0, np.asarray(x, dtype=float).ravel()
        while done < n:
            m = min(RESTEP_CHUNK, n - done)
            X = ev(cur, p, h)[0].T[:m]
            yield X
            if not np.all(np.isfinite(X)):
                return
            done, cur = done + m, X[-1]

    @property
    def field_jac(self) -> ca.Function:
        """``(x, p) -> A``: the closed-loop field's ambient Jacobian, built on first use."""
        if self._field_jac is None:
            self._field_jac = self._jac_builder()
        return self._field_jac

    @property
    def step_jac(self) -> ca.Function:
        """``(x, p, h) -> (x_next, J)``: the step and its ambient Jacobian.

        Built on first use: the derivative of an implicit step's unrolled Newton iteration
        takes a while to build.
        """
        if self._step_jac is None:
            if self.step is None:
                raise SolverError("no step map to linearise")  # a caller's defect
            self._step_jac = self.step.factory("step_jac", ["x", "p", "h"],
                                               ["x_next", "jac:x_next:x"])
        return self._step_jac


_PROBES: dict[tuple, tuple[Any, Probe]] = {}
_PROBES_MAX = 32  # entries kept; each holds the functions it is keyed by, so ids stay valid


def probe_for(model: Model, controller: ca.Function | None, *, sign: float = 1.0,
              step: ca.Function | None = None, rk4: bool = False) -> Probe:
    """The (cached) functions of the checks.

    Parameters
    ----------
    model : Model
        The model.
    controller : casadi.Function or None
        The feedback in the loop.
    sign : float
        ``+1`` forward, ``-1`` backward (the field is negated).
    step : casadi.Function, optional
        A geometric method's step ``(x, p, h) -> (x_next, ...)``.
    rk4 : bool
        Use the classical RK4 step of the signed field (casadi's ``rk``) as the step.

    Returns
    -------
    Probe
    """
    f = model.function("f")
    key = (id(f), controller_key(controller), float(sign), id(step), bool(rk4))
    hit = _PROBES.get(key)
    if hit is not None and hit[0][0] is f and hit[0][1] is step:
        return hit[1]
    S = model.sym
    x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
    u = feedback_function(model, controller)(x, p)
    xdot = sign * f(x, u, p)
    field = ca.Function("signed_loop", [x, p], [xdot, u], ["x", "p"], ["xdot", "u"])
    # the model's own Jacobians (a mechanics MX model supplies them: AD through its
    # linear solves is slower and fails where casadi's LU meets a structural zero)
    def field_jac() -> ca.Function:
        A = model.function("f_x")(x, u, p)
        if controller is not None and model.n_inputs:
            A = A + ca.mtimes(model.function("f_u")(x, u, p), ca.jacobian(u, x))
        return ca.Function("field_jac", [x, p], [ca.densify(sign * A)], ["x", "p"], ["A"])

    rates = None
    if model.invariant_names:
        grads = ca.jacobian(model.function("invariants")(x, p), x)  # (n_inv, n_x)
        rates = ca.Function("invariant_rates", [x, p],
                            [ca.mtimes(grads, xdot), ca.sqrt(ca.sum2(grads * grads)),
                             ca.norm_2(xdot)], ["x", "p"], ["rate", "grad_norm", "f_norm"])
    if rk4:
        step = rk4_step(field, S)
    probe = Probe(field, field_jac, step, rates)
    if len(_PROBES) >= _PROBES_MAX:
        _PROBES.pop(next(iter(_PROBES)))
    _PROBES[key] = ((f, step if not rk4 else None, controller), probe)
    return probe
