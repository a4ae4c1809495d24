"""Lie group variational integrator on TSO(3) (Lee, Leok and McClamroch, CDC 2005).

For a rigid body about a fixed point with inertia ``J`` (any symmetric positive-definite
matrix), ``R-dot = R hat(omega)`` and ``J omega-dot = J omega x omega + tau(R, u)``, the
discrete Lagrangian ``L_d = tr[(I - F_k) J_d] / h - h/2 (U(R_k) + U(R_{k+1}))`` with
``J_d = tr(J)/2 I - J`` and the discrete Lagrange-d'Alembert principle with the
trapezoidal forces ``h/2 u_k``, ``h/2 u_{k+1}`` give, with ``tau = M + u`` (``M`` the
potential moment, ``m g rho x R^T e3`` for the 3D pendulum)::

    h hat(J omega_k + h/2 tau_k) = F_k J_d - J_d F_k^T                     (implicit in F_k)
    R_{k+1} = R_k F_k
    J omega_{k+1} = F_k^T (J omega_k + h/2 tau_k) + h/2 tau_{k+1}

``F_k = exp(hat(f))`` is found by Newton's method on ``f``: with ``a = h (J omega_k +
h/2 tau_k)`` the equation reads ``sin|f|/|f| J f + (1 - cos|f|)/|f|^2 f x J f = a``
(exact for every symmetric ``J``); the Jacobian is casadi's derivative of that residual.
The moment ``tau(R, u)`` is read from the model's own graph as ``J omega-dot`` at
``omega = 0``; a feedback ``u = k(R, omega)`` that depends on ``omega`` makes the last
equation implicit in ``omega_{k+1}``, solved by Newton as well. ``R_{k+1}`` is a product
of rotations, so the state stays on SO(3) to round-off; with ``u = 0`` the method is
symplectic, symmetric (a step of ``-h`` undoes a step of ``h``) and conserves the
vertical angular momentum exactly (discrete Noether).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.manifolds import SO3, Rn, _exp_coefficients, hat, so3_exp
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

__all__ = ["lgvi", "rigid_body_factors"]

STRUCTURE_TOL = 1e-9
"""Relative tolerance of the numeric check that a model has the rigid-body form."""


def rigid_body_factors(model: Model) -> tuple[str, str]:
    """Names of the SO(3) and angular-velocity factors of a rigid-body model.

    Parameters
    ----------
    model : Model
        A model on SO(3) x R^3 with a parameter ``J`` of shape (3, 3).

    Returns
    -------
    (str, str)
        The attitude and angular-velocity factor names.

    Raises
    ------
    ModelError
        If the model does not have exactly these factors and the parameter ``J``.
    """
    man = model.manifold
    rot = [n for n, f in man.factors if isinstance(f, SO3)]
    vel = [n for n, f in man.factors if isinstance(f, Rn) and f.n == 3]
    if len(man.factors) != 2 or len(rot) != 1 or len(vel) != 1:
        raise ModelError(
            f"the Lie group variational integrator needs a rigid body on TSO(3): one SO3 "
            f"factor and one R^3 angular velocity; model {model.name!r} has "
            f"{man.describe()}. Use method 'rkmk4' for other models."
        )
    if "J" not in model.parameter_slices or model.parameter("J").shape != (3, 3):
        raise ModelError(
            f"the Lie group variational integrator needs the inertia as a (3, 3) parameter "
            f"'J'; model {model.name!r} has parameters {[p.name for p in model.parameters]}"
        )
    return rot[0], vel[0]


def _check_rigid_body(model: Model, rname: str, wname: str) -> None:
    """Check numerically that the vector field is R-dot = R w^, J w-dot = J w x w + tau(R,u)."""
    rng = np.random.default_rng(20050101)
    man = model.manifold
    sr, sw = man.slices[rname], man.slices[wname]
    J = model.values["J"]
    worst = 0.0
    for _ in range(3):
        x = man.random_point(rng, scale=1.0)
        u = rng.standard_normal(model.n_inputs)
        fx = model.rhs(x, u)
        R, w = SO3.matrix(x[sr]), x[sw]
        x0 = x.copy()
        x0[sw] = 0.0
        tau = J @ model.rhs(x0, u)[sw]
        dev_R = np.max(np.abs(fx[sr] - SO3.flat(R @ hat(w))))
        dev_w = np.max(np.abs(J @ fx[sw] - np.cross(J @ w, w) - tau))
        scale = 1.0 + np.max(np.abs(fx))
        worst = max(worst, dev_R / scale, dev_w / scale)
    if not worst <= STRUCTURE_TOL:
        raise ModelError(
            f"the Lie group variational integrator needs R-dot = R hat(omega) and "
            f"J omega-dot = J omega x omega + tau(R, u) with tau independent of omega; the "
            f"vector field of {model.name!r} deviates from that form by {worst:.3g} "
            f"(relative, on seeded samples). Use method 'rkmk4' for it."
        )


def lgvi(
    model: Model,
    controller: ca.Function | None = None,
    *,
    newton_tol: float = NEWTON_TOL,
    newton_max_iter: int = NEWTON_MAX_ITER,
    jit: bool = False,
) -> DiscreteFlow:
    """The Lie group variational integrator for a rigid-body model on TSO(3).

    Parameters
    ----------
    model : Model
        A model on SO(3) x R^3 with inertia parameter ``J`` whose vector field has the
        rigid-body form (checked numerically), e.g. :func:`models.pendulum3d.full`.
    controller : casadi.Function, optional
        Feedback ``u = k(x)`` or ``k(x, p)``, applied in discrete Lagrange-d'Alembert form
        (trapezoidal moments); ``u = 0`` when omitted.
    newton_tol : float
        Largest relative residual accepted for each implicit update.
    newton_max_iter : int
        Newton iterations per implicit update (unrolled in the graph).
    jit : bool
        Compile the step function to C (faster steps, a compile of ~1 s once per process).

    Returns
    -------
    DiscreteFlow
        Order 2; the step function is cached in the model's build log.

    Raises
    ------
    ModelError
        If the model is not a rigid body on TSO(3) with parameter ``J``, or the controller
        does not fit it.
    ParameterError
        Bad Newton options.
    """
    tol, kmax = check_newton_options(newton_tol, newton_max_iter)
    rname, wname = rigid_body_factors(model)
    _check_rigid_body(model, rname, wname)
    k_fn = feedback_function(model, controller)
    key = (
        f"lgvi_step[tol={tol:.3g},max_iter={kmax},controller={controller_key(controller)}"
        f"{',jit' if jit else ''}]"
    )

    def make() -> ca.Function:
        fn = _make_step(model, rname, wname, k_fn, tol, kmax)
        return compile_step(fn) if jit else fn

    step = model._build(key, make)
    closed = controller is not None
    return DiscreteFlow(
        name="lgvi",
        step=step,
        order=2,
        newton_tol=tol,
        newton_max_iter=kmax,
        evaluations_per_step=2,
        structure={
            "manifold": "R_{k+1} = R_k exp(hat f_k): SO(3) kept to round-off, never projected",
            "symplectic": not closed,
            "symmetric": True,
            "implicit": True,
            "momentum": "vertical angular momentum conserved exactly for u = 0 "
            "(rotation-invariant potential)",
            "forcing": "discrete Lagrange-d'Alembert, trapezoidal moments h/2 (u_k, u_{k+1})"
            if closed else "none",
        },
    )


def _make_step(
    model: Model, rname: str, wname: str, k_fn: ca.Function, tol: float, kmax: int
) -> ca.Function:
    ctx = model.context()
    S = model.sym
    man = model.manifold
    sr, sw = man.slices[rname], man.slices[wname]
    f = model.function("f")
    p = ctx.p
    J = ctx["J"]
    h = S.sym("h")

    def assemble(r_flat, w):  # noqa: ANN001, ANN202
        parts = {rname: r_flat, wname: w}
        return ca.vertcat(*[parts[n] for n in man.names])

    def tau(r_flat, u):  # noqa: ANN001, ANN202
        """Moment tau(R, u) = J omega-dot at omega = 0, from the model's graph."""
        return J @ f(assemble(r_flat, S.zeros(3)), u, p)[sw]

    x = ctx.x
    R, w = SO3.matrix(x[sr]), x[sw]
    tau_k = tau(x[sr], k_fn(x, p))
    mom = J @ w + h / 2 * tau_k
    a = h * mom

    def res_f(z):  # noqa: ANN001, ANN202
        al, be = _exp_coefficients(ca.dot(z, z))
        Jz = J @ z
        return al * Jz + be * ca.cross(z, Jz) - a

    f0 = ca.solve(J, a)
    guess = ca.solve(J, a - 0.5 * ca.cross(f0, J @ f0))  # second-order initial guess
    fk, rel_f, its_f = newton(res_f, guess, ca.norm_inf(a), tol=tol, max_iter=kmax)
    F = so3_exp(fk)
    r1 = ca.vec(R @ F)
    c = F.T @ mom

    w_sym = S.sym("w", 3)
    implicit_u = ca.depends_on(k_fn(assemble(x[sr], w_sym), p), w_sym)
    if implicit_u:
        def res_w(z):  # noqa: ANN001, ANN202
            return J @ z - c - h / 2 * tau(r1, k_fn(assemble(r1, z), p))

        w_pred = ca.solve(J, c)
        guess_w = ca.solve(J, c + h / 2 * tau(r1, k_fn(assemble(r1, w_pred), p)))
        scale = ca.fmax(ca.norm_inf(c), ca.norm_inf(J @ guess_w))
        w1, rel_w, its_w = newton(res_w, guess_w, scale, tol=tol, max_iter=kmax)
    else:
        w1 = ca.solve(J, c + h / 2 * tau(r1, k_fn(assemble(r1, S.zeros(3)), p)))
        rel_w, its_w = 0, 0
    return ca.Function(
        "lgvi_step",
        [x, p, h],
        [assemble(r1, w1), ca.fmax(rel_f, rel_w), its_f + its_w],
        ["x", "p", "h"],
        ["x_next", "residual", "iterations"],
        {"cse": True} if S is ca.SX else {},
    )
