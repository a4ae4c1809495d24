"""Zeros of maps on manifolds: Newton's method with the retraction.

A *zero problem* (:class:`ZeroProblem`) is a smooth map ``F: P -> R^m`` on a product
manifold ``P``, written as one casadi graph that returns ``F``, its Jacobian (from
automatic differentiation) and optional scalar monitors. Its zeros are found by a damped
Gauss-Newton iteration *on the manifold* (:func:`newton_on_manifold`): at an iterate ``y``
with tangent basis ``N = tangent_basis(y)`` the step solves ``(dF/dy N) v = -F`` in the
least-squares, minimum-norm sense (singular values below ``rank_rtol`` times the largest
are dropped), and the next iterate is ``retract(y, lambda v)``, so every iterate is exactly
on ``P``. The minimum-norm step makes the iteration converge quadratically also where the
zeros are not isolated (a family of equilibria, a free cart position): it lands on the zero
set near the guess, and the rank of the Jacobian there gives the local dimension of the
zero set, ``dim P - rank``.

Failure is a status with a message (:class:`RootStatus`): iteration limit, stagnation of
``|F|`` (a local minimum of the residual that is not a zero: no zero near the guess),
divergence past a bound. Nothing is projected or retried silently.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._evaluator import DenseEvaluator
from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.manifolds import ProductManifold
from workbench.core.status import StatusEnum, StatusResult, raise_if
from workbench.core.types import ArrayLike, Matrix, Vector
from workbench.core.validate import count as check_count
from workbench.core.validate import positive as check_positive

__all__ = [
    "RootStatus",
    "Root",
    "DenseEvaluator",
    "ZeroProblem",
    "newton_on_manifold",
    "check_positive",
    "check_count",
]


class RootStatus(StatusEnum):
    """Outcome of a Newton solve; the value is a readable message, ``.code`` the short name.

    Attributes
    ----------
    CONVERGED
        ``max |F| <= tol``.
    MAX_ITERATIONS
        The iteration limit was reached with ``max |F| > tol``.
    STAGNATED
        No step along the Gauss-Newton direction decreases ``|F|``: a local minimum of the
        residual that is not a zero (there may be no zero near the guess, or none at all).
    DIVERGED
        An iterate left the declared bound or produced non-finite values.
    """

    CONVERGED = "converged: max |F| <= tol"
    MAX_ITERATIONS = "the iteration limit was reached with max |F| > tol"
    STAGNATED = ("stagnated: no step along the Gauss-Newton direction decreases |F| (a local "
                 "minimum of the residual that is not a zero)")
    DIVERGED = "diverged: an iterate left the bound or produced non-finite values"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"CONVERGED"})


@dataclass
class Root(StatusResult):
    """Result of :func:`newton_on_manifold`.

    Attributes
    ----------
    x : ndarray, shape=(ambient_dim,)
        The last iterate (a zero when ``status`` is CONVERGED), exactly on the manifold.
    status : RootStatus
    message : str
        What happened, in words.
    residual : float
        ``max |F(x)|``.
    iterations : int
        Newton steps taken.
    evaluations : int
        Evaluations of ``F`` and its Jacobian (line-search trials included).
    wall_time : float
        Seconds.
    singular_values : ndarray
        Of the tangent Jacobian ``dF/dy N`` at ``x`` (empty without diagnostics).
    rank : int
        Number of singular values above ``rank_rtol`` times the largest (-1 without
        diagnostics).
    local_dimension : int
        ``dim P - rank``: the dimension of the zero set near ``x`` when the rank is
        constant there (0 for an isolated zero; -1 without diagnostics).
    history : list of float
        ``max |F|`` at every iterate, starting with the guess.
    constraint_residual : float
        Max constraint residual of ``x`` on the manifold (nan without diagnostics).
    """

    x: Vector
    status: RootStatus
    message: str
    residual: float
    iterations: int
    evaluations: int
    wall_time: float
    singular_values: Vector
    rank: int
    local_dimension: int
    history: list[float] = field(default_factory=list)
    constraint_residual: float = 0.0

    def summary(self) -> dict[str, Any]:
        """Plain-data summary (no arrays but the point)."""
        return {
            "status": self.status.code,
            "message": self.message,
            "residual": self.residual,
            "constraint_residual": self.constraint_residual,
            "iterations": self.iterations,
            "evaluations": self.evaluations,
            "wall_time": self.wall_time,
            "rank": self.rank,
            "local_dimension": self.local_dimension,
            "x": self.x.tolist(),
        }


# ----------------------------------------------------------------------------------------
# zero problems


class ZeroProblem:
    """A smooth map ``F: P -> R^m`` on a product manifold, from one casadi graph.

    Parameters
    ----------
    name : str
        What is solved, for messages.
    manifold : ProductManifold
        The unknowns ``y``.
    function : casadi.Function
        ``(y, u, p) -> (F, dF/dy, m_1, ..., m_r)``: the residual (shape ``(m, 1)``), its
        Jacobian in ambient coordinates (``(m, ambient_dim)``) and scalar monitors.
    u : array-like
        Fixed value of the second input (the model input; may be empty).
    p : array-like
        Parameter values (third input).
    monitor_names : sequence of str
        Names of the monitor outputs, in order. Monitors are recorded along branches and
        their zero crossings can be located as events.
    state : callable, optional
        ``state(y) -> x``, the model state a point stands for (identity by default).
    model : Model, optional
        The model the graph comes from.
    """

    def __init__(
        self,
        *,
        name: str,
        manifold: ProductManifold,
        function: ca.Function,
        u: ArrayLike,
        p: ArrayLike,
        monitor_names: Sequence[str] = (),
        state: Callable[[Vector], Vector] | None = None,
        model: Model | None = None,
    ) -> None:
        if function.n_out() != 2 + len(monitor_names):
            raise ModelError(
                f"function must have 2 + {len(monitor_names)} outputs (F, dF/dy, monitors); "
                f"got {function.n_out()}"
            )
        self.name = name
        self.manifold = manifold
        self.function = function
        self.u = np.asarray(u, dtype=float).ravel()
        self.p = np.asarray(p, dtype=float).ravel()
        self.model = model
        self._state = state
        self._ev = DenseEvaluator(function)
        self.monitor_names: list[str] = list(monitor_names)
        self._last: tuple[bytes, tuple[np.ndarray, ...]] | None = None
        self._basis: Matrix | None = None
        self.evaluations = 0

    @classmethod
    def equilibria(cls, model: Model, *, u: ArrayLike | None = None) -> ZeroProblem:
        """Zeros of the model's vector field ``f(x, u, p)`` on its state manifold.

        The graph calls the model's cached ``f`` and ``f_x``; nothing is differentiated
        again.
        """
        uv = _check_input(model, u)
        f, fx = model.function("f"), model.function("f_x")
        x, uu, p = f.mx_in()
        fn = ca.Function("equilibria", [x, uu, p], [f(x, uu, p), fx(x, uu, p)],
                         ["y", "u", "p"], ["F", "D"])
        return cls(name=f"equilibria of {model.name}", manifold=model.manifold, function=fn,
                   u=uv, p=model.p, model=model)

    def _eval(self, y: ArrayLike) -> tuple[np.ndarray, ...]:
        yv = np.asarray(y, dtype=float).ravel()
        key = yv.tobytes()
        if self._last is None or self._last[0] != key:
            self.evaluations += 1
            self._last = (key, self._ev(yv, self.u, self.p))
            self._basis = None
        return self._last[1]

    def state(self, y: ArrayLike) -> Vector:
        """The model state a point stands for."""
        yv = np.asarray(y, dtype=float).ravel()
        return yv.copy() if self._state is None else np.asarray(self._state(yv), float).ravel()

    def residual(self, y: ArrayLike) -> Vector:
        """``F(y)``."""
        return self._eval(y)[0].copy()

    def linearization(self, y: ArrayLike) -> tuple[Vector, Matrix, Matrix]:
        """``F(y)``, the tangent Jacobian ``dF/dy N`` and the tangent basis ``N``."""
        out = self._eval(y)
        if self._basis is None:
            self._basis = self.manifold.tangent_basis(y)
        N = self._basis
        return out[0].copy(), out[1] @ N, N.copy()

    def monitor(self, name: str, y: ArrayLike) -> float:
        """Value of one monitor at ``y``."""
        if name not in self.monitor_names:
            raise ModelError(f"unknown monitor {name!r}; known: {self.monitor_names}")
        return float(self._eval(y)[2 + self.monitor_names.index(name)][0])

    def monitors(self, y: ArrayLike) -> dict[str, float]:
        """Values of all monitors at ``y``."""
        out = self._eval(y)
        return {k: float(out[2 + i][0]) for i, k in enumerate(self.monitor_names)}

    def with_parameters(self, p: ArrayLike) -> ZeroProblem:
        """The same problem with another parameter vector (graph shared)."""
        clone = object.__new__(ZeroProblem)
        clone.__dict__.update(self.__dict__)
        clone.p = np.asarray(p, dtype=float).ravel()
        clone._last = None
        clone.evaluations = 0
        return clone

    def __repr__(self) -> str:
        return f"ZeroProblem({self.name!r}, {self.manifold.describe()})"


def _check_input(model: Model, u: ArrayLike | None) -> Vector:
    if u is None:
        return np.zeros(model.n_inputs)
    try:
        uv = np.asarray(u, dtype=float).ravel()
    except (TypeError, ValueError) as exc:
        raise ModelError(f"u must be numeric with {model.n_inputs} entries; got {u!r}") from exc
    if uv.size != model.n_inputs:
        raise ModelError(
            f"u must have {model.n_inputs} entries for model {model.name!r}; "
            f"got shape {np.shape(u)}"
        )
    if not np.all(np.isfinite(uv)):
        raise ModelError(f"u must be finite; got {uv.tolist()}")
    return uv


# ----------------------------------------------------------------------------------------
# Newton on the manifold


def _rank(s: Vector, rank_rtol: float) -> int:
    if s.size == 0 or s[0] == 0.0:
        return 0
    return int(np.sum(s > rank_rtol * s[0]))


def newton_on_manifold(
    fun: Callable[[Vector], tuple[Vector, Matrix]],
    manifold: ProductManifold,
    x0: ArrayLike,
    *,
    tol: float = 1e-12,
    max_iterations: int = 50,
    rank_rtol: float = 1e-8,
    max_step: float | None = None,
    bound: Callable[[Vector], str | None] | None = None,
    min_damping: float = 1.0 / 1024,
    step_tol: float | None = None,
    diagnostics: bool = True,
    raise_on_failure: bool = True,
) -> Root:
    """Damped minimum-norm Gauss-Newton for ``F(y) = 0`` on a product manifold.

    Parameters
    ----------
    fun : callable
        ``fun(y) -> (F, A)`` with ``A = dF/dy N(y)`` the Jacobian in the tangent
        coordinates of ``manifold.tangent_basis(y)``.
    manifold : ProductManifold
        Where ``y`` lives; iterates move by ``manifold.retract``.
    x0 : array-like, shape=(ambient_dim,)
        Start, on the manifold (not checked here).
    tol : float
        Convergence when ``max |F| <= tol`` (absolute).
    max_iterations : int
        Iteration limit.
    rank_rtol : float
        Singular values below ``rank_rtol * sigma_max`` are treated as zero (in the step
        and in the reported rank).
    max_step : float, optional
        Largest tangent step norm (the step is scaled down to it).
    bound : callable, optional
        ``bound(y) -> message or None``; a message stops the iteration as DIVERGED.
    min_damping : float
        Smallest line-search factor tried before declaring STAGNATED.
    step_tol : float, optional
        Also converged when the Newton step norm falls below this and ``max |F|`` is
        below ``100 tol`` (the residual is then at its roundoff level; it is reported as
        it is).
    diagnostics : bool
        Compute the singular values, rank and constraint residual at the last iterate.
    raise_on_failure : bool
        Raise when the status is not CONVERGED (default); ``False`` returns the last
        iterate with its status (what a continuation corrector wants).

    Returns
    -------
    Root
        The status says what happened.

    Raises
    ------
    SolverError
        If it did not converge and ``raise_on_failure`` (the root is ``.result``).
    """
    t0 = time.perf_counter()
    y = np.asarray(x0, dtype=float).ravel().copy()
    F, A = fun(y)
    evals = 1
    r = float(np.max(np.abs(F))) if F.size else 0.0
    history = [r]
    status, message = RootStatus.MAX_ITERATIONS, ""
    it = 0
    if not np.all(np.isfinite(F)) or not np.all(np.isfinite(A)):
        status, message = RootStatus.DIVERGED, (
            "the residual or its Jacobian is not finite at the start (e.g. a singular solve "
            "inside the field there, such as a mass matrix singular at that state)")
    elif r <= tol:
        status = RootStatus.CONVERGED
    else:
        for it in range(1, max_iterations + 1):  # noqa: B007
            step = -np.linalg.lstsq(A, F, rcond=rank_rtol)[0]
            norm = float(np.linalg.norm(step))
            if step_tol is not None and norm <= step_tol and r <= 100 * tol:
                status = RootStatus.CONVERGED
                break
            if max_step is not None and norm > max_step:
                step *= max_step / norm
            f2 = float(F @ F)
            lam, accepted = 1.0, False
            while lam >= min_damping:
                y_try = manifold.retract(y, lam * step)
                F_try, A_try = fun(y_try)
                evals += 1
                if np.all(np.isfinite(F_try)) and float(F_try @ F_try) <= (1 - 1e-4 * lam) * f2:
                    accepted = True
                    break
                lam *= 0.5
            if not accepted:
                status = RootStatus.STAGNATED
                message = (
                    f"no decrease of |F| along the Gauss-Newton direction after {it - 1} "
                    f"steps: max |F| = {r:.3e} > tol {tol:.1e} at a local minimum of the "
                    f"residual; there is no zero near the guess"
                )
                if norm <= 1e-8 * max(1.0, float(np.linalg.norm(y))):
                    message += (
                        f", or, as the last Newton step is only {norm:.1e}, the residual is "
                        f"at its rounding level above tol (large or badly scaled F): "
                        f"try a larger tol"
                    )
                break
            y, F, A = y_try, F_try, A_try
            r = float(np.max(np.abs(F)))
            history.append(r)
            if bound is not None:
                why = bound(y)
                if why:
                    status, message = RootStatus.DIVERGED, f"iterate left the bound: {why}"
                    break
            if r <= tol:
                status = RootStatus.CONVERGED
                break
        else:
            message = (
                f"no convergence in {max_iterations} iterations: max |F| = {r:.3e} > tol "
                f"{tol:.1e} (residuals {', '.join(f'{h:.1e}' for h in history[-4:])})"
            )
    if status is RootStatus.CONVERGED:
        message = f"converged in {it} iterations to max |F| = {r:.2e}"
        if r > tol:
            message += f" (step below step_tol {step_tol:.1e}: roundoff level)"
    n = A.shape[1] if A.ndim == 2 else 0
    if diagnostics and np.all(np.isfinite(A)):
        s = np.linalg.svd(A, compute_uv=False) if A.size else np.zeros(0)
        rank = _rank(s, rank_rtol)
        cres = float(max(manifold.residual_norms(y).values(), default=0.0))
    elif diagnostics:  # a non-finite Jacobian (e.g. a mass matrix singular at y): no rank
        s, rank = np.full(min(A.shape) if A.ndim == 2 else 0, np.nan), -1
        cres = float(max(manifold.residual_norms(y).values(), default=0.0))
    else:
        s, rank, cres = np.zeros(0), -1, float("nan")
    root = Root(
        x=y,
        status=status,
        message=message,
        residual=r,
        iterations=it,
        evaluations=evals,
        wall_time=time.perf_counter() - t0,
        singular_values=s,
        rank=rank,
        local_dimension=n - rank if rank >= 0 else -1,
        history=history,
        constraint_residual=cres,
    )
    return raise_if(root, raise_on_failure)
