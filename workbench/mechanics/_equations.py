"""The Lagrange-d'Alembert equations on each factor, derived by automatic differentiation.

With the Lagrangian ``L(c, nu) = T(c, nu_eff) - V(c)`` (``nu_eff``: see :mod:`._factors`),
``Pi = dL/dnu`` and the generalised forces ``Q``, each factor obeys

* R^k:    ``d/dt dL/dv = dL/dx + Q``;
* SO(3):  ``d/dt dL/dOmega + Omega x dL/dOmega = sum_i dL/dr_i x r_i + Q``
  (``r_i`` the rows of ``R``; for ``L = T - U`` the sum is ``sum_i r_i x dU/dr_i``);
* S^2:    ``P(q) d/dt dL/domega = q x dL/dq + Q``, ``P(q) = (q.q) I - q q^T``, with
  ``q . omega-dot = 0`` so that ``omega`` stays tangent.

Writing ``d/dt Pi = M(c) nu-dot + (dPi/dc) c-dot`` with the mass matrix
``M = d^2 T / dnu^2`` (its S^2 blocks are singular along ``q`` by construction), the
accelerations solve one linear system

    (M + sum_{S^2} mu q q^T) nu-dot = b(c, nu, u),   mu = tr(M_qq) / 2 > 0,

symmetric positive definite when ``T`` is positive definite on the tangent velocities.
``M`` costs O(n^2) nodes for a chain (it is dense); ``b``, ``dL/dc``, ``dPi/dc c-dot`` and
the loads are reverse/forward sweeps of O(n) each.

Two back-ends (:class:`Symbolic`): SX writes the solve symbolically as L D L^T
(:func:`workbench.core.solve_spd`; small systems: compact scalar graphs that export to C
and convert to sympy). MX puts a numeric linear
solve (a casadi linsol plugin) in the graph inside a function whose Jacobian is supplied
(``custom_jacobian``): by the implicit-function theorem on the residual
``r(x, u, p, a) = M a + sum mu q q^T a - b``,

    d nu-dot / d(x, u, p) = -(M + sum mu q q^T)^{-1} dr/d(x, u, p) at a = nu-dot,

where ``M a`` is a Hessian-vector product (O(n) nodes), so the Jacobian graph grows like
n^2, not like the n^3 of differentiating ``M`` entry by entry. The supplied Jacobian is
itself a casadi graph (solves and AD), so second derivatives stay exact.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca

from workbench.core.manifolds import S2
from workbench.mechanics._bodies import kinetic_energy_of_bodies
from workbench.mechanics._engine import TS2, ModelError, ProductManifold
from workbench.mechanics._forces import load_covector

__all__ = ["Derivation", "Ingredients", "SPARSE_JACOBIAN_MAX", "FORWARD_BATCH"]

SPARSE_JACOBIAN_MAX = 40
"""Up to this many velocity coordinates the residual's Jacobian is a sparse AD graph
(fast to evaluate); above, mapped forward sweeps (fast to build, O(n) graph)."""

FORWARD_BATCH = 16
"""Directions per forward sweep of the residual in the large-system Jacobian."""


@dataclass(eq=False)
class Ingredients:
    """What a system declares, as SX expressions of its symbols.

    Attributes
    ----------
    factors : list of Factor
        In storage order.
    u, p : casadi.SX
        Input and parameter symbols (columns).
    kinetic : casadi.SX
        Kinetic energy written directly (a scalar expression of configuration, velocities
        and parameters); the bodies' energy is added.
    bodies : list
        Point masses and rigid bodies.
    potential : casadi.SX
        Potential energy (gravity included).
    loads : list of Load
        Generalised forces as covectors.
    dissipation : casadi.SX
        Rayleigh function (0 for none).
    momenta : dict of str to dict
        Per momentum, the generator's velocity on each factor by ``id(factor)``.
    """

    factors: list
    u: ca.SX
    p: ca.SX
    kinetic: ca.SX
    bodies: list
    potential: ca.SX
    loads: list
    dissipation: ca.SX
    momenta: dict = field(default_factory=dict)


class Derivation:
    """The derived equations of motion of a system, as SX expressions and functions.

    Parameters
    ----------
    ing : Ingredients
        The declared system.
    name : str
        Prefix of the casadi function names.
    """

    def __init__(self, ing: Ingredients, name: str) -> None:
        self.ing, self.name = ing, name
        fs = ing.factors
        self.x = ca.vertcat(*[s for f in fs for s in f.state_symbols()])
        self.c = ca.vertcat(*[f.config_sym for f in fs])
        self.nu = ca.vertcat(*[f.velocity_sym for f in fs])
        self.slices: list[slice] = []
        k = 0
        for f in fs:
            n = f.velocity_sym.shape[0]
            self.slices.append(slice(k, k + n))
            k += n
        self.n_nu = k
        nu_eff = [f.effective_velocity() for f in fs]
        self.nu_eff = ca.vertcat(*nu_eff)
        by_id = {id(f): f.velocity_sym for f in fs}
        self.cdot = ca.vertcat(*[f.kinematics(f.velocity_sym) for f in fs])
        # bodies see omega only through omega x q (their momentum is normal to q already);
        # terms written directly see omega_eff
        direct = ca.substitute(ing.kinetic, self.nu, self.nu_eff)
        self.T = direct + kinetic_energy_of_bodies(ing.bodies, self.c, self.cdot, by_id)
        self.V = ing.potential
        self.D = ca.substitute(ing.dissipation, self.nu, self.nu_eff)
        self.Pi = ca.gradient(self.T, self.nu)
        self._equations()

    def _equations(self) -> None:
        fs, ing = self.ing.factors, self.ing
        # inertial part (quadratic in nu) and the rest (potential, loads, dissipation)
        cov_T = ca.gradient(self.T, self.c)
        cov_rest = -ca.gradient(self.V, self.c) + load_covector(ing.loads, self.c)
        pidot_c = ca.jtimes(self.Pi, self.c, self.cdot)
        q_nu = -ca.gradient(self.D, self.nu)
        inertial, rest, kc = [], [], 0
        for f, sl in zip(fs, self.slices):
            nc = f.config_sym.shape[0]
            cs = slice(kc, kc + nc)
            inertial.append(f.project(-pidot_c[sl] - f.gyroscopic(self.Pi[sl])
                                      + f.kt(cov_T[cs])))
            rest.append(f.project(f.kt(cov_rest[cs]) + q_nu[sl]))
            kc += nc
        self.b_inertial, self.b_rest = ca.vertcat(*inertial), ca.vertcat(*rest)
        self.b = self.b_inertial + self.b_rest
        # M is symmetric: differentiate once, keep the lower triangle and mirror it (the
        # upper triangle's expressions are then never built into a function: ~25% fewer)
        full = ca.jacobian(self.Pi, self.nu)
        self.M = ca.tril(full) + ca.tril(full, False).T
        blocks = []
        for f, sl in zip(fs, self.slices):
            cb = f.constraint_block()
            n = f.velocity_sym.shape[0]
            if cb is None:
                blocks.append(ca.SX(n, n))
                continue
            # q q^T scaled like the tangent block (half its trace): the diagonal block of a
            # point mass on a link becomes m l^2 I, well scaled whatever m l^2 is
            blocks.append(0.5 * ca.trace(self.M[sl, sl]) * cb)
        self.Qbar = ca.diagcat(*blocks)
        self.A = self.M + self.Qbar
        self.a = ca.SX.sym("a", self.n_nu)
        self.residual = (ca.jtimes(self.Pi, self.nu, self.a) + ca.mtimes(self.Qbar, self.a)
                         - self.b)
        # T quadratic in nu (no terms linear in nu): then at rest with zero acceleration the
        # Jacobian of the residual is that of -b_rest alone
        self.quadratic = bool(ca.substitute(self.Pi, self.nu, ca.SX.zeros(self.n_nu)).is_zero())

    # functions -------------------------------------------------------------------------------

    def assembly(self, *, cse: bool = False) -> ca.Function:
        """``(x, u, p) -> (A, b)``: the linear system of the accelerations (SX).

        ``cse`` eliminates common subexpressions (worth it for small systems; its cost grows
        faster than the graph).
        """
        return ca.Function(f"{self.name}_assemble", [self.x, self.ing.u, self.ing.p],
                           [self.A, self.b], ["x", "u", "p"], ["A", "b"], {"cse": cse})

    def residual_jacobian(self) -> ca.Function:
        """``(x, u, p, a) -> [dr/dx, dr/du, dr/dp]`` of the residual (SX, sparse AD)."""
        r, ing = self.residual, self.ing
        return ca.Function(
            f"{self.name}_residual_jac", [self.x, ing.u, ing.p, self.a],
            [ca.jacobian(r, self.x), ca.jacobian(r, ing.u), ca.jacobian(r, ing.p)],
            ["x", "u", "p", "a"], ["r_x", "r_u", "r_p"])

    def residual_function(self) -> ca.Function:
        """``(x, u, p, a) -> r`` (SX)."""
        ing = self.ing
        return ca.Function(f"{self.name}_residual", [self.x, ing.u, ing.p, self.a],
                           [self.residual], ["x", "u", "p", "a"], ["r"])

    def rest_jacobian(self) -> ca.Function:
        """``(x, u, p) -> -[db_rest/dx, db_rest/du, db_rest/dp]`` at ``nu = 0`` (SX).

        Equal to the Jacobian of the residual at rest with zero acceleration when ``T`` is
        quadratic in the velocities (then ``b - b_rest`` and ``M a`` have zero Jacobians
        there).
        """
        ing, b = self.ing, self.b_rest
        zero = ca.SX.zeros(self.n_nu)
        outs = [ca.substitute(-ca.jacobian(b, w), self.nu, zero) for w in (self.x, ing.u, ing.p)]
        return ca.Function(f"{self.name}_rest_jac", [self.x, ing.u, ing.p], outs,
                           ["x", "u", "p"], ["r_x", "r_u", "r_p"])

    def at_rest(self) -> ca.Function:
        """``(x, a) -> 1`` when every velocity and acceleration is exactly zero, else 0."""
        return ca.Function(f"{self.name}_at_rest", [self.x, self.a],
                           [ca.logic_and(ca.norm_inf(self.nu) == 0, ca.norm_inf(self.a) == 0)],
                           ["x", "a"], ["rest"])

    def rates(self) -> ca.Function:
        """``(x, acc) -> x-dot`` in storage order (kinematics plus accelerations)."""
        acc = ca.SX.sym("acc", self.n_nu)
        out = []
        for f, sl in zip(self.ing.factors, self.slices):
            out += f.state_rate(acc[sl])
        return ca.Function(f"{self.name}_rates", [self.x, acc], [ca.vertcat(*out)],
                           ["x", "acc"], ["xdot"])

    def rates_jacobian(self) -> ca.Function:
        """``(x, acc) -> [d x-dot/dx, d x-dot/d acc]`` of :meth:`rates` (SX, sparse AD).

        With the accelerations' Jacobian ``d acc/dx`` the field's Jacobian is
        ``d x-dot/dx + d x-dot/d acc * d acc/dx`` (the chain rule written out).
        """
        acc = ca.SX.sym("acc", self.n_nu)
        xdot = self.rates()(self.x, acc)
        return ca.Function(f"{self.name}_rates_jac", [self.x, acc],
                           [ca.jacobian(xdot, self.x), ca.jacobian(xdot, acc)], ["x", "acc"],
                           ["rates_x", "rates_acc"])

    def _jacobian_columns(self, x: ca.MX, u: ca.MX, p: ca.MX, a: ca.MX) -> ca.MX:
        """``dr/d(x, u, p)`` at ``a`` as MX: sparse AD (small) or mapped forward sweeps."""
        if self.n_nu <= SPARSE_JACOBIAN_MAX:
            return ca.horzcat(*self.residual_jacobian()(x, u, p, a))
        rfun = self.residual_function()
        n = x.shape[0] + u.shape[0] + p.shape[0]
        k = FORWARD_BATCH
        fwd = rfun.forward(k)
        seeds = ca.DM.eye(n)
        cols = []
        r0 = rfun(x, u, p, a)
        zero_a = ca.MX.zeros(self.n_nu, k)
        nx, nu_ = x.shape[0], u.shape[0]
        for j in range(0, n, k):
            S = ca.horzcat(seeds[:, j : min(j + k, n)], ca.DM.zeros(n, max(0, j + k - n)))
            cols.append(fwd(x, u, p, a, r0, S[:nx, :], S[nx : nx + nu_, :], S[nx + nu_ :, :],
                            zero_a))
        return ca.horzcat(*cols)[:, :n]

    def accelerations_mx(self, linear_solver: str) -> tuple[ca.Function, ca.Function]:
        """``(x, u, p) -> nu-dot`` as an MX function with a numeric solve and its Jacobian.

        Returns the function and its supplied Jacobian ``(x, u, p, out_acc) -> [d nu-dot/dx,
        d nu-dot/du, d nu-dot/dp]`` (to call once where a whole Jacobian is wanted: AD of
        the function calls it once per batch of directions).
        """
        asm, ing = self.assembly(), self.ing
        x = ca.MX.sym("x", self.x.shape[0])
        u = ca.MX.sym("u", ing.u.shape[0])
        p = ca.MX.sym("p", ing.p.shape[0])
        A, b = asm(x, u, p)
        acc = ca.solve(A, b, linear_solver)
        out = ca.MX.sym("out_acc", self.n_nu)
        sol = -ca.solve(A, self._jacobian_columns(x, u, p, out), linear_solver)
        if self.quadratic:
            # at rest with zero acceleration only -db_rest/d(x, u, p) remains: solve for its
            # structurally nonzero columns only
            rest = ca.horzcat(*self.rest_jacobian()(x, u, p))
            nz = sorted(set(rest.sparsity().get_col()))
            sol_rest = ca.MX(rest.shape[0], rest.shape[1])
            if nz:
                sol_rest[:, nz] = -ca.solve(A, ca.densify(rest[:, nz]), linear_solver)
            sol = ca.if_else(self.at_rest()(x, out), sol_rest, sol, True)
        nx, nu_ = x.shape[0], u.shape[0]
        jac = ca.Function(
            f"jac_{self.name}_acc", [x, u, p, out],
            [sol[:, :nx], sol[:, nx : nx + nu_], sol[:, nx + nu_ :]],
            ["x", "u", "p", "out_acc"], ["jac_acc_x", "jac_acc_u", "jac_acc_p"])
        return ca.Function(f"{self.name}_acc", [x, u, p], [acc], ["x", "u", "p"], ["acc"],
                           {"custom_jacobian": jac, "jac_penalty": 0}), jac

    @property
    def homogeneous(self) -> bool:
        """True when ``T`` is a quadratic form in the velocities.

        No terms of degree 0 or 1 and a mass matrix free of velocities: then
        ``Pi . nu = 2 T``.
        """
        zero = ca.SX.zeros(self.n_nu)
        return (self.quadratic and ca.substitute(self.T, self.nu, zero).is_zero()
                and not ca.depends_on(self.M, self.nu))

    def energy(self) -> ca.Function:
        """``(x, p) -> E``, conserved when ``u = 0`` and there is no dissipation or load.

        ``E = T + V`` when ``T`` is quadratic in the velocities; otherwise (a rotating
        frame, a magnetic term, ``T`` with terms of degree 0, 1 or above 2 in the
        velocities) the Jacobi integral ``E = Pi . nu - T + V``, which is then the
        conserved quantity (``T + V`` is not).
        """
        E = self.T + self.V if self.homogeneous else ca.dot(self.Pi, self.nu) - self.T + self.V
        return ca.Function(f"{self.name}_energy", [self.x, self.ing.p], [E], ["x", "p"], ["E"])

    def momentum(self, generators: dict[int, ca.SX]) -> ca.Function:
        """``(x, p) -> sum_f Pi_f . eta_f`` for a symmetry's generator ``eta``."""
        val = ca.SX(0)
        for f, sl in zip(self.ing.factors, self.slices):
            if id(f) in generators:
                val = val + ca.dot(self.Pi[sl], generators[id(f)])
        return ca.Function(f"{self.name}_momentum", [self.x, self.ing.p], [val], ["x", "p"],
                           ["J"])

    def mass_matrix(self) -> ca.Function:
        """``(x, p) -> M`` (the Hessian of T in the velocities, ambient)."""
        return ca.Function(f"{self.name}_mass", [self.x, self.ing.p], [self.M], ["x", "p"],
                           ["M"])

    # the configuration space (for critical points and equilibria at rest) -------------------

    def configuration_manifold(self) -> ProductManifold:
        """The configuration manifold ``Q``: each factor's configuration, in storage order.

        Named as the factors' configurations are stored (R^k: ``Rn(k)``, S^1: ``S1``,
        SO(3): ``SO3``, S^2: ``S2``, the direction ``q`` of its TS^2 storage); its
        ambient coordinates are :attr:`c`.
        """
        out = []
        for f in self.ing.factors:
            name, fac = f.storage()[0]
            out.append((name, S2() if isinstance(fac, TS2) else fac))
        return ProductManifold(out)

    def potential_function(self) -> ca.Function:
        """``(c, p) -> V``: the potential energy (gravity included) on the configuration.

        Raises
        ------
        ModelError
            If the potential depends on the velocities.
        """
        if ca.depends_on(self.V, self.nu):
            raise ModelError(f"the potential of {self.name!r} depends on the velocities")
        return ca.Function(f"{self.name}_potential", [self.c, self.ing.p], [self.V],
                           ["c", "p"], ["V"])

    def rest_state(self) -> ca.Function:
        """``c -> x``: the state at rest over a configuration (every velocity zero)."""
        x = ca.substitute(self.x, self.nu, ca.SX.zeros(self.n_nu))
        return ca.Function(f"{self.name}_rest_state", [self.c], [x], ["c"], ["x"])
