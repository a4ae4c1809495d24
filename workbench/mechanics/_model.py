"""From a declared system to an ordinary :class:`workbench.Model`.

The derivation (:mod:`._equations`) is done once, when the model is made; the model's
casadi functions (``f``, its Jacobians, the invariants) are built lazily by the Model and
logged as usual. Invariants: ``energy`` (``T + V``) and one Noether momentum per declared
symmetry.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._engine import (
    Context,
    Model,
    ModelError,
    ProductManifold,
    Symbolic,
    solve_spd,
)
from workbench.mechanics._equations import Derivation, Ingredients

__all__ = ["build_model", "check_kinetic_energy", "MAX_SX_VELOCITIES"]

MAX_SX_VELOCITIES = 9
"""``symbolic="auto"`` takes SX (a symbolic solve) up to this many velocity coordinates."""

PD_RTOL = 1e-10
"""A tangent mass-matrix eigenvalue below ``PD_RTOL * max eigenvalue`` counts as singular."""

MOMENTUM_RTOL = 1e-8
"""Declared momenta must have ``|dJ/dt| <= MOMENTUM_RTOL |grad J| |f|`` at the check state."""


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
        raise ModelError(f"system {system.name!r} has no factors; add rn(...), s2(...) or "
                         "so3(...)")
    for f in system.factors:
        if not ca.depends_on(der.T, f.velocity_sym):
            raise ModelError(
                f"the kinetic energy does not depend on the velocity of factor {f.name!r} "
                f"({f.velocity_names}); every declared velocity needs inertia (add a body or a "
                "kinetic term)")


def check_kinetic_energy(der: Derivation, factors: list, x: np.ndarray, p: np.ndarray) -> None:
    """Raise ModelError unless ``T`` is positive definite on the tangent velocities at ``x``.

    Parameters
    ----------
    der : Derivation
        The derived equations.
    factors : list of Factor
        The system's factors.
    x : ndarray, shape=(n_x,)
        A state (only its configuration matters).
    p : ndarray, shape=(n_p,)
        Parameter values.
    """
    M = np.asarray(der.mass_matrix()(x, p))
    bases, spans, k = [], [], 0
    xs = np.asarray(x, dtype=float).ravel()
    kx = 0
    for f in factors:
        nc = f.config_sym.shape[0]
        B = f.velocity_basis(xs[kx : kx + nc])
        kx += sum(s.shape[0] for s in f.state_symbols())
        bases.append(B)
        spans.append((f, k, k + B.shape[1]))
        k += B.shape[1]
    N = np.zeros((M.shape[0], k))
    r = c = 0
    for B in bases:
        N[r : r + B.shape[0], c : c + B.shape[1]] = B
        r, c = r + B.shape[0], c + B.shape[1]
    K = N.T @ M @ N
    if not np.all(np.isfinite(K)):
        raise ModelError(f"the kinetic energy's mass matrix is not finite at x = {xs.tolist()}")
    eig, vec = np.linalg.eigh(0.5 * (K + K.T))
    scale = max(float(np.max(np.abs(eig))), 1e-300)
    if eig[0] > PD_RTOL * scale:
        return
    v = vec[:, 0]
    worst = max(spans, key=lambda s: float(np.linalg.norm(v[s[1] : s[2]])))
    kind = "singular" if abs(eig[0]) <= PD_RTOL * scale else "not positive definite"
    raise ModelError(
        f"the kinetic energy is {kind} at the state x = {_flat(xs)}: "
        f"smallest eigenvalue {eig[0]:.3g} of the mass matrix on the tangent velocities "
        f"(largest {eig[-1]:.3g}); its direction lies mostly in factor {worst[0].name!r} "
        f"({worst[0].velocity_names})")


def _check_momenta(model: Model, der: Derivation, x: np.ndarray) -> None:
    if not der.ing.momenta:
        return
    # a throw-away graph: the check must not build (and log) the model's own f
    f = model._make_f()  # noqa: SLF001 - the builder, without the model's cache and log
    xdot = np.asarray(f(x, np.zeros(model.n_inputs), model.p), dtype=float).ravel()
    for name, gens in der.ing.momenta.items():
        J = der.momentum(gens)
        grad = np.asarray(ca.Function("g", [der.x, der.ing.p],
                                      [ca.gradient(J(der.x, der.ing.p), der.x)])(x, model.p))
        rate = float(grad.ravel() @ xdot)
        scale = float(np.linalg.norm(grad) * np.linalg.norm(xdot))
        if abs(rate) > MOMENTUM_RTOL * max(scale, 1e-300) and abs(rate) > 1e-14:
            raise ModelError(
                f"declared momentum {name!r} is not conserved: dJ/dt = {rate:.3g} at the "
                f"state x = {_flat(x)} with u = 0; the Lagrangian or "
                "the loads are not invariant under its generator")


def _describe(system: Any) -> str:
    parts = [f"{f.kind} {f.name}" for f in system.factors]
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
    model = Model(
        name=name, manifold=manifold, n_inputs=int(der.ing.u.shape[0]),
        parameters=system.parameters, values=system.values, vector_field=field,
        invariants=invariants, symbolic=sym, description=description or _describe(system),
        equations=tuple(equations) or (
            r"\frac{d}{dt}\frac{\partial L}{\partial \nu} + \mathrm{ad}^*"
            r" = K(c)^T \frac{\partial L}{\partial c} + Q"
            r"\quad\text{(Lagrange-d'Alembert on each factor, derived by AD)}",),
        input_description=input_description or "; ".join(system.input_descriptions()),
        jacobian=jacobian if sym == "MX" else None, spd_solves=True)
    model.mechanics = der  # the derivation, for inspection (mass matrix, residual)
    if check:
        x0 = manifold.random_point(np.random.default_rng(0))
        check_kinetic_energy(der, system.factors, x0, model.p)
        _check_momenta(model, der, x0)
    return model
