"""Variational integrator on S^2 (Lee, Leok and McClamroch, IJNME 79, 2009).

For a point on the sphere with kinetic energy ``c/2 |q-dot|^2``, stored as ``(q, omega)``
with ``q-dot = omega x q``, ``q . omega = 0`` and ``omega-dot = a(q, u)`` (``a`` the
moment divided by ``c``, normal to ``q``; for the spherical pendulum
``a = (g/l) q x e3 + (I - q q^T) u / (m l^2)``), the discrete Lagrangian
``L_d = c/h (1 - q_k . q_{k+1}) - h/2 (U(q_k) + U(q_{k+1}))`` and the discrete
Lagrange-d'Alembert principle with trapezoidal moments give::

    q_k x q_{k+1} = v_k := h omega_k + h^2/2 a_k
    q_{k+1} = exp(hat(f_k)) q_k,  f_k = asin|v_k| v_k / |v_k|,
              i.e. q_{k+1} = v_k x q_k + sqrt(1 - |v_k|^2) q_k
    omega_{k+1} = omega_k + h/2 (a_k + a_{k+1})

The update of ``q`` is explicit (it exists while ``|v_k| < 1``; otherwise the step
reports an infinite residual); a feedback ``u = k(q, omega)`` that depends on ``omega``
makes the last equation implicit in ``omega_{k+1}``, solved by Newton with the Jacobian
from casadi. ``a`` is read from the model's graph (``omega-dot`` at ``omega = 0``).
``|q|`` and ``q . omega`` are kept to round-off; for ``u = 0`` the method is symplectic,
symmetric and conserves the momentum of any rotational symmetry of ``U`` exactly.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.manifolds import TS2
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

__all__ = ["s2_variational"]

STRUCTURE_TOL = 1e-9
"""Relative tolerance of the numeric check that a model has the S^2 mechanical form."""


def _check_sphere_model(model: Model) -> str:
    man = model.manifold
    if len(man.factors) != 1 or not isinstance(man.factors[0][1], TS2):
        raise ModelError(
            f"the S^2 variational integrator needs a model on TS^2 (one TS2 factor storing "
            f"(q, omega)); model {model.name!r} has {man.describe()}. Use method 'rkmk4' "
            f"for other models."
        )
    name = man.factors[0][0]
    rng = np.random.default_rng(20090101)
    worst = 0.0
    for _ in range(3):
        x = man.random_point(rng, scale=1.0)
        u = rng.standard_normal(model.n_inputs)
        fx = model.rhs(x, u)
        q, w = x[:3], x[3:]
        x0 = np.concatenate([q, np.zeros(3)])
        a = model.rhs(x0, u)[3:]
        scale = 1.0 + np.max(np.abs(fx))
        dev = max(
            np.max(np.abs(fx[:3] - np.cross(w, q))),  # q-dot = omega x q
            np.max(np.abs(fx[3:] - a)),  # omega-dot independent of omega
            abs(q @ a),  # moment normal to q
        )
        worst = max(worst, dev / scale)
    if not worst <= STRUCTURE_TOL:
        raise ModelError(
            f"the S^2 variational integrator needs q-dot = omega x q and omega-dot = a(q, u) "
            f"normal to q and independent of omega; the vector field of {model.name!r} "
            f"deviates from that form by {worst:.3g} (relative, on seeded samples). Use "
            f"method 'rkmk4' for it."
        )
    return name


def s2_variational(
    model: Model,
    controller: ca.Function | None = None,
    *,
    newton_tol: float = NEWTON_TOL,
    newton_max_iter: int = NEWTON_MAX_ITER,
    jit: bool = False,
) -> DiscreteFlow:
    """The variational integrator on S^2 for a model on TS^2 such as the spherical pendulum.

    Parameters
    ----------
    model : Model
        One TS2 factor ``(q, omega)`` with ``q-dot = omega x q`` and ``omega-dot = a(q, u)``
        (checked numerically), e.g. :func:`models.spherical.spherical_pendulum`.
    controller : casadi.Function, optional
        Feedback ``u = k(x)`` or ``k(x, p)`` in discrete Lagrange-d'Alembert form.
    newton_tol : float
        Largest relative residual accepted for the implicit velocity update (used only when
        the feedback depends on ``omega``).
    newton_max_iter : int
        Newton iterations for that update.
    jit : bool
        Compile the step function to C.

    Returns
    -------
    DiscreteFlow
        Order 2.

    Raises
    ------
    ModelError
        If the model does not have that form or the controller does not fit it.
    ParameterError
        Bad Newton options.
    """
    tol, kmax = check_newton_options(newton_tol, newton_max_iter)
    _check_sphere_model(model)
    k_fn = feedback_function(model, controller)
    key = (
        f"s2vi_step[tol={tol:.3g},max_iter={kmax},controller={controller_key(controller)}"
        f"{',jit' if jit else ''}]"
    )

    def make() -> ca.Function:
        fn = _make_step(model, k_fn, tol, kmax)
        return compile_step(fn) if jit else fn

    step = model._build(key, make)
    closed = controller is not None
    return DiscreteFlow(
        name="s2_variational",
        step=step,
        order=2,
        newton_tol=tol,
        newton_max_iter=kmax,
        evaluations_per_step=2,
        no_solution="|h omega_k + h^2 a_k / 2| >= 1: no q_{k+1} on S^2 with "
        "q_k x q_{k+1} = v_k",
        structure={
            "manifold": "q_{k+1} = exp(hat f_k) q_k, omega_{k+1} normal to q_{k+1}: TS^2 kept "
            "to round-off, never projected",
            "symplectic": not closed,
            "symmetric": True,
            "implicit": closed,
            "momentum": "momentum of rotational symmetries of U conserved exactly for u = 0",
            "forcing": "discrete Lagrange-d'Alembert, trapezoidal moments h/2 (u_k, u_{k+1})"
            if closed else "none",
        },
    )


def _make_step(model: Model, k_fn: ca.Function, tol: float, kmax: int) -> ca.Function:
    S = model.sym
    f = model.function("f")
    x = S.sym("x", 6)
    p = S.sym("p", model.n_params)
    h = S.sym("h")
    q, w = x[0:3], x[3:6]

    def acc(qq, u):  # noqa: ANN001, ANN202
        """a(q, u) = omega-dot at omega = 0, from the model's graph."""
        return f(ca.vertcat(qq, S.zeros(3)), u, p)[3:6]

    a_k = acc(q, k_fn(x, p))
    v = h * w + h**2 / 2 * a_k
    nv2 = ca.dot(v, v)
    admissible = nv2 < 1
    q1 = ca.cross(v, q) + ca.sqrt(ca.if_else(admissible, 1 - nv2, 0)) * q
    c = w + h / 2 * a_k  # = v / h, normal to q_{k+1}

    w_sym = S.sym("w", 3)
    implicit_u = ca.depends_on(k_fn(ca.vertcat(q, w_sym), p), w_sym)
    if implicit_u:
        def res_w(z):  # noqa: ANN001, ANN202
            return z - c - h / 2 * acc(q1, k_fn(ca.vertcat(q1, z), p))

        guess = c + h / 2 * acc(q1, k_fn(ca.vertcat(q1, c), p))
        scale = ca.fmax(ca.norm_inf(c), ca.norm_inf(guess))
        w1, rel, its = newton(res_w, guess, scale, tol=tol, max_iter=kmax)
    else:
        w1 = c + h / 2 * acc(q1, k_fn(ca.vertcat(q1, S.zeros(3)), p))
        rel, its = 0, 0
    residual = ca.if_else(admissible, rel, np.inf)
    return ca.Function(
        "s2vi_step",
        [x, p, h],
        [ca.vertcat(q1, w1), residual, its],
        ["x", "p", "h"],
        ["x_next", "residual", "iterations"],
        {"cse": True} if S is ca.SX else {},
    )
