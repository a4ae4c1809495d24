"""The linearised step of a fixed-step method, against the exact linearised flow.

A fixed-step method beyond its stability range amplifies some mode of the flow by more
than the flow does, every step. :class:`LinearisedStep` measures that at a state: the
closed-loop field is linearised, ``A = df/dx`` (the model's own Jacobian, with the
controller's; in tangent coordinates for the methods that keep the manifold, ambient for
``rk``, which integrates the ambient equations). Where ``h |lambda|max <= SAFE_H_RHO`` (1:
inside every method's range by a factor 2 or more) nothing more is done. Elsewhere the step
map is linearised, ``J = d Phi_h / dx`` (automatic derivative of its graph), and its
spectral radius, the smaller of its ambient and tangent values, is compared with what the
exact flow allows, ``max(1, exp(h alpha))^2`` with ``alpha = max Re lambda(A)`` (a growing
mode may grow up to twice as fast numerically, never more), times ``1 + STABILITY_RTOL``
plus the relative change of the amplification over the step. At an output state the step
is unstable when that bound is exceeded at the state and again at the step's end (an
instability persists; a frozen-coefficient artefact off an equilibrium does not). For a
linear field the test is exact: on ``x'' = -w^2 x`` it finds RK4's ``h w <= 2 sqrt 2`` and
the variational steps' ``h w <= 2`` (Stormer-Verlet's). The stable step is estimated by
bisection on ``h`` of the same test. :meth:`LinearisedStep.locate` steps an output interval
again to find the state between outputs where a run that is known to have failed took an
unstable step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from workbench.core._model import Model
from workbench.core.errors import SolverError
from workbench.core.status import StatusEnum
from workbench.simulation._probe import RESTEP_CHUNK, Probe

__all__ = [
    "StepStability",
    "StabilityFinding",
    "LinearisedStep",
    "Located",
    "STABILITY_RTOL",
    "SAFE_H_RHO",
    "FROZEN_MAX",
    "RK4_IMAGINARY",
    "RK4_REAL",
    "LOCATE_CANDIDATES",
    "WALK_KEEP",
]

WALK_KEEP = 100_000
"""States kept of an interval stepped again (the last ones before the failure), for the
model's state check."""

LOCATE_CANDIDATES = 8
"""States between two outputs at which the step is linearised when a check failed there:
those where ``h |A|_F`` (a bound on the spectral radius) is largest."""

STABILITY_RTOL = 1e-2
"""Accepted excess of the linearised step's spectral radius over the exact flow's growth
per step. A symmetry of the model (a conserved momentum) gives the linearised step an
eigenvalue 1 in a Jordan block, which a perturbation ``eps`` (the method's local error)
moves by ``sqrt(eps)``: about 3e-3 for the LGVI at ``h omega = 1.4``. Just beyond the
stable range the amplification rises far faster (RK4: 1.01 at ``h w = 2.832`` against the
boundary 2.828; Stormer-Verlet: 1.01 at ``h w = 2.00005``), so the boundary moves by under
0.2 %."""

FROZEN_MAX = 0.1
"""Where the linearised step's amplification changes by more than this fraction over the
step (at the step's end state), the frozen-coefficient estimate decides nothing; below
it, the change is a margin on the accepted amplification. Just beyond the stable range the
amplification rises steeply (RK4: 1.19 at ``h w = 2.9``, 1.5 at 3; Stormer-Verlet: 1.33 at
``h w = 2.02``), so the margin moves the detected boundary of a near-linear motion by a
few per cent at most (none for a linear field, whose amplification is the same
everywhere)."""

