"""The declarative optimal control problem: dynamics, boundary conditions, costs, bounds.

An :class:`OCP` states *what* is to be optimised; a transcription
(:class:`~workbench.control.ocp.transcription.Collocation` or
:class:`~workbench.control.ocp.transcription.MultipleShooting`) and a manifold handling say *how*.

Boundary conditions are imposed through charts, as independent equations only. The state
lives on a manifold of dimension ``n`` inside an ambient space of dimension ``N > n``; the
transcription carries the ``N - n`` constraints (``|q| = 1``, ``q . w = 0``,
``R^T R = I``) through the dynamics. Demanding an ambient equality such as ``q_N = -e3``
adds ``N`` equations where only ``n`` are independent, and Ipopt then reports the problem
infeasible or fails to converge (LICQ does not hold). A terminal condition is therefore
written as ``chart(y*, phi(x_N)) = 0`` with ``phi: M -> P`` a submersion onto a target
manifold ``P`` (the identity for a target point, ``(R, omega) -> (R^T e3, omega)`` for the
inverted equilibrium manifold of the 3D pendulum), which is ``dim P`` equations; their
independence is verified at a witness point before anything is solved. A chart is only
injective on a neighbourhood (the S^2 chart ``B^T (q* x q)`` vanishes at ``q = -q*`` too);
the neighbourhood is imposed as inequalities (``q* . q >= 0``, ``tr(R*^T R) >= 1``) that are
inactive at a solution.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import FrozenInstanceError, dataclass, field, fields
from typing import Any

import casadi as ca
import numpy as np

from workbench.control.ocp._chart_domain import chart_domain
from workbench.control.ocp._immutable import Remade, frozen, frozen_bound
from workbench.core import validate
from workbench.core._model import Model
from workbench.core.errors import ManifoldError, ModelError, ParameterError
from workbench.core.manifolds import DEFAULT_TOL, ProductManifold
from workbench.core.types import ArrayLike, Expr, Vector

__all__ = ["OCP", "TargetPoint", "TargetSet", "PathConstraint", "chart_domain"]

CostFn = Callable[[Any, Any], Any]
"""``L(x, u)``: a scalar casadi expression of the symbolic state and input."""


def _last_line(exc: BaseException) -> str:
    """The last line of an exception's message (casadi's are long)."""
    lines = str(exc).strip().splitlines()
    return lines[-1] if lines else repr(exc)


class Target:
    """A terminal set ``{x : chart(y*, phi(x)) = 0}`` (base of the two target kinds)."""

    manifold: ProductManifold
    value: Vector
    witness: Vector
    description: str

    def phi(self, x: Expr) -> Expr:
        """The map from the model's state to the target manifold."""
        raise NotImplementedError

    def equations(self, x: Expr) -> Expr:
        """``chart(y*, phi(x))``: ``dim P`` independent equations, zero on the set."""
        return self.manifold.chart(self.value, self.phi(x))

    def domain(self, x: Expr) -> list[Expr]:
        """Inequalities ``>= 0`` keeping ``phi(x)`` where the chart is injective."""
        return chart_domain(self.manifold, self.value, self.phi(x))

    def distance(self, x: ArrayLike) -> float:
        """``|chart(y*, phi(x))|`` at a numeric state (max-norm)."""
        xs = ca.DM(np.asarray(x, float).ravel())
        return float(np.max(np.abs(np.asarray(ca.evalf(self.equations(xs)), float))))

    def validate(self, model: Model, *, tol: float = DEFAULT_TOL) -> None:
        """Check the set is consistent and its equations independent, before any solve.

        Raises
        ------
        ManifoldError
            If the target value is off the target manifold, the witness off the model's
            manifold or not in the set, or the equations are not independent at the witness.
        """
        self.manifold.check(self.value, name="target value", tol=tol)
        model.manifold.check(self.witness, name="target witness", tol=tol)
        x = ca.SX.sym("x", model.manifold.ambient_dim)
        try:
            y = self.phi(x)
        except Exception as exc:  # noqa: BLE001 - re-raised with context
            raise ModelError(f"target map phi failed on the model's state: {exc}") from exc
        if y.numel() != self.manifold.ambient_dim:
            raise ModelError(
                f"target map phi must return {self.manifold.ambient_dim} numbers "
                f"({self.manifold.describe()}); got {y.numel()}"
            )
        yw = np.asarray(ca.Function("phi", [x], [y])(self.witness), float).ravel()
        self.manifold.check(yw, name="phi(target witness)", tol=max(tol, 1e-9))
        res = float(np.max(np.abs(yw - self.value)))
        if res > 1e-8:
            raise ManifoldError(
                f"target witness is not in the target set {self.description}: "
                f"|phi(witness) - y*| = {res:.3g}"
            )
        Nw = model.manifold.tangent_basis(self.witness)
        J = np.asarray(ca.Function("J", [x], [ca.jacobian(self.equations(x), x)])(self.witness))
        sv = np.linalg.svd(J @ Nw, compute_uv=False)
        rank = int(np.sum(sv > 1e-9 * max(sv.max(initial=0.0), 1.0)))
        if rank < self.manifold.dim:
            raise ManifoldError(
                f"target {self.description}: its {self.manifold.dim} equations are not "
                f"independent on the state manifold (rank {rank} at the witness); phi must "
                f"be a submersion there"
            )


