"""Two rigid bodies joined by spherical joints, the first to a fixed pivot, on SO(3) x SO(3).

Body ``i`` has mass ``m_i``, inertia ``J_i`` about its own pivot (body frame) and centre of
mass at ``rho_i`` from that pivot (body frame); the second body's pivot is the point ``d1``
of the first body (body frame of body 1). ``e3`` points down, along gravity. No inputs. The
equations come from the Lagrangian by :mod:`workbench.mechanics`.

State factors, in storage order: ``R1``, ``Omega1``, ``R2``, ``Omega2``. Invariants:
``energy`` and the angular momentum about the vertical through the pivot, ``L_z``.
Equilibria: each body hanging (``R_i = I``) or inverted (``R_i = exp(pi e1-hat)``) when
``rho_i`` and ``d1`` lie along the body ``e3`` axes: four types. Being made by the mechanics
layer, it runs with the variational integrator ``simulate(..., method=
"mechanics_variational")`` (symplectic, L_z kept to the Newton tolerance, bounded energy
error: ``problems/double_pendulum3d``).
"""

from __future__ import annotations

from workbench import Model, mechanics
from workbench.core import positive

__all__ = ["double_pendulum3d"]


def double_pendulum3d(*, m1: float = 1.0,
                      J1=((0.20, 0.0, 0.0), (0.0, 0.22, 0.0), (0.0, 0.0, 0.05)),
                      rho1=(0.0, 0.0, 0.25), d1=(0.0, 0.0, 0.5), m2: float = 0.8,
                      J2=((0.10, 0.0, 0.0), (0.0, 0.12, 0.0), (0.0, 0.0, 0.03)),
                      rho2=(0.0, 0.0, 0.2),
                      g: float = 9.81) -> Model:
    """Build the double 3D pendulum.

    Parameters
    ----------
    m1, m2 : float
        Masses [kg], positive.
    J1, J2 : array-like, shape=(3, 3)
        Inertias about each body's pivot, body frame [kg m^2] (physical).
    rho1, rho2 : array-like, shape=(3,)
        Pivot to centre of mass of each body, its body frame [m].
    d1 : array-like, shape=(3,)
        Pivot of body 1 to the joint with body 2, body frame of body 1 [m].
    g : float
        Gravitational acceleration [m/s^2], positive.

    Returns
    -------
    Model
    """
    s = mechanics.System("double_pendulum3d")
    b1, b2 = s.so3("R1", velocity="Omega1"), s.so3("R2", velocity="Omega2")
    m1_ = s.parameter("m1", m1, "mass of body 1 [kg]", check=positive)
    J1_ = s.parameter("J1", J1, "inertia of body 1 about its pivot [kg m^2]",
                      check=mechanics.inertia)
    rho1_ = s.parameter("rho1", rho1, "pivot to centre of mass of body 1 [m]")
    d1_ = s.parameter("d1", d1, "pivot of body 1 to the joint, body 1 frame [m]")
    m2_ = s.parameter("m2", m2, "mass of body 2 [kg]", check=positive)
    J2_ = s.parameter("J2", J2, "inertia of body 2 about the joint [kg m^2]",
                      check=mechanics.inertia)
    rho2_ = s.parameter("rho2", rho2, "joint to centre of mass of body 2 [m]")
    g_ = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    s.rigid_body(m1_, J1_, b1, com=rho1_, inertia_about="origin", name="body1")
    s.rigid_body(m2_, J2_, b2, origin=b1.R @ d1_, com=rho2_, inertia_about="origin",
                 name="body2")
    s.gravity(g_)
    s.momentum("L_z", rotate=[0.0, 0.0, 1.0])
    return s.model()
