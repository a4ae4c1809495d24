"""Domains of attraction: certified sublevel sets (Ipopt) and sampled basins (simulation).

Certification (sublevel sets :class:`~workbench.control._lyapunov.SublevelSet` of a Lyapunov
function inside a domain) is in :mod:`workbench.control._certify` (:func:`optimize`,
:func:`optimize_lyapunov`, :func:`level_in_domain`, re-exported here);
:func:`~workbench.control._lyapunov.ray_extent` measures a set's size along tangent rays.

Testing and estimation by integrating the closed loop from many initial states:

* :func:`check_convergence` -- integrate the closed loop from many initial states and
  report how many reach a target, the worst case, and a one-sided Clopper-Pearson bound
  on the failure probability under the sampling distribution.
* :func:`estimate_basin` -- the fraction of proposal samples that converge against the
  fraction in a certified set, with binomial confidence intervals.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.control._certify import (
    Constraint,
    Extremum,
    ExtremumStatus,
    OptimizeCost,
    level_in_domain,
    optimize,
    optimize_lyapunov,
)
from workbench.control._lyapunov import SublevelSet, as_states
from workbench.core._model import Model
from workbench.core.errors import ParameterError
from workbench.core.status import Record, StatusEnum, StatusResult
from workbench.core.types import ArrayLike
from workbench.simulation._cvodes import Corrector, Multistep, cvodes_options
from workbench.simulation._simulate import closed_loop_function

__all__ = [
    "Constraint",
    "Extremum",
    "ExtremumStatus",
    "OptimizeCost",
    "optimize",
    "optimize_lyapunov",
    "level_in_domain",
    "ConvergenceStatus",
    "ConvergenceCost",
    "ConvergenceReport",
    "check_convergence",
    "BasinEstimate",
    "estimate_basin",
    "clopper_pearson",
]


def clopper_pearson(k: int, n: int, *, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided Clopper-Pearson interval for a binomial proportion ``k / n``.

    Parameters
    ----------
    k, n : int
        Successes and trials, ``0 <= k <= n``, ``n >= 1``.
    confidence : float
        Coverage in (0, 1).

    Returns
    -------
    (float, float)
        Lower and upper bounds.
    """
    if not (0 < confidence < 1):
        raise ParameterError(f"confidence must lie in (0, 1); got {confidence!r}")
    if n < 1 or not (0 <= k <= n):
        raise ParameterError(f"need 0 <= k <= n and n >= 1; got k = {k}, n = {n}")
    from scipy.stats import beta  # here: scipy.stats takes 0.7 s to import

    a = 1 - confidence
    lo = 0.0 if k == 0 else float(beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


# ----------------------------------------------------------------------------------------
# Monte-Carlo convergence


class ConvergenceStatus(StatusEnum):
    """Outcome of :func:`check_convergence`; the value is a readable message."""

    ALL_CONVERGED = "every sample converged to the target within the horizon"
    NOT_ALL_CONVERGED = ("some samples did not converge (not close enough at the horizon, "
                         "left the domain, or the integrator failed)")

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"ALL_CONVERGED"})


@dataclass(frozen=True)
class ConvergenceCost(Record):
    """What :func:`check_convergence` cost.

    Attributes
    ----------
    wall_seconds : float
        Integration of all samples.
    build_seconds : float
        Construction of the closed loop and the integrator.
    per_sample_seconds : float
        ``wall_seconds / n_samples``.
    """

    wall_seconds: float
    build_seconds: float
    per_sample_seconds: float


@dataclass
class ConvergenceReport(StatusResult):
    """Outcome of :func:`check_convergence`; ``status`` is ALL_CONVERGED or not.

    A measurement, not a solve: :func:`check_convergence` returns it whatever the samples
    did (the share that converged is the answer); :meth:`raise_for_status` raises when
    not every sample converged.

    Attributes
    ----------
    n_samples, n_converged, n_failed : int
        Samples, samples within ``tolerance`` of the target at the horizon, and samples
        whose integration failed or that left the domain (counted as not converged).
    distances : ndarray, shape=(n_samples,)
        Distance to the target at the horizon (``inf`` for failures).
    statuses : list of str
        ``"converged"``, ``"not converged"``, ``"left the domain by t = ..."`` or the
        integrator's error.
    worst_index : int
        Sample with the largest final distance.
    horizon, tolerance : float
        As given.
    confidence : float
        Level of :attr:`failure_rate_bound`.
    failure_rate_bound : float
        One-sided Clopper-Pearson upper bound on the probability that a sample from the
        same distribution does not converge.
    cost : ConvergenceCost
        ``wall_seconds``, ``build_seconds``, ``per_sample_seconds``.
    """

    n_samples: int
    n_converged: int
    n_failed: int
    distances: np.ndarray
    statuses: list[str]
    worst_index: int
    horizon: float
    tolerance: float
    confidence: float
    failure_rate_bound: float
    initial_states: np.ndarray
    cost: ConvergenceCost | dict[str, Any] = field(default_factory=dict)

    @property
    def all_converged(self) -> bool:
        """Whether every sample converged."""
        return self.n_converged == self.n_samples

    @property
    def status(self) -> ConvergenceStatus:
        """ALL_CONVERGED when every sample converged, else NOT_ALL_CONVERGED."""
        return (ConvergenceStatus.ALL_CONVERGED if self.all_converged
                else ConvergenceStatus.NOT_ALL_CONVERGED)

    def failure_message(self) -> str:  # noqa: D102
        return (f"{self.n_samples - self.n_converged} of {self.n_samples} samples did not "
                f"converge (worst final distance {self.worst_distance:.3g} > tolerance "
                f"{self.tolerance:g})")

    @property
    def worst_distance(self) -> float:
        """Largest final distance."""
        return float(self.distances[self.worst_index])

    def as_dict(self) -> dict[str, Any]:
        """Plain form (without the per-sample arrays)."""
        return {"n_samples": self.n_samples, "n_converged": self.n_converged,
                "n_failed": self.n_failed, "worst_distance": self.worst_distance,
                "worst_initial_state": self.initial_states[self.worst_index].tolist(),
                "horizon": self.horizon, "tolerance": self.tolerance,
                "confidence": self.confidence,
                "failure_rate_bound": self.failure_rate_bound, "cost": dict(self.cost)}


