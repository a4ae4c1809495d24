"""Lyapunov functions as expressions of a model's state, differentiated along a closed loop.

A :class:`Lyapunov` is a scalar ``V(x, p)`` written once as a casadi expression of the
model's stored ambient state (by a builder ``ctx -> V``, like a model's invariants). Its
time derivative along the closed loop ``x-dot = f(x, k(x, p), p)`` is *not* written by
hand: :meth:`Lyapunov.derivative` differentiates the graph, ``V-dot = dV/dx . f``, with a
forward directional derivative (``casadi.jtimes``). Since ``f`` is tangent to the state
manifold, ``V-dot`` does not depend on how ``V`` is extended off the manifold.

Numeric helpers evaluate ``V`` and ``V-dot`` on batches of states and measure how far a
sampled trajectory departs from being non-increasing (:meth:`Lyapunov.monotonicity`).

Sublevel sets: :class:`SublevelSet` is ``{x : V(x) <= c}`` (or ``< c``), optionally
intersected with a domain ``D = {b(x) < 0}``, with membership and rejection sampling from
a proposal; :func:`ray_extent` measures its size along tangent rays from the equilibrium.
Certifying a level (with Ipopt) is in :mod:`workbench.control._attraction`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._model import BuildRecord, Context, Model
from workbench.core.errors import ModelError, SolverError
from workbench.core.types import ArrayLike
from workbench.simulation._simulate import Trajectory, closed_loop_function

__all__ = [
    "Lyapunov",
    "Monotonicity",
    "as_states",
    "state_function",
    "SublevelSet",
    "ray_extent",
]


def state_function(
    model: Model, name: str, build: Callable, out: str = "u", *, record: bool = True
) -> ca.Function:
    """Wrap ``build(ctx) -> expression`` into ``casadi.Function(name, [x, p], [out])``.

    For feedback laws and other expressions of a model's state (the papers' controllers
    in :mod:`models.controllers`). The expression is written on scalar (SX) symbols,
    whatever the model's symbol class, so it stays compact and exports to C; for an MX
    model the SX function is called on MX symbols (one call node). The build is recorded
    in the model's build log.

    Parameters
    ----------
    model : Model
        The model whose stored state and parameters are the inputs.
    name : str
        Function name (also the build-log entry ``<model>.<name>``).
    build : callable
        ``build(ctx) -> casadi SX`` with ``ctx`` a :class:`~workbench.core._model.Context` on SX
        symbols.
    out : str
        Name of the output.
    record : bool
        Whether to add the build to the model's build log.

    Returns
    -------
    casadi.Function
        ``(x, p) -> out``.
    """
    t0 = time.perf_counter()
    sx = Context(model, ca.SX.sym("x", model.manifold.ambient_dim),
                 ca.SX.sym("u", model.n_inputs), ca.SX.sym("p", model.n_params))
    core = ca.Function(name, [sx.x, sx.p], [ca.vec(build(sx))], ["x", "p"], [out],
                       {"cse": True})
    if model.symbolic == "MX":
        x, p = ca.MX.sym("x", model.manifold.ambient_dim), ca.MX.sym("p", model.n_params)
        fn = ca.Function(name, [x, p], [core(x, p)], ["x", "p"], [out])
    else:
        fn = core
    if record:
        model.build_log.add(BuildRecord(f"{model.name}.{name}", int(fn.n_nodes()),
                                        time.perf_counter() - t0, model.symbolic))
    return fn


def as_states(model: Model, states: ArrayLike, name: str = "states") -> np.ndarray:
    """Return a batch of stored states as an array of shape ``(n, ambient_dim)``, or raise."""
    X = np.atleast_2d(np.asarray(states, dtype=float))
    n = model.manifold.ambient_dim
    if X.ndim != 2 or X.shape[1] != n:
        raise ModelError(f"{name} must have shape (n, {n}) for model {model.name!r}; "
                         f"got {np.shape(states)}")
    if not np.all(np.isfinite(X)):
        bad = np.flatnonzero(~np.all(np.isfinite(X), axis=1))
        raise ModelError(f"{name} must be finite; rows {bad[:10].tolist()} of {len(X)} are not")
    return X


@dataclass(frozen=True)
class Monotonicity:
    """How far a sampled series ``V(t_k)`` is from non-increasing.

    Attributes
    ----------
    V0, Vf : float
        First and last values.
    max_increase : float
        ``max_k (V(t_{k+1}) - max_{j <= k} V(t_j))``, clipped below at 0: the largest rise
        above the running maximum (0 for a non-increasing series).
    relative_increase : float
        ``max_increase / max(|V0|, tiny)``.
    tolerance : float
        Allowed relative rise (integration error), as given.
    n_samples : int
        Number of samples.
    """

    V0: float
    Vf: float
    max_increase: float
    relative_increase: float
    tolerance: float
    n_samples: int

    @property
    def ok(self) -> bool:
        """Whether the relative rise is within the tolerance."""
        return self.relative_increase <= self.tolerance

    def as_dict(self) -> dict[str, Any]:
        """Plain form."""
        return {"V0": self.V0, "Vf": self.Vf, "max_increase": self.max_increase,
                "relative_increase": self.relative_increase, "tolerance": self.tolerance,
                "n_samples": self.n_samples, "ok": self.ok}


class Lyapunov:
    """A (candidate) Lyapunov function ``V(x, p)`` of a model.

    Parameters
    ----------
    model : Model
        The model on whose state ``V`` is defined.
    expression : callable
        ``expression(ctx) -> scalar casadi expression``; ``ctx`` is a
        :class:`~workbench.core._model.Context` (``ctx["omega"]``, ``ctx["J"]``, ...) on the
        model's symbol class.
    name : str
        Identifier, e.g. ``"V30"``.
    description : str
        What it is, with the paper and equation number.
    equation : str
        LaTeX of ``V`` (for reports).
    """

    def __init__(
        self,
        model: Model,
        expression: Callable[[Context], Any],
        *,
        name: str,
        description: str = "",
        equation: str = "",
    ) -> None:
        if not isinstance(model, Model):
            raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
        self.model = model
        self.expression = expression
        self.name = name
        self.description = description
        self.equation = equation
        self._cache: dict[Any, Any] = {}

    # graphs ----------------------------------------------------------------------------------

    def _record(self, key: str, fn: ca.Function, seconds: float) -> None:
        self.model.build_log.add(
            BuildRecord(f"{self.model.name}.{key}", int(fn.n_nodes()), seconds,
                        self.model.symbolic)
        )

    def _symbols(self) -> tuple[Any, Any, Any]:
        ctx = self.model.context()
        V = self.expression(ctx)
        if not hasattr(V, "shape") or V.shape != (1, 1):
            raise ModelError(
                f"Lyapunov expression {self.name!r} must be a scalar casadi expression; got "
                f"shape {getattr(V, 'shape', type(V).__name__)}"
            )
        return ctx.x, ctx.p, V

    def function(self) -> ca.Function:
        """``(x, p) -> V``, built once.

        Returns
        -------
        casadi.Function
        """
        if "V" not in self._cache:
            t0 = time.perf_counter()
            x, p, V = self._symbols()
            fn = ca.Function(self.name, [x, p], [V], ["x", "p"], ["V"])
            self._cache["V"] = fn
            self._record(self.name, fn, time.perf_counter() - t0)
        return self._cache["V"]

    def derivative(self, controller: ca.Function | None = None) -> ca.Function:
        """``(x, p) -> V-dot`` along the closed loop, by automatic differentiation.

        ``V-dot = dV/dx(x) . f(x, k(x, p), p)``, a forward directional derivative of the
        graph of ``V`` in the direction of the closed-loop field (``u = 0`` without a
        controller). Built once per controller.

        Parameters
        ----------
        controller : casadi.Function, optional
            ``u = k(x)`` or ``k(x, p)``.

        Returns
        -------
        casadi.Function
        """
        key = ("Vdot", id(controller))
        if key not in self._cache:
            t0 = time.perf_counter()
            loop = closed_loop_function(self.model, controller)
            x, p, V = self._symbols()
            xdot = loop(x, p)[0]
            Vdot = ca.jtimes(V, x, xdot)
            cname = "open_loop" if controller is None else controller.name()
            fn = ca.Function(f"{self.name}_dot_{cname}", [x, p], [Vdot], ["x", "p"], ["Vdot"])
            self._cache[key] = (fn, controller)  # keep the controller alive with its id
            self._record(fn.name(), fn, time.perf_counter() - t0)
        return self._cache[key][0]

    # numbers ---------------------------------------------------------------------------------

    def _batch(self, fn: ca.Function, states: ArrayLike) -> np.ndarray:
        X = as_states(self.model, states)
        key = ("map", id(fn), X.shape[0])  # fn is kept alive by the cache of its builder
        if key not in self._cache:  # building a map costs more than evaluating it
            self._cache[key] = fn.map(X.shape[0])
        return np.asarray(self._cache[key](X.T, self.model.p)).ravel()

    def values(self, states: ArrayLike) -> np.ndarray:
        """``V`` at a batch of states.

        Parameters
        ----------
        states : array-like, shape=(n, ambient_dim) or (ambient_dim,)

        Returns
        -------
        ndarray, shape=(n,)
        """
        return self._batch(self.function(), states)

    def derivative_values(
        self, states: ArrayLike, controller: ca.Function | None = None
    ) -> np.ndarray:
        """``V-dot`` along the closed loop at a batch of states.

        Parameters
        ----------
        states : array-like, shape=(n, ambient_dim) or (ambient_dim,)
        controller : casadi.Function, optional

        Returns
        -------
        ndarray, shape=(n,)
        """
        return self._batch(self.derivative(controller), states)

    def monotonicity(self, trajectory: Trajectory, *, tolerance: float = 1e-8) -> Monotonicity:
        """Measure how far ``V`` along a simulated trajectory is from non-increasing.

        Parameters
        ----------
        trajectory : Trajectory
            A trajectory of this Lyapunov function's model.
        tolerance : float
            Allowed rise relative to ``|V(0)|`` (integration error); only used for
            :attr:`Monotonicity.ok`.

        Returns
        -------
        Monotonicity
        """
        if trajectory.model.manifold.ambient_dim != self.model.manifold.ambient_dim:
            raise ModelError(
                f"trajectory of {trajectory.model.name!r} does not match the state of "
                f"{self.model.name!r}"
            )
        V = self.values(trajectory.x)
        running = np.maximum.accumulate(V)
        rise = float(max(0.0, np.max(V[1:] - running[:-1]))) if V.size > 1 else 0.0
        scale = max(abs(float(V[0])), np.finfo(float).tiny)
        return Monotonicity(float(V[0]), float(V[-1]), rise, rise / scale, float(tolerance),
                            int(V.size))

    def __repr__(self) -> str:
        return f"Lyapunov({self.name!r} on {self.model.name!r})"


# ----------------------------------------------------------------------------------------
# sublevel sets


@dataclass
class SublevelSet:
    """``{x : V(x) <= level}`` (``< level`` if ``strict``), intersected with ``{b(x) < 0}``.

    Attributes
    ----------
    lyapunov : Lyapunov
        The function ``V``.
    level : float
        The level ``c``.
    strict : bool
        Strict inequality ``V < c``.
    domain : casadi.Function, optional
        ``b(x, p)``; the set is intersected with ``D = {b < 0}``.
    """

    lyapunov: Lyapunov
    level: float
    strict: bool = False
    domain: ca.Function | None = None
    _domain_maps: dict[tuple[int, int], tuple[Any, Any]] = field(
        default_factory=dict, init=False, repr=False, compare=False)

    def contains(self, states: ArrayLike) -> np.ndarray:
        """Membership of a batch of states.

        Parameters
        ----------
        states : array-like, shape=(n, ambient_dim)

        Returns
        -------
        ndarray of bool, shape=(n,)
        """
        model = self.lyapunov.model
        X = as_states(model, states)
        V = self.lyapunov.values(X)
        inside = V < self.level if self.strict else V <= self.level
        if self.domain is not None:
            # building a map costs more than evaluating it: kept per (domain, batch size),
            # the domain held with it so that its id stays unique
            key = (id(self.domain), X.shape[0])
            hit = self._domain_maps.get(key)
            if hit is None:
                if len(self._domain_maps) >= 16:
                    self._domain_maps.pop(next(iter(self._domain_maps)))
                hit = (self.domain, self.domain.map(X.shape[0]))
                self._domain_maps[key] = hit
            b = np.asarray(hit[1](X.T, model.p)).ravel()
            inside &= b < 0
        return inside

    def sample(
        self,
        proposal: Callable[[np.random.Generator, int], np.ndarray],
        n: int,
        *,
        seed: int = 0,
        batch: int = 1000,
        max_draws: int = 1_000_000,
    ) -> tuple[np.ndarray, int]:
        """Rejection-sample ``n`` states of the set from a proposal distribution.

        Parameters
        ----------
        proposal : callable
            ``proposal(rng, k) -> ndarray, shape=(k, ambient_dim)`` of states on the manifold.
        n : int
            Number of samples wanted.
        seed : int
            Seed of the generator handed to ``proposal``.
        batch : int
            Proposals drawn per round.
        max_draws : int
            Give up (``SolverError``) after this many proposals.

        Returns
        -------
        samples : ndarray, shape=(n, ambient_dim)
            Accepted states, samples of the proposal conditioned on the set.
        draws : int
            Number of proposals drawn (acceptance rate ``n / draws`` at the last round).
        """
        rng = np.random.default_rng(seed)
        kept: list[np.ndarray] = []
        draws = 0
        while sum(len(k) for k in kept) < n:
            if draws >= max_draws:
                raise SolverError(
                    f"rejection sampling accepted {sum(len(k) for k in kept)} of {n} states "
                    f"in {draws} proposals; widen or move the proposal", status="max_draws")
            X = as_states(self.lyapunov.model, proposal(rng, batch), "proposal(rng, k)")
            draws += len(X)
            kept.append(X[self.contains(X)])
        return np.concatenate(kept)[:n], draws


def ray_extent(
    sublevel: SublevelSet,
    x_e: ArrayLike,
    directions: ArrayLike,
    *,
    s_max: float,
    n_grid: int = 2000,
    rtol: float = 1e-10,
) -> np.ndarray:
    """Distance from an equilibrium to the first exit from a set along tangent rays.

    Along each ray ``s -> retract(x_e, s d)`` (``d`` a tangent direction in the manifold's
    tangent coordinates at ``x_e``, normalised) membership is scanned on ``n_grid``
    points up to ``s_max``; the first change from inside to outside is refined by
    bisection to ``rtol * s_max``. A ray that never leaves gives ``inf`` (the set
    reaches beyond ``s_max``). A size measure that needs no optimisation (the set need
    not be star-shaped: the first exit is reported).

    Parameters
    ----------
    sublevel : SublevelSet
    x_e : array-like, shape=(ambient_dim,)
        A point of the set (the equilibrium).
    directions : array-like, shape=(n_rays, dim)
        Tangent directions (coordinates in the manifold's tangent basis at ``x_e``).
    s_max : float
        Largest ray parameter scanned.
    n_grid : int
        Scan points per ray.
    rtol : float
        Bisection tolerance relative to ``s_max``.

    Returns
    -------
    ndarray, shape=(n_rays,)
    """
    model = sublevel.lyapunov.model
    xe = model.check_state(x_e, name="x_e")
    D = np.atleast_2d(np.asarray(directions, dtype=float))
    if D.shape[1] != model.manifold.dim:
        raise ModelError(f"directions must have {model.manifold.dim} columns (tangent "
                         f"coordinates); got shape {D.shape}")
    if not sublevel.contains(xe)[0]:
        raise ModelError("x_e must lie in the set")
    out = np.full(len(D), np.inf)
    grid = np.linspace(0.0, float(s_max), int(n_grid) + 1)
    for k, d in enumerate(D):
        d = d / np.linalg.norm(d)

        def point(s: float, d: np.ndarray = d) -> np.ndarray:
            return model.manifold.retract(xe, s * d)

        inside = sublevel.contains(np.array([point(s) for s in grid]))
        if inside.all():
            continue
        j = int(np.argmin(inside))
        lo, hi = grid[j - 1], grid[j]
        while hi - lo > rtol * s_max:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if sublevel.contains(point(mid))[0] else (lo, mid)
        out[k] = 0.5 * (lo + hi)
    return out
