"""Whether a fixed-step run is stable: the linearised step against the exact flow.

A fixed-step method beyond its stability range amplifies some mode of the flow by more
than the flow does, every step, and its states grow without bound (RK4 on ``x'' = -w^2 x``
with ``h w = 3``: by ``|R(3i)| = 1.8`` per step). :func:`check_fixed_step` tells such a run
from a legitimate one, and :func:`unstable_error` says why and for which step:

* **Stability estimate** (every fixed-step method with a step map: ``rk``, ``rkmk4``,
  ``lgvi``, ``s2_variational``, ``mechanics_variational``). At a few output states (the
  start, evenly spaced ones, the largest state and the fastest) the step map is
  linearised, ``J = d Phi_h / dx`` (automatic derivative of the step's graph; in tangent
  coordinates for the methods that stay on the manifold, ambient for ``rk``, which
  integrates the ambient equations), and so is the closed-loop field, ``A = df/dx`` (with
  the controller; the same coordinates). The run is unstable there when the spectral
  radius of ``J`` exceeds what the exact flow allows, ``max(1, exp(h alpha))`` with
  ``alpha = max Re lambda(A)``, by more than the margins of the estimate: a factor
  :data:`STABILITY_RTOL`; the change of the linearisation over the step,
  ``exp(h |A(x_next) - A(x)|_2)`` (zero for a linear field, so the estimate is exact
  there; off an equilibrium the frozen-coefficient estimate is off by about that much);
  and, for the modes that grow in the flow itself (``Re lambda > 0``), the method's own
  error there, ``2 (h |lambda|)^(p+1) / (p+1)!`` (``p`` its order). Damping
  (``alpha < 0``) and forcing (a controller) enter through ``A`` and ``J`` alike, so
  neither is mistaken for instability. The stable step is estimated by bisection on ``h``
  of the same test.
  Collocation (Gauss-Legendre, A-stable: ``|R(z)| <= 1`` for ``Re z <= 0``) has no such
  range; it is checked by the next test only.
* **Invariant drift.** An invariant that the closed-loop field conserves at every checked
  state (``|grad I . f| <= CONSERVED_RTOL |grad I| |f|``: no controller that works on it,
  no dissipation, no load) must not drift by more than :data:`DRIFT_LIMIT` times its
  scale ``max(|I(x0)|, |grad I(x0)| |x0|)``. A dissipated or forced invariant is not
  checked.

The linearised step at a state off an equilibrium is the frozen-coefficient estimate of
the usual stability analysis: exact for linear fields, a close estimate for the smooth
fields of mechanics; a mode the flow itself amplifies fast (a large ``alpha`` from an
unstable equilibrium) can hide a slightly unstable fast mode behind it, but not an
exploding one (that explodes the state, and the largest state is checked).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._feedback import feedback_function
from workbench.core._model import Model
from workbench.core.errors import SolverError
from workbench.core.status import StatusEnum
from workbench.simulation.integrators.common import controller_key

__all__ = [
    "StepStability",
    "StabilityFinding",
    "STABILITY_RTOL",
    "DRIFT_LIMIT",
    "CONSERVED_RTOL",
    "SAMPLES",
    "RK4_IMAGINARY",
    "RK4_REAL",
    "Probe",
    "probe_for",
    "rk4_step",
    "check_fixed_step",
    "find_unstable",
    "unstable_error",
]

STABILITY_RTOL = 1e-6
"""Accepted excess of the linearised step's spectral radius over the exact flow's growth
per step (``1 + 1e-6`` per step is a factor ``e`` after a million steps)."""

DRIFT_LIMIT = 10.0
"""Largest accepted change of a conserved invariant, in multiples of its scale."""

CONSERVED_RTOL = 1e-8
"""``|grad I . f| <= CONSERVED_RTOL |grad I| |f|`` at every checked state: the closed-loop
field conserves ``I`` (round-off is ~1e-16 of the terms)."""

SAMPLES = 8
"""Evenly spaced output states checked, besides the start, the largest and the fastest."""

RK4_IMAGINARY = 2.0 * math.sqrt(2.0)
"""RK4's stability interval on the imaginary axis: ``|R(iy)| <= 1`` for ``|y| <= 2 sqrt 2``."""

RK4_REAL = 2.785293563405282
"""RK4's stability interval on the negative real axis (root of ``R(-x) = 1``)."""

