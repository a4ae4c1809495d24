"""Lyapunov functions of the papers' closed loops (derivatives come from the graph).

:func:`velocity_feedback_lyapunov` (paper 001 (30)) with :func:`hanging_set_level` (the
levels of H_eps (29) and N (33)), and :func:`cart_lyapunov` (paper 003 (25)). Each is a
:class:`~workbench.control._lyapunov.Lyapunov`; all are re-exported by :mod:`models.controllers`.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from models._checks import E3, require_model
from models.cart_feedback import CartGains, _cart_terms, _require_cart
from workbench.control import Lyapunov, state_function
from workbench.core import Context, Model
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import SO3, Rn

__all__ = ["cart_lyapunov", "hanging_distance", "hanging_set_level",
           "velocity_feedback_lyapunov"]


def velocity_feedback_lyapunov(model: Model) -> Lyapunov:
    """Paper 001 (30): ``V = (omega^T J omega + m g |rho| |Gamma - Gamma_h|^2) / 2``.

    ``Gamma_h = rho / |rho|``; ``Gamma`` is the factor ``Gamma`` of the reduced model or
    ``R^T e3`` of the full one. Along ``u = -Psi(omega)`` the paper finds
    ``V-dot = -omega^T Psi(omega)``; here ``V-dot`` comes from the graph.

    Parameters
    ----------
    model : Model
        :func:`models.pendulum3d.full` or :func:`models.pendulum3d.reduced`.

    Returns
    -------
    Lyapunov
    """
    require_model(model, "Lyapunov function (30) of paper 001", factors={"omega": Rn},
             params=("J", "rho", "m", "g"))
    names = model.manifold.names
    if "Gamma" not in names and "R" not in names:
        raise ModelError(f"Lyapunov function (30) needs a factor 'Gamma' (S2) or 'R' (SO3); "
                         f"model {model.name!r} has {names}")
    if not np.linalg.norm(model.values["rho"]) > 0:
        raise ParameterError("rho must be nonzero for (30) (Gamma_h = rho/|rho|); got rho = 0 "
                             "(the balanced case has no hanging equilibrium)")

    def V(ctx: Context) -> Any:
        gam = ctx["Gamma"] if "Gamma" in names else SO3.matrix(ctx["R"]).T @ ca.DM(E3)
        rho, w = ctx["rho"], ctx["omega"]
        nrho = ca.norm_2(rho)
        d = gam - rho / nrho
        return 0.5 * (ca.dot(w, ctx["J"] @ w) + ctx["m"] * ctx["g"] * nrho * ca.dot(d, d))

    return Lyapunov(model, V, name="V30", description="paper 001 (30)",
                    equation=r"V = \tfrac12[\omega^TJ\omega + mg\|\rho\|\|\Gamma-\Gamma_h\|^2]")


def hanging_distance(model: Model) -> ca.Function:
    """``(x, p) -> angle(Gamma, Gamma_h) + |omega|`` on the reduced 3D pendulum (radians).

    A distance to the hanging equilibrium ``(Gamma_h, 0)``, ``Gamma_h = rho / |rho|`` (the
    values of ``model``), with the angle by ``atan2`` (accurate near 0 and pi); for
    convergence checks of paper 001's feedbacks.

    Parameters
    ----------
    model : Model
        The reduced model on S^2 x R^3 (factors ``Gamma``, ``omega``).

    Returns
    -------
    casadi.Function
        ``hanging_distance(x, p) -> d``.
    """
    x = ca.SX.sym("x", model.manifold.ambient_dim)
    p = ca.SX.sym("p", model.n_params)
    gam, w = x[0:3], x[3:6]
    gh = ca.DM(model.values["rho"] / np.linalg.norm(model.values["rho"]))
    ang = ca.atan2(ca.norm_2(ca.cross(gam, gh)), ca.dot(gam, gh))
    return ca.Function("hanging_distance", [x, p], [ang + ca.norm_2(w)], ["x", "p"], ["d"])


def hanging_set_level(model: Model, *, eps: float = 0.0) -> float:
    """Level ``2 m g |rho| - eps`` of the sets ``H_eps`` (29) and ``N = H_0`` (33).

    Parameters
    ----------
    model : Model
        A 3D pendulum model (its current ``m``, ``g``, ``rho``).
    eps : float
        ``0 <= eps < 2 m g |rho|``; 0 gives ``N``.

    Returns
    -------
    float
    """
    top = 2 * float(model.values["m"] * model.values["g"] * np.linalg.norm(model.values["rho"]))
    if not (0 <= eps < top):
        raise ParameterError(f"eps must lie in [0, 2 m g |rho|) = [0, {top:.6g}) (paper 001 "
                             f"Lemma 5); got {eps!r}")
    return top - float(eps)


def cart_lyapunov(model: Model, *, k_y: float, k_ydot: float, k_w: float, k_q: float
                  ) -> Lyapunov:
    """Paper 003 (25): ``V = k_y |y|^2 / 2 + |y-dot|^2 / 2 + k_w W``.

    ``W = -k_q l^2 |omega|^2 / 2 + k_q g l (1 + q . e3) + |x-dot|^2 / 2``, ``y`` of (24).
    Along (21), (26) the paper finds ``V-dot = -k_ydot |y-dot|^2``; here ``V-dot`` comes
    from the graph.

    Parameters
    ----------
    model : Model
        :func:`models.chain_cart.chain_cart` with ``n = 1``.
    k_y, k_ydot, k_w, k_q : float
        Gains of Prop. 5.

    Returns
    -------
    Lyapunov
    """
    _require_cart(model, "control Lyapunov function (25) of paper 003")
    G = CartGains(k_y, k_ydot, k_w, k_q)
    core = state_function(model, "V25", lambda ctx: _cart_V(ctx, G), out="V", record=False)
    return Lyapunov(model, lambda ctx: core(ctx.x, ctx.p), name="V25",
                    description="paper 003 (25)",
                    equation=r"\mathcal V = \tfrac12 k_y\|y\|^2 + \tfrac12\|\dot y\|^2 + k_w"
                    r"\mathcal W")


def _cart_V(ctx: Context, G: CartGains) -> ca.SX:
    t = _cart_terms(ctx, G.k_q)
    W = (-0.5 * G.k_q * t["l1"] ** 2 * t["w2"] + G.k_q * ctx["g"] * t["l1"] * (1 + t["q"][2])
         + 0.5 * ca.dot(t["v"], t["v"]))
    return 0.5 * G.k_y * ca.dot(t["y"], t["y"]) + 0.5 * ca.dot(t["ydot"], t["ydot"]) + G.k_w * W
