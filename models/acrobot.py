"""The acrobot: two links in a vertical plane, a torque at the elbow only, on S^1 x S^1.

Spong's underactuated double pendulum (M. W. Spong, "The swing up control problem for the
Acrobot", IEEE Control Systems Magazine 15(1):49-55, 1995; R. Tedrake, *Underactuated
Robotics*, MIT course notes, ch. "The Acrobot and Cart-Pole"), written with the S^1
factors of :mod:`workbench.mechanics`: no angle is stored, each joint is a unit vector
``(cos, sin)`` and its rate, and the equations come from the Lagrangian by AD.

Conventions. The plane of motion is the world's ``e1``-``e3`` plane with ``e3`` pointing
down, along gravity (the workbench's convention). ``theta1`` is the shoulder angle of link
1 from the downward vertical, ``theta2`` the elbow angle of link 2 relative to link 1; both
turn by the right-hand rule about ``e2`` (positive from ``e3`` towards ``e1``). So link
``i``'s direction is ``(sin phi_i, 0, cos phi_i)`` with ``phi_1 = theta1`` and
``phi_2 = theta1 + theta2``; ``theta1 = theta2 = 0`` hangs straight down, ``theta1 = pi,
theta2 = 0`` stands straight up. The input is the torque at the elbow [N m] (virtual work
``tau delta theta2``), none at the shoulder. Units SI, angles in radians.

In these angles the equations are Spong's ``M(q) q-ddot + C(q, q-dot) q-dot = tau_g(q) + B
u`` with ``B = (0, 1)`` (Tedrake's form; ``I_i`` below are about the centres of mass, so
his inertias about the joints are ``I_i + m_i lc_i^2``); they are *not* used here, only in
the tests, as an independent check.

State factors, in storage order: ``theta1`` (S1: ``(cos theta1, sin theta1)``),
``theta1_dot`` (R^1), ``theta2`` (S1), ``theta2_dot`` (R^1). ``model.state(theta1=pi,
...)`` takes the angles in radians.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench import Model, mechanics
from workbench.core import positive
from workbench.core.errors import ModelError

__all__ = ["acrobot", "hanging", "upright", "SPONG_1995"]

SPONG_1995 = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "lc1": 0.5, "lc2": 1.0, "I1": 0.083,
              "I2": 0.33, "g": 9.81}
"""The parameters of Spong (1995), as Tedrake's course and Drake use them: ``l2 = 2`` m
enters only through ``lc2 = 1`` m and ``I2 = 0.33`` kg m^2 (about ``m l^2/12`` of uniform
rods of 1 m and 2 m); ``g = 9.81`` m/s^2 (Spong wrote 9.8)."""


def _sum(a: mechanics.S1Factor, b: mechanics.S1Factor) -> tuple[ca.SX, ca.SX]:
    """``cos(a + b)``, ``sin(a + b)`` from the two unit vectors (no angle is formed)."""
    return a.cos * b.cos - a.sin * b.sin, a.sin * b.cos + a.cos * b.sin


def acrobot(*, m1: float = 1.0, m2: float = 1.0, l1: float = 1.0, lc1: float = 0.5,
            lc2: float = 1.0, I1: float = 0.083, I2: float = 0.33,  # noqa: N803
            g: float = 9.81) -> Model:
    """Build the acrobot from its Lagrangian (defaults: Spong 1995, :data:`SPONG_1995`).

    Parameters
    ----------
    m1, m2 : float
        Link masses [kg], positive.
    l1 : float
        Length of link 1, shoulder to elbow [m], positive.
    lc1, lc2 : float
        Joint to centre of mass of link 1 (from the shoulder) and of link 2 (from the
        elbow) [m], positive.
    I1, I2 : float
        Moments of inertia of the links about their centres of mass, about the axis
        ``e2`` normal to the plane [kg m^2], positive.
    g : float
        Gravitational acceleration [m/s^2], positive, along ``e3`` (down).

    Returns
    -------
    Model
        Input: the elbow torque [N m]; invariant ``energy`` (conserved when ``u = 0``).
        All eight values are parameters of the graph (sweeps need no rebuild).
    """
    s = mechanics.System("acrobot")
    shoulder = s.s1("theta1", velocity="theta1_dot")
    elbow = s.s1("theta2", velocity="theta2_dot")
    m1_ = s.parameter("m1", m1, "mass of link 1 [kg]", check=positive)
    m2_ = s.parameter("m2", m2, "mass of link 2 [kg]", check=positive)
    l1_ = s.parameter("l1", l1, "length of link 1 [m]", check=positive)
    lc1_ = s.parameter("lc1", lc1, "shoulder to centre of mass of link 1 [m]", check=positive)
    lc2_ = s.parameter("lc2", lc2, "elbow to centre of mass of link 2 [m]", check=positive)
    I1_ = s.parameter("I1", I1, "inertia of link 1 about its centre of mass [kg m^2]",  # noqa: N806
                      check=positive)
    I2_ = s.parameter("I2", I2, "inertia of link 2 about its centre of mass [kg m^2]",  # noqa: N806
                      check=positive)
    g_ = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    c12, s12 = _sum(shoulder, elbow)
    d1 = ca.vertcat(shoulder.sin, 0, shoulder.cos)  # link directions in the e1-e3 plane
    d2 = ca.vertcat(s12, 0, c12)
    s.point_mass(m1_, lc1_ * d1, name="link1")
    s.point_mass(m2_, l1_ * d1 + lc2_ * d2, name="link2")
    # the links turn about e2 at theta1-dot and theta1-dot + theta2-dot
    s.kinetic(0.5 * I1_ * shoulder.rate**2 + 0.5 * I2_ * (shoulder.rate + elbow.rate) ** 2)
    s.gravity(g_)
    s.moment(elbow, s.input(1, "torque at the elbow [N m]"))
    return s.model()


def _at(model: Model, theta1: float, theta2: float) -> np.ndarray:
    if not isinstance(model, Model) or set(model.manifold.names) != {
            "theta1", "theta1_dot", "theta2", "theta2_dot"}:
        raise ModelError(f"model must be an acrobot from models.acrobot.acrobot(); got "
                         f"{model!r}")
    return model.state(theta1=theta1, theta1_dot=[0.0], theta2=theta2, theta2_dot=[0.0])


def hanging(model: Model) -> np.ndarray:
    """The acrobot hanging straight down at rest (``theta1 = theta2 = 0``), stable."""
    return _at(model, 0.0, 0.0)


def upright(model: Model) -> np.ndarray:
    """The acrobot standing straight up at rest (``theta1 = pi``, ``theta2 = 0``)."""
    return _at(model, np.pi, 0.0)