_INTERVALS = {
    "rk": f"RK4 is stable for h |lambda| <= {RK4_IMAGINARY:.3g} on the imaginary axis and "
          f"<= {RK4_REAL:.3g} on the negative real axis",
    "rkmk4": f"RKMK4 is RK4 in the group's coordinates: stable for h |lambda| <= "
             f"{RK4_IMAGINARY:.3g} on the imaginary axis and <= {RK4_REAL:.3g} on the negative "
             f"real axis",
    "variational": "the variational step is, like Stormer-Verlet, stable for h omega < 2 "
                   "on an undamped oscillation of frequency omega",
}
_IMAGINARY = {"rk": RK4_IMAGINARY, "rkmk4": RK4_IMAGINARY, "variational": 2.0}


class StepStability(StatusEnum):
    """Outcome of the checks of a fixed-step run (the ``status`` of its SolverError)."""

    STABLE = "the linearised step stays within the flow's growth and conserved invariants stay"
    UNSTABLE_STEP = "the step is beyond the method's stable range: the run has exploded"
    INVARIANT_DRIFT = "a conserved invariant drifted by orders of magnitude"
    NON_FINITE_FIELD = "the field or the controller returned NaN or inf"

    @classmethod
    def successes(cls) -> frozenset[str]:
        """Only ``STABLE``."""
        return frozenset({"STABLE"})


@dataclass(frozen=True)
class StabilityFinding:
    """The stability estimate at one state.

    Attributes
    ----------
    index : int
        Output index of the state.
    amplification : float
        Spectral radius of the linearised step (``inf`` when it is not finite).
    flow_growth : float
        ``max(1, exp(h alpha))``: what the exact linearised flow allows per step.
    bound : float
        The accepted amplification (``flow_growth`` with the margins).
    spectral_radius : float
        ``max |lambda|`` of the linearised field.
    stable : bool
        ``amplification <= bound``.
    """

    index: int
    amplification: float
    flow_growth: float
    bound: float
    spectral_radius: float
    stable: bool


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
        ``(x, p) -> A``, its ambient Jacobian.
    step_jac : casadi.Function or None
        ``(x, p, h) -> (x_next, J)``, the step map and its ambient Jacobian (None: no step
        map).
    rates : casadi.Function or None
        ``(x, p) -> (grad I . f, |grad I|, |f|)`` for every invariant (None: none).
    """

    field: ca.Function
    field_jac: ca.Function
    step_jac: ca.Function | None
    rates: ca.Function | None


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
    field_jac = ca.Function("field_jac", [x, p], [ca.jacobian(xdot, x)], ["x", "p"], ["A"])
    rates = None
    if model.invariant_names:
        grads = ca.jacobian(model.function("invariants")(x, p), x)  # (n_inv, n_x)
        rates = ca.Function("invariant_rates", [x, p],
                            [ca.mtimes(grads, xdot), ca.sqrt(ca.sum2(grads * grads)),
                             ca.norm_2(xdot)], ["x", "p"], ["rate", "grad_norm", "f_norm"])
    if rk4:
        step = rk4_step(field, S)
    step_jac = None
    if step is not None:
        step_jac = step.factory("step_jac", ["x", "p", "h"], ["x_next", "jac:x_next:x"])
    probe = Probe(field, field_jac, step_jac, rates)
    if len(_PROBES) >= _PROBES_MAX:
        _PROBES.pop(next(iter(_PROBES)))
    _PROBES[key] = ((f, step if not rk4 else None, controller), probe)
    return probe


def _basis(model: Model, x: np.ndarray, tangent: bool) -> np.ndarray | None:
    """Orthonormal tangent basis at ``x`` (None: ambient coordinates)."""
    if not tangent or model.manifold.dim == model.manifold.ambient_dim:
        return None
    try:
        Q, _ = np.linalg.qr(model.manifold.tangent_basis(x))
    except (ValueError, ArithmeticError):  # a state too far off the manifold for its basis
        return None
    return Q


def _finding(probe: Probe, model: Model, x: np.ndarray, h: float, order: int,
             tangent: bool, index: int = -1) -> StabilityFinding:
    p = model.p
    A = np.asarray(probe.field_jac(x, p), dtype=float)
    x_next, J = (np.asarray(v, dtype=float) for v in probe.step_jac(x, p, h))
    A_next = np.asarray(probe.field_jac(x_next.ravel(), p), dtype=float)
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(J)) and np.all(np.isfinite(A_next))):
        return StabilityFinding(index, math.inf, math.nan, math.nan, math.inf, False)
    ha = abs(h)
    # how far the frozen estimate can be off: the change of h A over the step
    frozen = ha * float(np.linalg.norm(A_next - A, 2))
    Q = _basis(model, x, tangent)
    if Q is not None:
        A, J = Q.T @ A @ Q, Q.T @ J @ Q
    lam = np.linalg.eigvals(A)
    mu = np.linalg.eigvals(J)
    alpha = float(np.max(lam.real)) if lam.size else 0.0
    rho_a = float(np.max(np.abs(lam))) if lam.size else 0.0
    growth = max(1.0, math.exp(min(ha * alpha, 700.0)))
    unstable_modes = np.abs(lam[lam.real > 0]) * ha
    own = float(np.max(2 * unstable_modes ** (order + 1) / math.factorial(order + 1))) \
        if unstable_modes.size else 0.0
    bound = growth * (1.0 + STABILITY_RTOL + own) * math.exp(min(frozen, 700.0))
    amp = float(np.max(np.abs(mu))) if mu.size else 0.0
    return StabilityFinding(index, amp, growth, bound, rho_a, bool(amp <= bound))


def _samples(x: np.ndarray, xdot: np.ndarray | None) -> list[int]:
    n = len(x)
    idx = set(np.linspace(0, n - 1, min(n, SAMPLES)).round().astype(int).tolist()) | {0}
    idx.add(int(np.argmax(np.max(np.abs(x), axis=1))))
    if xdot is not None:
        idx.add(int(np.argmax(np.max(np.abs(xdot), axis=1))))
    return sorted(idx)


def find_unstable(model: Model, probe: Probe, x: np.ndarray, indices: list[int], h: float,
                  order: int, tangent: bool) -> tuple[StabilityFinding | None, float]:
    """The earliest state of ``indices`` where the step is unstable, and the worst margin.

    Returns
    -------
    (StabilityFinding or None, float)
        The first unstable finding (None if all are stable) and the largest
        ``amplification / flow_growth`` seen (for the diagnostics).
    """
    worst = 0.0
    for i in indices:
        fnd = _finding(probe, model, x[i], h, order, tangent, i)
        if fnd.stable:
            worst = max(worst, fnd.amplification / fnd.flow_growth)
            continue
        return fnd, worst
    return None, worst


def _stable_step(probe: Probe, model: Model, x: np.ndarray, h: float, order: int,
                 tangent: bool) -> float | None:
    """Largest ``|h'| < |h|`` (bisection) where the linearised step at ``x`` is stable."""
    lo, hi = 0.0, abs(h)
    sign = 1.0 if h > 0 else -1.0
    trial = abs(h)
    for _ in range(40):  # find a stable step first
        trial /= 2
        if _finding(probe, model, x, sign * trial, order, tangent).stable:
            lo = trial
            break
    else:
        return None
    hi = 2 * lo
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if _finding(probe, model, x, sign * mid, order, tangent).stable:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-4 * lo:
            break
    return lo


