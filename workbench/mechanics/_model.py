"""From a declared system to an ordinary :class:`workbench.Model`.

The derivation (:mod:`._equations`) is done once, when the model is made; the model's
casadi functions (``f``, its Jacobians, the invariants) are built lazily by the Model and
logged as usual. Invariants: ``energy`` (``T + V``, or the Jacobi integral
``Pi . nu - T + V`` when ``T`` is not quadratic in the velocities) and one Noether momentum
per declared symmetry.

Build checks (``check=True``), at a random state of the manifold and the parameter values:
the mass matrix is positive definite on the tangent velocities, every rigid body's inertia
(as given, about its centre of mass or origin, also when made of parameters) is symmetric
and positive definite, and one given about the origin implies an inertia about the centre of
mass that is positive semi-definite and satisfies the triangle inequality (where that
inertia enters the kinetic energy: not for a body on a fixed pivot, written about the pivot
with the inertia as given), every attitude
expression is a rotation, the dissipation function is a positive semi-definite form,
gravity's direction is a unit vector, and every declared momentum is conserved. The same
checks run again on every :meth:`Model.with_parameters`.

The definiteness of the kinetic energy depends on the state, so one state is not enough:
the model also carries ``model.state_check`` (a :class:`._state_check.StateCheck`), which
:func:`workbench.simulate`, the OCP and :func:`workbench.linearize` call at the states they
use (the initial state, every output state, every node).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._bodies import RigidBody, written_about_origin
from workbench.mechanics._checks import check_origin_inertia, inertia
from workbench.mechanics._engine import (
    Context,
    Model,
    ModelError,
    ProductManifold,
    Symbolic,
    solve_spd,
)
from workbench.mechanics._equations import Derivation, Ingredients
from workbench.mechanics._state_check import StateCheck, check_kinetic_energy

__all__ = ["build_model", "check_kinetic_energy", "MAX_SX_VELOCITIES"]

MAX_SX_VELOCITIES = 9
"""``symbolic="auto"`` takes SX (a symbolic solve) up to this many velocity coordinates."""

MOMENTUM_RTOL = 1e-8
"""Declared momenta must have ``|dJ/dt| <= MOMENTUM_RTOL |grad J| |f|`` at the check state."""

ROTATION_TOL = 1e-10
"""An attitude expression must have ``max |R^T R - I| <= ROTATION_TOL`` and ``det R > 0``."""

DIRECTION_TOL = 1e-12
"""Gravity's direction must have ``| |d| - 1 | <= DIRECTION_TOL``."""

PSD_RTOL = 1e-12
"""The dissipation's Hessian in the velocities may have eigenvalues down to
``-PSD_RTOL * max |eigenvalue|`` (rounding), no lower."""


def _flat(x: np.ndarray) -> str:
    """A state on one line, four significant digits."""
    return np.array2string(np.asarray(x), precision=4, max_line_width=100000)


def _sum(terms: list) -> ca.SX:
    out = ca.SX(0)
    for t in terms:
        out = out + t
    return out


def _ingredients(system: Any) -> Ingredients:
    return Ingredients(
        factors=list(system.factors), u=system.stacked_inputs(), p=system.stacked_parameters(),
        kinetic=_sum(system.kinetic_terms), bodies=list(system.bodies),
        potential=system.total_potential(), loads=list(system.loads),
        dissipation=_sum(system.dissipation_terms), momenta=dict(system.momenta))


def _structural_checks(system: Any, der: Derivation) -> None:
    if not system.factors:
        raise ModelError(f"system {system.name!r} has no factors; add rn(...), s1(...), "
                         "s2(...) or so3(...)")
    for f in system.factors:
        if not ca.depends_on(der.T, f.velocity_sym):
            raise ModelError(
                f"the kinetic energy does not depend on the velocity of factor {f.name!r} "
                f"({f.velocity_names}); every declared velocity needs inertia (add a body or a "
                "kinetic term)")


