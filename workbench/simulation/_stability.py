"""Whether a fixed-step run is stable: the linearised step, the growth and the invariants.

A fixed-step method beyond its stability range amplifies some mode of the flow by more
than the flow does, every step, and its states grow without bound (RK4 on ``x'' = -w^2 x``
with ``h w = 3``: by ``|R(3i)| = 1.5`` per step). :meth:`StepCheck.run` tells such a run
from a legitimate one, and :meth:`StepCheck.unstable_error` says why and for which step.
Three checks, on a few output states (the start, evenly spaced ones, the largest and the
fastest, and the largest and fastest states between outputs when the integrator gives
them), so that they cost little next to the integration:

* **Stability estimate** (the methods with a step map: ``rk``, ``rkmk4``, ``lgvi``,
  ``s2_variational``, ``mechanics_variational``): the linearised step against the exact
  linearised flow (:mod:`workbench.simulation._linearised_step`). Damping (``alpha < 0``)
  and forcing (a controller, ``alpha > 0`` when it feeds energy) enter the field's and the
  step's linearisations alike, so neither is mistaken for instability. Collocation
  (Gauss-Legendre, A-stable: ``|R(z)| <= 1`` for ``Re z <= 0``) has no such range.
* **Growth.** A state larger than :data:`GROWTH_LIMIT` times what the flow allows from
  ``x0`` (``max(|x0|, |t - t0| |f(x0)|, |t - t0|^2 |A f(x0)| / 2) exp(max(alpha(x0), 0)
  |t - t0|)``, max-norms) is an explosion, whatever the linearisation said.
* **Invariants** (:mod:`workbench.simulation._invariant_check`). One that the closed-loop
  field conserves at every sampled state must not move by more than :data:`DRIFT_LIMIT`
  times its scale ``max(|I(x0)|, |grad I(x0)| |x0|)``; one that it does not increase
  (dissipated, with no input feeding it) must not *rise* by more: along the exact flow it
  can only fall. An invariant fed by the loop is not checked: its change is legitimate.

The linearised step at an output state can miss an instability between outputs (a stiff
wall hit and left within one output interval): the invariants and the growth do not.
When one of those fails, the interval is stepped again with the run's step map
(:meth:`~workbench.simulation._linearised_step.LinearisedStep.locate`), and the error names
the state between outputs where the step is unstable and the stable step estimated there.

The linearised step at a state off an equilibrium is the frozen-coefficient estimate of
the usual stability analysis: exact for a linear field, close for the smooth fields of
mechanics near an equilibrium, and only indicative in fast nonlinear motion (hence the
margins and the persistence); a mode the flow itself amplifies fast can hide a slightly
unstable fast mode behind it, but not an exploding one (the growth check).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from workbench.core.errors import SolverError
from workbench.simulation._invariant_check import (
    CONSERVED_RTOL,
    DRIFT_LIMIT,
    Watch,
    classify,
    first_excess,
    invariant_values,
)
from workbench.simulation._linearised_step import (
    _INTERVALS,
    FROZEN_MAX,
    LOCATE_CANDIDATES,
    RK4_IMAGINARY,
    RK4_REAL,
    SAFE_H_RHO,
    STABILITY_RTOL,
    LinearisedStep,
    Located,
    StabilityFinding,
    StepStability,
)
from workbench.simulation._probe import Probe, probe_for, rk4_step

__all__ = [
    "StepStability",
    "StabilityFinding",
    "STABILITY_RTOL",
    "DRIFT_LIMIT",
    "CONSERVED_RTOL",
    "SAMPLES",
    "SAFE_H_RHO",
    "FROZEN_MAX",
    "GROWTH_LIMIT",
    "EXPLODED",
    "RK4_IMAGINARY",
    "RK4_REAL",
    "LOCATE_CANDIDATES",
    "Probe",
    "probe_for",
    "StepCheck",
    "LinearisedStep",
    "Located",
    "rk4_step",
]

GROWTH_LIMIT = 1e4
"""States larger than this many times what the flow allows from ``x0`` are an explosion
(see :meth:`StepCheck._check_growth`). The allowance is a bound of the linearised flow: for
``x' = A x + b`` with ``A`` diagonalisable, ``|x(t)| <= kappa(V) e^(alpha t)`` times the
Taylor terms ``max(|x0|, t |f0|, t^2 |A f0| / 2)`` (which cover a free particle under a
constant force, whose growth is polynomial), ``kappa(V)`` the condition number of ``A``'s
eigenvectors; 1e4 leaves room for the transient growth (peaking) of strongly non-normal
loops and for the nonlinearity, while an unstable step multiplies the state by at least its
amplification (above 1.01, typically 1.1 to 1.5) every step, so that it passes 1e4 within a
few tens to a few hundred steps. It was 1e6, which let a 3000-fold growth through."""

EXPLODED = 1e3
"""A non-increasing invariant that rose by more than this many times its scale has exploded:
the run is refused as an unstable step even where re-stepping located no unstable state
(below it, as an untrustworthy run: an unstable or too coarse step)."""

SAMPLES = 4
"""Evenly spaced output states checked (the first and the last among them), besides the
largest and the fastest."""

def _samples(x: np.ndarray, xdot: np.ndarray | None) -> list[int]:
    """The output indices checked, in order.

    Evenly spaced ones (the first and the last among them), the largest state and the
    fastest.
    """
    n, k = len(x), min(len(x), SAMPLES)
    idx = {round(i * (n - 1) / max(k - 1, 1)) for i in range(k)} | {0}
    idx.add(int(np.abs(x).max(axis=1).argmax()))
    if xdot is not None:
        idx.add(int(np.abs(xdot).max(axis=1).argmax()))
    return sorted(idx)


@dataclass(frozen=True)
class StepCheck(LinearisedStep):
    """The checks of one fixed-step run (the linearised step, growth, invariants).

    Attributes
    ----------
    model, probe, method, family, tangent, h
        As :class:`~workbench.simulation._linearised_step.LinearisedStep`.
    """

    def run(self, t: np.ndarray, x: np.ndarray, xdot: np.ndarray | None = None,
            drift: dict[str, Any] | None = None,
            between: list[tuple[float, np.ndarray, str]] | None = None) -> dict[str, Any]:
        """All the checks on a finished run; raise SolverError, or return the diagnostics.

        Parameters
        ----------
        t : ndarray, shape=(n_times,)
            Output times.
        x : ndarray, shape=(n_times, ambient_dim)
            States (finite).
        xdot : ndarray, shape=(n_times, ambient_dim), optional
            The field at the states, when already computed (the fastest state is checked).
        drift : dict, optional
            The run's ``invariant_drift`` diagnostics, when already computed (the
            invariants are then evaluated again only when one moved beyond its allowance).
        between : list of (float, ndarray, str), optional
            States between outputs where the step is linearised too (time, state, what it
            is: the largest, the fastest), when the integrator gave them.

        Returns
        -------
        dict
            ``{"stability": {...}}``: ``status``, ``checked_states``,
            ``step_linearised_at`` (how many of them had ``h |lambda|max`` above
            :data:`SAFE_H_RHO`, so that the step map was linearised; None without a step
            map), ``conserved_invariants`` (whose change was checked both ways) and
            ``non_increasing_invariants`` (whose rise was checked).

        Raises
        ------
        SolverError
            Status ``unstable_step`` or ``invariant_drift``.
        """
        idx = _samples(x, xdot)
        linearised, A0 = None, None
        between = list(between or []) if self.linearised else []
        if self.linearised:  # the outputs and the states between them, in one evaluation
            n = len(x)
            xs = np.vstack([x, *[xb[None, :] for _, xb, _ in between]]) if between else x
            at = idx + list(range(n, len(xs)))
            spectra = self._field_spectra(xs[at])
            A0 = spectra[0][0]
            fnd, linearised = self.find_unstable(xs, at, spectra=spectra)
            if fnd is not None and fnd.index < n:
                raise self.unstable_error(fnd, x[fnd.index], float(t[fnd.index]))
            if fnd is not None:
                tb, xb, what = between[fnd.index - n]
                raise self.unstable_error(fnd, xb, tb, what=f" ({what} between outputs)")
        self._check_growth(t, x, xdot, A0)
        initial = None if drift is None else np.array(
            [float(drift[k]["initial"]) for k in self.model.invariant_names])
        watch = classify(self.probe, self.model, x, idx, initial)  # idx[0] == 0
        if watch.names:
            self._check_invariants(t, x, watch, drift)
        return {"stability": {
            "status": StepStability.STABLE.code,
            "checked_states": len(idx) + len(between),
            "step_linearised_at": linearised,
            "conserved_invariants": watch.conserved,
            "non_increasing_invariants": watch.non_increasing,
        }}

    def _growth_allowance(self, t: np.ndarray, x: np.ndarray, xdot: np.ndarray | None,
                          rate: bool, A: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """What the flow allows ``max |x|`` to be at the times ``t``, and ``alpha(x0)``.

        ``max(|x0|, |t - t0| |f0|, |t - t0|^2 |A0 f0| / 2)`` (max-norms), times ``exp(max(
        alpha, 0) |t - t0|)`` when ``rate`` (``alpha`` the largest real part of the
        linearised field's eigenvalues at ``x0``; 0 otherwise).
        """
        f0 = (np.asarray(xdot[0], dtype=float) if xdot is not None else
              np.asarray(self.probe.field(x[0], self.model.p)[0], dtype=float).ravel())
        if A is None:  # the ambient Jacobian at x0
            n = x.shape[1]
            A = np.asarray(self.probe.mapped("field_jac", 1)(x[:1], self.model.p)[0],
                           dtype=float).reshape(n, n)
        af0 = float(np.max(np.abs(A @ f0))) if np.all(np.isfinite(A)) else math.inf
        dt = np.abs(t - t[0])
        alpha = 0.0
        if rate:
            lam = self._field_spectra(x[:1], 0.0)[0][2]
            alpha = float(np.max(lam.real)) if lam is not None and lam.size else 0.0
        with np.errstate(over="ignore", invalid="ignore"):  # inf is an allowance too
            base = np.maximum(max(float(np.max(np.abs(x[0]))), np.finfo(float).tiny),
                              np.maximum(dt * float(np.max(np.abs(f0))), 0.5 * dt**2 * af0))
            return base * np.exp(np.minimum(max(alpha, 0.0) * dt, 700.0)), alpha

    def _check_growth(self, t: np.ndarray, x: np.ndarray, xdot: np.ndarray | None,
                      A0: np.ndarray | None = None) -> None:
        """Refuse states grown by orders of magnitude beyond what the flow allows.

        The allowance at ``t_k`` is ``GROWTH_LIMIT`` times :meth:`_growth_allowance`: the
        run's own scale, its drift at the initial speed and acceleration, and the growth
        of the linearised flow at the start.
        """
        size = np.max(np.abs(x), axis=1)
        allowed, alpha = self._growth_allowance(t, x, xdot, rate=False, A=A0)
        if np.all(size <= GROWTH_LIMIT * allowed):  # common: no need of the growth rate
            return
        allowed, alpha = self._growth_allowance(t, x, xdot, rate=True, A=A0)
        bad = np.flatnonzero(~(size <= GROWTH_LIMIT * allowed))
        if not bad.size:
            return
        k = int(bad[0])
        what = (f" (the state grew to max |x| = {size[k]:.3g} by t = {t[k]:.6g}, more than "
                f"{GROWTH_LIMIT:.0e} times what the flow allows from x0, {allowed[k]:.3g}: "
                f"max(|x0|, |t - t0| |f(x0)|, |t - t0|^2 |A f(x0)| / 2) times the growth "
                f"exp(alpha t) of the linearised field at t0, alpha = {alpha:.3g})")
        located = self._locate(t, x, k, self._size_stop(t, allowed), what=what[2:-1])
        if located is not None:
            raise located
        estimate = ""
        if self.linearised:
            fnd = self.finding(x[0], 0)
            est = self.stable_step(x[0])
            amp = ("" if math.isnan(fnd.amplification) else
                   f" and the linearised step amplifies by {fnd.amplification:.3g}")
            estimate = (f"; at t = {t[0]:.6g}, h * |lambda|max = "
                        f"{abs(self.h) * fnd.spectral_radius:.3g}{amp}"
                        f" ({_INTERVALS.get(self.family or '', '')}); "
                        + (f"estimated stable step h < {est:.4g} from the linearised step "
                           f"there" if est is not None else "no stable step was estimated"))
        raise SolverError(
            f"{self.method}: step h = {abs(self.h):.4g} is beyond the stable range of the "
            f"method integrating {self.model.name}{what}{estimate}. Reduce step, or use an "
            f"adaptive method (cvodes) or an A-stable one (collocation)",
            status=StepStability.UNSTABLE_STEP.code)

    def _size_stop(self, t: np.ndarray, allowed: np.ndarray) -> Any:
        """A stop rule for :meth:`locate`: the state's size beyond the allowance."""
        t0, a0 = float(t[0]), float(allowed[0])
        rate = (np.log(allowed[-1] / a0) / abs(t[-1] - t0)
                if allowed[-1] > a0 and t[-1] != t0 else 0.0)

        def stop(ts: np.ndarray, X: np.ndarray) -> int | None:
            # the allowance between outputs: the larger of its values at the two ends
            lim = GROWTH_LIMIT * a0 * np.exp(np.minimum(rate * np.abs(ts - t0), 700.0))
            bad = np.flatnonzero(~(np.max(np.abs(X), axis=1) <= np.maximum(lim, a0)))
            return int(bad[0]) if bad.size else None
        return stop

    def _check_invariants(self, t: np.ndarray, x: np.ndarray, watch: Watch,
                          drift: dict[str, Any] | None) -> None:
        """Refuse a conserved invariant that moved, or a non-increasing one that rose.

        Either by more than :data:`DRIFT_LIMIT` times its scale (see
        :mod:`workbench.simulation._invariant_check`).
        """
        model = self.model
        known = drift or {}
        moved = [n for n in watch.names if n not in known
                 or not float(known[n]["max_abs"]) <= DRIFT_LIMIT * watch.scale[n]]
        if not moved:  # the common case: every watched invariant within its allowance
            return
        values = invariant_values(model, x)
        names = model.invariant_names
        hit = first_excess(watch, names, values, values[:, 0])
        if hit is None:  # a non-increasing invariant that fell: legitimate
            return
        name, j = hit
        k = names.index(name)
        rising = name in watch.non_increasing
        scale = watch.scale[name]
        what = (f"the invariant {name!r}, which the closed-loop field "
                + ("does not increase at any sampled state (dissipated, no input feeding it: "
                   "it can only fall along the exact flow), rose"
                   if rising else
                   "conserves at every sampled state (no controller working on it, no "
                   "dissipation, no load), changed")
                + f" from {values[k, 0]:.6g} to {values[k, j]:.6g} by t = {t[j]:.6g}, more "
                f"than {DRIFT_LIMIT:g} times its scale {scale:.3g} (max(|I(x0)|, "
                f"|grad I(x0)| |x0|))")
        initial = values[:, 0]

        def stop(ts: np.ndarray, X: np.ndarray) -> int | None:
            found = first_excess(watch, names, invariant_values(model, X), initial)
            return None if found is None else found[1]
        located = self._locate(t, x, j, stop, what=what)
        if located is not None:
            raise located
        if rising and self.linearised and values[k, j] - values[k, 0] > EXPLODED * scale:
            # orders of magnitude: an instability even where no step was located
            raise SolverError(
                f"{self.method}: step h = {abs(self.h):.4g} is beyond the stable range of the "
                f"method integrating {model.name} somewhere between t = {t[j - 1]:.6g} and "
                f"t = {t[j]:.6g}: {what}. Reduce step, or use an adaptive method (cvodes) or "
                f"an A-stable one (collocation)", status=StepStability.UNSTABLE_STEP.code)
        raise SolverError(
            f"{self.method}: step h = {abs(self.h):.4g} gives an untrustworthy run of "
            f"{model.name}: {what}. Reduce step", status=StepStability.INVARIANT_DRIFT.code)

    def _locate(self, t: np.ndarray, x: np.ndarray, j: int, stop: Any,
                what: str = "") -> SolverError | None:
        """The unstable-step error found by re-stepping the interval before output ``j``."""
        if not self.linearised or j == 0:
            return None
        loc = self.locate(float(t[j - 1]), x[j - 1], float(t[j]), stop)
        if loc.finding is None:
            return None
        return self.unstable_error(loc.finding, loc.x, loc.t,
                                   what=f", between outputs (found by stepping again the "
                                        f"interval where {what})")