def check_convergence(
    model: Model,
    controller: ca.Function | None,
    initial_states: ArrayLike,
    *,
    distance: ca.Function,
    horizon: float,
    tolerance: float,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    max_steps: int = 20_000,
    check_interval: float = 1.0,
    domain: ca.Function | None = None,
    confidence: float = 0.95,
    multistep: Multistep = Multistep.ADAMS,
    corrector: Corrector | str | None = None,
) -> ConvergenceReport:
    """Integrate the closed loop from every initial state and test convergence.

    A sample converges when ``distance(x(horizon), p) <= tolerance``. The state is
    output on a grid of spacing at most ``check_interval``; a sample found outside
    ``domain`` (``b(x, p) >= 0``) at a grid time is reported as "left the domain", and an
    integrator failure (e.g. ``max_steps`` within one grid interval, near a singularity
    of the feedback) with its message. Both count as not converged.

    Parameters
    ----------
    model : Model
    controller : casadi.Function or None
        ``u = k(x, p)``.
    initial_states : array-like, shape=(n, ambient_dim)
        Each is checked to lie on the manifold.
    distance : casadi.Function
        ``(x, p) -> scalar`` distance to the target set.
    horizon : float
        Integration time.
    tolerance : float
        Convergence threshold on ``distance``.
    rtol, atol
        CVODES tolerances.
    max_steps : int
        CVODES' limit on steps per grid interval (a small value makes a sample that runs
        into a singularity fail fast).
    check_interval : float
        Longest grid interval.
    domain : casadi.Function, optional
        ``b(x, p)``; a sample with ``b >= 0`` at a grid time has left the domain (where
        the feedback may not be defined).
    confidence : float
        Level of the one-sided bound on the failure probability.
    multistep : Multistep
        CVODES' family (Adams for non-stiff closed loops, BDF for stiff ones).
    corrector : Corrector or str, optional
        CVODES' corrector, as in ``simulate``: functional (default with Adams) or Newton
        (default with BDF). On the cart's closed loop (600 samples) functional iteration
        took 7.2 s instead of 16.1 s with Newton, with the same 227 samples converging.

    Returns
    -------
    ConvergenceReport
    """
    X0 = as_states(model, initial_states, "initial_states")
    for i, x0 in enumerate(X0):
        model.check_state(x0, name=f"initial_states[{i}]")
    if not (np.isfinite(horizon) and horizon > 0):
        raise ParameterError(f"horizon must be positive; got {horizon!r}")
    opts = cvodes_options(multistep=multistep, corrector=corrector, rtol=rtol, atol=atol,
                          max_steps=max_steps, error=ParameterError)
    t0 = time.perf_counter()
    loop = closed_loop_function(model, controller)
    S = model.sym
    x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
    n_pieces = max(1, int(np.ceil(horizon / check_interval - 1e-12)))
    grid = np.linspace(0.0, float(horizon), n_pieces + 1)
    integ = ca.integrator("convergence", "cvodes", {"x": x, "p": p, "ode": loop(x, p)[0]},
                          0.0, grid[1:],
                          {**opts, "disable_internal_warnings": True})
    b_all = None if domain is None else domain.map(n_pieces)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    dist, statuses = np.full(len(X0), np.inf), []
    for i, x0 in enumerate(X0):
        try:
            xs = np.asarray(integ(x0=x0, p=model.p)["xf"])
        except RuntimeError as exc:
            statuses.append(f"integrator failed: {str(exc).splitlines()[-1][:200]}")
            continue
        if not np.all(np.isfinite(xs)):
            statuses.append("integrator failed: non-finite states")
            continue
        if b_all is not None:
            out = np.flatnonzero(np.asarray(b_all(xs, model.p)).ravel() >= 0)
            if out.size:
                statuses.append(f"left the domain by t = {grid[out[0] + 1]:.6g}")
                continue
        dist[i] = float(distance(xs[:, -1], model.p))
        statuses.append("converged" if dist[i] <= tolerance else "not converged")
    wall = time.perf_counter() - t0
    n_conv = statuses.count("converged")
    n_fail = sum(s.startswith(("integrator", "left")) for s in statuses)
    n = len(X0)
    from scipy.stats import beta  # here: scipy.stats takes 0.7 s to import

    bound = 1.0 if n_conv == 0 else float(beta.ppf(confidence, n - n_conv + 1, n_conv))
    return ConvergenceReport(n, n_conv, n_fail, dist, statuses, int(np.argmax(dist)),
                             float(horizon), float(tolerance), float(confidence), bound, X0,
                             ConvergenceCost(wall_seconds=wall, build_seconds=build,
                                             per_sample_seconds=wall / n))


