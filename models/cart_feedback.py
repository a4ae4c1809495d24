"""Nonlinear stabilisation of the inverted spherical pendulum on a cart, paper 003 (n = 1).

:class:`CartGains` (the gains of Proposition 5, checked against its conditions),
:func:`cart_inverted_feedback` (the feedback (21), with the erratum, and (26)) and
:func:`cart_domain` (the domain D of (43)). The control Lyapunov function (25) is
:func:`models.lyapunov_functions.cart_lyapunov`. All are re-exported by
:mod:`models.controllers`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from models._checks import E3, positive_scalar, require_model
from workbench.control import state_function
from workbench.core import Context, Model, validate
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import TS2, Rn

__all__ = ["CartGains", "cart_domain", "cart_domain_proposal", "cart_inverted_feedback",
           "cart_inverted_law"]

C2 = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])  # C = [e1, e2], R^2 -> R^3


@dataclass(frozen=True)
class CartGains:
    """Gains of paper 003 Proposition 5, checked against its conditions.

    Attributes
    ----------
    k_y, k_ydot, k_w, k_q : float
        Positive constants with ``k_q > 1 + k_w``.
    """

    k_y: float
    k_ydot: float
    k_w: float
    k_q: float

    def __post_init__(self) -> None:
        cond = "paper 003 Prop. 5: positive constants k_y, k_ydot, k_q, k_w with k_q > 1 + k_w"
        for name in ("k_y", "k_ydot", "k_w", "k_q"):
            object.__setattr__(self, name, positive_scalar(getattr(self, name), name, cond))
        if not self.k_q > 1 + self.k_w:
            raise ParameterError(
                f"k_q must exceed 1 + k_w ({cond}; it makes V of (25) positive definite on "
                f"the domain D of (43)); got k_q = {self.k_q}, 1 + k_w = {1 + self.k_w}"
            )

    @property
    def s(self) -> float:
        """``sqrt((1 + k_w) / k_q)``: ``D = {q1 . e3 < -s}`` of (43)."""
        return float(np.sqrt((1 + self.k_w) / self.k_q))


def _cart_terms(ctx: Context, k_q: Any) -> dict[str, Any]:
    """Build the output y (24), y-dot (44) and the pieces of (21), (26) on the n = 1 chain model."""
    Cd, e3 = ca.DM(C2), ca.DM(E3)
    x, v, link = ctx["x"], ctx["v"], ctx["link1"]
    q, w = link[0:3], link[3:6]
    l1, m1 = ctx["lengths"][0], ctx["masses"][0]
    qh2 = ca.skew(q) @ ca.skew(q)
    y = x + k_q * l1 * (Cd.T @ q)
    ydot = v - k_q * l1 * (Cd.T @ ca.cross(q, w))
    return {"C": Cd, "e3": e3, "x": x, "v": v, "q": q, "w": w, "l1": l1, "m1": m1,
            "qh2": qh2, "y": y, "ydot": ydot, "w2": ca.dot(w, w)}


def _require_cart(model: Model, who: str) -> None:
    require_model(model, who, factors={"x": Rn, "v": Rn, "link1": TS2},
                  params=("m", "masses", "lengths", "g"), inputs=2)
    if "link2" in model.manifold.names:
        raise ModelError(f"{who} is for one link (n = 1); model {model.name!r} has "
                         f"factors {model.manifold.names}")


@validate.arguments(error=ModelError, model=validate.instance(Model, "a workbench Model"))
def cart_inverted_feedback(
    model: Model, *, k_y: float, k_ydot: float, k_w: float, k_q: float
) -> ca.Function:
    """Nonlinear stabilisation of the inverted spherical pendulum on a cart, paper 003.

    The transformed input (26)
    ``mu = ((1 + k_w) I + k_q C^T hat(q)^2 C)^-1 (-k_y y - k_ydot y-dot
    + k_q g C^T hat(q)^2 e3 + k_q l |omega|^2 C^T q)`` with ``y = x + k_q l C^T q`` (24),
    put through the feedback transformation (21) with the erratum (no inverse):
    ``u = ((m + m1) I + m1 C^T hat(q)^2 C) mu - m1 g C^T hat(q)^2 e3
    - m1 l |omega|^2 C^T q``. The matrix inverted in (26) has the eigenvalues
    ``1 + k_w - k_q`` and ``1 + k_w - k_q (q . e3)^2``: it is singular on the boundary of
    the domain ``D = {q . e3 < -sqrt((1 + k_w)/k_q)}`` of (43) and invertible inside.

    Parameters
    ----------
    model : Model
        :func:`models.chain_cart.chain_cart` with ``n = 1``.
    k_y, k_ydot, k_w, k_q : float
        Positive gains with ``k_q > 1 + k_w`` (Prop. 5).

    Returns
    -------
    casadi.Function
        ``(x, p) -> u``, ``u`` shape=(2,).

    Raises
    ------
    ParameterError
        A gain breaks the conditions of Prop. 5.
    """
    who = "nonlinear cart controller (paper 003 (21), (26))"
    _require_cart(model, who)
    G = CartGains(k_y, k_ydot, k_w, k_q)
    return state_function(model, "cart_inverted_feedback", lambda ctx: cart_inverted_law(
        ctx, k_y=G.k_y, k_ydot=G.k_ydot, k_w=G.k_w, k_q=G.k_q))


def cart_inverted_law(ctx: Context, *, k_y: Any, k_ydot: Any, k_w: Any, k_q: Any) -> Any:
    """The law (21) (with the erratum) and (26) as an expression, gains unchecked.

    The one definition used by :func:`cart_inverted_feedback` (gains validated by
    :class:`CartGains`) and by exports whose gains are run-time inputs (casadi symbols).
    The 2x2 matrix of (26) is inverted by its adjugate over its determinant.

    Parameters
    ----------
    ctx : Context
        Symbols of the one-link chain on a cart (factors ``x``, ``v``, ``link1``).
    k_y, k_ydot, k_w, k_q : casadi scalar or float
        Gains of Prop. 5.

    Returns
    -------
    casadi expression, shape=(2, 1)
    """
    t = _cart_terms(ctx, k_q)
    Cd, e3, q, qh2, l1, m1, g = t["C"], t["e3"], t["q"], t["qh2"], t["l1"], t["m1"], ctx["g"]
    A = (1 + k_w) * ca.DM.eye(2) + k_q * (Cd.T @ qh2 @ Cd)
    b = (-k_y * t["y"] - k_ydot * t["ydot"] + k_q * g * (Cd.T @ qh2 @ e3)
         + k_q * l1 * t["w2"] * (Cd.T @ q))
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    mu = ca.vertcat(A[1, 1] * b[0] - A[0, 1] * b[1], A[0, 0] * b[1] - A[1, 0] * b[0]) / det
    M = (ctx["m"] + m1) * ca.DM.eye(2) + m1 * (Cd.T @ qh2 @ Cd)
    return M @ mu - m1 * g * (Cd.T @ qh2 @ e3) - m1 * l1 * t["w2"] * (Cd.T @ q)


def cart_domain(model: Model, *, k_w: float, k_q: float) -> ca.Function:
    """``b(x, p) = q1 . e3 + sqrt((1 + k_w)/k_q)``: the domain (43) is ``D = {b < 0}``.

    Parameters
    ----------
    model : Model
        :func:`models.chain_cart.chain_cart` with ``n = 1``.
    k_w, k_q : float
        Gains of Prop. 5 (``k_q > 1 + k_w``).

    Returns
    -------
    casadi.Function
        ``(x, p) -> b``.
    """
    _require_cart(model, "domain D of paper 003 (43)")
    s = CartGains(1.0, 1.0, k_w, k_q).s
    return state_function(model, "cart_domain_D", lambda ctx: ctx["link1"][2] + s, out="b")


def cart_domain_proposal(s: float, *, x_box: float, v_box: float, w_box: float
                         ) -> Callable[[np.random.Generator, int], np.ndarray]:
    """A sampler of states of the one-link cart in the domain (43) ``D = {q1 . e3 < -s}``.

    ``q1`` is area-uniform on the spherical cap ``q1 . e3 < -s``; ``omega1`` is drawn
    uniform in ``[-w_box, w_box]^3`` and projected onto ``T_q S^2`` (every tangent vector
    of the box is reached); ``x`` and ``x-dot`` are uniform in their boxes.

    Parameters
    ----------
    s : float
        ``sqrt((1 + k_w)/k_q)`` (:attr:`CartGains.s`), in [0, 1).
    x_box, v_box, w_box : float
        Half-widths of the boxes of ``x``, ``x-dot`` and ``omega1``.

    Returns
    -------
    callable
        ``draw(rng, k) -> ndarray, shape=(k, 10)``, stored states of
        :func:`models.chain_cart.chain_cart` with ``n = 1``.
    """

    def draw(rng: np.random.Generator, k: int) -> np.ndarray:
        q3 = rng.uniform(-1.0, -s, k)  # area-uniform on a spherical cap
        phi = rng.uniform(0.0, 2 * np.pi, k)
        r = np.sqrt(1 - q3**2)
        q = np.c_[r * np.cos(phi), r * np.sin(phi), q3]
        w = rng.uniform(-w_box, w_box, (k, 3))
        w -= np.sum(w * q, axis=1, keepdims=True) * q
        return np.c_[rng.uniform(-x_box, x_box, (k, 2)), rng.uniform(-v_box, v_box, (k, 2)),
                     q, w]

    return draw
