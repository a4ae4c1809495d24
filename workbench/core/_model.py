"""Models: a vector field on a product manifold, written once as a casadi graph.

A :class:`Model` holds named state factors (a :class:`~workbench.core.manifolds.ProductManifold`),
a number of inputs, named and validated parameters, and *builders*: Python callables that
write the vector field and the invariants as casadi expressions of symbolic state, input
and parameters. Nothing is built until it is asked for. Each casadi.Function is then built
once, cached, and recorded in the model's build log (name, node count, build time), so a
problem can report exactly what a scene required.

Parameters are an *input* of every function (``f(x, u, p)``), so a parameter sweep or a
continuation needs no rebuild: :meth:`Model.with_parameters` returns a model with other
values that shares the already built graphs. Freezing the numbers into a graph is an
explicit option (:meth:`Model.function` with ``frozen=True``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from enum import StrEnum
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._buildlog import BuildLog, BuildRecord
from workbench.core._evaluator import Evaluator
from workbench.core._parameters import Parameter, finite, nonnegative, positive, spd3
from workbench.core.errors import ManifoldError, ModelError, ParameterError
from workbench.core.manifolds import DEFAULT_TOL, S1, ProductManifold
from workbench.core.types import ArrayLike, Vector
from workbench.core.validate import choice

__all__ = ["Symbolic", "Parameter", "BuildRecord", "BuildLog", "Context", "Model", "positive",
           "nonnegative", "spd3", "finite", "Evaluator"]


class Symbolic(StrEnum):
    """Symbol class of a model's graphs (a str-enum: ``Symbolic.SX == "SX"``).

    Attributes
    ----------
    SX
        Scalar expression graphs (``casadi.SX``): compact, fast to evaluate, export to C
        and convert to sympy.
    MX
        Matrix expression graphs (``casadi.MX``): allow numeric sub-solves
        (``casadi.solve``) inside the graph, as the chain model needs.
    """

    SX = "SX"
    MX = "MX"


# ----------------------------------------------------------------------------------------
# symbolic context handed to model builders


class Context:
    """Symbolic state, input and parameters, as handed to a model's builders.

    Attributes
    ----------
    x : casadi SX or MX, shape=(ambient_dim, 1)
        The whole stored state.
    u : casadi SX or MX, shape=(n_inputs, 1)
        The input.
    p : casadi SX or MX, shape=(n_params, 1)
        All parameters stacked.
    """

    def __init__(self, model: Model, x: Any, u: Any, p: Any) -> None:
        self.model, self.x, self.u, self.p = model, x, u, p

    def __getitem__(self, name: str) -> Any:
        """A state part by factor name, or a parameter by name (matrices reshaped)."""
        man = self.model.manifold
        if name in man.slices:
            return self.x[man.slices[name]]
        if name in self.model.parameter_slices:
            par = self.model.parameter(name)
            piece = self.p[self.model.parameter_slices[name]]
            if len(par.shape) == 2:
                # stored row-major (numpy order): reshape then transpose
                return ca.reshape(piece, par.shape[1], par.shape[0]).T
            return piece
        raise ModelError(
            f"unknown name {name!r}; state factors are {man.names}, parameters are "
            f"{[p.name for p in self.model.parameters]}"
        )


Builder = Callable[[Context], Any]


# ----------------------------------------------------------------------------------------
# the model


RESERVED_NAMES = frozenset({"f", "f_x", "f_u", "residual", "invariants", "x", "u", "p"})
"""Names an invariant cannot take: the model's own functions and their inputs."""


class _Graphs:
    """Cache of built functions, shared between models that differ only in values."""

    def __init__(self) -> None:
        self.functions: dict[str, ca.Function] = {}
        self.log = BuildLog()


