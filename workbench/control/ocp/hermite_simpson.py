"""Hermite-Simpson collocation with first-order-hold controls (Drake's DirectCollocation).

On each interval ``[t_k, t_k + h]`` the state is the cubic Hermite interpolant of the
nodes and their slopes ``f_k = f(x_k, u_k)``, ``f_(k+1) = f(x_(k+1), u_(k+1))``; the
control is linear between its node values (first-order hold). Its midpoint is

    x_c = (x_k + x_(k+1)) / 2 + h (f_k - f_(k+1)) / 8,     u_c = (u_k + u_(k+1)) / 2,

and the collocation condition at the midpoint is Simpson's rule,

    x_(k+1) = x_k + h (f_k + 4 f(x_c, u_c) + f_(k+1)) / 6,                (defect)

the "compressed" form: no midpoint variables (the 3-stage Lobatto IIIA method, order 4).
The running cost is the trapezoid over the nodes, ``h (L(x_k, u_k) + L(x_(k+1),
u_(k+1))) / 2``, as Drake's ``AddRunningCost``.

``ManifoldHandling.AMBIENT`` applies this to the ambient coordinates (Lobatto IIIA does not
conserve quadratic invariants exactly: the nodes leave the manifold by the local error,
reported as the solution's manifold residual). ``ManifoldHandling.LIE_GROUP`` applies it to
the local coordinates ``y`` of the interval (``x = act(x_k, y)``, ``y(0) = 0``; see
:mod:`workbench.control.ocp.local`): one vector ``y_1 = y(h)`` per interval is a decision variable,
``y_c = y_1 / 2 + h (y'_0 - y'_1) / 8``, the defect is ``y_1 - h (y'_0 + 4 y'_c + y'_1) / 6``
and ``x_(k+1) = act(x_k, y_1)``, so every node is exactly on the manifold.
``ManifoldHandling.PROJECTED`` applies the ambient formulas and imposes
``x_(k+1) = Pi(x_k + h (f_k + 4 f_c + f_(k+1)) / 6)`` with the smooth projection ``Pi``
of :mod:`workbench.control.ocp.projection`: the nodes are on the manifold and the NLP has
the ambient one's size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca

__all__ = ["HermiteSimpson", "hermite_simpson_interval"]


@dataclass(frozen=True)
class HermiteSimpson:
    """Hermite-Simpson collocation, ``N`` intervals, first-order-hold controls.

    Parameters
    ----------
    N : int
        Number of intervals (``N + 1`` knots, each with a state and a control).
    """

    N: int = 40

    def __post_init__(self) -> None:
        from workbench.control.ocp.transcription import MAX_INTERVALS, _check_int

        _check_int(self.N, "N", 1, MAX_INTERVALS)

    def describe(self) -> str:
        """E.g. ``"hermite-simpson foh N=40"``."""
        return f"hermite-simpson foh N={self.N}"


def hermite_simpson_interval(S: Any, nx: int, nu: int, n_params: int, f: ca.Function,
                             L: ca.Function | None, local: Any | None,
                             fopts: dict[str, Any], *,
                             project: ca.Function | None = None) -> ca.Function:
    """``(X_k, X_(k+1), Z_k, U_k, U_(k+1), h, p) -> (defects, x_end, cost)``.

    Parameters
    ----------
    S : casadi.SX or casadi.MX
        Symbol class.
    nx, nu, n_params : int
        Sizes of the state, the input and the parameters.
    f : casadi.Function
        The vector field ``f(x, u, p)``.
    L : casadi.Function or None
        The running cost ``L(x, u)``.
    local : tuple of casadi.Function or None
        ``(act, ydot)`` of the local coordinates for ``LIE_GROUP``; ``None`` for ambient.
    fopts : dict
        Options of the returned function.
    project : casadi.Function, optional
        ``Pi(x)`` of ``ManifoldHandling.PROJECTED``: applied to the ambient end point.

    Returns
    -------
    casadi.Function
        ``x_end`` is the Simpson end point (ambient) or ``act(x_k, y_1)`` (Lie group);
        the caller imposes ``X_(k+1) = x_end``.
    """
    Xk, Xk1 = S.sym("Xk", nx), S.sym("Xk1", nx)
    Uk, Uk1 = S.sym("Uk", nu), S.sym("Uk1", nu)
    h, p = S.sym("h"), S.sym("p", n_params)
    Uc = (Uk + Uk1) / 2
    cost = 0 if L is None else h / 2 * (L(Xk, Uk) + L(Xk1, Uk1))
    if local is None:
        Z = S.sym("Z", 0, 1)
        fk, f1 = f(Xk, Uk, p), f(Xk1, Uk1, p)
        fc = f((Xk + Xk1) / 2 + h / 8 * (fk - f1), Uc, p)
        x_end = Xk + h / 6 * (fk + 4 * fc + f1)
        if project is not None:
            x_end = project(x_end)
        defects = S.zeros(0, 1)
    else:
        act, ydot_of = local
        ny = int(act.size1_in(1))
        Z = S.sym("Z", ny, 1)

        def rate(y: Any, u: Any) -> tuple[Any, Any]:
            x = act(Xk, y)
            return ydot_of(Xk, y, x, f(x, u, p)), x

        y0 = S.zeros(ny, 1)
        r0, _ = rate(y0, Uk)
        r1, x_end = rate(Z, Uk1)
        rc, _ = rate(Z / 2 + h / 8 * (r0 - r1), Uc)
        defects = Z - h / 6 * (r0 + 4 * rc + r1)
    return ca.Function("interval_hs", [Xk, Xk1, Z, Uk, Uk1, h, p], [defects, x_end, cost],
                       fopts)
