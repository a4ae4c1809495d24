"""Explicit Lie-group integrator: Runge-Kutta-Munthe-Kaas of order 4 (RKMK4).

Every factor of the state space is a homogeneous space of a Lie group acting on the left,
and the model's vector field is written as the infinitesimal action of a field of Lie
algebra elements ``xi(y)`` read from the graph (``y-dot = xi(y) . y``):

============  =====================  =================================  ===================
factor        group                  action ``exp(xi) . y``              generator ``xi(y)``
============  =====================  =================================  ===================
R^n           R^n (translations)     ``y + xi``                          ``y-dot``
S1            SO(2)                  rotation of ``p`` by angle ``xi``   ``p x p-dot``
S2            SO(3)                  ``exp(hat xi) q``                   ``q x q-dot``
SO3           SO(3)                  ``exp(hat xi) R``                   ``vee(R-dot R^T)``
TS2 (q, w)    SE(3) = SO(3) x| R^3   ``(Q q, Q w + b x Q q)``,           ``xi = q x q-dot``,
                                     ``(Q, b) = exp(xi, beta)``          ``beta = q x (w-dot
                                                                         - xi x w)``
============  =====================  =================================  ===================

The SE(3) action on TS^2 keeps ``|q| = 1`` and ``q . w = 0`` for any ``w`` (velocity or
angular velocity), because ``Q`` is a rotation and ``b x Q q`` is normal to ``Q q``. The
step (Hairer, Lubich and Wanner, Geometric Numerical Integration, IV.8) is::

    K_i = h dexpinv(Theta_i, xi(exp(Theta_i) . y0)),  Theta_i = sum_j a_ij K_j
    y1 = exp(sum_i b_i K_i) . y0

with the classical RK4 tableau and ``dexpinv(T, F) = F - [T, F]/2 + [T, [T, F]]/12``
(enough for order 4). Every stage lands on the manifold by a group action, so the state
stays on it to round-off. The method is explicit and neither symplectic nor symmetric.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca

from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.manifolds import S1, S2, SO3, TS2, Factor, Rn, so3_exp, vee
from workbench.simulation.integrators.common import (
    DiscreteFlow,
    compile_step,
    controller_key,
    feedback_function,
)

__all__ = ["rkmk4", "se3_v"]


def se3_v(xi: Any) -> Any:
    """The matrix ``V(xi) = I + (1 - cos t)/t^2 hat(xi) + (t - sin t)/t^3 hat(xi)^2``.

    ``exp`` of ``(xi, beta)`` in se(3) is ``(exp(hat xi), V(xi) beta)``; the coefficients
    switch to their Taylor series for ``t^2 < 1e-6`` (error below 1e-19).

    Parameters
    ----------
    xi : casadi expression, shape=(3, 1)

    Returns
    -------
    casadi expression, shape=(3, 3)
    """
    t2 = ca.dot(xi, xi)
    small = t2 < 1e-6
    safe = ca.if_else(small, 1.0, t2)
    t = ca.sqrt(safe)
    b = ca.if_else(small, 0.5 - t2 / 24 + t2**2 / 720, 2 * ca.sin(t / 2) ** 2 / safe)
    c = ca.if_else(small, 1.0 / 6 - t2 / 120 + t2**2 / 5040, (t - ca.sin(t)) / (safe * t))
    K = ca.skew(xi)
    return ca.DM.eye(3) + b * K + c * (K @ K)


@dataclass(frozen=True)
class _Action:
    """A Lie group acting on one factor: algebra dimension, generator, action, bracket."""

    kind: str
    dim: int

    def generator(self, y: Any, ydot: Any) -> Any:
        k = self.kind
        if k == "Rn":
            return ydot
        if k == "S1":
            return y[0] * ydot[1] - y[1] * ydot[0]
        if k == "S2":
            return ca.cross(y, ydot)
        if k == "SO3":
            R, Rd = SO3.matrix(y), SO3.matrix(ydot)
            return vee(Rd @ R.T)
        q, w, qd, wd = y[0:3], y[3:6], ydot[0:3], ydot[3:6]  # TS2
        xi = ca.cross(q, qd)
        return ca.vertcat(xi, ca.cross(q, wd - ca.cross(xi, w)))

    def act(self, xi: Any, y: Any) -> Any:
        k = self.kind
        if k == "Rn":
            return y + xi
        if k == "S1":
            c, s = ca.cos(xi), ca.sin(xi)
            return ca.vertcat(c * y[0] - s * y[1], s * y[0] + c * y[1])
        if k == "S2":
            return so3_exp(xi) @ y
        if k == "SO3":
            return ca.vec(so3_exp(xi) @ SO3.matrix(y))
        w_, b_ = xi[0:3], xi[3:6]  # TS2: SE(3) exponential, then the action
        Q = so3_exp(w_)
        b = se3_v(w_) @ b_
        qn = Q @ y[0:3]
        return ca.vertcat(qn, Q @ y[3:6] + ca.cross(b, qn))

    def bracket(self, a: Any, b: Any) -> Any | None:
        k = self.kind
        if k in ("Rn", "S1"):
            return None  # abelian
        if k in ("S2", "SO3"):
            return ca.cross(a, b)
        return ca.vertcat(  # se(3): [(x1, b1), (x2, b2)] = (x1 x x2, x1 x b2 - x2 x b1)
            ca.cross(a[0:3], b[0:3]), ca.cross(a[0:3], b[3:6]) - ca.cross(b[0:3], a[3:6])
        )


def _action(name: str, factor: Factor) -> _Action:
    if isinstance(factor, Rn):
        return _Action("Rn", factor.n)
    if isinstance(factor, S1):
        return _Action("S1", 1)
    if isinstance(factor, S2):
        return _Action("S2", 3)
    if isinstance(factor, SO3):
        return _Action("SO3", 3)
    if isinstance(factor, TS2):
        return _Action("TS2", 6)
    raise ModelError(
        f"rkmk4 has no group action for factor {name!r} of kind {factor.kind}; supported: "
        f"R^n, S1, S2, SO3, TS2"
    )


_A = ((), (0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))
_B = (1 / 6, 1 / 3, 1 / 3, 1 / 6)


def rkmk4(
    model: Model,
    controller: ca.Function | None = None,
    *,
    jit: bool = False,
) -> DiscreteFlow:
    """The explicit RKMK4 Lie-group method for any model on R^n, S1, S2, SO3, TS2 factors.

    Parameters
    ----------
    model : Model
        The model (SX or MX graph).
    controller : casadi.Function, optional
        Feedback ``u = k(x)`` or ``k(x, p)``, evaluated at every stage.
    jit : bool
        Compile the step function to C (SX models only).

    Returns
    -------
    DiscreteFlow
        Order 4, explicit (residual 0, no Newton iterations), 4 evaluations per step.

    Raises
    ------
    ModelError
        A factor without a group action, or a controller that does not fit the model.
    """
    actions = [(n, _action(n, f)) for n, f in model.manifold.factors]
    k_fn = feedback_function(model, controller)
    key = f"rkmk4_step[controller={controller_key(controller)}{',jit' if jit else ''}]"

    def make() -> ca.Function:
        fn = _make_step(model, actions, k_fn)
        return compile_step(fn) if jit else fn

    step = model._build(key, make)
    return DiscreteFlow(
        name="rkmk4",
        step=step,
        order=4,
        newton_tol=0.0,
        newton_max_iter=0,
        evaluations_per_step=4,
        structure={
            "manifold": "every stage is a group action exp(Theta) . y0: the factors "
            "(" + ", ".join(f"{n}: {a.kind}" for n, a in actions) + ") are kept to "
            "round-off, never projected",
            "symplectic": False,
            "symmetric": False,
            "implicit": False,
        },
    )


def _make_step(model: Model, actions: list[tuple[str, _Action]], k_fn: ca.Function) -> ca.Function:
    S = model.sym
    man = model.manifold
    f = model.function("f")
    n_x = man.ambient_dim
    offsets, k = [], 0
    for _, a in actions:
        offsets.append(slice(k, k + a.dim))
        k += a.dim
    # the group operations as scalar (SX) functions: inlined into SX steps, one call node
    # each in MX steps (many small MX operations would dominate the cost)
    th, g, y, yd = (ca.SX.sym(n, m) for n, m in (("theta", k), ("g", k), ("y", n_x),
                                                  ("ydot", n_x)))
    act = ca.Function("act", [th, y], [ca.vertcat(*[
        a.act(th[o], y[man.slices[n]]) for (n, a), o in zip(actions, offsets)])])
    gen = ca.Function("generator", [y, yd], [ca.vertcat(*[
        a.generator(y[man.slices[n]], yd[man.slices[n]]) for n, a in actions])])
    parts = []
    for (_, a), o in zip(actions, offsets):
        b1 = a.bracket(th[o], g[o])
        parts.append(g[o] if b1 is None else g[o] - b1 / 2 + a.bracket(th[o], b1) / 12)
    dexpinv = ca.Function("dexpinv", [th, g], [ca.vertcat(*parts)])

    x = S.sym("x", n_x)
    p = S.sym("p", model.n_params)
    h = S.sym("h")

    def xi(yy):  # noqa: ANN001, ANN202
        return gen(yy, f(yy, k_fn(yy, p), p))

    K: list[Any] = []
    for i in range(4):
        if i == 0:
            K.append(h * xi(x))
            continue
        theta = sum((c * K[j] for j, c in enumerate(_A[i]) if c != 0.0), S.zeros(k))
        K.append(h * dexpinv(theta, xi(act(theta, x))))
    theta = sum((b * Ki for b, Ki in zip(_B, K)), S.zeros(k))
    return ca.Function(
        "rkmk4_step",
        [x, p, h],
        [act(theta, x), S.zeros(1), S.zeros(1)],
        ["x", "p", "h"],
        ["x_next", "residual", "iterations"],
        {"cse": True} if S is ca.SX else {},
    )
