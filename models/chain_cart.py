"""The n-link spherical chain pendulum on a cart, paper 003, for any n >= 1, from its Lagrangian.

The cart (mass ``m``) moves in the horizontal plane, position ``x`` in R^2, driven by a
horizontal force ``u`` in R^2. Link ``i`` has direction ``q_i`` in S^2 (``e3`` points
down, along gravity), angular velocity ``omega_i`` with ``q_i . omega_i = 0`` and
``q_i-dot = omega_i x q_i`` (13), length ``l_i`` and a point mass ``m_i`` at its outer end.

Nothing is hand-derived: the model declares the cart and the bobs as point masses at
``C x`` and ``C x + sum_{a <= i} l_a q_a``, gravity and the cart force, and
:mod:`workbench.mechanics` derives the Euler-Lagrange equations (equivalent to (12) with
the erratum of docs/science.md). The accelerations are one numeric linear solve in an MX
graph (its size grows like n^2); the Jacobian comes from the implicit-function theorem on
the residual, cheap at an equilibrium. The printed (12)-(13) are kept, as an independent
check, in :func:`models.paper_forms.chain_cart_printed`.

State factors, in storage order: ``x`` (R^2), ``v`` (R^2, cart velocity), then
``link1 .. linkn`` (each TS2, storing ``(q_i, omega_i)``).
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np

from workbench import mechanics
from workbench.core import Model, positive
from workbench.core.errors import ParameterError
from workbench.core.types import ArrayLike
from workbench.core.validate import arguments as _arguments
from workbench.core.validate import array as _array
from workbench.core.validate import count as _count
from workbench.core.validate import parameter as _parameter

__all__ = ["chain_cart", "link_state", "E3", "C"]

E3 = np.array([0.0, 0.0, 1.0])
C = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])  # R^2 -> horizontal plane of R^3

LINEAR_SOLVER = "lapacklu"
"""casadi linear solver plugin for the (dense) acceleration solve."""


def _per_link(name: str, value: float | Sequence[float], n: int) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"parameter {name!r} must be a number or one number per link "
                             f"({n}); got {value!r}") from exc
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ParameterError(
            f"parameter {name!r} must be a scalar or have one entry per link ({n}); "
            f"got shape {arr.shape}"
        )
    return arr


MAX_LINKS = 100
"""Default ``max_links`` of :func:`chain_cart`: the largest chain built without asking."""


def _memory_gb(n: int) -> float:
    """Estimated peak memory [GB] of building and linearising an ``n``-link chain.

    Fit to the derived model's peak RSS (benchmarks/bench_mechanics.py: 0.24 GB at n = 50,
    0.52 GB at n = 100, of which 0.16 GB is the interpreter with casadi and numpy).
    """
    return 0.16 + 3.6e-5 * n**2


@_arguments(m=_parameter(_array, shape=()), masses=_parameter(_array),
            lengths=_parameter(_array), g=_parameter(_array, shape=()))
def chain_cart(
    n: int,
    *,
    m: float = 0.5,
    masses: float | Sequence[float] = 0.1,
    lengths: float | Sequence[float] = 0.1,
    g: float = 9.81,
    max_links: int = MAX_LINKS,
) -> Model:
    """Build the chain pendulum on a cart with ``n`` links, from its Lagrangian.

    Parameters
    ----------
    n : int
        Number of links, at least 1 and at most ``max_links``.
    max_links : int
        Size guard (default :data:`MAX_LINKS` = 100): a larger ``n`` is refused with the
        estimated memory unless this is raised (measured peak memory of building the
        graphs and linearising: n = 50 about 0.24 GB, n = 100 about 0.52 GB; growth n^2).
    m : float
        Cart mass [kg], positive.
    masses : float or sequence of float
        Link point masses ``m_i`` [kg], one per link or one for all; positive.
    lengths : float or sequence of float
        Link lengths ``l_i`` [m], one per link or one for all; positive.
    g : float
        Gravitational acceleration [m/s^2]; paper 003's examples use 9.81.

    Returns
    -------
    Model
        Input ``u`` (horizontal force on the cart, R^2); invariants ``energy``,
        ``px``, ``py`` (horizontal linear momentum) and ``Lz`` (vertical angular momentum
        about the origin), all conserved when ``u = 0``.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"n (number of links) must be an integer >= 1; got {n!r}")
    if n > _count("max_links", max_links):
        raise ParameterError(
            f"n = {n} links > max_links = {max_links}: building the chain's graphs and "
            f"Jacobians takes about {_memory_gb(n):.1f} GB (0.24 GB at n = 50, 0.52 GB at 100, "
            f"measured; growing like n^2); pass max_links={n} if you mean it")
    n = int(n)
    s = mechanics.System(f"chain_cart_n{n}")
    cart = s.rn("x", 2, velocity="v")
    mc = s.parameter("m", m, "cart mass [kg]", check=positive)
    mi = s.parameter("masses", _per_link("masses", masses, n), "link point masses m_i [kg]",
                     check=positive)
    li = s.parameter("lengths", _per_link("lengths", lengths, n), "link lengths l_i [m]",
                     check=positive)
    gg = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    point = ca.DM(C) @ cart.x
    s.point_mass(mc, point, name="cart")
    for i in range(n):
        point = point + li[i] * s.s2(f"link{i + 1}").q
        s.point_mass(mi[i], point, name=f"bob{i + 1}")
    s.gravity(gg, direction=E3)
    s.force(cart, s.input(2, "horizontal force on the cart u [N]"))
    s.momentum("px", translate={cart: [1.0, 0.0]})
    s.momentum("py", translate={cart: [0.0, 1.0]})
    s.momentum("Lz", rotate=E3, generators={cart: ca.vertcat(-cart.x[1], cart.x[0])})
    return s.model(
        symbolic="MX", linear_solver=LINEAR_SOLVER, check=False,
        description=f"{n}-link spherical chain pendulum on a cart on (S^2)^{n} x R^2 "
        "(paper 003; equations derived from the Lagrangian by workbench.mechanics)",
        equations=(
            r"L = \tfrac12 m\|\dot x\|^2 + \sum_i \tfrac12 m_i\|C\dot x + \sum_{a\le i} l_a"
            r" \omega_a\times q_a\|^2 + \sum_i m_i g\, e_3\cdot(Cx + \sum_{a\le i} l_a q_a)"
            r"\quad (5)\text{-}(7)",
            r"\tfrac{d}{dt}\tfrac{\partial L}{\partial\dot x} = \tfrac{\partial L}{\partial x}"
            r" + u,\; (I - q_iq_i^T)\tfrac{d}{dt}\tfrac{\partial L}{\partial\omega_i} = q_i\times"
            r"\tfrac{\partial L}{\partial q_i},\; \dot q_i = \omega_i\times q_i"
            r"\quad\text{(equivalent to (12)-(13))}",
        ),
        input_description="horizontal force on the cart u [N]",
    )


def link_state(q: ArrayLike, omega: ArrayLike | None = None) -> np.ndarray:
    """Stack one link's ``(q, omega)`` (omega defaults to zero); no normalisation."""
    w = np.zeros(3) if omega is None else _array("omega", omega, size=3).reshape(3)
    return np.concatenate([_array("q", q, size=3).reshape(3), w])