@dataclass(frozen=True)
class TargetPoint(Remade, Target):
    """A terminal point ``x_f`` on the model's manifold, imposed as ``chart(x_f, x_N) = 0``.

    Parameters
    ----------
    manifold : ProductManifold
        The model's manifold.
    point : array-like, shape=(ambient_dim,)
        The terminal state; must lie on the manifold (checked, never projected).
    description : str
        Words for messages.
    """

    manifold: ProductManifold
    point: Vector
    description: str = "terminal point"

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", frozen(
            self.manifold.check(self.point, name="terminal state x_f")))

    @property
    def value(self) -> Vector:  # type: ignore[override]
        """The terminal point (``phi`` is the identity)."""
        return self.point

    @property
    def witness(self) -> Vector:  # type: ignore[override]
        """The terminal point itself."""
        return self.point

    def phi(self, x: Expr) -> Expr:  # noqa: D102
        return x


@dataclass(frozen=True)
class TargetSet(Remade, Target):
    """A terminal set ``{x : phi(x) = y*}``, a submanifold of the state manifold.

    Parameters
    ----------
    map : callable
        ``phi(x)``, casadi expression of the model's ambient state, onto ``manifold``.
    manifold : ProductManifold
        The target manifold ``P``.
    value : array-like, shape=(P.ambient_dim,)
        ``y*`` on ``P``.
    witness : array-like, shape=(ambient_dim,)
        A state in the set (used to validate, and as the guess's end point).
    description : str
        Words for messages, e.g. ``"Gamma = -e3, omega = 0"``.
    """

    map: Callable[[Expr], Expr]
    manifold: ProductManifold
    value: Vector
    witness: Vector
    description: str = "terminal set"

    def __post_init__(self) -> None:
        object.__setattr__(self, "value", frozen(validate.array("value", self.value).ravel()))
        object.__setattr__(self, "witness",
                           frozen(validate.array("witness", self.witness).ravel()))
        n = self.witness.size  # a state of the model: the map's input has its size
        try:
            m = int(ca.vec(self.map(ca.SX.sym("x", n))).numel())
        except RuntimeError as exc:
            raise ParameterError(f"map must take a state of the model like the witness ({n} "
                                 f"entries); casadi: {str(exc).strip().splitlines()[-1]}"
                                 ) from exc
        if self.value.size != m:
            raise ParameterError(f"value must have {m} entries (the size of map(x)); got "
                                 f"{self.value.size}")

    def phi(self, x: Expr) -> Expr:  # noqa: D102
        return ca.vec(self.map(x))


