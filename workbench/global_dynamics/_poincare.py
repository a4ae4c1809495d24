"""Poincare sections with accurate event location, and finite-time Lyapunov exponents.

A :class:`Section` is a hypersurface ``{x : g(x) = 0}`` of a model's state space with an
optional side condition ``s(x) > 0`` and a crossing direction; ``g`` and ``s`` are written
as casadi expressions of the model's symbolic state, and the rate ``g-dot = dg/dx f(x)``
that event location needs comes from automatic differentiation of the model graph.

:func:`poincare_map` integrates an orbit with CVODES on a fine output grid (``sample_step``),
detects sign changes of ``g`` between samples, and refines each crossing by a safeguarded
Newton iteration on the crossing time ``tau`` (bisection when a step leaves the bracket),
each iterate ``x(tau)`` computed from the sample before the crossing by ``refine_substeps``
RK4 steps, a map that is smooth in ``tau`` (a re-started adaptive integrator is not: its
step sequence jumps with ``tau``, and Newton stalls at the 1e-10 noise that makes). The
refinement error is estimated by Richardson extrapolation against half the substeps.
Every crossing carries its event residual ``|g(x*)|``, that refinement error, the error of
an invariant (the energy, which restricts the orbit to an energy level), and the
transversality ``g-dot(x*)``; intervals
in which the cubic Hermite interpolant of ``g`` dips through zero without a sign change
at the samples (a pair of crossings that the grid may have missed) are counted.

Models stored in ambient coordinates (a TS^2 factor as 6 numbers) extend their vector
field off the manifold, and that extension may be unstable: the Lagrange-Routh field of
the 3D pendulum amplifies a constraint residual of 1e-16 to 1e-2 within 30 s on chaotic
orbits (parametric resonance of ``|q|^2 - 1`` and ``q . q-dot``). ``stabilization = k``
integrates ``f - k H^T (H H^T)^-1 h`` instead, ``h`` the manifold residual and ``H`` its
Jacobian (both from the graph): identical on the manifold, residuals decay at rate ``k``
off it. The default ``k = 0`` integrates the model as given and stops with a
:class:`~workbench.core.errors.SolverError` once the residual exceeds ``constraint_tol``.
Nothing is ever projected.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Evaluator, Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.status import Record, StatusEnum, StatusResult, raise_if
from workbench.core.types import ArrayLike
from workbench.core.validate import choice
from workbench.global_dynamics._sections import (
    Direction,
    Section,
    stabilized_field,
    turning_section,
    turning_section_state,
)
from workbench.simulation._cvodes import Multistep, cvodes_options

__all__ = [
    "Direction",
    "OrbitStatus",
    "OrbitCost",
    "Section",
    "turning_section",
    "turning_section_state",
    "stabilized_field",
    "PoincareOrbit",
    "poincare_map",
]


# CVODES' multistep family is the simulation's Multistep: Adams (with functional iteration
# here) is the efficient choice for these non-stiff Hamiltonian orbits (about 2.5x fewer
# steps than BDF at the same tolerance). (It was called Stepper here, a word the OCP uses
# for its one-step integrator.)


class OrbitStatus(StatusEnum):
    """How a Poincare orbit ended; the value is a readable message."""

    COMPLETE = "the requested number of crossings was reached"
    HORIZON = "t_max was reached before the requested number of crossings"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"COMPLETE"})


@dataclass(frozen=True)
class OrbitCost(Record):
    """What a Poincare orbit cost.

    Attributes
    ----------
    wall_seconds : float
        Integration and refinement.
    integrate_seconds, refine_seconds, build_seconds : float
        The main integration, the crossings' refinement, the functions' construction.
    steps, rhs_evaluations : int
        CVODES' steps and vector-field evaluations in the main integration.
    refinements : int
        Re-integrations while refining crossings.
    """

    wall_seconds: float
    integrate_seconds: float
    refine_seconds: float
    build_seconds: float
    steps: int
    rhs_evaluations: int
    refinements: int


# ----------------------------------------------------------------------------------------
# stabilised field and compiled functions


def _rk_flow(field_fn: ca.Function, xs: Any, ps: Any, tau: Any, n: int) -> ca.Function:
    """``(x, tau, p) -> x(tau)`` by ``n`` classical RK4 steps of ``tau / n`` (smooth in tau)."""
    x, h = xs, tau / n
    for _ in range(n):
        k1 = field_fn(x, ps)
        k2 = field_fn(x + 0.5 * h * k1, ps)
        k3 = field_fn(x + 0.5 * h * k2, ps)
        k4 = field_fn(x + h * k3, ps)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return ca.Function(f"rk4x{n}", [xs, tau, ps], [x], ["x", "tau", "p"], ["xf"])


def _event_function(model: Model, section: Section, field_fn: ca.Function) -> ca.Function:
    """``(x, p) -> [g, g-dot, s]`` with ``g-dot = dg/dx . field`` by AD."""
    ctx = model.context()
    g = section.event(ctx)
    if g.numel() != 1:
        raise ModelError(f"section {section.name!r}: event must be a scalar; got {g.shape}")
    s = section.side(ctx) if section.side is not None else model.sym(1.0)
    gdot = ca.jtimes(g, ctx.x, field_fn(ctx.x, ctx.p))
    return ca.Function("event", [ctx.x, ctx.p], [ca.vertcat(g, gdot, s)], ["x", "p"], ["gs"])


def _positive(name: str, value: float) -> float:
    """A positive finite number: :func:`workbench.core.validate.positive`."""
    return validate.positive(name, value)


# ----------------------------------------------------------------------------------------
# the orbit


@dataclass
class PoincareOrbit(StatusResult):
    """Section crossings of one orbit, with their accuracy and the cost.

    Attributes
    ----------
    model : str
        Name of the model.
    parameters : dict of str to ndarray
        The model's parameter values.
    section : str
        Name of the section.
    slices : dict of str to slice
        Where each state factor sits in a row of ``x``.
    x0 : ndarray, shape=(ambient_dim,)
        Initial state.
    t : ndarray, shape=(n,)
        Crossing times.
    x : ndarray, shape=(n, ambient_dim)
        States at the crossings.
    event_residual : ndarray, shape=(n,)
        ``|g(x*)|``.
    event_rate : ndarray, shape=(n,)
        ``g-dot(x*)`` (transversality: far from zero).
    invariant : str or None
        The invariant tracked.
    invariant_error : ndarray, shape=(n,)
        ``I(x*) - I(x0)``.
    refine_error : ndarray, shape=(n,)
        Richardson estimate ``|x*_n - x*_(n/2)| / (2^4 - 1)`` of the RK4 refinement error
        (``n = refine_substeps`` steps from the sample before the crossing); the orbit's
        own integration error adds to it.
    newton_iterations : ndarray of int, shape=(n,)
        Newton / bisection iterations spent refining each crossing.
    status : OrbitStatus
        How the orbit ended.
    t_end : float
        Time reached.
    options : dict
        Knobs as used.
    cost : OrbitCost
        ``wall_seconds``, ``build_seconds``, ``steps``, ``rhs_evaluations`` (main
        integration), ``refinements`` (re-integrations), ``refine_seconds`` (a typed
        record that also reads as a mapping).
    diagnostics : dict
        ``max_event_residual``, ``invariant_initial``, ``max_invariant_error``,
        ``max_refine_error``, ``max_relative_invariant_error`` (relative to ``max(1, |I0|)``),
        ``min_abs_event_rate``, ``max_constraint_residual`` (over all samples),
        ``suspect_intervals`` (possible missed crossing pairs), ``rejected_side``
        (sign changes with ``s <= 0``).
    """

    model: str
    parameters: dict[str, np.ndarray]
    section: str
    slices: dict[str, slice]
    x0: np.ndarray
    t: np.ndarray
    x: np.ndarray
    event_residual: np.ndarray
    event_rate: np.ndarray
    invariant: str | None
    invariant_error: np.ndarray
    refine_error: np.ndarray
    newton_iterations: np.ndarray
    status: OrbitStatus
    t_end: float
    options: dict[str, Any] = field(default_factory=dict)
    cost: OrbitCost | dict[str, Any] = field(default_factory=dict)
    diagnostics: dict[str, Any] = field(default_factory=dict)

    @property
    def n(self) -> int:
        """Number of crossings."""
        return int(len(self.t))

    def part(self, name: str) -> np.ndarray:
        """States of one factor at the crossings, shape ``(n, factor_ambient_dim)``."""
        if name not in self.slices:
            raise ModelError(f"unknown factor {name!r}; this orbit has {list(self.slices)}")
        return self.x[:, self.slices[name]]

    def summary(self) -> dict[str, Any]:
        """Plain account without the per-crossing arrays."""
        return {"model": self.model, "section": self.section, "n_crossings": self.n,
                "status": self.status.name, "t_end": self.t_end, "options": self.options,
                "cost": dict(self.cost), "diagnostics": self.diagnostics}


def _hermite_root(g0: float, d0: float, g1: float, d1: float, dt: float) -> float:
    """Root in (0, dt) of the cubic Hermite interpolant of g (Newton, else linear)."""
    lin = dt * g0 / (g0 - g1)
    th = lin / dt
    for _ in range(8):
        h00, h10 = 2 * th**3 - 3 * th**2 + 1, th**3 - 2 * th**2 + th
        h01, h11 = -2 * th**3 + 3 * th**2, th**3 - th**2
        val = h00 * g0 + h10 * dt * d0 + h01 * g1 + h11 * dt * d1
        der = ((6 * th**2 - 6 * th) * g0 + (3 * th**2 - 4 * th + 1) * dt * d0
               + (-6 * th**2 + 6 * th) * g1 + (3 * th**2 - 2 * th) * dt * d1)
        if der == 0:
            break
        th -= val / der
    return th * dt if 0.0 < th < 1.0 else lin


def _hermite_dips(G: np.ndarray, dt: float) -> np.ndarray:
    """Intervals whose ends have the same sign of g but whose Hermite cubic changes sign.

    ``G`` holds rows ``(g, g-dot, ...)`` at consecutive samples; returns a boolean mask
    over the ``len(G) - 1`` intervals.
    """
    g0, d0, g1, d1 = G[:-1, 0], G[:-1, 1] * dt, G[1:, 0], G[1:, 1] * dt
    same = np.sign(g0) == np.sign(g1)
    if not np.any(same):
        return same
    th = np.linspace(0.0, 1.0, 17)[1:-1, None]
    h = ((2 * th**3 - 3 * th**2 + 1) * g0[same] + (th**3 - 2 * th**2 + th) * d0[same]
         + (-2 * th**3 + 3 * th**2) * g1[same] + (th**3 - th**2) * d1[same])
    out = np.zeros_like(same)
    out[same] = np.any(np.sign(h) != np.sign(g0[same]), axis=0)
    return out


@validate.arguments(
    model=validate.instance(Model, "a workbench Model"), n_crossings=validate.count,
    t_max=validate.positive, rtol=validate.tolerance, atol=validate.tolerance,
    constraint_tol=validate.tolerance, time_tol=validate.tolerance
)
def poincare_map(
    model: Model,
    x0: ArrayLike,
    section: Section,
    *,
    n_crossings: int,
    t_max: float,
    sample_step: float = 0.01,
    chunk: float = 25.0,
    rtol: float = 1e-10,
    atol: float = 1e-10,
    multistep: Multistep = Multistep.ADAMS,
    stabilization: float = 0.0,
    constraint_tol: float = 1e-6,
    refine_substeps: int = 16,
    time_tol: float = 1e-14,
    max_newton: int = 40,
    invariant: str | None = "energy",
    max_steps: int = 1_000_000,
    raise_on_failure: bool = True,
) -> PoincareOrbit:
    """Integrate an orbit and locate its crossings of a section accurately.

    Parameters
    ----------
    model : Model
        An autonomous model (inputs are set to zero).
    x0 : array-like, shape=(ambient_dim,)
        Initial state, on the manifold to 1e-9 (never projected).
    section : Section
        The section.
    n_crossings : int
        Stop after this many crossings.
    t_max : float
        Stop at this time at the latest (status ``HORIZON``).
    sample_step : float
        Output grid on which sign changes of ``g`` are detected; it must be well below
        the shortest time between two crossings (see ``suspect_intervals``).
    chunk : float
        Length of one integrator call; the constraint residual is checked after each.
    rtol, atol : float
        CVODES tolerances, for the orbit and the refining re-integrations alike.
    multistep : Multistep
        CVODES method family (Adams by default: about 2.5x fewer steps than BDF on these
        non-stiff Hamiltonian orbits).
    stabilization : float
        Gain ``k`` of the constraint-stabilised field (see the module notes); 0 for the
        model's own field.
    constraint_tol : float
        Largest manifold residual accepted along the orbit.
    refine_substeps : int
        RK4 steps from the sample before a crossing to the crossing.
    time_tol : float
        Newton on the crossing time stops when the step is below this [s].
    max_newton : int
        Most Newton / bisection iterations per crossing.
    invariant : str or None
        Invariant whose error is reported at each crossing (the energy level).
    max_steps : int
        CVODES' limit on steps per output interval.
    raise_on_failure : bool
        Raise when the orbit ends at ``t_max`` before ``n_crossings`` (status HORIZON);
        ``False`` returns the crossings found with that status.

    Returns
    -------
    PoincareOrbit

    Raises
    ------
    SolverError
        If the integrator fails, the constraint residual exceeds ``constraint_tol``, or a
        crossing cannot be refined; or (``raise_on_failure``) the status is HORIZON.
    """
    if not isinstance(section, Section):
        raise ModelError(f"section must be a Section; got {type(section).__name__}")
    if not isinstance(n_crossings, (int, np.integer)) or n_crossings < 1:
        raise ParameterError(f"n_crossings must be an integer >= 1; got {n_crossings!r}")
    t_max, sample_step, chunk = (_positive(n, v) for n, v in
                                 (("t_max", t_max), ("sample_step", sample_step),
                                  ("chunk", chunk)))
    rtol, atol, time_tol, constraint_tol = (
        _positive(n, v) for n, v in (("rtol", rtol), ("atol", atol), ("time_tol", time_tol),
                                     ("constraint_tol", constraint_tol)))
    if chunk < sample_step:
        raise ParameterError(f"chunk must be at least sample_step = {sample_step}; got {chunk}")
    multistep = choice(Multistep, multistep, "multistep")
    if not isinstance(refine_substeps, (int, np.integer)) or refine_substeps < 1:
        raise ParameterError(f"refine_substeps must be an integer >= 1; got {refine_substeps!r}")
    if invariant is not None and invariant not in model.invariant_names:
        raise ModelError(f"model {model.name!r} has no invariant {invariant!r}; known: "
                         f"{model.invariant_names}")
    xc = model.check_state(x0, name="x0")
    p = model.p
    n_per = int(round(chunk / sample_step))
    dt = chunk / n_per

    tb = time.perf_counter()
    field_fn = stabilized_field(model, gain=stabilization)
    ev_fn = _event_function(model, section, field_fn)
    ev_map = ev_fn.map(n_per + 1)
    S = model.sym
    xs, ps, tau = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params), S.sym("tau")
    opts = cvodes_options(multistep=multistep, rtol=rtol, atol=atol, max_steps=max_steps,
                          error=ParameterError)
    grid = dt * np.arange(1, n_per + 1)
    orbit_int = ca.integrator("orbit", "cvodes", {"x": xs, "p": ps, "ode": field_fn(xs, ps)},
                              0.0, grid, opts)
    flow_ev = Evaluator(_rk_flow(field_fn, xs, ps, tau, refine_substeps))
    half = max(1, refine_substeps // 2)
    check_ev = Evaluator(_rk_flow(field_fn, xs, ps, tau, half))
    richardson = 1.0 / ((refine_substeps / half) ** 4 - 1.0)
    ev1 = Evaluator(ev_fn)
    residual = ca.Function("h", [xs], [model.manifold.residual(xs)]).map(n_per)
    inv_fn = model.function(invariant) if invariant is not None else None
    build = time.perf_counter() - tb

    def flow_to(x: np.ndarray, dtau: float) -> np.ndarray:
        return flow_ev(x, dtau, p)  # type: ignore[return-value]

    ts, xs_out, res_, rate, iters, ref_err = [], [], [], [], [], []
    steps = fevals = refinements = suspect = rejected = 0
    max_h = float(np.max(np.abs(model.manifold.residual(xc)))) if model.manifold.residual(
        xc).size else 0.0
    tc, wall, refine_wall = 0.0, 0.0, 0.0
    status = OrbitStatus.HORIZON
    while len(ts) < n_crossings and tc < t_max - 1e-12:
        t0 = time.perf_counter()
        try:
            X = np.asarray(orbit_int(x0=xc, p=p)["xf"]).T
        except RuntimeError as exc:
            st = orbit_int.stats()
            raise SolverError(
                f"cvodes failed on the orbit of {model.name} after t = {tc:g}: "
                f"{str(exc).splitlines()[-1]}", status=str(st.get("return_status", "")),
            ) from exc
        st = orbit_int.stats()
        steps += int(st.get("nsteps", 0))
        fevals += int(st.get("nfevals", 0))
        wall += time.perf_counter() - t0
        h = np.abs(np.asarray(residual(X.T)))
        max_h = max(max_h, float(h.max()) if h.size else 0.0)
        if not np.all(np.isfinite(X)) or max_h > constraint_tol:
            raise SolverError(
                f"constraint residual of {model.name} reached {max_h:.3g} > constraint_tol = "
                f"{constraint_tol:g} between t = {tc:g} and {tc + chunk:g}: the model's "
                f"ambient extension drifts off the manifold; pass stabilization = k > 0 "
                f"(e.g. 10) to integrate the constraint-stabilised field", status="drift")
        samples = np.vstack([xc, X])
        G = np.asarray(ev_map(samples.T, p)).T  # rows: g, gdot, s
        t_ref = time.perf_counter()
        suspect += int(np.count_nonzero(_hermite_dips(G, dt)))
        up = (G[:-1, 0] < 0) & (G[1:, 0] >= 0)
        down = (G[:-1, 0] > 0) & (G[1:, 0] <= 0)
        wanted = {Direction.BOTH: up | down, Direction.INCREASING: up,
                  Direction.DECREASING: down}[section.direction]
        for i in np.flatnonzero(wanted):
            tau_, x_star, k, gd = _refine(flow_to, ev1, p, samples[i], G[i], G[i + 1], dt,
                                          time_tol, max_newton, tc + i * dt)
            refinements += k
            if gd is None or gd[2] <= 0:
                rejected += 1
                continue
            ts.append(tc + i * dt + tau_)
            xs_out.append(x_star)
            res_.append(abs(gd[0]))
            rate.append(gd[1])
            iters.append(k)
            ref_err.append(richardson * float(np.max(np.abs(check_ev(samples[i], tau_, p)
                                                            - x_star))))
            if len(ts) == n_crossings:
                status = OrbitStatus.COMPLETE
                break
        refine_wall += time.perf_counter() - t_ref
        xc, tc = X[-1], tc + chunk
    t_end = ts[-1] if status is OrbitStatus.COMPLETE else tc
    x_arr = np.array(xs_out).reshape(-1, model.manifold.ambient_dim)
    if inv_fn is not None:
        I0 = float(inv_fn(model.check_state(x0), p))
        err = (np.asarray(inv_fn.map(len(x_arr))(x_arr.T, p)).ravel() - I0 if len(x_arr)
               else np.zeros(0))
    else:
        I0, err = float("nan"), np.zeros(len(x_arr))
    diag = {
        "max_event_residual": float(max(res_, default=0.0)),
        "max_refine_error": float(max(ref_err, default=0.0)),
        "invariant_initial": I0,
        "max_invariant_error": float(np.max(np.abs(err), initial=0.0)),
        "max_relative_invariant_error": float(np.max(np.abs(err), initial=0.0)
                                              / max(1.0, abs(I0)) if inv_fn else np.nan),
        "min_abs_event_rate": float(np.min(np.abs(rate), initial=np.inf)),
        "max_constraint_residual": max_h,
        "suspect_intervals": suspect,
        "rejected_side": rejected,
    }
    orbit = PoincareOrbit(
        model=model.name, parameters={k: v.copy() for k, v in model.values.items()},
        section=section.name, slices=dict(model.manifold.slices),
        x0=model.check_state(x0), t=np.array(ts), x=x_arr, event_residual=np.array(res_),
        event_rate=np.array(rate), invariant=invariant, invariant_error=err,
        refine_error=np.array(ref_err), newton_iterations=np.array(iters, dtype=int),
        status=status, t_end=float(t_end),
        options={"sample_step": dt, "chunk": chunk, "rtol": rtol, "atol": atol,
                 "multistep": multistep.value, "stabilization": stabilization,
                 "refine_substeps": int(refine_substeps), "time_tol": time_tol,
                 "n_crossings": int(n_crossings), "t_max": t_max},
        cost=OrbitCost(wall_seconds=wall + refine_wall, integrate_seconds=wall,
                       refine_seconds=refine_wall, build_seconds=build, steps=steps,
                       rhs_evaluations=fevals, refinements=refinements),
        diagnostics=diag,
    )
    return raise_if(orbit, raise_on_failure)


def _refine(
    flow_to: Callable[[np.ndarray, float], np.ndarray], ev1: Evaluator, p: np.ndarray,
    xa: np.ndarray, Ga: np.ndarray, Gb: np.ndarray, dt: float, time_tol: float,
    max_newton: int, t_a: float,
) -> tuple[float, np.ndarray, int, np.ndarray]:
    """Safeguarded Newton on the crossing time in (0, dt), re-integrating from ``xa``.

    Returns ``(tau, x, iterations, [g, g-dot, s])``, the last ``None`` when the side
    function is negative by a margin no remaining Newton step can close.
    """
    lo, hi = 0.0, dt
    glo = Ga[0]
    tau = _hermite_root(Ga[0], Ga[1], Gb[0], Gb[1], dt)
    side_rate = abs(Gb[2] - Ga[2]) / dt  # size of s-dot over the interval
    for k in range(1, max_newton + 1):
        x = flow_to(xa, tau)
        gd = ev1(x, p)
        g, gdot = gd[0], gd[1]
        if g == 0.0:
            return tau, x, k, gd
        if gd[2] < 0 and abs(gd[2]) > 10 * side_rate * (abs(g / gdot) + time_tol):
            return tau, x, k, None  # s < 0 at the crossing however the last step goes
        if np.sign(g) == np.sign(glo):
            lo, glo = tau, g
        else:
            hi = tau
        step = -g / gdot if gdot != 0 else np.inf
        if abs(step) < time_tol:
            return tau, x, k, gd
        new = tau + step
        if not (lo < new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - tau) < time_tol or hi - lo < time_tol:
            return tau, x, k, gd
        tau = new
    raise SolverError(
        f"crossing after t = {t_a:.12g} not refined to {time_tol:g} s in {max_newton} "
        f"re-integrations (bracket width {hi - lo:.3g} s)", status="newton")