def _state_text(x: np.ndarray) -> str:
    return np.array2string(np.asarray(x), precision=4, max_line_width=10_000)


def unstable_error(model: Model, probe: Probe, method: str, family: str, order: int,
                   tangent: bool, fnd: StabilityFinding, x: np.ndarray, t: float,
                   h: float, *, what: str = "") -> SolverError:
    """The SolverError for an unstable step, with the estimate of the stable one."""
    ha = abs(h)
    est = _stable_step(probe, model, x, h, order, tangent)
    limit = _IMAGINARY.get(family)
    prod = ha * fnd.spectral_radius
    cmp = f" > {limit:.3g}" if limit is not None and prod > limit else ""
    interval = _INTERVALS.get(family, "")
    est_text = (f"estimated stable step h < {est:.3g} from the linearised step there"
                if est is not None else
                "no stable step was found by halving h 40 times")
    if math.isfinite(fnd.amplification):
        amp = (f"the linearised step amplifies a mode by {fnd.amplification:.3g} per step "
               f"where the exact linearised flow grows by at most {fnd.flow_growth:.3g} "
               f"({fnd.bound:.3g} with the margins of the estimate)")
    else:
        amp = "the linearised step or field is not finite there (the state has exploded)"
    return SolverError(
        f"{method}: step h = {ha:.4g} is beyond the stable range of the method integrating "
        f"{model.name} at t = {t:.6g} (x = {_state_text(x)}){what}: {amp}; "
        f"h * |lambda|max = {prod:.3g}{cmp} (|lambda|max = {fnd.spectral_radius:.3g}, the "
        f"spectral radius of the linearised field there{'; ' + interval if interval else ''})"
        f"; {est_text}. Reduce step, or use an adaptive method (cvodes) or an A-stable one "
        f"(collocation)", status=StepStability.UNSTABLE_STEP.code)