@dataclass(frozen=True)
class PathConstraint(Remade):
    """``lower <= c(x, u) <= upper`` at the nodes of the transcription (immutable).

    An assignment to a field raises :class:`dataclasses.FrozenInstanceError`; array bounds
    are private copies that cannot be written nor made writable again (``ValueError``):
    a problem's cached transcription holds them. ``dataclasses.replace`` makes a changed
    constraint, validated again.

    Parameters
    ----------
    function : callable
        ``c(x, u)``, casadi expression (vector) of the symbolic state and input (at node
        ``k`` the control of interval ``k``; at the last node that of the last interval).
    lower, upper : float or array-like, shape=() or (n_c,)
        Bounds (``-inf``/``inf`` for one-sided), one per entry of ``c`` or one for all;
        real, never NaN, ``lower <= upper``, ``lower < inf`` and ``upper > -inf``
        (checked here; their size against ``c`` when the :class:`OCP` is made).
    name : str
        For messages and results (one line of text).
    nodes : str
        ``"all"`` (default), ``"first"`` or ``"last"``. A condition on the first node only
        can fix a gauge: the spherical cart swing-up is invariant under rotations about the
        vertical, so its optima come in circles and the reduced Hessian is singular there;
        ``u_y = 0`` on the first interval picks one optimum of each circle.
    """

    function: CostFn
    lower: Any = -np.inf
    upper: Any = np.inf
    name: str = "path constraint"
    nodes: str = "all"

    def __post_init__(self) -> None:
        name = validate.single_line("name (of a path constraint)", self.name)
        if not callable(self.function):
            raise ParameterError(f"function of path constraint {name!r} must be a callable "
                                 f"c(x, u) returning a casadi expression; got "
                                 f"{type(self.function).__name__} {self.function!r:.80}")
        if not isinstance(self.nodes, str) or self.nodes not in ("all", "first", "last"):
            raise ParameterError(
                f"nodes must be 'all', 'first' or 'last'; got {self.nodes!r}"
            )
        lo = validate.bound(f"lower (of path constraint {name!r})", self.lower)
        hi = validate.bound(f"upper (of path constraint {name!r})", self.upper)
        for label, v in (("lower", lo), ("upper", hi)):
            if np.ndim(v) > 1 or np.size(v) == 0:
                raise ParameterError(f"{label} of path constraint {name!r} must be a number "
                                     f"or a vector (one bound per entry of c); got shape "
                                     f"{np.shape(v)}")
        if np.size(lo) > 1 and np.size(hi) > 1 and np.size(lo) != np.size(hi):
            raise ParameterError(f"lower and upper of path constraint {name!r} must have the "
                                 f"same length (or one be a number); got {np.size(lo)} and "
                                 f"{np.size(hi)}")
        if np.any(np.asarray(lo) == np.inf) or np.any(np.asarray(hi) == -np.inf):
            raise ParameterError(f"path constraint {name!r}: lower must be < inf and upper "
                                 f"> -inf (no point would be admissible); got lower "
                                 f"{np.asarray(lo).tolist()}, upper {np.asarray(hi).tolist()}")
        if np.any(np.asarray(lo) > np.asarray(hi)):
            raise ParameterError(f"path constraint {name!r}: lower must not exceed upper; got "
                                 f"lower {np.asarray(lo).tolist()} > upper "
                                 f"{np.asarray(hi).tolist()}")
        object.__setattr__(self, "lower", frozen_bound(lo))
        object.__setattr__(self, "upper", frozen_bound(hi))

    def check(self, model: Model) -> None:
        """Check ``c(x, u)`` on the model's symbols: a casadi expression whose size fits.

        Called with SX and with MX symbols (the transcriptions use both); ``c`` must return
        an expression of the same class, with at least one entry and as many as the
        bounds have (a bound that is a number applies to every entry).

        Raises
        ------
        ModelError
            Naming the constraint, what it returned or how it failed.
        """
        for S in (ca.SX, ca.MX):
            x, u = S.sym("x", model.manifold.ambient_dim), S.sym("u", model.n_inputs)
            try:
                value = self.function(x, u)
            except Exception as exc:  # noqa: BLE001 - the user's code, re-raised with context
                raise ModelError(
                    f"function of path constraint {self.name!r} must be a casadi expression "
                    f"c(x, u) of the symbolic state ({x.shape[0]} entries) and input "
                    f"({u.shape[0]}); calling it with {S.__name__} symbols raised "
                    f"{type(exc).__name__}: {_last_line(exc)}") from exc
            if not isinstance(value, S):
                raise ModelError(
                    f"function of path constraint {self.name!r} must return a casadi "
                    f"expression of x and u ({S.__name__} when called with {S.__name__} "
                    f"symbols); got {type(value).__name__} {value!r:.80}")
            n = int(value.numel())
            if n == 0:
                raise ModelError(f"function of path constraint {self.name!r} returned an "
                                 f"empty expression (shape {value.shape})")
            for label, v in (("lower", self.lower), ("upper", self.upper)):
                if np.size(v) not in (1, n):
                    raise ModelError(
                        f"{label} of path constraint {self.name!r} must be a number or have "
                        f"{n} entries (one per entry of c(x, u), shape {value.shape}); got "
                        f"{np.size(v)}")

    def applies(self, k: int, N: int) -> bool:
        """Whether the constraint holds at node ``k`` of ``0 .. N``."""
        return (self.nodes == "all" or (self.nodes == "first" and k == 0)
                or (self.nodes == "last" and k == N))


