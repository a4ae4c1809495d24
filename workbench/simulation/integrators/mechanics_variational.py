"""A variational integrator on R^k, S^1, SO(3), S^2 factors for the models of the mechanics layer.

The mechanics layer keeps its derivation on the model (``model.mechanics``: the kinetic
energy ``T(c, nu)``, the potential ``V(c)``, the loads, the factors). From them this module
writes a discrete Lagrangian and its discrete Lagrange-d'Alembert equations, so that any
system declared with R^k, S^1, SO(3) and S^2 factors (the 3D pendulum, the pendulum on a
cart, the double 3D pendulum, the chains on a cart, the quadrotor with a slung load, the
Furuta pendulum, the acrobot) gets a symplectic, momentum-preserving step.

Discrete configuration update, per factor (``h`` the signed step, ``xi`` the unknown
discrete velocity)::

    R^k:    x_{k+1} = x_k + h v
    S^1:    p_{k+1} = cay(h w) p_k,       cay(a) = [[1 - a^2/4, -a], [a, 1 - a^2/4]] / d
    SO(3):  R_{k+1} = R_k cay(h Omega),   cay(a) = (I - hat(a)/2)^{-1} (I + hat(a)/2)
    S^2:    q_{k+1} = cay(h w) q_k,       q_k . w = 0

(``d = 1 + a^2/4``) so ``p_{k+1}``, ``R_{k+1}`` and ``q_{k+1}`` are rotated by rotations
(S^1, SO(3) and S^2 are kept to round-off, never projected). On S^1 the planar Cayley map
is the rotation by ``2 atan(a/2)``, the SO(3) map about a fixed axis. On S^2 the discrete
angular velocity ``w`` is normal to both ends, ``w = 2/h (q_k x q_{k+1}) / (1 + q_k .
q_{k+1})``; the equation ``q_k . w = 0`` is added to the S^2 rows (whose other terms are
normal to ``q_k``), weighted like the mass matrix's block, as the continuous derivation
pins ``q . omega = 0``. The discrete Lagrangian is the trapezoidal rule at the discrete velocity::

    L_d(c_k, xi) = h/2 [L(c_k, xi) + L(c_{k+1}, xi)],   L = T - V.

It is symmetric (``L_d(c_{k+1}, c_k; -h) = -L_d(c_k, c_{k+1}; h)``, as
``cay(-a) = cay(a)^{-1}``), hence of order 2. Its left-trivialised derivatives (along the
perturbations ``x + eps eta`` and ``R exp(eps hat(eta))`` of one end, the other held) follow
from the right-trivialised inverse derivative of the Cayley map, ``dcay_a^{-1} = I -
hat(a)/2 + a a^T/4`` (identity on R^k, ``1 + a^2/4`` on S^1; on S^2 the derivative of the
formula for ``w`` by AD, ``P`` pulled back through it, left-trivialised by ``q x``)::

    -D_1 L_d = 1/2 (dcay_{h xi}^{-1})^T P - h/2 G(c_k, xi)
     D_2 L_d = 1/2 (dcay_{-h xi}^{-1})^T P + h/2 G(c_{k+1}, xi)

with ``P = Pi(c_k, xi) + Pi(c_{k+1}, xi)``, ``Pi = dT/dnu`` and ``G = K(c)^T dL/dc`` (the
factors' ``K^T`` applied to casadi's gradient). (The tests check them against AD of ``L_d``
written through the inverse map ``hat(h Omega/2) = (F - I)(F + I)^{-1}``, ``F = R_k^T
R_{k+1}``.) With the trapezoidal discrete forces ``f^-_k = h/2 Q(x_k, u_k)`` and ``f^+_k =
h/2 Q(x_{k+1}, u_{k+1})`` (``Q`` the generalised loads and ``-dD/dnu`` of the Rayleigh
function) the discrete Lagrange-d'Alembert principle in position-momentum form reads::

    mu_k + f^-_k = -D_1 L_d(c_k, xi)          (implicit in xi: Newton, Jacobian by AD)
    mu_{k+1}     =  D_2 L_d(c_k, xi) + f^+_k

The momenta ``mu`` are identified with the model's state through the Legendre transform
``Pi = dT/dnu`` (``der.Pi``; the left-trivialised momentum: body angular momentum on
SO(3)), so the flow maps a stored state to a stored state like the other
:class:`~workbench.simulation.integrators.common.DiscreteFlow` schemes: ``mu_k = Pi(c_k,
nu_k)``, and ``nu_{k+1}`` solves the linear equation ``Pi(c_{k+1}, nu) = mu_{k+1}`` (``T``
is quadratic in ``nu``; a velocity-dependent feedback or damping makes it nonlinear, solved
by Newton as well). With ``u = 0`` and no damping the map is symplectic and conserves the
momentum of every symmetry of ``L_d`` (discrete Noether: the rotations about the vertical
and the translations the system declares), to the Newton tolerance.

Factors of other kinds are refused.
"""

