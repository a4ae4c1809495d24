"""Systems written with workbench.mechanics, shared by the mechanics tests.

Each definition is what a user writes: factors, parameters, bodies, gravity, loads and
symmetries; the equations of motion come from the layer.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench import mechanics
from workbench.core import positive, spd3

E3 = np.array([0.0, 0.0, 1.0])


def chain(n, *, m=0.5, masses=0.1, lengths=0.1, g=9.81, symbolic="MX", check=True):
    """The chain pendulum on a cart, n links with point masses (paper 003)."""
    s = mechanics.System(f"chain_cart_n{n}")
    cart = s.rn("x", 2, velocity="v")
    mc = s.parameter("m", m, "cart mass [kg]", check=positive)
    ms = s.parameter("masses", np.broadcast_to(masses, (n,)).copy(), "link masses", check=positive)
    ls = s.parameter("lengths", np.broadcast_to(lengths, (n,)).copy(), "lengths", check=positive)
    gg = s.parameter("g", g, "gravity [m/s^2]", check=positive)
    p = ca.vertcat(cart.x, 0)
    s.point_mass(mc, p)
    for i in range(n):
        p = p + ls[i] * s.s2(f"link{i + 1}").q
        s.point_mass(ms[i], p)
    s.gravity(gg)
    s.force(cart, s.input(2, "horizontal force on the cart [N]"))
    s.momentum("px", translate={cart: [1, 0]})
    s.momentum("py", translate={cart: [0, 1]})
    s.momentum("Lz", rotate=E3, generators={cart: ca.vertcat(-cart.x[1], cart.x[0])})
    return s.model(symbolic=symbolic, check=check)


def pendulum3d(J, rho, m=1.0, g=9.81):
    """The 3D pendulum on TSO(3): inertia J about the pivot, centre of mass at rho."""
    s = mechanics.System("pendulum3d_full")
    body = s.so3("R", velocity="omega")
    Jp = s.parameter("J", J, "inertia about the pivot", check=spd3)
    r, mm, gg = s.parameter("rho", rho), s.parameter("m", m), s.parameter("g", g)
    s.rigid_body(mm, Jp, body, com=r, inertia_about="origin")
    s.gravity(gg)
    s.moment(body, s.input(3, "body moment [N m]"))
    s.momentum("h", rotate=E3)
    return s.model()


def spherical(m=1.0, l=1.0, g=9.81):  # noqa: E741
    """The spherical pendulum with a moment at the pivot (paper 002)."""
    s = mechanics.System("spherical_pendulum")
    link = s.s2("q")
    mm, ll, gg = s.parameter("m", m), s.parameter("l", l), s.parameter("g", g)
    s.point_mass(mm, ll * link.q)
    s.gravity(gg)
    s.moment(link, s.input(3, "moment at the pivot [N m]"))
    s.momentum("h", rotate=E3)
    return s.model()


J_CART = np.diag([0.02, 0.03, 0.04])
J_QUAD = np.diag([0.01, 0.012, 0.02])
J1, J2 = np.diag([0.02, 0.03, 0.035]), np.diag([0.01, 0.015, 0.02])


def pendulum_on_cart(J=J_CART, rho=(0.01, -0.02, 0.3), m=0.8, M=1.5,
                     g=9.81, damping=0.0, symbolic="auto"):
    """A 3D pendulum (rigid body on a spherical joint) on a planar cart: R^2 x SO(3)."""
    s = mechanics.System("pendulum3d_cart")
    cart = s.rn("x", 2, velocity="v")
    body = s.so3("R", velocity="omega")
    Jc, r = s.inertia("J", J), s.parameter("rho", np.asarray(rho, float))
    mm, MM, gg = s.parameter("m", m), s.parameter("M", M), s.parameter("g", g)
    c = s.parameter("c", damping, "cart damping [N s/m]")
    pivot = ca.vertcat(cart.x, 0)
    s.point_mass(MM, pivot, name="cart")
    s.rigid_body(mm, Jc, body, origin=pivot, com=r, name="pendulum")
    s.gravity(gg)
    s.force(cart, s.input(2, "cart force [N]"))
    s.moment(body, s.input(3, "body moment [N m]"))
    s.dissipation(0.5 * c * ca.dot(cart.v, cart.v))
    if damping == 0.0:
        s.momentum("px", translate={cart: [1, 0]})
        s.momentum("py", translate={cart: [0, 1]})
        s.momentum("Lz", rotate=E3, generators={cart: ca.vertcat(-cart.x[1], cart.x[0])})
    return s.model(symbolic=symbolic)


def quadrotor_slung_load(mQ=1.2, J=J_QUAD, mL=0.3, L=0.8, g=9.81):
    """A quadrotor (R^3 x SO(3)) with a point load on a cable (S^2): thrust f along -R e3
    (e3 points down), body moment M; Sreenath, Lee, Kumar (CDC 2013)."""
    s = mechanics.System("quadrotor_slung_load")
    quad = s.rn("xQ", 3, velocity="vQ")
    att = s.so3("R", velocity="Omega")
    cable = s.s2("q")
    mq, ml, ll, gg = (s.parameter(k, v) for k, v in (("mQ", mQ), ("mL", mL), ("L", L),
                                                       ("g", g)))
    s.rigid_body(mq, s.inertia("J", J), att, origin=quad.x, name="quad")
    s.point_mass(ml, quad.x + ll * cable.q, name="load")
    s.gravity(gg)
    f, M = s.input(1, "thrust [N]"), s.input(3, "body moment [N m]")
    s.force_at(quad.x, ca.vertcat(0, 0, -f), body="quad")
    s.moment(att, M)
    return s.model()


def double_pendulum3d(J1=J1, J2=J2,
                      m1=1.0, m2=0.7, rho1=(0.0, 0.05, 0.2), d=(0.0, 0.0, 0.4),
                      rho2=(0.03, 0.0, 0.15), g=9.81):
    """Two rigid bodies on spherical joints, the first on a fixed pivot: SO(3) x SO(3)."""
    s = mechanics.System("double_pendulum3d")
    b1, b2 = s.so3("R1", velocity="Omega1"), s.so3("R2", velocity="Omega2")
    joint = b1.R @ s.parameter("d", np.asarray(d, float), "pivot to joint, body 1 [m]")
    s.rigid_body(s.parameter("m1", m1), s.inertia("J1", J1), b1,
                 com=s.parameter("rho1", np.asarray(rho1, float)))
    s.rigid_body(s.parameter("m2", m2), s.inertia("J2", J2), b2, origin=joint,
                 com=s.parameter("rho2", np.asarray(rho2, float)))
    s.gravity(s.parameter("g", g))
    s.momentum("h", rotate=E3)
    return s.model()