def check_fixed_step(model: Model, probe: Probe, method: str, family: str | None,
                     order: int, tangent: bool, t: np.ndarray, x: np.ndarray, h: float,
                     xdot: np.ndarray | None = None) -> dict[str, Any]:
    """Both checks on a finished run; raise SolverError, or return the diagnostics.

    Parameters
    ----------
    model : Model
        The model.
    probe : Probe
        Its functions (:func:`probe_for`).
    method : str
        The method's name, for messages.
    family : str or None
        ``"rk"``, ``"rkmk4"`` or ``"variational"`` (its stability interval), or None for a
        method without a step map to linearise (collocation).
    order : int
        The method's order.
    tangent : bool
        Linearise in tangent coordinates (methods that stay on the manifold).
    t : ndarray, shape=(n_times,)
        Output times.
    x : ndarray, shape=(n_times, ambient_dim)
        States (finite).
    h : float
        The signed step used.
    xdot : ndarray, shape=(n_times, ambient_dim), optional
        The field at the states, when already computed.

    Returns
    -------
    dict
        ``stability``: ``checked_states``, ``max_amplification_over_flow``,
        ``conserved_invariants``, ``status``.

    Raises
    ------
    SolverError
        Status ``unstable_step`` or ``invariant_drift``.
    """
    idx = _samples(x, xdot)
    worst = None
    if probe.step_jac is not None and family is not None:
        fnd, worst = find_unstable(model, probe, x, idx, h, order, tangent)
        if fnd is not None:
            raise unstable_error(model, probe, method, family, order, tangent, fnd,
                                 x[fnd.index], float(t[fnd.index]), h)
    conserved = _conserved(model, probe, x, idx)
    if conserved:
        _check_drift(model, x, t, conserved, method, h, probe, family, order, tangent)
    return {"stability": {
        "status": StepStability.STABLE.code,
        "checked_states": len(idx),
        "max_amplification_over_flow": worst,
        "conserved_invariants": conserved,
    }}


def _conserved(model: Model, probe: Probe, x: np.ndarray, idx: list[int]) -> list[str]:
    if probe.rates is None:
        return []
    names = model.invariant_names
    keep = np.ones(len(names), dtype=bool)
    for i in idx:
        rate, gn, fn = (np.asarray(v, dtype=float).ravel() for v in probe.rates(x[i], model.p))
        ok = np.abs(rate) <= CONSERVED_RTOL * gn * fn[0] + np.finfo(float).tiny
        keep &= ok & np.isfinite(rate)
    return [n for n, k in zip(names, keep) if k]


def _check_drift(model: Model, x: np.ndarray, t: np.ndarray, names: list[str], method: str,
                 h: float, probe: Probe, family: str | None, order: int,
                 tangent: bool) -> None:
    fn = model.function("invariants")
    values = np.asarray(fn.map(len(x))(x.T, model.p), dtype=float)  # (n_inv, n_times)
    all_names = model.invariant_names
    grad_norm = np.asarray(probe.rates(x[0], model.p)[1], dtype=float).ravel()
    x0_norm = float(np.linalg.norm(x[0]))
    for name in names:
        k = all_names.index(name)
        series = values[k]
        scale = max(abs(series[0]), float(grad_norm[k]) * x0_norm, np.finfo(float).tiny)
        dev = np.abs(series - series[0])
        bad = np.flatnonzero(~(dev <= DRIFT_LIMIT * scale))
        if not bad.size:
            continue
        j = int(bad[0])
        hint = ""
        if probe.step_jac is not None and family is not None:
            fnd = _finding(probe, model, x[max(j - 1, 0)], h, order, tangent, j)
            hint = (f"; the linearised step at the output before amplifies by "
                    f"{fnd.amplification:.3g} per step (the exact flow by at most "
                    f"{fnd.flow_growth:.3g})")
        raise SolverError(
            f"{method}: step h = {abs(h):.4g} gives an untrustworthy run of {model.name}: the "
            f"invariant {name!r}, which the field conserves at every checked state (no "
            f"controller working on it, no dissipation, no load), changed from "
            f"{series[0]:.6g} to {series[j]:.6g} by t = {t[j]:.6g}, more than "
            f"{DRIFT_LIMIT:g} times its scale {scale:.3g} (max(|I(x0)|, |grad I(x0)| |x0|))"
            f"{hint}. Reduce step", status=StepStability.INVARIANT_DRIFT.code)