from __future__ import annotations

from typing import Any

import casadi as ca

from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.manifolds import hat, vee
from workbench.simulation.integrators.common import (
    NEWTON_MAX_ITER,
    NEWTON_TOL,
    DiscreteFlow,
    check_newton_options,
    compile_step,
    controller_key,
    feedback_function,
    newton,
)

__all__ = ["mechanics_variational", "SUPPORTED_FACTORS"]

SUPPORTED_FACTORS = ("R^k", "S^1", "SO(3)", "S^2")
"""Kinds of mechanics factors this integrator steps."""


def _derivation(model: Model) -> Any:
    """The mechanics derivation of ``model``, checked for supported factors."""
    if not isinstance(model, Model):
        raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
    der = getattr(model, "mechanics", None)
    if der is None or not hasattr(der, "ing") or not hasattr(der, "Pi"):
        raise ModelError(
            f"the mechanics variational integrator needs a model made by workbench.mechanics "
            f"(System(...).model(), which carries its Lagrangian as model.mechanics); model "
            f"{model.name!r} has none. Use method 'rkmk4' (any model) or 'lgvi' (a rigid body "
            f"with parameter 'J')."
        )
    for f in der.ing.factors:
        if f.kind not in SUPPORTED_FACTORS:
            raise ModelError(
                f"the mechanics variational integrator steps factors of kinds "
                f"{list(SUPPORTED_FACTORS)}; factor {f.name!r} of model {model.name!r} is "
                f"{f.kind}. Use method 'rkmk4'."
            )
    if ca.depends_on(der.M, der.nu):
        raise ModelError(
            f"the mechanics variational integrator needs a kinetic energy quadratic in the "
            f"velocities (a constant mass matrix in nu); that of model {model.name!r} is not"
        )
    if der.ing.p.shape[0] != model.n_params:
        raise ModelError(
            f"model {model.name!r} has {model.n_params} parameters but its derivation "
            f"{der.ing.p.shape[0]}: it was not made by workbench.mechanics as it stands"
        )
    return der


def _cayley(a: ca.SX) -> ca.SX:
    """``cay(a) = (I - hat(a)/2)^{-1}(I + hat(a)/2) = I + 4/(4+|a|^2)(hat a + hat(a)^2/2)``."""
    A = hat(a)
    return ca.SX.eye(3) + 4.0 / (4.0 + ca.dot(a, a)) * (A + 0.5 * A @ A)


def _cayley2(a: ca.SX) -> ca.SX:
    """The planar Cayley map, the rotation by ``2 atan(a/2)``: ``(I - a J/2)^{-1}(I + a J/2)``.

    ``J`` the quarter turn; ``cay(a) = [[1 - a^2/4, -a], [a, 1 - a^2/4]] / (1 + a^2/4)``.
    """
    d = 1.0 + 0.25 * a * a
    c, s = (1.0 - 0.25 * a * a) / d, a / d
    return ca.vertcat(ca.horzcat(c, -s), ca.horzcat(s, c))