class Model:
    """A controlled vector field on a product manifold, with invariants.

    Parameters
    ----------
    name : str
        Identifier of the model, e.g. ``"pendulum3d_full"``.
    manifold : ProductManifold
        The state space, in storage order.
    n_inputs : int
        Dimension of the input ``u`` (0 for none).
    parameters : sequence of Parameter
        Declared parameters, in storage order of ``p``.
    values : mapping of str to array-like
        A value for every declared parameter; validated.
    vector_field : callable
        ``vector_field(ctx) -> xdot`` as a casadi expression of shape ``(ambient_dim, 1)``.
    invariants : mapping of str to callable, optional
        ``invariant(ctx) -> scalar`` expressions conserved when ``u = 0``.
    symbolic : Symbolic or {"SX", "MX"}
        Symbol class for the graphs (:class:`Symbolic`; the strings are accepted). MX allows
        numeric sub-solves (``casadi.solve``) inside the graph, as the chain model needs.
    description : str
        One line saying what the model is, with the paper and equation numbers.
    equations : sequence of str
        The equations implemented, as LaTeX with their paper equation numbers (for reports).
    input_description : str
        What ``u`` is (units).
    jacobian : callable, optional
        ``jacobian(ctx, which) -> df/dx`` (``which == "f_x"``) or ``df/du`` (``"f_u"``) as
        an expression, for a field whose Jacobian is cheaper written out than found by AD of
        its graph (e.g. one call of a supplied Jacobian instead of one per batch of
        directions). It must equal the Jacobian of ``vector_field``; None differentiates.
    spd_solves : bool
        True declares that every linear solve in ``vector_field``'s graph has a symmetric
        positive definite matrix (a mass matrix; :mod:`workbench.mechanics` declares it).
        When an OCP replays an MX graph on SX
        (:func:`workbench.control.ocp.expand.sx_function`), those solves are then written
        as L D L^T (:func:`workbench.core.solve_spd`) instead of QR: the same function,
        fewer operations. (An SX model writes its own solves; the mechanics models write
        L D L^T.)
    value_check : callable, optional
        ``value_check(model)`` raises (a :class:`ModelError` or :class:`ParameterError`
        naming what is wrong) when the model's parameter values are not physical as a
        whole, e.g. a mass matrix that is not positive definite. :meth:`with_parameters`
        calls it on every model it makes (the constructor does not: whoever builds the
        model checks its first values). :mod:`workbench.mechanics` supplies its build
        checks here.
    """

    def __init__(
        self,
        *,
        name: str,
        manifold: ProductManifold,
        n_inputs: int,
        parameters: Sequence[Parameter],
        values: Mapping[str, ArrayLike],
        vector_field: Builder,
        invariants: Mapping[str, Builder] | None = None,
        symbolic: Symbolic | str = Symbolic.SX,
        description: str = "",
        equations: Sequence[str] = (),
        input_description: str = "",
        jacobian: Callable[[Context, str], Any] | None = None,
        spd_solves: bool = False,
        value_check: Callable[[Model], None] | None = None,
    ) -> None:
        symbolic = choice(Symbolic, symbolic, "symbolic", error=ModelError)
        validate.count("n_inputs", n_inputs, minimum=0, maximum=validate.MAX_DIM,
                       error=ModelError)
        if not name:
            raise ModelError(f"name must be a non-empty str; got {name!r}")
        validate.single_line("name", name, error=ModelError)
        if not isinstance(manifold, ProductManifold):
            raise ModelError(f"manifold must be a ProductManifold; got {type(manifold).__name__}")
        for inv in invariants or {}:
            # an invariant becomes a casadi.Function (and output) of that name
            validate.identifier("invariant name", inv, error=ModelError)
            if inv in RESERVED_NAMES:
                raise ModelError(f"invariant name must not be one of "
                                 f"{sorted(RESERVED_NAMES)} (the model's own functions and "
                                 f"their inputs); got {inv!r}")
        self.name = name
        self.manifold = manifold
        self.n_inputs = int(n_inputs)
        self.parameters: tuple[Parameter, ...] = tuple(parameters)
        self.symbolic: Symbolic = symbolic
        self.description = description
        self.equations = tuple(equations)
        self.input_description = input_description
        self._vector_field, self._jacobian = vector_field, jacobian
        if not isinstance(spd_solves, bool):
            raise ModelError(f"spd_solves must be a bool; got {spd_solves!r}")
        self.spd_solves = spd_solves
        if value_check is not None and not callable(value_check):
            raise ModelError(f"value_check must be callable or None; got {value_check!r}")
        self._value_check = value_check
        self._invariants: dict[str, Builder] = dict(invariants or {})
        self.parameter_slices: dict[str, slice] = {}
        k = 0
        for par in self.parameters:
            self.parameter_slices[par.name] = slice(k, k + par.size)
            k += par.size
        self.n_params = k
        self.values: dict[str, np.ndarray] = self._validate_values(values)
        self._graphs = _Graphs()

    # parameters ---------------------------------------------------------------------------

    def parameter(self, name: str) -> Parameter:
        """The declared parameter called ``name``."""
        for par in self.parameters:
            if par.name == name:
                return par
        raise ModelError(
            f"unknown parameter {name!r} of model {self.name!r}; "
            f"known: {[p.name for p in self.parameters]}"
        )

    def _validate_values(self, values: Mapping[str, ArrayLike]) -> dict[str, np.ndarray]:
        declared = [p.name for p in self.parameters]
        unknown = [k for k in values if k not in declared]
        if unknown:
            raise ParameterError(
                f"unknown parameter(s) {unknown} for model {self.name!r}; known: {declared}"
            )
        missing = [k for k in declared if k not in values]
        if missing:
            raise ParameterError(f"model {self.name!r} needs values for {missing}")
        return {p.name: p.validate(values[p.name]) for p in self.parameters}

    @property
    def p(self) -> Vector:
        """All parameter values stacked in storage order (matrices row-major)."""
        if not self.parameters:
            return np.zeros(0)
        return np.concatenate([self.values[p.name].reshape(-1) for p in self.parameters])

    def with_parameters(self, **values: ArrayLike) -> Model:
        """A model with some parameter values changed, sharing the already built graphs.

        Parameters
        ----------
        **values : array-like
            New values by parameter name; validated.

        Returns
        -------
        Model
            A new model; its build log is the same object as this one's.

        Raises
        ------
        ParameterError
            An unknown name, or a value refused by its parameter's check.
        ModelError
            Values refused by the model's ``value_check`` (a mechanics model re-runs its
            build checks: mass matrix positive definite, inertias, dissipation, ...).
        """
        merged = dict(self.values)
        unknown = [k for k in values if k not in merged]
        if unknown:
            raise ParameterError(
                f"unknown parameter(s) {unknown} for model {self.name!r}; known: {list(merged)}"
            )
        merged.update(values)
        clone = object.__new__(Model)
        clone.__dict__.update(self.__dict__)
        clone.values = self._validate_values(merged)
        if clone._value_check is not None:
            clone._value_check(clone)
        return clone

    # symbols ------------------------------------------------------------------------------

    @property
    def sym(self) -> type:
        """``casadi.SX`` or ``casadi.MX``."""
        return ca.SX if self.symbolic is Symbolic.SX else ca.MX

    def context(self) -> Context:
        """Fresh symbols for state, input and parameters."""
        S = self.sym
        return Context(
            self,
            S.sym("x", self.manifold.ambient_dim),
            S.sym("u", self.n_inputs),
            S.sym("p", self.n_params),
        )

    @property
    def build_log(self) -> BuildLog:
        """What has been built so far (shared with models from :meth:`with_parameters`)."""
        return self._graphs.log

    @property
    def invariant_names(self) -> list[str]:
        """Names of the declared invariants."""
        return list(self._invariants)

    # functions ----------------------------------------------------------------------------

    def _build(self, key: str, make: Callable[[], ca.Function]) -> ca.Function:
        cache = self._graphs.functions
        if key not in cache:
            t0 = time.perf_counter()
            fn = cache[key] = make()
            self._graphs.log.add(BuildRecord(f"{self.name}.{key}", int(fn.n_nodes()),
                                             time.perf_counter() - t0, self.symbolic))
        return cache[key]

    def function(self, name: str, *, frozen: bool = False) -> ca.Function:
        """A built (cached) casadi.Function of the model.

        Parameters
        ----------
        name : str
            ``"f"`` (``(x, u, p) -> xdot``), ``"f_x"`` and ``"f_u"`` (Jacobians of ``f``
            w.r.t. ``x`` and ``u``), ``"residual"`` (``x -> h(x)``), ``"invariants"``
            (``(x, p) -> all invariants``) or the name of one invariant (``(x, p) -> I``).
        frozen : bool
            If true, substitute the current parameter values into the graph and drop the
            ``p`` input (smaller graphs and faster code; rebuilt for other values).

        Returns
        -------
        casadi.Function
        """
        if frozen:
            return self._frozen(name)
        if name == "f":
            return self._build("f", self._make_f)
        if name in ("f_x", "f_u"):
            return self._build(name, lambda: self._make_jac(name))
        if name == "residual":
            return self._build("residual", self._make_residual)
        if name == "invariants":
            return self._build("invariants", self._make_invariants)
        if name in self._invariants:
            return self._build(name, lambda: self._make_invariant(name))
        raise ModelError(
            f"model {self.name!r} has no function {name!r}; known: f, f_x, f_u, residual, "
            f"invariants, {', '.join(self._invariants) or '(no invariants)'}"
        )

    def _frozen(self, name: str) -> ca.Function:
        key = f"{name}@frozen[{hash(self.p.tobytes())}]"

        def make() -> ca.Function:
            fn = self.function(name)
            ins = [fn.sx_in(i) if self.symbolic is Symbolic.SX else fn.mx_in(i)
                   for i in range(fn.n_in())]
            names = [fn.name_in(i) for i in range(fn.n_in())]
            args = [ca.DM(self.p) if n == "p" else s for n, s in zip(names, ins)]
            outs = fn.call(args)
            keep = [(s, n) for s, n in zip(ins, names) if n != "p"]
            return ca.Function(
                f"{fn.name()}_frozen",
                [s for s, _ in keep],
                outs,
                [n for _, n in keep],
                [fn.name_out(i) for i in range(fn.n_out())],
                {"cse": True} if self.symbolic is Symbolic.SX else {},
            )

        return self._build(key, make)

    def _make_f(self) -> ca.Function:
        ctx = self.context()
        xdot = ca.vec(self._vector_field(ctx))
        if xdot.shape != (self.manifold.ambient_dim, 1):
            raise ModelError(
                f"vector field of {self.name!r} must have shape ({self.manifold.ambient_dim}, 1);"
                f" got {xdot.shape}"
            )
        return ca.Function("f", [ctx.x, ctx.u, ctx.p], [xdot], ["x", "u", "p"], ["xdot"])

    def _make_jac(self, which: str) -> ca.Function:
        if self._jacobian is not None:
            ctx = self.context()
            jac = self._jacobian(ctx, which)
            cols = self.manifold.ambient_dim if which == "f_x" else self.n_inputs
            if jac.shape != (self.manifold.ambient_dim, cols):
                raise ModelError(f"the jacobian builder of {self.name!r} must give shape "
                                 f"({self.manifold.ambient_dim}, {cols}) for {which}; got "
                                 f"{jac.shape}")
            return ca.Function(which, [ctx.x, ctx.u, ctx.p], [jac], ["x", "u", "p"], [which])
        f = self.function("f")
        S = self.sym
        x, u, p = S.sym("x", f.size1_in(0)), S.sym("u", f.size1_in(1)), S.sym("p", f.size1_in(2))
        xdot = f(x, u, p)
        wrt = x if which == "f_x" else u
        return ca.Function(which, [x, u, p], [ca.jacobian(xdot, wrt)], ["x", "u", "p"], [which])

    def _make_residual(self) -> ca.Function:
        x = self.sym.sym("x", self.manifold.ambient_dim)
        return ca.Function("residual", [x], [self.manifold.residual(x)], ["x"], ["h"])

    def _make_invariant(self, name: str) -> ca.Function:
        ctx = self.context()
        val = self._invariants[name](ctx)
        return ca.Function(name, [ctx.x, ctx.p], [val], ["x", "p"], [name])

    def _make_invariants(self) -> ca.Function:
        ctx = self.context()
        vals = [self._invariants[n](ctx) for n in self._invariants]
        out = ca.vertcat(*vals) if vals else self.sym(0, 1)
        return ca.Function("invariants", [ctx.x, ctx.p], [out], ["x", "p"], ["I"])

    # numeric conveniences -----------------------------------------------------------------

    def check_state(self, x: ArrayLike, *, name: str = "x", tol: float = DEFAULT_TOL) -> Vector:
        """Validate a numeric state on the model's manifold; return it flat and unchanged."""
        return self.manifold.check(x, name=name, tol=tol)

    def state(self, *, tol: float = DEFAULT_TOL, **parts: ArrayLike) -> Vector:
        """Assemble and validate a state from named parts, e.g. ``state(R=I, omega=w)``.

        Each part is its factor's stored value (flattened column-major). A part of an
        ``S1`` factor (an angle, stored as the unit vector ``(cos theta, sin theta)``) may
        also be the angle itself, a real number ``theta`` [rad], stored as
        ``(cos theta, sin theta)``; a 2-vector is validated as given, never normalised.
        """
        man = self.manifold
        angles = {n: validate.real(f"part {n!r} (an S1 factor: an angle [rad] or a unit "
                                   "2-vector (cos, sin))", v, error=ManifoldError)
                  for n, v in parts.items() if n in man.slices and isinstance(man.factor(n), S1)
                  and np.ndim(v) == 0 and not isinstance(v, (ca.SX, ca.MX, ca.DM))}
        parts.update({n: np.array([np.cos(a), np.sin(a)]) for n, a in angles.items()})
        return self.check_state(man.join(parts), tol=tol)

    def _input(self, u: ArrayLike | None) -> Vector:
        if u is None:
            return np.zeros(self.n_inputs)
        uv = validate.array("u", u, finite=False, error=ModelError).ravel()
        if uv.size != self.n_inputs:
            raise ModelError(
                f"u must have {self.n_inputs} entries for model {self.name!r}; "
                f"got shape {np.shape(u)}"
            )
        if not np.all(np.isfinite(uv)):
            raise ModelError(f"u must be finite; got {uv.tolist()}")
        return uv

    def _raw_state(self, x: ArrayLike) -> Vector:
        """``x`` flat, of the ambient size and finite (no manifold check), or ModelError."""
        xv = validate.array(f"x (a state of model {self.name!r})", x, finite=False,
                            error=ModelError).ravel()
        n = self.manifold.ambient_dim
        if xv.size != n or not np.all(np.isfinite(xv)):
            raise ModelError(
                f"x must be {n} finite numbers for model {self.name!r} "
                f"({self.manifold.describe()}); got shape {np.shape(x)}"
                + ("" if xv.size != n else f" with non-finite entries {xv.tolist()}")
            )
        return xv

    def rhs(self, x: ArrayLike, u: ArrayLike | None = None) -> Vector:
        """Evaluate the vector field at a numeric state (no manifold check).

        Raises ModelError if the value is not finite (e.g. parameters so large that the
        field overflows): never a NaN or inf in a result.
        """
        xv, uv = self._raw_state(x), self._input(u)
        try:
            out = np.asarray(self.function("f")(xv, uv, self.p)).ravel()
        except RuntimeError as exc:  # casadi's evaluation failed (e.g. a singular solve)
            raise ModelError(
                f"the vector field of {self.name!r} cannot be evaluated at x = {xv.tolist()}, "
                f"u = {uv.tolist()} with parameters {self.p.tolist()}: "
                f"{str(exc).strip().splitlines()[-1]}") from exc
        if not np.all(np.isfinite(out)):
            raise ModelError(
                f"the vector field of {self.name!r} is not finite at x = {xv.tolist()}, "
                f"u = {uv.tolist()} with parameters {self.p.tolist()}: an overflow, or a "
                f"singular solve inside the field there (e.g. a mass matrix singular at that "
                f"state) (f = {out.tolist()})")
        return out

    def invariants(self, x: ArrayLike) -> dict[str, float]:
        """All invariants at a numeric state."""
        vals = np.asarray(self.function("invariants")(self._raw_state(x), self.p))
        return {n: float(v) for n, v in zip(self._invariants, vals.ravel())}

    def __repr__(self) -> str:
        return (
            f"Model({self.name!r}, {self.manifold.describe()}, inputs={self.n_inputs}, "
            f"parameters={[p.name for p in self.parameters]})"
        )
