"""A double pendulum on a cart, planar: R^1 x S^1 x S^1 with one force on the cart.

The double inverted pendulum on a cart (DIPC) of A. Bogdanov, "Optimal control of a double
inverted pendulum on a cart", Technical Report CSE-04-006, OGI School of Science and
Engineering, OHSU, December 2004: a cart of mass ``m0`` on a horizontal track carries two
uniform rods in series, masses ``m1``, ``m2`` and lengths ``L1``, ``L2`` (centres of mass
at ``L_i / 2``, inertias ``m_i L_i^2 / 12`` about them), frictionless joints, a horizontal
force ``u`` on the cart. Written with the S^1 factors of :mod:`workbench.mechanics`: no
angle is stored, each link is a unit vector ``(cos, sin)`` and its rate; the equations
come from the Lagrangian by AD. Bogdanov's closed form ``D(theta) theta-ddot +
C(theta, theta-dot) theta-dot + G(theta) = H u`` is not used here, only in the tests, as
an independent check.

Conventions. The plane of motion is the world's ``e1``-``e3`` plane with ``e3`` pointing
down, along gravity (the workbench's convention); the cart moves along ``e1`` (position
``x``, the input is the force on it along ``e1`` [N], virtual work ``u delta x``). Both
link angles are absolute, measured from the downward vertical and turning by the
right-hand rule about ``e2`` (positive from ``e3`` towards ``e1``): link ``i``'s direction
is ``(sin phi_i, 0, cos phi_i)``. ``phi1 = phi2 = 0`` hangs (stable), ``phi1 = phi2 = pi``
stands upright. Bogdanov measures his angles ``theta_i`` from the upward vertical, positive
towards ``+x``: ``theta_i = pi - phi_i``. Units SI, angles in radians.

Symmetry. The cart's track has no spring: translating the whole along ``e1`` changes
nothing, so the horizontal momentum ``linear_momentum_x`` is conserved when ``u = 0``
(the force is its rate).

State factors, in storage order: ``x`` (R^1, the cart's position [m]), ``v`` (R^1, its
velocity [m/s]), ``phi1`` (S1), ``phi1_dot`` (R^1), ``phi2`` (S1), ``phi2_dot`` (R^1).
``model.state(phi1=np.pi, ...)`` takes the angles in radians.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench import Model, mechanics
from workbench.core import positive
from workbench.core.errors import ModelError

__all__ = ["double_cartpole", "double_cartpole_system", "hanging", "upright",
           "BOGDANOV_2004"]

BOGDANOV_2004 = {"m0": 1.5, "m1": 0.5, "m2": 0.75, "L1": 0.5, "L2": 0.75, "g": 9.81}
"""Bogdanov (2004)'s cart and rod masses [kg] and rod lengths [m]; ``g = 9.81`` m/s^2
(Bogdanov wrote 9.8)."""

_NAMES = {"x", "v", "phi1", "phi1_dot", "phi2", "phi2_dot"}


def double_cartpole_system(*, m0: float = 1.5, m1: float = 0.5, m2: float = 0.75,
                           L1: float = 0.5, L2: float = 0.75,  # noqa: N803
                           g: float = 9.81) -> mechanics.System:
    """The double pendulum on a cart as a :class:`workbench.mechanics.System`.

    Parameters are as in :func:`double_cartpole`; the momentum ``linear_momentum_x`` (the
    translation of the cart along the track) is declared.

    Returns
    -------
    workbench.mechanics.System
    """
    s = mechanics.System("double_cartpole")
    cart = s.rn("x", 1, velocity="v")
    link1 = s.s1("phi1", velocity="phi1_dot")
    link2 = s.s1("phi2", velocity="phi2_dot")
    m0_ = s.parameter("m0", m0, "cart mass [kg]", check=positive)
    m1_ = s.parameter("m1", m1, "mass of rod 1 (next to the cart) [kg]", check=positive)
    m2_ = s.parameter("m2", m2, "mass of rod 2 [kg]", check=positive)
    L1_ = s.parameter("L1", L1, "length of rod 1 [m]", check=positive)  # noqa: N806
    L2_ = s.parameter("L2", L2, "length of rod 2 [m]", check=positive)  # noqa: N806
    g_ = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    pivot = ca.vertcat(cart.x, 0, 0)
    d1 = ca.vertcat(link1.sin, 0, link1.cos)  # the rods' directions in the e1-e3 plane
    d2 = ca.vertcat(link2.sin, 0, link2.cos)
    s.point_mass(m0_, pivot, name="cart")
    s.point_mass(m1_, pivot + 0.5 * L1_ * d1, name="rod1")
    s.point_mass(m2_, pivot + L1_ * d1 + 0.5 * L2_ * d2, name="rod2")
    # uniform thin rods turning about e2: inertia m L^2 / 12 about the centre of mass
    s.kinetic(0.5 * m1_ * L1_**2 / 12 * link1.rate**2 + 0.5 * m2_ * L2_**2 / 12 * link2.rate**2)
    s.gravity(g_)
    s.force(cart, s.input(1, "force on the cart along the track [N]"))
    s.momentum("linear_momentum_x", translate={cart: [1.0]})
    return s


def double_cartpole(*, m0: float = 1.5, m1: float = 0.5, m2: float = 0.75,
                    L1: float = 0.5, L2: float = 0.75, g: float = 9.81) -> Model:  # noqa: N803
    """Build the double pendulum on a cart from its Lagrangian (defaults: Bogdanov 2004).

    Parameters
    ----------
    m0 : float
        Cart mass [kg], positive.
    m1, m2 : float
        Masses of rod 1 (jointed to the cart) and rod 2 (jointed to the end of rod 1)
        [kg], positive; uniform thin rods.
    L1, L2 : float
        Lengths of the rods [m], positive.
    g : float
        Gravitational acceleration [m/s^2], positive, along ``e3`` (down).

    Returns
    -------
    Model
        Input: the force on the cart along the track [N]; invariants ``energy`` and
        ``linear_momentum_x`` (both conserved when ``u = 0``). All six values are
        parameters of the graph (sweeps need no rebuild).
    """
    return double_cartpole_system(m0=m0, m1=m1, m2=m2, L1=L1, L2=L2, g=g).model()


def _at(model: Model, phi: float) -> np.ndarray:
    if not isinstance(model, Model) or set(model.manifold.names) != _NAMES:
        raise ModelError(f"model must be a double pendulum on a cart from "
                         f"models.double_cartpole.double_cartpole(); got {model!r}")
    return model.state(x=[0.0], v=[0.0], phi1=phi, phi1_dot=[0.0], phi2=phi,
                       phi2_dot=[0.0])


def hanging(model: Model) -> np.ndarray:
    """Both rods hanging straight down at rest (``phi1 = phi2 = 0``), the cart at 0."""
    return _at(model, 0.0)


def upright(model: Model) -> np.ndarray:
    """Both rods standing straight up at rest (``phi1 = phi2 = pi``), the cart at 0."""
    return _at(model, np.pi)
