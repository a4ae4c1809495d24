"""A quadrotor carrying a point-mass load on a cable, on R^3 x SO(3) x S^2.

The system of Sreenath, Lee and Kumar (CDC 2013): a quadrotor (mass ``mQ``, inertia ``JQ``
about its centre of mass, body frame) at ``xQ`` with attitude ``R`` and body angular velocity
``Omega``; a load (point mass ``mL``) on a massless cable of fixed length ``L`` at
``xQ + L q``, ``q`` in S^2 the cable direction. ``e3`` points down, along gravity, so the
thrust ``f`` acts along ``-R e3`` (up for a level quadrotor). Inputs: ``u = (f, M)``, the
thrust [N] and the body moment [N m] (4 inputs). The equations come from the Lagrangian by
:mod:`workbench.mechanics`.

State factors, in storage order: ``xQ`` (R^3), ``vQ`` (R^3), ``R`` (SO3, column-major),
``Omega`` (R^3), ``q`` (TS2, storing ``(q, omega)``). Invariants: ``energy``, the horizontal
momentum ``p_x``, ``p_y`` and the angular momentum about the vertical ``L_z`` (conserved when
``u = 0``). At hover (``R = I``, ``q = e3``, at rest) ``f = (mQ + mL) g``.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench import Model, mechanics
from workbench.core import positive

__all__ = ["quadrotor_slung_load", "hover_input"]

E3 = np.array([0.0, 0.0, 1.0])


def quadrotor_slung_load(*, mQ: float = 0.5,
                         JQ=((2.32e-3, 0.0, 0.0), (0.0, 2.32e-3, 0.0), (0.0, 0.0, 4.0e-3)),
                         mL: float = 0.1, L: float = 1.0, g: float = 9.81) -> Model:
    """Build the quadrotor with a slung load.

    Parameters
    ----------
    mQ, mL : float
        Masses of the quadrotor and of the load [kg], positive.
    JQ : array-like, shape=(3, 3)
        Inertia of the quadrotor about its centre of mass, body frame [kg m^2] (physical:
        SPD, triangle inequalities).
    L : float
        Cable length [m], positive.
    g : float
        Gravitational acceleration [m/s^2], positive.

    Returns
    -------
    Model
    """
    s = mechanics.System("quadrotor_slung_load")
    quad, att, cable = s.rn("xQ", 3, velocity="vQ"), s.so3("R", velocity="Omega"), s.s2("q")
    mQ_ = s.parameter("mQ", mQ, "quadrotor mass [kg]", check=positive)
    JQ_ = s.parameter("JQ", JQ, "quadrotor inertia, body frame [kg m^2]", check=mechanics.inertia)
    mL_ = s.parameter("mL", mL, "load mass [kg]", check=positive)
    L_ = s.parameter("L", L, "cable length [m]", check=positive)
    g_ = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    s.rigid_body(mQ_, JQ_, att, origin=quad.x, name="quadrotor")
    s.point_mass(mL_, quad.x + L_ * cable.q, name="load")
    s.gravity(g_)
    f, M = s.input(1, "thrust [N]"), s.input(3, "body moment [N m]")
    s.force(quad, -f * (att.R @ ca.DM(E3)))
    s.moment(att, M)
    s.momentum("p_x", translate={quad: [1.0, 0.0, 0.0]})
    s.momentum("p_y", translate={quad: [0.0, 1.0, 0.0]})
    s.momentum("L_z", rotate=E3, generators={quad: ca.vertcat(-quad.x[1], quad.x[0], 0)})
    return s.model()


def hover_input(model: Model) -> np.ndarray:
    """The input that holds hover: thrust ``(mQ + mL) g``, no moment; shape=(4,)."""
    v = model.values
    return np.array([(float(v["mQ"]) + float(v["mL"])) * float(v["g"]), 0.0, 0.0, 0.0])