@dataclass(eq=False)
class OCP(Remade):
    """An optimal control problem on a model's manifold (immutable once made).

    Minimise ``integral_0^T L(x, u) dt + Phi(x(T), T)`` subject to the model's dynamics
    ``x' = f(x, u, p)`` (from ``model.function("f")``), ``x(0) = x0``, ``x(T)`` in the
    target set, ``u_lower <= u <= u_upper``, path constraints, and ``T`` fixed or free in
    a range. Controls are piecewise constant on the transcription's intervals.

    A problem cannot be changed after it is made: its transcriptions (built from its
    costs, target and constraints) and its horizon are derived once and cached on it, so an
    assignment such as ``ocp.T = 3.0`` raises :class:`dataclasses.FrozenInstanceError` (an
    ``AttributeError``), and so does one to a field of its target or of a
    :class:`PathConstraint`. Every array it holds (``x0``, the input bounds, a target's
    point, value and witness, a path constraint's bounds) is a private copy that numpy
    refuses to write (``ValueError``) and refuses to make writable again
    (``setflags(write=True)`` raises ``ValueError`` on it, its views and its base).
    ``dataclasses.replace(ocp, T=3.0)`` makes the changed problem: validated again, with its
    own (empty) cache; ``copy.copy``, ``copy.deepcopy`` and pickling make it again the same
    way. Two problems are equal only if they are the same object.

    Out of reach of this guard: the state a cost, a path constraint's function or a target's
    map captures (a closure over a mutable object is the caller's to leave alone), and the
    model (its parameter values belong to it; the NLP reads them at each solve).

    Parameters
    ----------
    model : Model
        The dynamics.
    x0 : array-like, shape=(ambient_dim,)
        Initial state; must lie on the model's manifold to ``tol`` (never projected) and
        pass the model's state check (a :mod:`workbench.mechanics` model: its kinetic
        energy positive definite there; :func:`solve` checks a converged solution's nodes
        too).
    target : TargetPoint or TargetSet
        Terminal condition.
    u_lower, u_upper : array-like, shape=(n_inputs,)
        Control bounds.
    T : float or (float, float)
        Fixed final time, or the range ``(T_min, T_max)`` of a free final time.
    running_cost : callable, optional
        ``L(x, u)``; ``0`` when omitted.
    terminal_cost : callable, optional
        ``Phi(x_T, T)``; ``0`` when omitted. Minimum time is ``lambda x, T: T``.
    path_constraints : sequence of PathConstraint
        Constraints at every node; each function is checked on the model's symbols (SX
        and MX) here: a casadi expression whose size fits its bounds.
    tol : float
        Largest accepted manifold residual of ``x0`` and of a target point.
    name : str
        For messages and results.
    gauge : bool
        Gauge a continuous symmetry automatically (default): when
        :attr:`symmetry` finds a rotation that maps the problem to itself (the cart
        pendulums about the vertical), the transcriptions add the phase condition of
        :mod:`workbench.control.ocp.symmetry`, which picks one optimum of each circle; the
        solution says so. ``False`` solves the problem as posed.

    Attributes
    ----------
    symmetry : Symmetry or None
        The verified rotation symmetry (detected on first use, shared with the problems
        of :meth:`with_bounds`), whether or not it is gauged.
    """

    model: Model
    x0: ArrayLike
    target: Target
    u_lower: ArrayLike
    u_upper: ArrayLike
    T: float | tuple[float, float]
    running_cost: CostFn | None = None
    terminal_cost: Callable[[Any, Any], Any] | None = None
    path_constraints: Sequence[PathConstraint] = ()
    tol: float = DEFAULT_TOL
    name: str = "ocp"
    gauge: bool = True
    _cache: dict = field(default_factory=dict, init=False, repr=False)

    def __setattr__(self, name: str, value: Any) -> None:
        """Refuse any assignment once the problem is made (see the class docstring)."""
        if self.__dict__.get("_made", False):
            fix = (f"Make the changed problem with dataclasses.replace(ocp, {name}=...), "
                   f"which validates it again" if name in _OCP_FIELDS else
                   f"{name!r} is none of its fields {sorted(_OCP_FIELDS)}")
            raise FrozenInstanceError(
                f"OCP {self.name!r} cannot be changed after it is made (its transcriptions "
                f"and horizon are derived from it and cached); got an assignment to "
                f"{name!r}. {fix}")
        object.__setattr__(self, name, value)

    def __delattr__(self, name: str) -> None:
        """Refuse to delete a field (see the class docstring)."""
        raise FrozenInstanceError(f"OCP {self.name!r} cannot be changed after it is made; "
                                  f"got a deletion of {name!r}")

    def __post_init__(self) -> None:
        m = validate.instance(Model, "a workbench Model")("model", self.model, error=ModelError)
        self.name = validate.text("name", self.name)
        self.tol = validate.tolerance("tol", self.tol)
        self.x0 = frozen(m.check_state(self.x0, name="x0", tol=self.tol))
        self.check_states(self.x0, what="x0")
        if not isinstance(self.target, Target):
            raise ModelError(
                f"target must be a TargetPoint or a TargetSet; got {type(self.target).__name__}"
            )
        if self.target.manifold is not m.manifold and isinstance(self.target, TargetPoint):
            if self.target.manifold.ambient_dim != m.manifold.ambient_dim:
                raise ModelError(
                    f"target point is on {self.target.manifold.describe()}, the model's state "
                    f"is on {m.manifold.describe()}"
                )
        self.target.validate(m, tol=self.tol)
        self.u_lower = frozen(self._bound(self.u_lower, "u_lower"))
        self.u_upper = frozen(self._bound(self.u_upper, "u_upper"))
        if np.any(self.u_lower > self.u_upper):
            raise ParameterError(
                f"u_lower must not exceed u_upper; got {self.u_lower.tolist()} > "
                f"{self.u_upper.tolist()}"
            )
        self.T_range = self._horizon(self.T)
        # a list or array T would stay mutable under the range derived from it
        self.T = self.T_range[0] if np.ndim(self.T) == 0 else self.T_range
        self._check_costs()
        if not isinstance(self.gauge, (bool, np.bool_)):
            raise ParameterError(f"gauge must be True or False; got {self.gauge!r}")
        if isinstance(self.path_constraints, PathConstraint) or not isinstance(
                self.path_constraints, Sequence) or isinstance(self.path_constraints, str):
            raise ModelError(f"path_constraints must be a sequence (list or tuple) of "
                             f"PathConstraint objects; got {self.path_constraints!r:.80}")
        for c in self.path_constraints:
            if not isinstance(c, PathConstraint):
                raise ModelError(
                    f"path_constraints must hold PathConstraint objects; got {type(c).__name__}"
                )
            c.check(m)
        self.path_constraints = tuple(self.path_constraints)  # a list would stay mutable
        self._made = True

    def _check_costs(self) -> None:
        """Each cost must be a scalar expression of the symbolic state and input."""
        m = self.model
        x, u = m.sym.sym("x", m.manifold.ambient_dim), m.sym.sym("u", m.n_inputs)
        for name, fn, args in (("running_cost", self.running_cost, (x, u)),
                               ("terminal_cost", self.terminal_cost, (x, ca.MX.sym("T")
                                                                       if m.sym is ca.MX
                                                                       else ca.SX.sym("T")))):
            if fn is None:
                continue
            if not callable(fn):
                raise ModelError(f"{name} must be a callable; got {type(fn).__name__}")
            try:
                value = ca.vec(fn(*args))
            except (RuntimeError, TypeError, IndexError) as exc:
                raise ModelError(f"{name} must be a casadi expression of the symbolic "
                                 f"arguments {[str(a.shape) for a in args]}; it failed: "
                                 f"{str(exc).strip().splitlines()[-1]}") from exc
            if value.numel() != 1:
                raise ModelError(f"{name} must be a scalar expression; got shape "
                                 f"{value.shape}")
            self._check_cost_values(name, ca.Function(name, list(args), [value]))

    def _check_cost_values(self, name: str, fn: ca.Function) -> None:
        """A cost that is not finite at the start or the target is refused, naming where."""
        finite_u = np.isfinite(self.u_lower) & np.isfinite(self.u_upper)
        u = np.where(finite_u, 0.5 * (self.u_lower + self.u_upper),
                     np.clip(0.0, self.u_lower, self.u_upper))
        for where, x in (("x0", self.x0), ("the target's witness", self.target.witness)):
            for second in ((u,) if name == "running_cost" else self.T_range):
                try:
                    value = float(np.asarray(fn(x, second)).ravel()[0])
                except RuntimeError as exc:
                    raise ModelError(f"{name} cannot be evaluated at {where}: "
                                     f"{str(exc).strip().splitlines()[-1]}") from exc
                if not np.isfinite(value):
                    raise ModelError(f"{name} must be finite; it is {value} at {where} (x = "
                                     f"{np.round(x, 6).tolist()})")

    def _bound(self, value: ArrayLike, name: str) -> Vector:
        arr = np.asarray(validate.bound(name, value), dtype=float)
        if arr.ndim == 0:
            arr = np.full(self.model.n_inputs, float(arr))
        if arr.shape != (self.model.n_inputs,) or np.any(np.isnan(arr)):
            raise ParameterError(
                f"{name} must be a number or have {self.model.n_inputs} entries (one per "
                f"input of {self.model.name}); got {np.asarray(value).tolist()}"
            )
        # a lower bound of +inf (or an upper bound of -inf) leaves no admissible control
        wrong = np.inf if name.endswith("lower") else -np.inf
        if np.any(arr == wrong):
            raise ParameterError(f"{name} must not be {wrong} (no control would be "
                                 f"admissible); got {arr.tolist()}")
        return arr

    @staticmethod
    def _horizon(T: float | tuple[float, float]) -> tuple[float, float]:
        try:
            Tv = validate.array("T", T)
            if Tv.ndim == 0:
                lo = hi = float(Tv)
            else:
                lo, hi = (float(v) for v in Tv)
        except (TypeError, ValueError) as exc:
            raise ParameterError(
                f"T must be a final time or a range (T_min, T_max); got {T!r}"
            ) from exc
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= hi):
            raise ParameterError(f"T must satisfy 0 < T_min <= T_max < inf; got {T!r}")
        return lo, hi

    def check_states(self, x: ArrayLike, t: ArrayLike | None = None, *,
                     what: str = "x0") -> None:
        """The model's state check at states of this problem (``x0``, a solution's nodes).

        A :mod:`workbench.mechanics` model checks that its kinetic energy is positive
        definite there (``model.state_check``); other models have no such check.

        Parameters
        ----------
        x : array-like, shape=(ambient_dim,) or (n, ambient_dim)
            The states.
        t : array-like, shape=(n,), optional
            Their times, for the message.
        what : str
            What they are, for the message.

        Raises
        ------
        ModelError
            Naming the state (and its time) where the check fails.
        """
        check = getattr(self.model, "state_check", None)
        if check is not None:
            check(self.model, x, t=t, what=what)

    @property
    def symmetry(self) -> Any:
        """The verified rotation symmetry of the problem, or None (detected once)."""
        if "symmetry" not in self._cache:
            from workbench.control.ocp.symmetry import detect_symmetry

            self._cache["symmetry"] = detect_symmetry(self)
        return self._cache["symmetry"]

    @property
    def free_time(self) -> bool:
        """Whether the final time is a decision variable."""
        return self.T_range[0] < self.T_range[1]

    def with_bounds(self, *, u_lower: ArrayLike | None = None, u_upper: ArrayLike | None = None,
                    T: float | tuple[float, float] | None = None,
                    gauge: bool | None = None) -> OCP:
        """The same problem with other control bounds, horizon or gauge (for continuation).

        Built transcriptions are shared: bounds are data of the NLP, not of its graph (the
        gauged and the ungauged NLP are two transcriptions in the shared cache).
        """
        new = OCP(
            model=self.model, x0=self.x0, target=self.target,
            u_lower=self.u_lower if u_lower is None else u_lower,
            u_upper=self.u_upper if u_upper is None else u_upper,
            T=self.T if T is None else T, running_cost=self.running_cost,
            terminal_cost=self.terminal_cost, path_constraints=self.path_constraints,
            tol=self.tol, name=self.name, gauge=self.gauge if gauge is None else gauge,
        )
        object.__setattr__(new, "_cache", self._cache)
        return new


_OCP_FIELDS = frozenset(f.name for f in fields(OCP) if f.init)
"""The fields :func:`dataclasses.replace` can change (re-validated by the new problem)."""