class _Parts:
    """Per-factor slices of ``c``, ``nu`` and the stored state ``x`` of a derivation."""

    def __init__(self, der: Any) -> None:
        self.factors = list(der.ing.factors)
        self.c_sl, self.nu_sl, self.x_sl = [], [], []
        kc = kv = kx = 0
        for f in self.factors:
            nc, nv = f.config_sym.shape[0], f.velocity_sym.shape[0]
            self.c_sl.append(slice(kc, kc + nc))
            self.nu_sl.append(slice(kv, kv + nv))
            self.x_sl.append((slice(kx, kx + nc), slice(kx + nc, kx + nc + nv)))
            kc, kv, kx = kc + nc, kv + nv, kx + nc + nv

    def split(self, x: ca.SX) -> tuple[ca.SX, ca.SX]:
        """``(c, nu)`` from a stored state."""
        return (ca.vertcat(*[x[a] for a, _ in self.x_sl]),
                ca.vertcat(*[x[b] for _, b in self.x_sl]))

    def join(self, c: ca.SX, nu: ca.SX) -> ca.SX:
        """The stored state from ``(c, nu)``."""
        return ca.vertcat(*[ca.vertcat(c[a], nu[b]) for a, b in zip(self.c_sl, self.nu_sl)])

    def kt(self, c: ca.SX, cov: ca.SX) -> ca.SX:
        """``K(c)^T cov`` per factor (``cov`` a covector on the configuration)."""
        out = []
        for f, sl in zip(self.factors, self.c_sl):
            if f.kind == "SO(3)":
                R, G = ca.reshape(c[sl], 3, 3), ca.reshape(cov[sl], 3, 3)
                out.append(vee(R.T @ G - G.T @ R))
            elif f.kind == "S^2":
                out.append(ca.cross(c[sl], cov[sl]))
            elif f.kind == "S^1":
                p, g = c[sl], cov[sl]
                out.append(p[0] * g[1] - p[1] * g[0])
            else:
                out.append(cov[sl])
        return ca.vertcat(*out)

    def advance(self, c: ca.SX, xi: ca.SX, h: ca.SX) -> ca.SX:
        """``c_{k+1} = c_k tau(h xi)``."""
        out = []
        for f, cs, vs in zip(self.factors, self.c_sl, self.nu_sl):
            if f.kind == "SO(3)":
                out.append(ca.vec(ca.reshape(c[cs], 3, 3) @ _cayley(h * xi[vs])))
            elif f.kind == "S^2":
                out.append(_cayley(h * xi[vs]) @ c[cs])
            elif f.kind == "S^1":
                out.append(_cayley2(h * xi[vs]) @ c[cs])
            else:
                out.append(c[cs] + h * xi[vs])
        return ca.vertcat(*out)

    def xi_terms(self, c0: ca.SX, c1: ca.SX, xi: ca.SX, h: ca.SX,
                 P: ca.SX) -> tuple[ca.SX, ca.SX]:
        """The parts of ``(-D_1 L_d, D_2 L_d)`` from the velocity's dependence on the ends.

        ``P = Pi(c_k, xi) + Pi(c_{k+1}, xi)``. R^k: ``(P/2, P/2)``. SO(3): ``1/2
        (dcay_{+-h xi}^{-1})^T P`` with ``(dcay_a^{-1})^T = I + hat(a)/2 + a a^T/4``; S^1,
        its planar case: ``(1 + a^2/4) P/2`` at both ends (``a = h xi``).
        S^2: ``-/+ q_i x (dw/dq_i)^T (h/2 P)`` by AD of the inverse map.
        """
        m1, m2 = [], []
        for f, cs, vs in zip(self.factors, self.c_sl, self.nu_sl):
            m = P[vs]
            if f.kind == "SO(3)":
                a = h * xi[vs]
                sym = m + 0.25 * ca.dot(a, m) * a
                m1.append(0.5 * (sym + 0.5 * ca.cross(a, m)))
                m2.append(0.5 * (sym - 0.5 * ca.cross(a, m)))
            elif f.kind == "S^2":
                g0, g1 = _s2_vjp()(c0[cs], c1[cs], h, m)
                m1.append(-g0)
                m2.append(g1)
            elif f.kind == "S^1":
                a = h * xi[vs]
                m1.append(0.5 * (1.0 + 0.25 * a * a) * m)
                m2.append(0.5 * (1.0 + 0.25 * a * a) * m)
            else:
                m1.append(0.5 * m)
                m2.append(0.5 * m)
        return ca.vertcat(*m1), ca.vertcat(*m2)

    def gauge(self, c: ca.SX, xi: ca.SX, M: ca.SX) -> ca.SX:
        """``mu_f q (q . xi_f)`` on S^2 factors (``mu_f = tr(M_ff)/2``), zero elsewhere.

        Added to the S^2 rows of an equation whose left side is normal to ``q``: it pins
        ``q . xi = 0`` and makes the Jacobian regular (as the continuous derivation's
        gauge block).
        """
        out = []
        for f, cs, vs in zip(self.factors, self.c_sl, self.nu_sl):
            if f.kind == "S^2":
                q = c[cs]
                out.append(0.5 * ca.trace(M[vs, vs]) * ca.dot(q, xi[vs]) * q)
            else:
                out.append(ca.SX.zeros(vs.stop - vs.start))
        return ca.vertcat(*out)


