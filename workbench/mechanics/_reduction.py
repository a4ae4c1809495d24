"""Symmetry reduction of a mechanics model: Lagrange-Poincare and Routh, by lifting.

For a momentum ``J`` of an abelian symmetry (a translation of R^k factors, a shift of S^1
angles, a rotation about a constant axis turning an SO(3) factor: see
:mod:`._reduction_geometry`), the full
field ``f`` is invariant: ``f(g x) = g_* f(x)``. The reduced field at a reduced state
``r`` is therefore the derivative of the quotient map ``pi`` along ``f`` at *any* full
state over ``r``:

    r-dot = d pi(x) [f(x, u)],   x = lift(r),

which does not depend on the lift chosen. The lift puts the configuration on a section
and the velocities over those of ``r``; for the Routh kind the group velocity ``xi`` is
eliminated through the momentum, ``J(lift(r, xi)) = mu``, affine in ``xi``:

    xi = (mu - J(lift(r, 0))) / I(c),   I(c) = dJ/dxi = eta^T M eta  (locked inertia).

Nothing is transcribed: ``f`` is the model's own derived field, ``pi`` and the lift are
kinematics, and the chain rule is automatic differentiation. The amended potential is
``V_mu = V + mu^2 / (2 I)`` on the section (its critical points are the relative
equilibria). :func:`reduce` requires the symmetry established exactly (the momentum
conserved and ``[X, f] = 0``: :func:`._symmetry.symmetry_evidence`), checks numerically, at
seeded random states, that the reduced field does not depend on the lift, that
``pi(lift(r)) = r``, and which inputs keep the symmetry: an input whose effect is not
invariant, or (Routh) that changes the momentum (``dJ/du != 0`` beyond rounding), is named
and refused unless ``breaking_inputs="hold_zero"``.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.mechanics._engine import Context, Model, ModelError, Parameter, ProductManifold
from workbench.mechanics._reduction_classify import classify
from workbench.mechanics._reduction_geometry import (
    Kind,
    Quotient,
    ReductionKind,
    join_state,
    split_reduced,
    split_state,
    split_velocity,
)
from workbench.mechanics._reduction_momentum import check_momentum, momentum_scale
from workbench.mechanics._reduction_reconstruct import Reconstructed, ReconstructionMixin
from workbench.mechanics._symmetry import INPUT_MOMENTUM_TOL, established, input_momentum_rates

__all__ = ["reduce", "Reduction", "ReductionKind", "BreakingInputs", "Reconstructed",
           "INVARIANCE_RTOL", "MAX_CHECK_STATES"]

MAX_CHECK_STATES = 1000
"""Largest accepted ``n_states`` of :func:`reduce` (random states checked, each a few
evaluations of the derived graphs): bounded before any state is drawn."""

INVARIANCE_RTOL = 1e-8
"""The reduced field from two lifts (one turned by a random group element) must agree to
this relative tolerance; an input column whose effect differs more breaks the symmetry.
Whether an input changes the momentum (Routh) is decided at rounding level instead
(:data:`INPUT_MOMENTUM_TOL`), whatever ``rtol``."""


class Reduction(ReconstructionMixin):
    """A reduced model of a mechanics model by one of its symmetries (see :func:`reduce`).

    Attributes
    ----------
    model : Model
        The reduced model: an ordinary :class:`workbench.Model` (simulate, linearise,
        equilibria, continuation, OCP and C export accept it), carrying this reduction as
        ``model.reduction``. Routh: parameters of the full model plus the momentum value
        (``momentum_parameter``).
    full : Model
        The full mechanics model.
    kind : ReductionKind
        ``ROUTH`` or ``LAGRANGE_POINCARE``.
    symmetry : str
        The momentum's name.
    quotient : Quotient
        The geometry (quotient coordinates, section, group action).
    held_inputs : tuple of int
        Full-model input columns held at zero in the reduced model (they break the
        symmetry; ``breaking_inputs="hold_zero"``); the other columns are the reduced
        model's inputs, in order.
    momentum_parameter : str or None
        Name of the Routh model's momentum parameter.
    evidence : str
        Why the symmetry holds: exactly (``"exact: ..."``), or what kept it from being
        established when reduced with ``accept_sampled=True``.
    lift : casadi.Function
        ``(r, p, mu) -> x``: the full state over a reduced one, on the section (``p`` the
        full model's parameters; ``mu`` ignored by Lagrange-Poincare).
    project : casadi.Function
        ``x -> r``: the quotient map.
    project_rate : casadi.Function
        ``(x, dx) -> r-dot``: its derivative along ``dx``.
    act : casadi.Function
        ``(x, theta) -> g_theta x``: the group action on full states.
    eta : casadi.Function
        ``(x, p) -> eta``: the generator (stacked velocities).
    locked_inertia_full : casadi.Function
        ``(x, p) -> I = eta^T M eta`` at a full state.
    """

    def __init__(self, full: Model, symmetry: str, kind: Kind, quotient: Quotient,
                 mu_name: str | None) -> None:
        self.full, self.symmetry, self.kind, self.quotient = full, symmetry, kind, quotient
        self.momentum_parameter = mu_name
        der = full.mechanics
        self._der = der
        self.factors = list(der.ing.factors)
        self.storage = quotient.storage(kind)
        if not self.storage:
            raise ModelError(f"reducing {full.name!r} by {symmetry!r} leaves no state")
        self.n_r = sum(m.ambient_dim for _, m in self.storage)
        self.n_p = full.n_params
        self._J = der.momentum(der.ing.momenta[symmetry])
        self._J_affine = self._J
        if der.homogeneous:  # T a quadratic form: Pi = M nu, J = eta . M nu (fewer products)
            gens = der.ing.momenta[symmetry]
            eta = ca.vertcat(*[gens.get(id(f), ca.SX.zeros(f.velocity_sym.shape[0], 1))
                               for f in self.factors])
            self._J_affine = ca.Function("J", [der.x, der.ing.p],
                                         [ca.dot(eta, ca.mtimes(der.M, der.nu))], ["x", "p"],
                                         ["J"])
        self._functions()
        self.held_inputs: tuple[int, ...] = ()
        self.rtol, self.seed = INVARIANCE_RTOL, 0  # reduce's, for with_parameters' checks
        self._model: Model | None = None
        self.evidence = ""  # reduce's: why the symmetry holds

    # the symbolic pieces ---------------------------------------------------------------
    def _functions(self) -> None:
        S, der = ca.SX, self._der
        r, p, mu, xi = S.sym("r", self.n_r), S.sym("p", self.n_p), S.sym("mu"), S.sym("xi")
        parts = split_reduced(self.storage, r)
        c = self.quotient.section(parts, self.kind)
        if self.kind is Kind.ROUTH:
            x_xi = join_state(c, self.quotient.velocity(c, parts, self.kind, xi))
            J = self._J_affine(x_xi, p)
            inertia = ca.jacobian(J, xi)
            if ca.depends_on(inertia, xi):
                raise ModelError(
                    f"the momentum {self.symmetry!r} is not affine in the velocities (the "
                    "kinetic energy is not quadratic in them): the group velocity cannot be "
                    "eliminated at a momentum value; use kind='lagrange_poincare'")
            xi_mu = (mu - ca.substitute(J, xi, 0)) / inertia
            x = ca.substitute(x_xi, xi, xi_mu)
        else:
            x = join_state(c, self.quotient.velocity(c, parts, self.kind, None))
        self.lift = ca.Function("lift", [r, p, mu], [x], ["r", "p", "mu"], ["x_full"])
        xs, dx = S.sym("x", der.x.shape[0]), S.sym("dx", der.x.shape[0])
        cs, nus = split_state(self.factors, xs)
        q = ca.vertcat(*self.quotient.quotient(cs, nus, self.kind))
        self.project = ca.Function("project", [xs], [q], ["x"], ["r"])
        self.project_rate = ca.Function("project_rate", [xs, dx], [ca.jtimes(q, xs, dx)],
                                        ["x", "dx"], ["r_dot"])
        theta = S.sym("theta")
        ct, nt = self.quotient.act(theta, cs, nus)
        self.act = ca.Function("act", [xs, theta], [join_state(ct, nt)], ["x", "theta"],
                               ["gx"])
        # the generator, the locked inertia and the potential at a full state
        gens = der.ing.momenta[self.symmetry]
        eta = ca.Function("eta", [der.x, der.ing.p], [ca.vertcat(*[
            gens.get(id(f), ca.SX.zeros(f.velocity_sym.shape[0], 1)) for f in self.factors])],
            ["x", "p"], ["eta"])
        at_eta = join_state(cs, split_velocity(self.factors, eta(xs, p)))
        inertia_x = self._J(at_eta, p) - self._J(join_state(cs, _zeros(self.factors)), p)
        self.eta = eta
        self.locked_inertia_full = ca.Function("locked_inertia", [xs, p], [inertia_x],
                                               ["x", "p"], ["I"])
        self.potential_full = ca.Function("V", [der.x, der.ing.p], [der.V], ["x", "p"],
                                          ["V"])

    # the model ----------------------------------------------------------------------------
    def _build_model(self, kept: list[int], name: str, mu: float) -> Model:
        full, routh = self.full, self.kind is Kind.ROUTH
        n_full_u = full.n_inputs
        sel = np.zeros((n_full_u, len(kept)))
        for i, k in enumerate(kept):
            sel[k, i] = 1.0
        sel_dm = ca.DM(sel)
        lift, rate, n_p = self.lift, self.project_rate, self.n_p

        def lifted(ctx: Context) -> tuple[Any, Any]:
            mu = ctx.p[n_p] if routh else 0.0
            return lift(ctx.x, ctx.p[:n_p], mu), ctx.p[:n_p]

        def field(ctx: Context) -> Any:
            x, p = lifted(ctx)
            u = ca.mtimes(sel_dm, ctx.u) if kept else ca.DM.zeros(n_full_u, 1)
            out = rate(x, full.function("f")(x, u, p))
            # the lift, the full field and the projection repeat subexpressions (the mass
            # matrix, the section's entries): merged (SX only, as the full model's assembly)
            return ca.cse(out) if isinstance(out, ca.SX) else out

        invariants = {"energy": lambda ctx: full.function("energy")(*lifted(ctx))}
        if not routh:
            invariants[self.symmetry] = lambda ctx: full.function(self.symmetry)(*lifted(ctx))
        params = list(full.parameters)
        values = dict(full.values)
        if routh:
            params.append(Parameter(self.momentum_parameter, (),
                                    f"value of the momentum {self.symmetry!r}"))
            values[self.momentum_parameter] = mu

        def value_check(model: Model) -> None:
            values = full.with_parameters(**{k: model.values[k] for k in full.values})
            if routh:
                mu_new = validate.real(self.momentum_parameter,
                                       model.values[self.momentum_parameter], error=ModelError)
                check_momentum(self.momentum_parameter, mu_new,
                               momentum_scale(self, values.p, self.rtol, seed=self.seed))

        what = ("Routh model at the momentum value "
                f"{self.momentum_parameter}" if routh else "Lagrange-Poincare reduced model")
        in_desc = "; ".join(f"u[{k}]" for k in kept)
        return Model(
            name=name, manifold=ProductManifold(self.storage), n_inputs=len(kept),
            parameters=params, values=values, vector_field=field, invariants=invariants,
            symbolic=full.symbolic,
            description=f"{what} of {full.name} by its symmetry {self.quotient.description}",
            equations=(r"\dot r = d\pi(x)[f(x, u)],\; x = \mathrm{lift}(r)" + (
                r",\; J(x) = \mu" if routh else "") + r"\quad\text{(reduction by lifting)}",),
            input_description=(f"full-model inputs {in_desc} of: {full.input_description}"
                               if kept else ""),
            spd_solves=full.spd_solves, value_check=value_check)

    @property
    def configuration(self) -> list[str]:
        """The reduced model's factors that are configuration (the shape coordinates).

        Its S^1, S^2, SO(3) and TS^2 factors (a TS^2 factor: its direction) and the R^k
        factors that are positions (a factor's configuration, seen from the reference or
        with the group's coordinate dropped); the others are velocities. What
        :meth:`workbench.equilibria.ConfigurationFunction.from_state` reads by default
        (e.g. for the critical points of :attr:`amended_potential`).
        """
        positions = {f.name for f in self.factors} | {f"{f.name}_rel" for f in self.factors}
        return [n for n, m in self.storage
                if m.kind in ("S1", "S2", "SO3", "TS2") or n in positions]

    @property
    def model(self) -> Model:
        """The reduced model (see the class attributes)."""
        if self._model is None:
            raise ModelError("the reduced model is made by reduce(...)")
        return self._model

    # numeric maps ---------------------------------------------------------------------------
    def _mu(self, mu: float | None) -> float:
        if self.kind is not Kind.ROUTH:
            return 0.0
        if mu is None:
            return float(self.model.values[self.momentum_parameter])
        return validate.real("mu", mu, error=ModelError)

    def state_from_full(self, x_full: Any, *, tol: float = 1e-9) -> np.ndarray:
        """The reduced state of a full state (the quotient map).

        Parameters
        ----------
        x_full : array-like, shape=(n_full,)
            A state of the full model (checked on its manifold).
        tol : float
            Routh: the full state's momentum must equal the model's momentum value to
            ``tol * max(1, |mu|)``, else ModelError (change the value with
            ``model.with_parameters``).

        Returns
        -------
        ndarray, shape=(n_reduced,)
        """
        x = self.full.check_state(x_full, name="x_full")
        tol = validate.tolerance("tol", tol, error=ModelError)
        if self.kind is Kind.ROUTH:
            J = self.momentum_of(x)
            mu = self._mu(None)
            if abs(J - mu) > validate.scaled_tolerance(tol, mu):
                raise ModelError(
                    f"the full state has momentum {self.symmetry} = {J:.12g} but the Routh "
                    f"model is at {self.momentum_parameter} = {mu:.12g}; use "
                    f"model.with_parameters({self.momentum_parameter}={J:.12g})")
        return np.asarray(self.project(x), dtype=float).ravel()

    def momentum_of(self, x_full: Any) -> float:
        """The momentum ``J`` of a full state."""
        x = self.full.check_state(x_full, name="x_full")
        return float(self._J(x, self.full.p))

    def full_state(self, r: Any, *, mu: float | None = None) -> np.ndarray:
        """The full state over a reduced one on the section (Routh: momentum ``mu``).

        Parameters
        ----------
        r : array-like, shape=(n_reduced,)
            A reduced state (checked on the reduced manifold).
        mu : float, optional
            Routh: the momentum value (default the model's).

        Returns
        -------
        ndarray, shape=(n_full,)
        """
        rv = self.model.check_state(r, name="r")
        return np.asarray(self.lift(rv, self.full.p, self._mu(mu)), dtype=float).ravel()

    def field_at_lift(self, r: Any, u: Any = None, *, theta: float = 0.0,
                      mu: float | None = None) -> np.ndarray:
        """The reduced field from the full field at the lift of ``r`` turned by ``theta``.

        ``d pi(x) [f(x, u)]`` at ``x = g_theta lift(r)``: the same for every ``theta`` (and
        every section) when the full field is invariant, which :func:`reduce` checks and
        this method lets one measure. At ``theta = 0`` it is the reduced model's field.

        Parameters
        ----------
        r : array-like, shape=(n_reduced,)
            A reduced state.
        u : array-like, shape=(n_full_inputs,), optional
            Input of the *full* model (default zero).
        theta : float
            The group element (an angle, or a translation's length).
        mu : float, optional
            Routh: the momentum value (default the model's).

        Returns
        -------
        ndarray, shape=(n_reduced,)
        """
        rv = self.model.check_state(r, name="r")
        theta = validate.real("theta", theta, error=ModelError)
        uv = self.full._input(u)  # noqa: SLF001 - the full model's own input check
        x = self.act(self.lift(rv, self.full.p, self._mu(mu)), theta)
        xd = self.full.function("f")(x, uv, self.full.p)
        return np.asarray(self.project_rate(x, xd), dtype=float).ravel()

    def _amended(self) -> tuple[Any, Any, Any]:
        S = ca.SX
        r, p = S.sym("r", self.n_r), S.sym("p", self.n_p + (self.kind is Kind.ROUTH))
        x = self.lift(r, p[: self.n_p], 0.0)
        inertia = self.locked_inertia_full(x, p[: self.n_p])
        return r, p, (x, inertia)

    @property
    def locked_inertia(self) -> ca.Function:
        """``(r, p) -> I``: the locked inertia ``eta^T M eta`` over the reduced state."""
        r, p, (_, inertia) = self._amended()
        return ca.Function("locked_inertia", [r, p], [inertia], ["x", "p"], ["I"])

    @property
    def amended_potential(self) -> ca.Function:
        """``(r, p) -> V_mu = V + mu^2 / (2 I)`` on the Routh model's state and parameters.

        Its critical points on the shape manifold (the velocities of ``r`` are ignored)
        are the relative equilibria: the equilibria of the Routh model at rest.

        Raises
        ------
        ModelError
            For a Lagrange-Poincare reduction (no momentum value), or a kinetic energy
            that is not a quadratic form in the velocities (the amended potential then has
            more terms).
        """
        if self.kind is not Kind.ROUTH:
            raise ModelError("the amended potential belongs to the Routh model (a momentum "
                             "value); reduce with kind='routh'")
        if not self._der.homogeneous:
            raise ModelError("the amended potential V + mu^2/(2 I) needs a kinetic energy "
                             "quadratic in the velocities; this one has other terms")
        r, p, (x, inertia) = self._amended()
        mu = p[self.n_p]
        V = self.potential_full(x, p[: self.n_p]) + mu**2 / (2 * inertia)
        return ca.Function("amended_potential", [r, p], [V], ["x", "p"], ["V_mu"])


def _zeros(factors: list) -> list:
    return [ca.SX.zeros(f.velocity_sym.shape[0], 1) for f in factors]


def _evaluator(der: Any, p: np.ndarray) -> Any:
    def evaluate(expr: Any, x: np.ndarray) -> np.ndarray:
        fn = ca.Function("g", [der.x, der.ing.p], [ca.SX(expr)])
        return np.asarray(fn(x, p), dtype=float).ravel()

    return evaluate


class BreakingInputs(StrEnum):
    """What :func:`reduce` does with inputs that break the symmetry.

    Attributes
    ----------
    REFUSE
        Raise ModelError naming them.
    HOLD_ZERO
        Hold them at zero: the reduced model has the other inputs only
        (:attr:`Reduction.held_inputs` lists the ones held).
    """

    REFUSE = "refuse"
    HOLD_ZERO = "hold_zero"


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b), initial=0.0)) / max(
        float(np.max(np.abs(a), initial=0.0)), float(np.max(np.abs(b), initial=0.0)), 1e-300)


def _check(red: Reduction, mu: float, rng: np.random.Generator, n_states: int,
           rtol: float) -> list[int]:
    """The numeric checks of :func:`reduce`; the input columns that break the symmetry."""
    full, S = red.full, red.full.sym
    n_u, p = full.n_inputs, full.p
    f = full.function("f")
    x, u = S.sym("x", full.manifold.ambient_dim), S.sym("u", n_u)
    rd = red.project_rate(x, f(x, u, p))
    rates = ca.Function("rates", [x, u], [rd, ca.jacobian(rd, u)])
    dJ_du, proved = input_momentum_rates(red._der, red._der.ing.momenta[red.symmetry])
    man = ProductManifold(red.storage)
    broken: dict[int, str] = {}
    for _ in range(n_states):
        r = man.random_point(rng)
        x1 = np.asarray(red.lift(r, p, mu), dtype=float).ravel()
        x2 = np.asarray(red.act(x1, rng.uniform(0.5, 6.0)), dtype=float).ravel()
        for xx, where in ((x1, "the lifted state"), (x2, "the turned lifted state")):
            back = np.asarray(red.project(xx), dtype=float).ravel()
            if _rel(back, r) > rtol:
                raise ModelError(f"internal: the quotient of {where} is not the reduced state "
                                 f"(relative deviation {_rel(back, r):.3g})")
        if red.kind is Kind.ROUTH and abs(red.momentum_of(x1) - mu) > rtol * max(1, abs(mu)):
            raise ModelError(f"internal: the lifted state has momentum {red.momentum_of(x1)!r}"
                             f", not {mu!r}")
        uu = rng.standard_normal(n_u)
        (a0, B1), (a1, B2) = ((np.asarray(v, dtype=float) for v in rates(xx, 0 * uu))
                              for xx in (x1, x2))
        if _rel(a0, a1) > rtol:
            raise ModelError(
                f"the field of {full.name!r} is not invariant under {red.quotient.description}:"
                f" the reduced field from two lifts differs by {_rel(a0, a1):.3g} (relative); "
                "the declared momentum is not a symmetry of the unforced system")
        B1, B2 = (np.asarray(rates(xx, uu)[1], dtype=float) for xx in (x1, x2))
        scale = max(float(np.max(np.abs(a0), initial=0.0)), 1e-300)
        dj, dj_abs = (np.asarray(v, dtype=float).ravel() for v in dJ_du(x1, uu, p))
        for k in range(n_u):
            d = float(np.max(np.abs(B1[:, k] - B2[:, k]), initial=0.0))
            col = max(float(np.max(np.abs(B1[:, k]), initial=0.0)), scale)
            if d > rtol * col:
                broken.setdefault(k, "its effect is not invariant under the symmetry")
            # whether an input changes the momentum is structural (rounding level), not
            # a question of the caller's rtol
            if red.kind is Kind.ROUTH and not proved[k] \
                    and abs(dj[k]) > INPUT_MOMENTUM_TOL * dj_abs[k]:
                broken.setdefault(k, f"it changes the momentum {red.symmetry!r} "
                                     f"(dJ/du = {dj[k]:.3g})")
    red._broken = broken
    return sorted(broken)


def reduce(source: Any, symmetry: str, *, kind: ReductionKind | str = ReductionKind.ROUTH,
           momentum: float | None = None,
           breaking_inputs: BreakingInputs | str = BreakingInputs.REFUSE,
           name: str | None = None, n_states: int = 3, seed: int = 0,
           rtol: float = INVARIANCE_RTOL, accept_sampled: bool = False) -> Reduction:
    """Reduce a mechanics model by one of its symmetries: Routh or Lagrange-Poincare.

    Parameters
    ----------
    source : System or Model
        A :class:`workbench.mechanics.System` (its :meth:`~System.model` is built) or a
        model made by one.
    symmetry : str
        The name of a declared or detected momentum (:meth:`System.momentum`,
        :meth:`System.detect_momenta`): a translation of R^k factors or a rotation about
        a constant axis that turns an SO(3) factor.
    kind : ReductionKind or {"routh", "lagrange_poincare"}
        ``"routh"``: the shape configuration and the shape velocities at a momentum value
        (the group velocity eliminated); ``"lagrange_poincare"``: the shape configuration
        with every velocity in invariant form (for a rotation with an SO(3) factor: the
        reduced attitude ``Gamma = R^T a`` and the body angular velocity).
    momentum : float, optional
        Routh (required): the momentum value, the reduced model's parameter ``mu``
        (``mu_<symmetry>`` if the full model already has a ``mu``); continuation and
        ``with_parameters`` change it. Lagrange-Poincare: must be omitted. Its size is
        bounded by what the lift can carry in double precision,
        ``|mu| <= (rtol / eps) min(I / |eta|)`` over the shape space (``I`` the locked
        inertia, ``eta`` the generator; :mod:`._reduction_momentum`), checked here and by
        ``with_parameters``.
    breaking_inputs : BreakingInputs or {"refuse", "hold_zero"}
        Inputs whose effect is not invariant under the symmetry, or (Routh) that change
        the momentum (a motor on the symmetry's own coordinate: ``dJ/du != 0`` beyond
        rounding, whatever ``rtol``), are refused with their names (default) or held at
        zero (then :attr:`Reduction.held_inputs` lists them).
    name : str, optional
        The reduced model's name (default ``<full>_routh`` or ``<full>_reduced``).
    n_states : int
        Seeded random reduced states at which the checks run (module docstring), in
        ``[1, MAX_CHECK_STATES]``.
    seed : int
        Their seed.
    rtol : float
        Relative tolerance of the invariance checks (the reduced field, and each input's
        effect, from two lifts), in (0, 1).
    accept_sampled : bool
        The symmetry must be *established*: the momentum conserved and the field at zero
        input invariant, each zero in the graph or an identity of its exact evaluation
        on the manifold (:func:`~workbench.mechanics._symmetry.symmetry_evidence`), as
        for every momentum :meth:`System.detect_momenta` declares by default. Random
        states alone miss a symmetry broken between them (a narrow bump), so a symmetry
        whose graph the exact test cannot decide (``exp``, ``fmax``...) or that it finds
        broken is refused, unless ``accept_sampled=True``: then reduced on the checks'
        evidence with a UserWarning (:attr:`Reduction.evidence` says which).

    Returns
    -------
    Reduction
        With ``.model`` (an ordinary Model), ``.state_from_full``, ``.full_state``,
        ``.amended_potential``, ``.locked_inertia``, ``.reconstruction`` and
        ``.reconstruct``.

    Raises
    ------
    ModelError
        Not a mechanics model, an unknown momentum, a momentum value too large for double
        precision (with the bound), a symmetry of another kind, a field that is not
        invariant, or inputs that break the symmetry (named).
    """
    from workbench.mechanics._system import System

    full = source.model() if isinstance(source, System) else source
    der = getattr(full, "mechanics", None)
    if not isinstance(full, Model) or der is None:
        raise ModelError(f"source must be a workbench.mechanics System or a model made by one; "
                         f"got {type(source).__name__}")
    kind = validate.choice(Kind, kind, "kind", error=ModelError)
    breaking = validate.choice(BreakingInputs, breaking_inputs, "breaking_inputs",
                               error=ModelError)
    if symmetry not in der.ing.momenta:
        raise ModelError(f"symmetry must name a momentum of {full.name!r}; got {symmetry!r}, "
                         f"known: {sorted(der.ing.momenta)} (declare one with "
                         "System.momentum or find them with System.detect_momenta)")
    n_states = validate.count("n_states", n_states, maximum=MAX_CHECK_STATES, error=ModelError)
    seed = validate.count("seed", seed, minimum=0, error=ModelError)
    rtol = validate.relative_tolerance(
        "rtol", rtol, why="1 or more would accept a field that is not invariant",
        error=ModelError)
    if not isinstance(accept_sampled, bool):
        raise ModelError(f"accept_sampled must be True or False; got {accept_sampled!r}")
    mu_name = None
    if kind is Kind.ROUTH:
        if momentum is None:
            raise ModelError("momentum (the value of the momentum the Routh model is at) is "
                             "required for kind='routh'")
        mu = validate.real("momentum", momentum, error=ModelError)
        mu_name = "mu" if "mu" not in full.values else f"mu_{symmetry}"
        if mu_name in full.values:
            raise ModelError(f"the full model already has parameters 'mu' and {mu_name!r}")
    else:
        if momentum is not None:
            raise ModelError(f"momentum is a Routh value; kind='lagrange_poincare' keeps the "
                             f"group velocity (got momentum={momentum!r})")
        mu = 0.0
    for f in der.ing.factors:
        g = der.ing.momenta[symmetry].get(id(f))
        if g is not None and ca.depends_on(ca.SX(g), der.ing.p):
            raise ModelError(
                f"the generator of {symmetry!r} on factor {f.name!r} depends on parameters; "
                "the reduction fixes the symmetry's geometry (axis, direction), so write it "
                "with numbers")
    rng = np.random.default_rng(seed)
    states = [full.manifold.random_point(rng) for _ in range(max(n_states, 2))]
    quotient = classify(list(der.ing.factors), der.ing.momenta[symmetry],
                        _evaluator(der, full.p), states, symmetry)
    red = Reduction(full, symmetry, kind, quotient, mu_name)
    red.rtol, red.seed = rtol, seed
    red.evidence = established(der, symmetry, red.act, full, seed=seed, n_states=n_states,
                               accept_sampled=accept_sampled)
    if kind is Kind.ROUTH:  # a momentum the lift cannot carry is refused before the checks
        check_momentum("momentum", mu, momentum_scale(red, full.p, rtol, seed=seed))
    broken = _check(red, mu, rng, n_states, rtol)
    if broken and breaking is BreakingInputs.REFUSE:
        named = "; ".join(f"u[{k}]: {red._broken[k]}" for k in broken)
        raise ModelError(
            f"inputs of {full.name!r} ({full.input_description or 'no description'}) break "
            f"the symmetry {symmetry!r}: {named}; pass breaking_inputs='hold_zero' to reduce "
            "the system with them held at zero")
    red.held_inputs = tuple(broken)
    kept = [k for k in range(full.n_inputs) if k not in broken]
    default = f"{full.name}_{'routh' if kind is Kind.ROUTH else 'reduced'}"
    red._model = red._build_model(kept, name or default, mu)
    red._model.reduction = red  # the reduction, for inspection (configuration, lift)
    return red
