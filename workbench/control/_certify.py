"""Extrema of functions on the state manifold with Ipopt: the certification of sublevel sets.

* :func:`optimize` / :func:`optimize_lyapunov` -- extremise a function (``V``) over the
  state manifold under constraints with Ipopt, from several starts (a local solver: the
  global optimum is not guaranteed; every start's Ipopt status is reported);
* :func:`level_in_domain` -- the minimum of ``V`` on the boundary ``b = 0`` of a domain:
  every level below it gives a sublevel set (its component through the equilibrium)
  inside ``D``.

The result, :class:`Extremum`, follows the status protocol of
:mod:`workbench.core.status` (:class:`ExtremumStatus`, ``.ok``, a typed
:class:`OptimizeCost`); a program that fails from every start raises unless
``raise_on_failure=False``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.control._lyapunov import Lyapunov, as_states
from workbench.core._model import Model
from workbench.core.errors import SolverError
from workbench.core.status import Record, StatusEnum, StatusResult
from workbench.core.types import ArrayLike

__all__ = [
    "Constraint",
    "ExtremumStatus",
    "OptimizeCost",
    "Extremum",
    "optimize",
    "optimize_lyapunov",
    "level_in_domain",
]


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


class ExtremumStatus(StatusEnum):
    """Outcome of :func:`optimize`; the value is a readable message."""

    SOLVED = "Ipopt solved the program from at least one start (the best is reported)"
    FAILED = "Ipopt failed from every start"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"SOLVED"})


@dataclass(frozen=True)
class OptimizeCost(Record):
    """What :func:`optimize` cost.

    Attributes
    ----------
    wall_seconds : float
        All starts.
    iterations : int
        Ipopt iterations, summed over the starts.
    """

    wall_seconds: float
    iterations: int


@dataclass
class Extremum(StatusResult):
    """Best point found by :func:`optimize_lyapunov`.

    Attributes
    ----------
    value : float
        ``V`` at the best point.
    x : ndarray, shape=(ambient_dim,)
        The best point.
    ipopt_status : str
        Ipopt's return status at the best start.
    statuses : list of str
        Return status of every start.
    n_success : int
        Starts that Ipopt solved.
    values : list of float
        ``V`` at the end of every start (NaN when it failed).
    constraint_violation : float
        Max violation of the manifold and user constraints at the best point.
    cost : OptimizeCost
        ``wall_seconds``, ``iterations`` (sum over starts).
    status : ExtremumStatus
        SOLVED, or FAILED (returned only with ``raise_on_failure=False``).
    """

    value: float
    x: np.ndarray
    ipopt_status: str
    statuses: list[str]
    n_success: int
    values: list[float]
    constraint_violation: float
    cost: OptimizeCost | dict[str, Any] = field(default_factory=dict)
    status: ExtremumStatus = ExtremumStatus.SOLVED

    @property
    def iterations(self) -> int:
        """Ipopt iterations, summed over the starts."""
        return int(self.cost.get("iterations", 0))

    def failure_message(self) -> str:  # noqa: D102
        return (f"Ipopt failed from all {len(self.statuses)} starts "
                f"(statuses: {', '.join(sorted(set(self.statuses)))})")

    @property
    def spread(self) -> float:
        """Range of the values reached by the successful starts (0 if they agree)."""
        v = np.asarray([x for x in self.values if np.isfinite(x)])
        return float(v.max() - v.min()) if v.size else float("nan")

    def as_dict(self) -> dict[str, Any]:
        """Plain form."""
        return {"value": self.value, "x": self.x.tolist(), "status": self.status.code,
                "ipopt_status": self.ipopt_status,
                "statuses": self.statuses, "n_success": self.n_success,
                "spread": self.spread, "constraint_violation": self.constraint_violation,
                "cost": dict(self.cost)}


def optimize(
    model: Model,
    objective: ca.Function,
    starts: ArrayLike,
    *,
    maximize: bool = False,
    constraints: Sequence[Constraint] = (),
    tol: float = 1e-10,
    max_iter: int = 500,
    raise_on_failure: bool = True,
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
    raise_on_failure : bool
        Raise when no start succeeds (default); ``False`` returns an :class:`Extremum`
        with status FAILED, value NaN and the first start as ``x``.

    Returns
    -------
    Extremum

    Raises
    ------
    SolverError
        If no start succeeds and ``raise_on_failure`` (with every start's Ipopt status).
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
    cost = OptimizeCost(wall_seconds=wall, iterations=iters)
    if best is None:
        if raise_on_failure:
            raise SolverError(
                f"Ipopt failed from all {len(X0)} starts optimising {objective.name()}",
                status=", ".join(sorted(set(statuses))))
        return Extremum(float("nan"), X0[0].copy(), statuses[-1], statuses, 0, values,
                        float("nan"), cost, ExtremumStatus.FAILED)
    g = np.asarray(gfun(best[1], model.p)).ravel()
    viol = float(np.max(np.maximum(0.0, np.maximum(lbg - g, g - ubg)))) if g.size else 0.0
    return Extremum(best[0], best[1], best[2], statuses, int(np.isfinite(values).sum()),
                    values, viol, cost)


def optimize_lyapunov(
    lyapunov: Lyapunov,
    starts: ArrayLike,
    *,
    maximize: bool = False,
    constraints: Sequence[Constraint] = (),
    tol: float = 1e-10,
    max_iter: int = 500,
    raise_on_failure: bool = True,
) -> Extremum:
    """Minimise (or maximise) ``V`` over the state manifold: :func:`optimize` with ``V``.

    Parameters
    ----------
    lyapunov : Lyapunov
        The objective ``V``.
    starts, maximize, constraints, tol, max_iter, raise_on_failure
        As in :func:`optimize`.

    Returns
    -------
    Extremum
    """
    return optimize(lyapunov.model, lyapunov.function(), starts, maximize=maximize,
                    constraints=constraints, tol=tol, max_iter=max_iter,
                    raise_on_failure=raise_on_failure)


def level_in_domain(
    lyapunov: Lyapunov,
    boundary: ca.Function,
    starts: ArrayLike,
    *,
    tol: float = 1e-10,
    max_iter: int = 500,
    raise_on_failure: bool = True,
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
    raise_on_failure : bool
        As in :func:`optimize`.

    Returns
    -------
    Extremum
    """
    return optimize_lyapunov(
        lyapunov, starts, maximize=False, tol=tol, max_iter=max_iter,
        constraints=[Constraint(boundary, 0.0, 0.0, "boundary of D")],
        raise_on_failure=raise_on_failure)