_S2_VJP: list[ca.Function] = []


def _s2_vjp() -> ca.Function:
    """``(q0, q1, h, s) -> (q0 x (dw/dq0)^T (h/2 s), q1 x (dw/dq1)^T (h/2 s))``.

    ``w = 2/h (q0 x q1)/(1 + q0 . q1)`` is the discrete angular velocity normal to both
    ends with ``q1 = cay(h w) q0``.
    """
    if not _S2_VJP:
        q0, q1, s = ca.SX.sym("q0", 3), ca.SX.sym("q1", 3), ca.SX.sym("s", 3)
        h = ca.SX.sym("h")
        w = 2.0 / h * ca.cross(q0, q1) / (1.0 + ca.dot(q0, q1))
        seed = h / 2 * s
        _S2_VJP.append(ca.Function(
            "s2_vjp", [q0, q1, h, s],
            [ca.cross(q0, ca.jtimes(w, q0, seed, True)),
             ca.cross(q1, ca.jtimes(w, q1, seed, True))]))
    return _S2_VJP[0]


def mechanics_variational(
    model: Model,
    controller: ca.Function | None = None,
    *,
    newton_tol: float = NEWTON_TOL,
    newton_max_iter: int = NEWTON_MAX_ITER,
    jit: bool = False,
) -> DiscreteFlow:
    """The variational integrator of a model made by :mod:`workbench.mechanics`.

    Parameters
    ----------
    model : Model
        A model from ``workbench.mechanics.System(...).model()`` whose factors are R^k,
        S^1, SO(3) and S^2 (e.g. :func:`models.pendulum3d.full`, :func:`models.pendulum3d_cart.
        pendulum3d_cart`, :func:`models.double_pendulum3d.double_pendulum3d`,
        :func:`models.acrobot.acrobot`, :func:`models.furuta.furuta`).
    controller : casadi.Function, optional
        Feedback ``u = k(x)`` or ``k(x, p)``, applied in discrete Lagrange-d'Alembert form
        (trapezoidal forces ``h/2 Q`` at both ends of a step); ``u = 0`` when omitted.
    newton_tol : float
        Largest relative residual accepted for each implicit update.
    newton_max_iter : int
        Newton iterations per implicit update (unrolled in the graph).
    jit : bool
        Compile the step function to C.

    Returns
    -------
    DiscreteFlow
        Order 2, symmetric; symplectic and momentum-preserving when unforced and undamped.
        The step function is cached in the model's build log.

    Raises
    ------
    ModelError
        The model is not made by workbench.mechanics, has a factor of another kind or a
        kinetic energy not quadratic in the velocities, or the
        controller does not fit it.
    ParameterError
        Bad Newton options.
    """
    der = _derivation(model)
    tol, kmax = check_newton_options(newton_tol, newton_max_iter)
    k_fn = feedback_function(model, controller)
    if k_fn.is_a("MXFunction"):
        k_fn = k_fn.expand()
    key = (f"mechanics_variational_step[tol={tol:.3g},max_iter={kmax},"
           f"controller={controller_key(controller)}{',jit' if jit else ''}]")

    def make() -> ca.Function:
        fn = _make_step(der, k_fn, tol, kmax)
        return compile_step(fn) if jit else fn

    step = model._build(key, make)
    free = ca.substitute(_forces(der, _Parts(der))(der.x, der.ing.u, der.ing.p), der.ing.u,
                         ca.SX.zeros(der.ing.u.shape[0]))
    forced = controller is not None or not free.is_zero()  # loads acting at u = 0, damping
    return DiscreteFlow(
        name="mechanics_variational",
        step=step,
        order=2,
        newton_tol=tol,
        newton_max_iter=kmax,
        evaluations_per_step=0,  # no vector field: gradients of the Lagrangian instead
        structure={
            "manifold": "R_{k+1} = R_k cay(h Omega_k) per SO(3) factor, q_{k+1} = "
                        "cay(h w_k) q_k per S^2 factor, p_{k+1} = cay(h w_k) p_k per S^1 "
                        "factor: kept to round-off, never projected",
            "symplectic": not forced,
            "symmetric": True,
            "implicit": True,
            "momentum": "momenta of the symmetries of L (rotations, translations) conserved "
                        "to the Newton tolerance when unforced (discrete Noether)",
            "forcing": "discrete Lagrange-d'Alembert, trapezoidal h/2 (Q_k, Q_{k+1})"
                       if forced else "none",
        },
    )


