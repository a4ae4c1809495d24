"""An energy-pumping feedback, simulated: the default strategy's start for weak inputs.

Where the inputs cannot follow a direct path to the target (a 0.01 N m motor lifting a
pendulum), the start that works is a trajectory of the model that gains the target's
energy swing by swing. :func:`energy_pumping` simulates one, with a feedback built from the
model's ``energy`` invariant and its field alone (Astrom and Furuta's law, generalised):
the energy ``E_p`` of the factors to invert is raised to its value at the target, the
energy the other factors carry (an arm set spinning, a cart set running) is taken out.
Everything it needs is read off the model: the factors to invert and the kinematics from
:mod:`workbench.control.ocp.initial`, the rates of both energies by automatic
differentiation.
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from workbench.control.ocp.expand import sx_function
from workbench.control.ocp.guess import Guess
from workbench.control.ocp.initial import (
    Structure,
    StructuredGuess,
    _turns,
    controllable_axes,
    natural_frequency,
    structure,
)
from workbench.control.ocp.local import ProductLocal
from workbench.control.ocp.problem import OCP
from workbench.core import validate
from workbench.core._evaluator import Evaluator, evaluate_rows
from workbench.core.errors import ManifoldError, SolverError

__all__ = ["energy_pumping", "target_gap", "target_gaps"]

PUMP_LAWS = ((20.0, 0.0, 0.0), (20.0, 0.2, 0.0), (20.0, 0.0, 0.5), (20.0, 0.2, 0.5))
"""``(kappa, overshoot, brake)`` of the pumping laws tried, in order (see
:func:`energy_pumping`); the one that comes closest to the target is kept."""

PUMP_SHARPNESS = 0.05
"""``beta_i`` of the pumping law, as a fraction of the largest ``|b_i|`` seen so far."""

MAX_PUMP_SAMPLES = 5_000
"""At most this many held samples per pumping law (each is a CVODES step; four laws)."""

PUMP_SAMPLES_PER_PERIOD = 20
"""At least this many held samples per period of the pumped factors' oscillation at x0."""

STOP_PERIODS = 3
"""A refined run (see :func:`_resolution`) stops when its closest approach to the target
lies this many periods back."""

KICK_SAMPLES = 1
"""Samples at the upper input bounds that start the pumping (at rest ``b = 0``)."""


def _pumped_energy(ocp: OCP, st: Structure, pumped: list[str]) -> tuple[Evaluator, ...]:
    """``E_p``, ``b = d(dE_p/dt)/du``, ``E_o = E - E_p`` and ``b_o = d(dE_o/dt)/du``.

    ``E_p`` is the model's energy with the velocities of the other factors set to zero: for
    a pendulum on a cart, the pendulum's energy with the cart at rest (Astrom and Furuta's
    pumping law uses exactly this one); for the Furuta pendulum, the link's with the arm at
    rest. ``E_o`` is what the other factors' velocities add. Both rates are affine in the
    input, ``dE/dt = a(x) + b(x) . u``. Each comes as an :class:`Evaluator` (the pumping
    calls them at every sample).
    """
    model = ocp.model
    man = model.manifold
    rows = {int(r): i for i, r in enumerate(st.config)}
    keep = set()  # the velocities the pumped factors' kinematics depends on, at any state
    for name in pumped:
        for r in range(man.slices[name].start, man.slices[name].stop):
            if r in rows:
                keep |= {int(st.velocity[j]) for j in np.flatnonzero(st.pattern[rows[r]])}
    nx = man.ambient_dim
    x, u = ca.SX.sym("x", nx), ca.SX.sym("u", model.n_inputs)
    p = ca.SX.sym("p", model.n_params)
    mask = ca.DM([0.0 if (j in st.velocity and j not in keep) else 1.0 for j in range(nx)])
    energy = sx_function(model.function("energy"), spd=model.spd_solves)
    Ep = energy(x * mask, p)
    Eo = energy(x, p) - Ep
    f = sx_function(model.function("f"), spd=model.spd_solves)
    zero = ca.DM.zeros(model.n_inputs)
    b, bo = (ca.substitute(ca.jacobian(ca.dot(ca.gradient(E, x), f(x, u, p)), u), u, zero)
             for E in (Ep, Eo))
    return tuple(Evaluator(ca.Function(name, [x, p], [e])) for name, e in (
        ("Ep", Ep), ("b", b), ("Eo", Eo), ("bo", bo)))