def _check_momenta(model: Model, der: Derivation, x: np.ndarray, cache: dict) -> None:
    if not der.ing.momenta:
        return
    if "f" not in cache:
        # a throw-away graph: the check must not build (and log) the model's own f
        cache["f"] = model._make_f()  # noqa: SLF001 - the builder, without cache and log
        cache["grad"] = {
            name: ca.Function("g", [der.x, der.ing.p],
                              [ca.gradient(der.momentum(gens)(der.x, der.ing.p), der.x)])
            for name, gens in der.ing.momenta.items()}
    xdot = np.asarray(cache["f"](x, np.zeros(model.n_inputs), model.p), dtype=float).ravel()
    for name, grad_fn in cache["grad"].items():
        grad = np.asarray(grad_fn(x, model.p), dtype=float).ravel()
        rate = float(grad @ xdot)
        scale = float(np.linalg.norm(grad) * np.linalg.norm(xdot))
        # relative only: an absolute floor would pass any momentum of a small enough system
        if abs(rate) > MOMENTUM_RTOL * scale:
            raise ModelError(
                f"declared momentum {name!r} is not conserved: dJ/dt = {rate:.3g} "
                f"(|grad J| |f| = {scale:.3g}) at the state x = {_flat(x)} with u = 0; the "
                "Lagrangian or the loads are not invariant under its generator")


def _value_checks(system: Any, der: Derivation) -> Any:
    """The build checks that depend on parameter values, as ``check(model, x)``.

    Each numeric function is made once here; ``check`` evaluates them at the state ``x``
    and the model's values, and raises ModelError naming the body, factor or term.
    """
    x, p = der.x, der.ing.p
    rigid = [b for b in system.bodies if isinstance(b, RigidBody)]
    given = [b.inertia_origin if b.inertia_origin is not None else b.inertia for b in rigid]
    inertias = ca.Function("J", [p], [ca.horzcat(*given)]) if rigid else None
    # J_com implied by a J_O made of parameters is checked where it enters T (the papers'
    # pendulum on a fixed pivot takes J_O, m, rho as independent parameters: its energy is
    # written about the pivot with J_O alone, checked as given above)
    origin = [b for b in rigid if b.inertia_origin is not None
              and not written_about_origin(b, x)]
    implied = [ca.Function("Jm", [p], [b.inertia_origin, b.mass, b.com_offset]) for b in origin]
    free = [b for b in rigid if b.factor is None]  # attitudes written as expressions
    attitudes = ca.Function("R", [x, p], [ca.horzcat(*[b.attitude for b in free])]) \
        if free else None
    directions = [ca.Function("d", [p], [d]) for _, d in system._gravity]  # noqa: SLF001
    dissipation = None
    if not der.D.is_zero():
        dissipation = ca.Function("D", [x, p], [der.D, ca.hessian(der.D, der.nu)[0]])
    cache: dict[str, Any] = {}
    mass = der.mass_matrix()

    def check(model: Model, xs: np.ndarray) -> None:
        pv = model.p
        if inertias is not None:  # before the mass matrix: the message names the body
            Js = np.asarray(inertias(pv), dtype=float)
            for k, b in enumerate(rigid):
                msg = inertia(Js[:, 3 * k: 3 * k + 3], triangle=False)
                if msg:
                    about = "origin" if b.inertia_origin is not None else "centre of mass"
                    raise ModelError(f"rigid body {b.name!r}: its inertia about its {about}, "
                                     f"with the parameter values, {msg}")
            for b, fn in zip(origin, implied):
                J_O, mb, c = (np.asarray(v, dtype=float) for v in fn(pv))
                msg = check_origin_inertia(J_O, float(mb.ravel()[0]), c.ravel())
                if msg:
                    raise ModelError(f"rigid body {b.name!r}, with the parameter values: {msg}")
        if attitudes is not None:
            Rs = np.asarray(attitudes(xs, pv), dtype=float)
            for k, b in enumerate(free):
                R = Rs[:, 3 * k: 3 * k + 3]
                err = float(np.max(np.abs(R.T @ R - np.eye(3))))
                det = float(np.linalg.det(R))
                if not err <= ROTATION_TOL or not det > 0:
                    raise ModelError(
                        f"rigid body {b.name!r}: its attitude must be a rotation (R^T R = I, "
                        f"det R = +1); at the state x = {_flat(xs)} it has max |R^T R - I| = "
                        f"{err:.3g} and det R = {det:.6g}")
        for fn in directions:
            d = np.asarray(fn(pv), dtype=float).ravel()
            if not abs(float(np.linalg.norm(d)) - 1.0) <= DIRECTION_TOL:
                raise ModelError(f"gravity's direction must be a unit vector; with the "
                                 f"parameter values it is {d.tolist()} (norm "
                                 f"{np.linalg.norm(d):.12g})")
        check_kinetic_energy(der, system.factors, xs, pv, mass_matrix=mass)
        if dissipation is not None:
            Dv, H = (np.asarray(v, dtype=float) for v in dissipation(xs, pv))
            eig = np.linalg.eigvalsh(0.5 * (H + H.T))
            floor = -PSD_RTOL * max(float(np.max(np.abs(eig))), 1e-300)
            if not float(Dv.ravel()[0]) >= floor or not eig[0] >= floor:
                raise ModelError(
                    f"the dissipation function must be >= 0, a positive semi-definite form in "
                    f"the velocities (it takes energy out); at the state x = {_flat(xs)} it "
                    f"is {float(Dv.ravel()[0]):.3g} with Hessian eigenvalues "
                    f"{np.array2string(eig, precision=3)}")
        _check_momenta(model, der, xs, cache)

    return check


