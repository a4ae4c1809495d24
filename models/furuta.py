"""The Furuta (rotary inverted) pendulum: a motor-driven horizontal arm carrying a link.

K. Furuta, M. Yamakita, S. Kobayashi, "Swing-up control of inverted pendulum using
pseudo-state feedback", J. Systems and Control Engineering 206:263-269, 1992; the
equations as in B. S. Cazzolato and Z. Prime, "On the dynamics of the Furuta pendulum",
J. Control Science and Engineering 2011:528341. Written with the S^1 factors of
:mod:`workbench.mechanics`: no angle is stored, each joint is a unit vector ``(cos, sin)``
and its rate; the equations come from the Lagrangian by AD.

Conventions. ``e3`` points down, along gravity (the workbench's convention); the motor
axis is ``e3`` through the origin. The arm angle ``theta`` turns the arm about ``e3`` by
the right-hand rule (clockwise seen from above); ``theta = 0`` points the arm along
``e1``, so the arm's direction is ``a = (cos theta, sin theta, 0)`` and the pendulum's
pivot is at ``Lr a``. The link angle ``alpha`` turns the link about ``a`` by the right-hand
rule, from the downward vertical: the link's direction is ``d = cos alpha e3 + sin alpha (a
x e3)``, so ``alpha = 0`` hangs (the link points down, stable) and ``alpha = pi`` is
upright. The input is the motor torque on the arm [N m] (virtual work
``tau delta theta``). Units SI, angles in radians.

Bodies. The arm is a uniform thin rod of mass ``mr`` and length ``Lr`` turning about its
end on the motor axis (inertia ``mr Lr^2 / 3`` about the axis; it stays horizontal, so it
has no potential energy). The link is a uniform thin rod of mass ``mp`` and length ``Lp``
pivoted at its end: centre of mass at ``Lp / 2`` along ``d``, inertia ``Jp = mp Lp^2 / 12``
about any axis normal to it through its centre of mass and none about its own axis, so its
rotational energy is ``Jp |omega x d|^2 / 2 = Jp (alpha-dot^2 + theta-dot^2 sin^2 alpha)
/ 2``. Defaults: the masses and lengths of Quanser's QUBE-Servo 2 rotary pendulum module
(arm 0.095 kg, 0.085 m; pendulum 0.024 kg, 0.129 m), without motor, hub or friction.

Symmetry. With the motor off, turning the whole pendulum about the motor axis
(``theta -> theta + c``) changes nothing: the momentum ``angular_momentum_theta`` (the
angular momentum about ``e3``) is conserved; the motor torque breaks it.

State factors, in storage order: ``theta`` (S1), ``theta_dot`` (R^1), ``alpha`` (S1),
``alpha_dot`` (R^1). ``model.state(theta=0.0, alpha=np.pi, ...)`` takes the angles in
radians.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench import Model, mechanics
from workbench.core import positive
from workbench.core.errors import ModelError

__all__ = ["furuta", "furuta_system", "hanging", "upright", "QUBE_SERVO_2"]

QUBE_SERVO_2 = {"mr": 0.095, "Lr": 0.085, "mp": 0.024, "Lp": 0.129, "g": 9.81}
"""Masses [kg] and lengths [m] of the arm and pendulum of Quanser's QUBE-Servo 2."""


def furuta_system(*, mr: float = 0.095, Lr: float = 0.085, mp: float = 0.024,  # noqa: N803
                  Lp: float = 0.129, g: float = 9.81) -> mechanics.System:  # noqa: N803
    """The Furuta pendulum as a :class:`workbench.mechanics.System` (to extend or reduce).

    Parameters are as in :func:`furuta`; the momentum ``angular_momentum_theta`` is
    declared (the shift of the arm angle).

    Returns
    -------
    workbench.mechanics.System
    """
    s = mechanics.System("furuta")
    arm = s.s1("theta", velocity="theta_dot")
    link = s.s1("alpha", velocity="alpha_dot")
    mr_ = s.parameter("mr", mr, "arm mass [kg]", check=positive)
    Lr_ = s.parameter("Lr", Lr, "arm length, motor axis to pendulum pivot [m]",  # noqa: N806
                      check=positive)
    mp_ = s.parameter("mp", mp, "pendulum mass [kg]", check=positive)
    Lp_ = s.parameter("Lp", Lp, "pendulum length [m]", check=positive)  # noqa: N806
    g_ = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    a = ca.vertcat(arm.cos, arm.sin, 0)              # the arm's direction
    a_x_e3 = ca.vertcat(arm.sin, -arm.cos, 0)
    d = link.cos * ca.DM([0.0, 0.0, 1.0]) + link.sin * a_x_e3   # the link's direction
    s.kinetic(0.5 * mr_ * Lr_**2 / 3 * arm.rate**2)  # thin rod about its end
    s.point_mass(mp_, Lr_ * a + 0.5 * Lp_ * d, name="pendulum")
    Jp = mp_ * Lp_**2 / 12  # noqa: N806 - thin rod about its centre of mass
    s.kinetic(0.5 * Jp * (link.rate**2 + (arm.rate * link.sin) ** 2))
    s.gravity(g_)
    s.moment(arm, s.input(1, "motor torque on the arm [N m]"))
    s.momentum("angular_momentum_theta", shift=[arm])
    return s


def furuta(*, mr: float = 0.095, Lr: float = 0.085, mp: float = 0.024,  # noqa: N803
           Lp: float = 0.129, g: float = 9.81) -> Model:  # noqa: N803
    """Build the Furuta pendulum from its Lagrangian (defaults: :data:`QUBE_SERVO_2`).

    Parameters
    ----------
    mr : float
        Arm mass [kg], positive (a uniform thin rod).
    Lr : float
        Arm length, motor axis to the pendulum's pivot [m], positive.
    mp : float
        Pendulum mass [kg], positive (a uniform thin rod).
    Lp : float
        Pendulum length [m], positive (centre of mass at ``Lp / 2``).
    g : float
        Gravitational acceleration [m/s^2], positive, along ``e3`` (down).

    Returns
    -------
    Model
        Input: the motor torque on the arm [N m]; invariants ``energy`` and
        ``angular_momentum_theta`` (both conserved when ``u = 0``). All five values are
        parameters of the graph.
    """
    return furuta_system(mr=mr, Lr=Lr, mp=mp, Lp=Lp, g=g).model()


def _at(model: Model, theta: float, alpha: float) -> np.ndarray:
    if not isinstance(model, Model) or set(model.manifold.names) != {
            "theta", "theta_dot", "alpha", "alpha_dot"}:
        raise ModelError(f"model must be a Furuta pendulum from models.furuta.furuta(); got "
                         f"{model!r}")
    return model.state(theta=theta, theta_dot=[0.0], alpha=alpha, alpha_dot=[0.0])


def hanging(model: Model, theta: float = 0.0) -> np.ndarray:
    """The link hanging down at rest (``alpha = 0``), the arm at ``theta`` [rad]."""
    return _at(model, theta, 0.0)


def upright(model: Model, theta: float = 0.0) -> np.ndarray:
    """The link upright at rest (``alpha = pi``), the arm at ``theta`` [rad]."""
    return _at(model, theta, np.pi)