def target_gap(ocp: OCP, x: np.ndarray) -> float:
    """``max |chart|`` of the target at ``x``, or ``1 + overshoot`` outside the chart's domain.

    The chart of an antipodal point vanishes at the antipode too (``q* x q = 0`` at
    ``q = -q*``): where the domain inequalities fail the point is counted as far.
    """
    return float(target_gaps(ocp, np.reshape(np.asarray(x, float), (1, -1)))[0])


def _gap_function(ocp: OCP) -> ca.Function:
    """``x -> (chart of the target at x, its domain inequalities)``."""
    x = ca.SX.sym("x", ocp.model.manifold.ambient_dim)
    dom = ocp.target.domain(x)
    return ca.Function("target_gap", [x], [ocp.target.equations(x),
                                           ca.vertcat(*dom) if dom else ca.SX(0, 1)])


def target_gaps(ocp: OCP, X: np.ndarray, *, fn: ca.Function | None = None) -> np.ndarray:
    """:func:`target_gap` at every row of ``X``, shape ``(n,)``.

    One casadi function of the target's chart and its domain (``fn``, built here unless
    the caller passes the one it built for the same OCP), evaluated over all rows at once
    (a pumping run has thousands of samples).
    """
    eq, d = evaluate_rows(_gap_function(ocp) if fn is None else fn, X)
    far = d.shape[1] > 0 and np.min(d, axis=1, initial=np.inf) < 0
    return np.where(far, 1.0 - np.min(d, axis=1, initial=0.0),
                    np.max(np.abs(eq), axis=1, initial=0.0))