def _describe(system: Any) -> str:
    parts = [f.describe() for f in system.factors]
    return (f"{system.name}: Lagrange-d'Alembert equations derived by AD on "
            + " x ".join(parts))


def build_model(system: Any, name: str, *, symbolic: str, linear_solver: str, check: bool,
                description: str, equations: Any, input_description: str) -> Model:
    """Derive the equations of a :class:`System` and wrap them in a Model (see there)."""
    if symbolic not in ("auto", "SX", "MX", Symbolic.SX, Symbolic.MX):
        raise ModelError(f"symbolic must be 'auto', 'SX' or 'MX'; got {symbolic!r}")
    if not isinstance(linear_solver, str) or not ca.has_linsol(linear_solver):
        raise ModelError(f"linear_solver must name a casadi linsol plugin (e.g. 'lapacklu', "
                         f"'ldl', 'qr'); got {linear_solver!r}")
    der = Derivation(_ingredients(system), name)
    _structural_checks(system, der)
    sym = str(symbolic)
    if sym == "auto":
        sym = "SX" if der.n_nu <= MAX_SX_VELOCITIES else "MX"
    rates = der.rates()
    asm = der.assembly(cse=True) if sym == "SX" else None
    cache: dict[str, ca.Function] = {}

    def field(ctx: Context) -> Any:
        if sym == "SX":
            A, b = asm(ctx.x, ctx.u, ctx.p)
            return rates(ctx.x, solve_spd(A, b))
        if "acc" not in cache:
            cache["acc"], cache["acc_jac"] = der.accelerations_mx(linear_solver)
        return rates(ctx.x, cache["acc"](ctx.x, ctx.u, ctx.p))

    def jacobian(ctx: Context, which: str) -> Any:
        # MX: the chain rule through the rates with the supplied Jacobian called once (AD of
        # f would call it once per batch of 64 directions)
        field(ctx)
        if "rates_jac" not in cache:
            cache["rates_jac"] = der.rates_jacobian()
        acc = cache["acc"](ctx.x, ctx.u, ctx.p)
        acc_x, acc_u, _ = cache["acc_jac"](ctx.x, ctx.u, ctx.p, acc)
        r_x, r_acc = cache["rates_jac"](ctx.x, acc)
        return r_x + ca.mtimes(r_acc, acc_x) if which == "f_x" else ca.mtimes(r_acc, acc_u)

    energy = der.energy()
    invariants = {"energy": lambda ctx: energy(ctx.x, ctx.p)}
    for mname, gens in system.momenta.items():
        invariants[mname] = (lambda fn: lambda ctx: fn(ctx.x, ctx.p))(der.momentum(gens))
    manifold = ProductManifold([s for f in system.factors for s in f.storage()])
    checks: Any = None
    if check:
        x0 = manifold.random_point(np.random.default_rng(0))
        at = _value_checks(system, der)

        def checks(model: Model) -> None:
            at(model, x0)

    model = Model(
        name=name, manifold=manifold, n_inputs=int(der.ing.u.shape[0]),
        parameters=system.parameters, values=system.values, vector_field=field,
        invariants=invariants, symbolic=sym, description=description or _describe(system),
        equations=tuple(equations) or (
            r"\frac{d}{dt}\frac{\partial L}{\partial \nu} + \mathrm{ad}^*"
            r" = K(c)^T \frac{\partial L}{\partial c} + Q"
            r"\quad\text{(Lagrange-d'Alembert on each factor, derived by AD)}",),
        input_description=input_description or "; ".join(system.input_descriptions()),
        jacobian=jacobian if sym == "MX" else None, spd_solves=True,
        value_check=checks)
    model.mechanics = der  # the derivation, for inspection (mass matrix, residual)
    # the definiteness of T at the states where the model is used (x0, trajectories, OCP
    # nodes): simulate, OCP, solve and linearize call it; check=False leaves it out too
    model.state_check = StateCheck(der, system.factors) if check else None
    if check:
        checks(model)
    return model
