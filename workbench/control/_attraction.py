"""Domains of attraction: certified sublevel sets (Ipopt) and sampled basins (simulation).

Certification (sublevel sets :class:`~workbench.control._lyapunov.SublevelSet` of a Lyapunov
function inside a domain):

* :func:`optimize` / :func:`optimize_lyapunov` -- extremise a function (``V``) over the
  state manifold under constraints with Ipopt, from several starts (a local solver: the
  global optimum is not guaranteed; every start's Ipopt status is reported);
* :func:`level_in_domain` -- the minimum of ``V`` on the boundary ``b = 0`` of a domain:
  every level below it gives a sublevel set (its component through the equilibrium)
  inside ``D``;
* :func:`~workbench.control._lyapunov.ray_extent` measures a set's size along tangent rays.

Testing and estimation by integrating the closed loop from many initial states:

* :func:`check_convergence` -- integrate the closed loop from many initial states and
  report how many reach a target, the worst case, and a one-sided Clopper-Pearson bound
  on the failure probability under the sampling distribution.
* :func:`estimate_basin` -- the fraction of proposal samples that converge against the
  fraction in a certified set, with binomial confidence intervals.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from scipy.stats import beta

from workbench.control._lyapunov import Lyapunov, SublevelSet, as_states
from workbench.core._model import Model
from workbench.core.errors import ParameterError, SolverError
from workbench.core.types import ArrayLike
from workbench.core.validate import choice
from workbench.simulation._simulate import Multistep, closed_loop_function

__all__ = [
    "Constraint",
    "Extremum",
    "optimize",
    "optimize_lyapunov",
    "level_in_domain",
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
    a = 1 - confidence
    lo = 0.0 if k == 0 else float(beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


# ----------------------------------------------------------------------------------------
# optimisation of V with Ipopt


@dataclass(frozen=True)
class Constraint:
    """``lower <= g(x, p) <= upper`` for a casadi.Function ``g``.

    Attributes
    ----------
    function : casadi.Function
        ``(x, p) -> g`` (any column size).
    lower, upper : float or array-like
        Bounds (``-inf`` / ``inf`` for one-sided, equal for equality).
    description : str
        What it says, for reports.
    """

    function: ca.Function
    lower: Any
    upper: Any
    description: str = ""


@dataclass
class Extremum:
    """Best point found by :func:`optimize_lyapunov`.

    Attributes
    ----------
    value : float
        ``V`` at the best point.
    x : ndarray, shape=(ambient_dim,)
        The best point.
    status : str
        Ipopt's return status at the best start.
    statuses : list of str
        Return status of every start.
    n_success : int
        Starts that Ipopt solved.
    values : list of float
        ``V`` at the end of every start (NaN when it failed).
    constraint_violation : float
        Max violation of the manifold and user constraints at the best point.
    cost : dict
        ``wall_seconds``, ``iterations`` (sum over starts).
    """

    value: float
    x: np.ndarray
    status: str
    statuses: list[str]
    n_success: int
    values: list[float]
    constraint_violation: float
    cost: dict[str, Any] = field(default_factory=dict)

    @property
    def spread(self) -> float:
        """Range of the values reached by the successful starts (0 if they agree)."""
        v = np.asarray([x for x in self.values if np.isfinite(x)])
        return float(v.max() - v.min()) if v.size else float("nan")

    def as_dict(self) -> dict[str, Any]:
        """Plain form."""
        return {"value": self.value, "x": self.x.tolist(), "status": self.status,
                "statuses": self.statuses, "n_success": self.n_success,
                "spread": self.spread, "constraint_violation": self.constraint_violation,
                "cost": self.cost}


def optimize(
    model: Model,
    objective: ca.Function,
    starts: ArrayLike,
    *,
    maximize: bool = False,
    constraints: Sequence[Constraint] = (),
    tol: float = 1e-10,
    max_iter: int = 500,
) -> Extremum:
    """Minimise (or maximise) ``objective(x, p)`` over the state manifold with Ipopt.

    The decision variable is the stored ambient state; the manifold's constraints
    ``h(x) = 0`` are equality constraints, the user's constraints are added. Ipopt is a
    local solver: it is run from every start, and every start's status is reported.

    Parameters
    ----------
    model : Model
        The model whose state is optimised (its current parameters are used).
    objective : casadi.Function
        ``(x, p) -> scalar``.
    starts : array-like, shape=(n_starts, ambient_dim)
        Initial guesses.
    maximize : bool
        Maximise instead of minimise.
    constraints : sequence of Constraint
        Further constraints.
    tol : float
        Ipopt ``tol``.
    max_iter : int
        Ipopt ``max_iter``.

    Returns
    -------
    Extremum

    Raises
    ------
    SolverError
        If no start succeeds (with every start's Ipopt status).
    """
    X0 = as_states(model, starts, "starts")
    S = model.sym
    x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
    F = objective(x, p)
    xs = ca.SX.sym("x", model.manifold.ambient_dim)  # residual on SX, called on x
    h = ca.Function("h", [xs], [model.manifold.residual(xs)])
    gs, lb, ub = [h(x)], [], []
    nres = gs[0].shape[0]
    lb.append(np.zeros(nres))
    ub.append(np.zeros(nres))
    for c in constraints:
        gi = c.function(x, p)
        k = gi.shape[0]
        gs.append(gi)
        lb.append(np.broadcast_to(np.asarray(c.lower, float), (k,)))
        ub.append(np.broadcast_to(np.asarray(c.upper, float), (k,)))
    lbg, ubg = np.concatenate(lb), np.concatenate(ub)
    nlp = {"x": x, "p": p, "f": -F if maximize else F, "g": ca.vertcat(*gs)}
    solver = ca.nlpsol("extremum", "ipopt", nlp, {
        "ipopt.tol": tol, "ipopt.max_iter": int(max_iter), "ipopt.print_level": 0,
        "print_time": False, "ipopt.sb": "yes"})
    gfun = ca.Function("g", [x, p], [nlp["g"]])
    best: tuple[float, np.ndarray, str] | None = None
    statuses, values, iters = [], [], 0
    t0 = time.perf_counter()
    for x0 in X0:
        sol = solver(x0=x0, p=model.p, lbg=lbg, ubg=ubg)
        st = solver.stats()
        statuses.append(str(st["return_status"]))
        iters += int(st.get("iter_count", 0))
        xv = np.asarray(sol["x"]).ravel()
        if not st["success"]:
            values.append(float("nan"))
            continue
        val = float(objective(xv, model.p))
        values.append(val)
        if best is None or (val > best[0] if maximize else val < best[0]):
            best = (val, xv, statuses[-1])
    wall = time.perf_counter() - t0
    if best is None:
        raise SolverError(
            f"Ipopt failed from all {len(X0)} starts optimising {objective.name()}",
            status=", ".join(sorted(set(statuses))))
    g = np.asarray(gfun(best[1], model.p)).ravel()
    viol = float(np.max(np.maximum(0.0, np.maximum(lbg - g, g - ubg)))) if g.size else 0.0
    return Extremum(best[0], best[1], best[2], statuses, int(np.isfinite(values).sum()),
                    values, viol, {"wall_seconds": wall, "iterations": iters})


def optimize_lyapunov(
    lyapunov: Lyapunov,
    starts: ArrayLike,
    *,
    maximize: bool = False,
    constraints: Sequence[Constraint] = (),
    tol: float = 1e-10,
    max_iter: int = 500,
) -> Extremum:
    """Minimise (or maximise) ``V`` over the state manifold: :func:`optimize` with ``V``.

    Parameters
    ----------
    lyapunov : Lyapunov
        The objective ``V``.
    starts, maximize, constraints, tol, max_iter
        As in :func:`optimize`.

    Returns
    -------
    Extremum
    """
    return optimize(lyapunov.model, lyapunov.function(), starts, maximize=maximize,
                    constraints=constraints, tol=tol, max_iter=max_iter)


def level_in_domain(
    lyapunov: Lyapunov,
    boundary: ca.Function,
    starts: ArrayLike,
    *,
    tol: float = 1e-10,
    max_iter: int = 500,
) -> Extremum:
    """Minimum of ``V`` on the boundary ``b(x) = 0`` of a domain ``D = {b < 0}``.

    If the equilibrium lies in ``D``, every path from it that leaves ``D`` crosses the
    boundary, where ``V >= c_min``; so for every ``c <= c_min`` the component of
    ``{V < c}`` through the equilibrium lies in ``D``. Ipopt is local: the minimum is
    sought from several starts and their spread is reported.

    Parameters
    ----------
    lyapunov : Lyapunov
    boundary : casadi.Function
        ``b(x, p)``, scalar.
    starts : array-like, shape=(n_starts, ambient_dim)
        Initial guesses (need not satisfy ``b = 0``).
    tol, max_iter
        Ipopt options.

    Returns
    -------
    Extremum
    """
    return optimize_lyapunov(
        lyapunov, starts, maximize=False, tol=tol, max_iter=max_iter,
        constraints=[Constraint(boundary, 0.0, 0.0, "boundary of D")])


# ----------------------------------------------------------------------------------------
# Monte-Carlo convergence


@dataclass
class ConvergenceReport:
    """Outcome of :func:`check_convergence`.

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
    cost : dict
        ``wall_seconds``, ``build_seconds``.
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
    cost: dict[str, Any] = field(default_factory=dict)

    @property
    def all_converged(self) -> bool:
        """Whether every sample converged."""
        return self.n_converged == self.n_samples

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
                "failure_rate_bound": self.failure_rate_bound, "cost": self.cost}


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

    Returns
    -------
    ConvergenceReport
    """
    X0 = as_states(model, initial_states, "initial_states")
    for i, x0 in enumerate(X0):
        model.check_state(x0, name=f"initial_states[{i}]")
    if not (np.isfinite(horizon) and horizon > 0):
        raise ParameterError(f"horizon must be positive; got {horizon!r}")
    multistep = choice(Multistep, multistep, "multistep")
    t0 = time.perf_counter()
    loop = closed_loop_function(model, controller)
    S = model.sym
    x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
    n_pieces = max(1, int(np.ceil(horizon / check_interval - 1e-12)))
    grid = np.linspace(0.0, float(horizon), n_pieces + 1)
    integ = ca.integrator("convergence", "cvodes", {"x": x, "p": p, "ode": loop(x, p)[0]},
                          0.0, grid[1:],
                          {"abstol": atol, "reltol": rtol, "max_num_steps": int(max_steps),
                           "disable_internal_warnings": True,
                           "linear_multistep_method": multistep.value})
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
    bound = 1.0 if n_conv == 0 else float(beta.ppf(confidence, n - n_conv + 1, n_conv))
    return ConvergenceReport(n, n_conv, n_fail, dist, statuses, int(np.argmax(dist)),
                             float(horizon), float(tolerance), float(confidence), bound, X0,
                             {"wall_seconds": wall, "build_seconds": build,
                              "per_sample_seconds": wall / n})


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