def _pump(ocp: OCP, law: tuple[float, float, float], fns: tuple[Evaluator, ...],
          stepper: Any, samples: int, gaps: Any, window: int | None
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Simulate one pumping law with held samples: states, controls, target gaps, early.

    With ``window``, the run stops (``early``) once its closest approach to the target
    (after the shortest allowed horizon of a free final time) lies ``window`` samples back.
    """
    kappa, over, brake = law
    Ep, b_of, Eo, bo_of = fns
    model, p = ocp.model, ocp.model.p
    E_star, E0 = float(Ep(ocp.target.witness, p)[0]), float(Ep(ocp.x0, p)[0])
    dE = abs(E_star - E0)
    mid, half = 0.5 * (ocp.u_upper + ocp.u_lower), 0.5 * (ocp.u_upper - ocp.u_lower)
    h = ocp.T_range[1] / samples
    X, U, gap = [ocp.x0], [], np.zeros(0)
    bmax, bomax = np.zeros(model.n_inputs), np.zeros(model.n_inputs)
    x = ocp.x0
    for i in range(samples):
        b = np.asarray(b_of(x, p), float).ravel()
        bo = np.asarray(bo_of(x, p), float).ravel()
        bmax, bomax = np.maximum(bmax, np.abs(b)), np.maximum(bomax, np.abs(bo))
        if i < KICK_SAMPLES:
            u = ocp.u_upper.copy()
        else:
            e = (E_star + over * dE - float(Ep(x, p)[0])) / dE
            pump = np.tanh(kappa * e) * np.tanh(b / np.maximum(PUMP_SHARPNESS * bmax, 1e-300))
            take = np.tanh(kappa * float(Eo(x, p)[0]) / dE) * np.tanh(
                bo / np.maximum(PUMP_SHARPNESS * bomax, 1e-300))
            u = mid + half * np.clip(pump - brake * take, -1.0, 1.0)
        try:  # projected after each step (the projection method): the guess's states are
            x = model.manifold.project(stepper.step(x, u, h))  # on the manifold exactly
        except (SolverError, ManifoldError):
            break
        U.append(u)
        X.append(x)
        if window and len(X) % window == 0:
            gap = np.concatenate([gap, gaps(np.array(X[len(gap):]))])
            lo = ocp.T_range[0] if ocp.free_time else 0.0  # a fixed T rests first
            ok = np.flatnonzero(h * np.arange(len(gap)) >= lo - 1e-12)
            if ok.size and len(gap) - 1 - ok[np.argmin(gap[ok])] >= window:
                return np.array(X), np.array(U), gap, True
    X_ = np.array(X)
    return X_, np.array(U), np.concatenate([gap, gaps(X_[len(gap):])]), False


def _resolution(ocp: OCP, samples: int, pumped: list[str], may_stop: bool
                ) -> tuple[int, int | None]:
    """Held samples over the longest horizon, and the early-stop window (None: no stop).

    ``samples`` over ``T_range[1]`` unless that holds fewer than
    :data:`PUMP_SAMPLES_PER_PERIOD` per period of the pumped factors' oscillation at
    ``x0`` (:func:`~workbench.control.ocp.initial.natural_frequency`): a law held over a
    good part of a swing cannot pump it (400 samples over 100 s hold each for 0.25 s,
    against the spherical cart's 0.58 s period). Then the samples are that many per
    period (at most :data:`MAX_PUMP_SAMPLES`), and, where the guess may end before the
    longest horizon (a free final time, or a fixed one reached by resting at ``x0``
    first), each law's run stops once its closest approach lies :data:`STOP_PERIODS`
    periods back.
    """
    omega = natural_frequency(ocp, pumped)
    if omega is None or not omega > 0:
        return samples, None
    need = math.ceil(ocp.T_range[1] * omega / (2 * np.pi) * PUMP_SAMPLES_PER_PERIOD)
    if need <= samples:
        return samples, None
    return min(need, MAX_PUMP_SAMPLES), (STOP_PERIODS * PUMP_SAMPLES_PER_PERIOD
                                         if may_stop else None)


def energy_pumping(ocp: OCP, *, samples: int = 400,
                   axes: dict[str, np.ndarray] | None = None) -> StructuredGuess | None:
    """A guess simulated with an energy-pumping feedback; ``None`` where none applies.

    The law raises the energy ``E_p`` of the factors to invert (see :func:`_pumped_energy`)
    to its value ``E*`` at the target's witness (plus an overshoot), and takes out the
    energy ``E_o`` the other factors' velocities carry (an arm or a cart set spinning or
    running by the pumping),

        u_i = mid_i + half_i clip(tanh(kappa e) tanh(b_i / beta_i)
                                  - brake tanh(kappa E_o / dE) tanh(b_oi / beta_oi), -1, 1),

    ``e = (E* + overshoot dE - E_p) / dE``, ``dE = |E* - E_p(x0)|``, with ``half_i`` the
    half-range of the bounds (:data:`PUMP_LAWS`, :data:`PUMP_SHARPNESS`), after a kick at
    the upper bounds for :data:`KICK_SAMPLES` samples (at rest ``b = 0``). It is held
    constant over each of ``samples`` intervals of the longest allowed horizon and
    integrated by CVODES, each step's end projected onto the manifold (the projection
    method), so the guess is a trajectory of the model under admissible controls. For each
    law a free final time ends where the factors to invert come closest to the target
    (:func:`target_gap`); with a fixed final time and ``x0`` an equilibrium (``u = 0``), the
    guess rests at ``x0`` first, so that the closest approach falls at ``T`` (resting there
    is a trajectory too). Of the laws tried, the one that comes closest is kept.
    It applies to models with an ``energy`` invariant, the
    second-order structure, finite input bounds and a factor to invert.

    Parameters
    ----------
    ocp : OCP
        The problem.
    samples : int
        Held samples over the longest allowed horizon (at most :data:`MAX_PUMP_SAMPLES`);
        more where they would hold fewer than :data:`PUMP_SAMPLES_PER_PERIOD` per period
        of the oscillation to pump (see :func:`_resolution`).
    axes : dict, optional
        The controllable axes by factor name, as :func:`controllable_axes` gives them
        (default: computed here; the strategy passes the ones it already has).

    Returns
    -------
    StructuredGuess or None
    """
    from workbench.control.ocp.stepper import Stepper

    samples = validate.count("samples", samples, minimum=2, maximum=MAX_PUMP_SAMPLES)
    model = ocp.model
    st = structure(model)
    finite = np.all(np.isfinite(ocp.u_lower) & np.isfinite(ocp.u_upper))
    if st is None or "energy" not in model.invariant_names or not finite:
        return None
    if axes is None:
        axes, _ = controllable_axes(ocp)
    turns = _turns(ocp, {k: np.asarray(v, float) for k, v in axes.items()}, 1.0)
    pumped = [t.name for t in turns if t.pumped]
    if not pumped:
        return None
    fns = _pumped_energy(ocp, st, pumped)
    p = model.p
    E_star, E0 = float(fns[0](ocp.target.witness, p)[0]), float(fns[0](ocp.x0, p)[0])
    if not abs(E_star - E0) > 1e-12 * max(1.0, abs(E_star)):
        return None
    man = model.manifold
    idx = np.concatenate([np.arange(man.slices[n].start, man.slices[n].stop) for n in pumped])
    stepper = Stepper(model, rtol=1e-8, atol=1e-8)
    f0 = np.asarray(model.function("f")(ocp.x0, np.zeros(model.n_inputs), p), float).ravel()
    at_rest = bool(np.max(np.abs(f0)) <= 1e-9 * max(1.0, float(np.max(np.abs(ocp.x0)))))
    samples, window = _resolution(ocp, samples, pumped, ocp.free_time or at_rest)
    h = ocp.T_range[1] / samples

    gap_fn = _gap_function(ocp)

    def gaps(X: np.ndarray) -> np.ndarray:  # the pumped factors' gap to the target
        probe = np.tile(ocp.target.witness, (len(X), 1))
        probe[:, idx] = X[:, idx]
        return target_gaps(ocp, probe, fn=gap_fn)

    runs = []
    for law in PUMP_LAWS:
        X, U, gap, early = _pump(ocp, law, fns, stepper, samples, gaps, window)
        t = h * np.arange(len(X))
        if ocp.free_time:
            ok = np.flatnonzero(t >= ocp.T_range[0] - 1e-12)
            if not ok.size:
                continue
            k = int(ok[np.argmin(gap[ok])])
            runs.append((float(gap[k]), law, X[: k + 1], U[:k], float(t[k])))
        elif len(X) == samples + 1 or early:
            k = int(np.argmin(gap)) if at_rest else samples
            rest = samples - k  # rest at x0 first, so that the closest approach falls at T
            runs.append((float(gap[k]), law,
                         np.vstack([np.tile(ocp.x0, (rest, 1)), X[: k + 1]]),
                         np.vstack([np.zeros((rest, model.n_inputs)), U[:k]]),
                         float(h * samples)))
        # else: the fixed horizon was not reached
    if not runs:
        return None
    gap, law, X, U, T = min(runs, key=lambda r: r[0])  # the run that comes closest
    guess = Guess(np.linspace(0.0, 1.0, len(X)), X, U, T, ProductLocal(man))
    return StructuredGuess(
        "energy pumping", guess,
        f"feedback pumping the energy of {', '.join(pumped)} from {E0:.4g} to {E_star:.4g} "
        f"(kappa, overshoot, brake = {law}; {samples} held samples over "
        f"{ocp.T_range[1]:.3g} s); T = {T:.3g} s, where they come closest to the target "
        f"(chart gap {gap:.2e})")