SAFE_H_RHO = 1.0
"""``h |lambda|max`` at or below which a step is inside the stable range of every
fixed-step method here by a factor 2 or more (RK4: 2.79 on the real axis, 2.83 on the
imaginary axis; the variational steps: 2 on an oscillation); the step map is then not
linearised."""

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
    UNSTABLE_STEP = "the step is beyond the method's stable range: the run explodes, or would"
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
        Spectral radius of the linearised step (``inf`` when it is not finite; NaN when
        the step was not linearised: ``h |lambda|max <= SAFE_H_RHO``).
    flow_growth : float
        ``max(1, exp(h alpha))``: what the exact linearised flow allows per step.
    bound : float
        The accepted amplification (``flow_growth`` with the margins; NaN when the step was
        not linearised).
    spectral_radius : float
        ``max |lambda|`` of the linearised field.
    stable : bool
        ``amplification <= bound`` (True where the estimate is not trusted).
    trusted : bool
        Whether the frozen-coefficient estimate holds there (the amplification changes by
        at most the fraction ``FROZEN_MAX`` over the step); an untrusted finding decides
        nothing.
    """

    index: int
    amplification: float
    flow_growth: float
    bound: float
    spectral_radius: float
    stable: bool
    trusted: bool = True


def _basis(model: Model, x: np.ndarray, tangent: bool) -> np.ndarray | None:
    """Orthonormal tangent basis at ``x`` (None: ambient coordinates)."""
    if not tangent or model.manifold.dim == model.manifold.ambient_dim:
        return None
    try:
        Q, _ = np.linalg.qr(model.manifold.tangent_basis(x))
    except (ValueError, ArithmeticError):  # a state too far off the manifold for its basis
        return None
    return Q


def _state_text(x: np.ndarray) -> str:
    return np.array2string(np.asarray(x), precision=4, max_line_width=10_000)


@dataclass(frozen=True)
class LinearisedStep:
    """The linearised step of one fixed-step run.

    Attributes
    ----------
    model : Model
        The model.
    probe : Probe
        Its functions (:func:`probe_for`).
    method : str
        The method's name, for messages.
    family : str or None
        ``"rk"``, ``"rkmk4"`` or ``"variational"`` (whose stability interval the message
        quotes), or None for a method without a step map to linearise (collocation).
    tangent : bool
        Linearise in tangent coordinates (the methods that stay on the manifold); ambient
        for ``rk``, which integrates the ambient equations.
    h : float
        The step: signed for a geometric step function, positive for the RK4 step of the
        signed field.
    """

    model: Model
    probe: Probe
    method: str
    family: str | None
    tangent: bool
    h: float

    @property
    def linearised(self) -> bool:
        """Whether the run has a step map to linearise."""
        return self.probe.step is not None and self.family is not None

    def _field_spectra(self, xs: np.ndarray, h: float | None = None
                       ) -> list[tuple[np.ndarray, np.ndarray | None, np.ndarray | None]]:
        """``(A, Q, lambda)`` at every state of ``xs`` (one call of the mapped Jacobian).

        ``A`` is ambient, ``Q`` the orthonormal tangent basis (None: ambient coordinates),
        ``lambda`` the eigenvalues of ``Q^T A Q`` (None when ``A`` is not finite). Where
        ``|h| |A|_F <= SAFE_H_RHO`` (a bound on the spectral radius of every compression
        of ``A``) ``Q`` and ``lambda`` are skipped (None, ``[]``): the step is safe there.
        ``h`` is the step (default the run's; 0 skips nothing).
        """
        h = self.h if h is None else h
        k, n = len(xs), xs.shape[1]
        # xs (k, n) in C order is the mapped input (n, k) in casadi's column-major order
        out = self.probe.mapped("field_jac", k)(xs, self.model.p)[0]
        As = np.asarray(out, dtype=float).reshape(n, k, n).transpose(1, 0, 2)
        safe = (abs(h) * np.sqrt(np.sum(As * As, axis=(1, 2))) <= SAFE_H_RHO) & (h != 0)
        res = []
        for x, A, ok in zip(xs, As, safe):
            if ok:
                res.append((A, None, np.zeros(0)))
                continue
            Q = _basis(self.model, x, self.tangent)
            lam = None
            if np.all(np.isfinite(A)):
                lam = np.linalg.eigvals(A if Q is None else Q.T @ A @ Q)
            res.append((A, Q, lam))
        return res

    def _amplification(self, x: np.ndarray, h: float, Q: np.ndarray | None
                       ) -> tuple[float, np.ndarray]:
        """Spectral radius of the linearised step at ``x``, and the step's end state.

        The smaller of its values in ambient coordinates and in the tangent space at ``x``
        (``Q``): a real instability shows in both, the artefact of a frame or of a
        direction normal to the manifold in one only. ``inf`` when not finite.
        """
        x_next, J = (np.asarray(v, dtype=float) for v in self.probe.step_jac(x, self.model.p, h))
        if not np.all(np.isfinite(J)):
            return math.inf, x_next.ravel()
        amp = float(np.max(np.abs(np.linalg.eigvals(J)))) if J.size else 0.0
        if Q is not None:
            amp = min(amp, float(np.max(np.abs(np.linalg.eigvals(Q.T @ J @ Q)))))
        return amp, x_next.ravel()

    def finding(self, x: np.ndarray, index: int = -1, h: float | None = None,
                spectrum: tuple | None = None) -> StabilityFinding:
        """The stability estimate at the state ``x`` (for step ``h``, default the run's).

        The field's linearisation first: with ``h |lambda|max <= SAFE_H_RHO`` the step is
        well inside the method's range and the step map is not linearised (its derivative
        costs about ``ambient_dim`` steps). Otherwise, where the frozen-coefficient
        estimate holds (the amplification changes by at most the fraction ``FROZEN_MAX``
        over the step), the linearised step decides.
        ``spectrum`` is ``(A, Q, lambda)`` at ``x`` when already computed.
        """
        h = self.h if h is None else h
        ha = abs(h)
        A, Q, lam = spectrum if spectrum is not None else \
            self._field_spectra(np.asarray(x, dtype=float)[None, :], h)[0]
        rho_a, alpha = math.inf, 0.0
        if lam is not None:
            rho_a = float(np.max(np.abs(lam))) if lam.size else 0.0
            alpha = float(np.max(lam.real)) if lam.size else 0.0
            if ha * rho_a <= SAFE_H_RHO:
                growth = max(1.0, math.exp(ha * alpha))
                return StabilityFinding(index, math.nan, growth, math.nan, rho_a, True)
        amp, x_next = self._amplification(x, h, Q)
        if lam is None or not math.isfinite(amp):
            return StabilityFinding(index, math.inf, math.nan, math.nan, rho_a, False)
        # the frozen-coefficient estimate holds where the amplification is about the same
        # one step on (exactly so for a linear field); there the change is a margin,
        # elsewhere (fast nonlinear motion, the frame turning) it decides nothing. An
        # instability persists: it must show at the step's end state as well.
        # exponents capped at 350: squared below, e^700 is the largest that stays finite
        growth = max(1.0, math.exp(min(ha * alpha, 350.0)))
        amp_next, growth_next = math.inf, math.nan
        if np.all(np.isfinite(x_next)):
            _, Q1, lam1 = self._field_spectra(x_next.reshape(1, -1), 0.0)[0]
            if lam1 is not None:
                alpha1 = float(np.max(lam1.real)) if lam1.size else 0.0
                growth_next = max(1.0, math.exp(min(ha * alpha1, 350.0)))
                amp_next = self._amplification(x_next, h, Q1)[0]
        change = abs(amp_next / amp - 1.0) if amp else 0.0
        # a growing mode may grow up to twice as fast numerically (the method's own error
        # on an unstable focus), never more: beyond that the step adds growth of its own
        margin = 1.0 + STABILITY_RTOL + change
        bound = growth ** 2 * margin
        stable = not (amp > bound and amp_next > max(bound, min(growth_next, growth) ** 2
                                                     * margin))
        return StabilityFinding(index, amp, growth, bound, rho_a, stable,
                                trusted=change <= FROZEN_MAX)

    def find_unstable(self, x: np.ndarray, indices: list[int], spectra: list | None = None
                      ) -> tuple[StabilityFinding | None, int]:
        """The earliest of the states ``x[indices]`` where the step is unstable.

        ``spectra`` is :meth:`_field_spectra` of ``x[indices]`` when already computed.

        Returns
        -------
        (StabilityFinding or None, int)
            The first unstable finding (None if all are stable) and the number of states
            before it where the step map had to be linearised (``h |lambda|max`` above
            :data:`SAFE_H_RHO`).
        """
        linearised = 0
        spectra = self._field_spectra(x[indices]) if spectra is None else spectra
        for i, spec in zip(indices, spectra):
            fnd = self.finding(x[i], i, spectrum=spec)
            if not fnd.stable:
                return fnd, linearised
            linearised += not math.isnan(fnd.amplification)
        return None, linearised

    def stable_step(self, x: np.ndarray) -> float | None:
        """Largest ``|h'| < |h|`` (bisection, 1e-4 relative) where the step at ``x`` is stable.

        None when no halving of ``h`` (40 of them) is stable there.
        """
        sign = 1.0 if self.h > 0 else -1.0
        lo = abs(self.h)
        for _ in range(40):  # a stable step first
            lo /= 2
            f = self.finding(x, h=sign * lo)
            if f.stable and f.trusted:
                break
        else:
            return None
        hi = min(2 * lo, abs(self.h))
        while hi - lo > 1e-4 * lo:
            mid = 0.5 * (lo + hi)
            f = self.finding(x, h=sign * mid)
            if f.stable and f.trusted:
                lo = mid
            else:
                hi = mid
        return lo

    def unstable_error(self, fnd: StabilityFinding, x: np.ndarray, t: float, *,
                       what: str = "", cause: str = "") -> SolverError:
        """The SolverError for an unstable step at ``x``, with the estimated stable step.

        ``what`` is said after the state, ``cause`` (the failure of the run itself) at the
        end.
        """
        ha = abs(self.h)
        est = self.stable_step(x)
        limit = _IMAGINARY.get(self.family or "")
        prod = ha * fnd.spectral_radius
        cmp = f" > {limit:.3g}" if limit is not None and prod > limit else ""
        interval = _INTERVALS.get(self.family or "", "")
        est_text = (f"estimated stable step h < {est:.4g} from the linearised step there"
                    if est is not None else
                    "no stable step was found by halving h 40 times")
        if math.isfinite(fnd.amplification):
            amp = (f"the linearised step amplifies a mode by {fnd.amplification:.3g} per "
                   f"step where the exact linearised flow grows by at most "
                   f"{fnd.flow_growth:.3g} ({fnd.bound:.3g} accepted with the margins of the "
                   f"estimate)")
        else:
            amp = "the linearised step or field is not finite there (the state has exploded)"
        return SolverError(
            f"{self.method}: step h = {ha:.4g} is beyond the stable range of the method "
            f"integrating {self.model.name} at t = {t:.6g} (x = {_state_text(x)}){what}: "
            f"{amp}; h * |lambda|max = {prod:.3g}{cmp} (|lambda|max = "
            f"{fnd.spectral_radius:.3g}, the spectral radius of the linearised field there"
            f"{'; ' + interval if interval else ''}); {est_text}. Reduce step, or use an "
            f"adaptive method (cvodes) or an A-stable one (collocation)"
            f"{'. The run itself reported: ' + cause if cause else ''}",
            status=StepStability.UNSTABLE_STEP.code)

    def locate(self, t0: float, x0: np.ndarray, t1: float, stop: Any = None) -> Located:
        """Step the output interval ``[t0, t1]`` again from ``x0`` and find where it failed.

        The states between two outputs are not kept by a run; this re-steps the interval
        with the run's step map (:meth:`Probe.walk`) until ``stop(times, states)`` names a
        state (or one is not finite), then linearises the step at the
        :data:`LOCATE_CANDIDATES` states before it where ``h |A|_F`` is largest and
        returns the earliest where the linearised step amplifies a mode beyond the flow's
        bound (the run is known to have failed there: the persistence one step on that
        :meth:`finding` asks of an output state is not asked here).

        Parameters
        ----------
        t0, t1 : float
            The interval's output times.
        x0 : ndarray, shape=(ambient_dim,)
            The state at ``t0``.
        stop : callable, optional
            ``stop(times, states) -> int or None``: the first index of a chunk of states
            where the run is known to have failed.

        Returns
        -------
        Located
        """
        n = max(1, round(abs(t1 - t0) / abs(self.h)))
        dt = (t1 - t0) / n
        cand: list[tuple[float, float, np.ndarray]] = []  # (h |A|_F, t, x)
        kept: list[tuple[np.ndarray, np.ndarray]] = []  # (times, states), the last WALK_KEEP
        last_t, last_x, done, nk = t0, np.asarray(x0, dtype=float), 0, 0
        for X in self.probe.walk(x0, self.model.p, self.h, n):
            ts = t0 + dt * np.arange(done + 1, done + len(X) + 1)
            finite = np.all(np.isfinite(X), axis=1)
            m = len(X) if np.all(finite) else int(np.argmin(finite))
            hit = stop(ts[:m], X[:m]) if stop is not None and m else None
            m = m if hit is None else hit
            if m:
                pad = np.vstack([X[:m], np.repeat(X[m - 1:m], RESTEP_CHUNK - m, axis=0)])
                out = self.probe.mapped("field_jac", RESTEP_CHUNK)(pad, self.model.p)[0]
                norms = abs(self.h) * np.sqrt(np.sum(np.asarray(out).reshape(
                    -1, RESTEP_CHUNK, X.shape[1])[:, :m] ** 2, axis=(0, 2)))
                for i in np.argsort(norms)[::-1][:LOCATE_CANDIDATES]:
                    cand.append((float(norms[i]), float(ts[i]), X[i]))
                cand = sorted(cand, key=lambda c: c[0], reverse=True)[:LOCATE_CANDIDATES]
                last_t, last_x = float(ts[m - 1]), X[m - 1]
                kept.append((ts[:m], X[:m]))
                nk += m
                while nk - len(kept[0][0]) >= WALK_KEEP:
                    nk -= len(kept.pop(0)[0])
            done += len(X)
            if m < len(X):
                break
        times = np.concatenate([k[0] for k in kept]) if kept else np.zeros(0)
        states = (np.vstack([k[1] for k in kept]) if kept else
                  np.zeros((0, np.asarray(x0).size)))
        # the run is known to have failed by the stop: a step that amplifies a mode beyond
        # the flow's bound is the cause even where it does not persist one step on (a
        # stiff wall kicks the state in one step and lets it go the next)
        for _, tc, xc in sorted(cand, key=lambda c: c[1]):
            fnd = self.finding(xc)
            if not fnd.stable or fnd.amplification > fnd.bound:
                return Located(fnd, xc, tc, last_x, last_t, states, times)
        return Located(None, None, None, last_x, last_t, states, times)


@dataclass(frozen=True)
class Located:
    """What :meth:`StepCheck.locate` found between two outputs.

    Attributes
    ----------
    finding : StabilityFinding or None
        The first unstable step found (None: none at the states linearised).
    x : ndarray or None
        Its state.
    t : float or None
        Its time.
    last_x : ndarray
        The last state before the failure (finite, before ``stop``).
    last_t : float
        Its time.
    states : ndarray, shape=(n, ambient_dim)
        The states stepped again, before the failure (the last :data:`WALK_KEEP`).
    times : ndarray, shape=(n,)
        Their times.
    """

    finding: StabilityFinding | None
    x: np.ndarray | None
    t: float | None
    last_x: np.ndarray
    last_t: float
    states: np.ndarray
    times: np.ndarray