def _forces(der: Any, parts: _Parts) -> ca.Function:
    """``(x, u, p) -> Q``: generalised loads ``K^T (dy/dc)^T w`` and ``-dD/dnu``."""
    from_loads = ca.SX.zeros(der.c.shape[0], 1)
    if der.ing.loads:
        targets = ca.vertcat(*[ld.target for ld in der.ing.loads])
        weights = ca.vertcat(*[ld.weight for ld in der.ing.loads])
        from_loads = ca.jtimes(targets, der.c, weights, True)
    Q = parts.kt(der.c, from_loads) - ca.gradient(ca.SX(der.D), der.nu)
    return ca.Function("Q", [der.x, der.ing.u, der.ing.p], [Q])


def _make_step(der: Any, k_fn: ca.Function, tol: float, kmax: int) -> ca.Function:
    parts = _Parts(der)
    p = der.ing.p
    n_nu = der.nu.shape[0]
    h = ca.SX.sym("h")
    L = der.T - der.V
    PG = ca.Function("PG", [der.c, der.nu, p],
                     [der.Pi, parts.kt(der.c, ca.gradient(L, der.c))])
    M = ca.Function("M", [der.c, p], [der.M])
    Q = _forces(der, parts)

    x = ca.SX.sym("x", der.x.shape[0])
    ck, nuk = parts.split(x)
    mu = PG(ck, nuk, p)[0]
    f_minus = h / 2 * Q(x, k_fn(x, p), p)
    lhs = mu + f_minus

    def ends(z: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
        """``(c_{k+1}, P, G_k, G_{k+1})``: ``P = Pi(c_k, xi) + Pi(c_{k+1}, xi)``."""
        c1 = parts.advance(ck, z, h)
        pi0, g0 = PG(ck, z, p)
        pi1, g1 = PG(c1, z, p)
        return c1, pi0 + pi1, g0, g1

    M0 = M(ck, p)

    def res_xi(z: ca.SX) -> ca.SX:  # -D_1 L_d - mu_k - f^-_k (+ the S^2 gauge rows)
        c1, P, g0, _ = ends(z)
        return parts.xi_terms(ck, c1, z, h, P)[0] - h / 2 * g0 - lhs + parts.gauge(ck, z, M0)

    scale = ca.fmax(ca.norm_inf(lhs), ca.norm_inf(h * PG(ck, nuk, p)[1]))
    xi_k, rel_xi, its_xi = newton(res_xi, nuk, scale, tol=tol, max_iter=kmax)
    c_next, P, _, g1 = ends(xi_k)
    mu_next = parts.xi_terms(ck, c_next, xi_k, h, P)[1] + h / 2 * g1  # D_2 L_d
    M1, Pi0 = M(c_next, p), PG(c_next, ca.SX.zeros(n_nu), p)[0]
    # Pi is affine in nu: Pi(c, nu) = M nu + Pi(c, 0); the S^2 gauge pins q . omega = 0
    nu_sym = ca.SX.sym("nu", n_nu)
    M1 = M1 + ca.jacobian(parts.gauge(c_next, nu_sym, M1), nu_sym)

    def force_end(nu: ca.SX) -> ca.SX:
        x1 = parts.join(c_next, nu)
        return h / 2 * Q(x1, k_fn(x1, p), p)

    if ca.depends_on(force_end(nu_sym), nu_sym):
        def res_nu(z: ca.SX) -> ca.SX:
            return M1 @ z + Pi0 - mu_next - force_end(z)

        guess = ca.solve(M1, mu_next - Pi0)
        guess = ca.solve(M1, mu_next - Pi0 + force_end(guess))
        sc = ca.fmax(ca.norm_inf(mu_next), ca.norm_inf(M1 @ guess))
        nu_next, rel_nu, its_nu = newton(res_nu, guess, sc, tol=tol, max_iter=kmax)
    else:
        nu_next = ca.solve(M1, mu_next - Pi0 + force_end(ca.SX.zeros(n_nu)))
        rel_nu, its_nu = 0, 0
    return ca.Function(
        "mechanics_variational_step",
        [x, p, h],
        [parts.join(c_next, nu_next), ca.fmax(rel_xi, rel_nu), its_xi + its_nu],
        ["x", "p", "h"],
        ["x_next", "residual", "iterations"],
        {"cse": True},
    )