# ----------------------------------------------------------------------------------------
# sampled basin against a certified set


@dataclass
class BasinEstimate:
    """Fractions of a proposal distribution: certified, converged, and their ratio.

    Attributes
    ----------
    n_samples : int
        Proposal samples simulated.
    n_membership : int
        Proposal samples tested for membership of the certified set.
    n_certified, n_converged : int
        Membership samples in the certified set; simulated samples that converged.
    n_certified_not_converged : int
        Simulated samples in the certified set that did not converge (0 if the
        certificate holds).
    certified_fraction, basin_fraction : (float, float, float)
        Estimate and two-sided Clopper-Pearson interval ``(p, lo, hi)``.
    ratio : (float, float, float)
        ``basin / certified`` volume ratio under the proposal, with the conservative
        interval ``(lo_basin / hi_cert, hi_basin / lo_cert)``.
    confidence : float
        Level of each interval.
    convergence : ConvergenceReport
    """

    n_samples: int
    n_membership: int
    n_certified: int
    n_converged: int
    n_certified_not_converged: int
    certified_fraction: tuple[float, float, float]
    basin_fraction: tuple[float, float, float]
    ratio: tuple[float, float, float]
    confidence: float
    convergence: ConvergenceReport

    def as_dict(self) -> dict[str, Any]:
        """Plain form."""
        return {"n_samples": self.n_samples, "n_membership": self.n_membership,
                "n_certified": self.n_certified,
                "n_converged": self.n_converged,
                "n_certified_not_converged": self.n_certified_not_converged,
                "certified_fraction": list(self.certified_fraction),
                "basin_fraction": list(self.basin_fraction), "ratio": list(self.ratio),
                "confidence": self.confidence, "convergence": self.convergence.as_dict()}


def estimate_basin(
    certified: SublevelSet,
    controller: ca.Function | None,
    samples: ArrayLike,
    *,
    distance: ca.Function,
    horizon: float,
    tolerance: float,
    confidence: float = 0.95,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    max_steps: int = 20_000,
    check_interval: float = 1.0,
    domain: ca.Function | None = None,
    membership_samples: ArrayLike | None = None,
) -> BasinEstimate:
    """Estimate how much larger the basin is than a certified set, by simulation.

    Every sample (drawn by the caller from a proposal distribution that covers the
    certified set) is simulated; the basin's share of the proposal is the converged
    fraction. The certified share is the fraction inside ``certified`` of
    ``membership_samples`` (further draws from the same proposal: membership costs no
    simulation, so a small certified set can be measured with many), or of ``samples``.

    Parameters
    ----------
    certified : SublevelSet
        The certified set.
    controller : casadi.Function or None
    samples : array-like, shape=(n, ambient_dim)
    membership_samples : array-like, shape=(m, ambient_dim), optional
        Draws from the same proposal for the certified share.
    distance, horizon, tolerance, rtol, atol, max_steps, check_interval, domain
        As in :func:`check_convergence`.
    confidence : float
        Level of the intervals.

    Returns
    -------
    BasinEstimate
    """
    model = certified.lyapunov.model
    X = as_states(model, samples)
    inside = certified.contains(X)
    rep = check_convergence(model, controller, X, distance=distance, horizon=horizon,
                            tolerance=tolerance, rtol=rtol, atol=atol, confidence=confidence,
                            max_steps=max_steps, check_interval=check_interval, domain=domain)
    conv = np.array([s == "converged" for s in rep.statuses])
    M = X if membership_samples is None else as_states(model, membership_samples)
    in_m = inside if membership_samples is None else certified.contains(M)
    n, m, nc, nb = len(X), len(M), int(in_m.sum()), int(conv.sum())
    cl, ch = clopper_pearson(nc, m, confidence=confidence)
    bl, bh = clopper_pearson(nb, n, confidence=confidence)
    ratio = ((nb / n) / (nc / m) if nc else float("inf"), bl / ch if ch > 0 else float("inf"),
             bh / cl if cl > 0 else float("inf"))
    return BasinEstimate(n, m, nc, nb, int((inside & ~conv).sum()), (nc / m, cl, ch),
                         (nb / n, bl, bh), ratio, float(confidence), rep)
