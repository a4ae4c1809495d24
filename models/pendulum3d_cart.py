"""A 3D pendulum whose pivot rides a cart in the horizontal plane, on R^2 x SO(3).

A rigid body (mass ``m``, inertia ``J`` about the pivot in the body frame, centre of mass at
``rho`` from the pivot in the body frame) hangs from a frictionless spherical joint on a
cart of mass ``M`` that moves in the horizontal plane (``e3`` points down, along gravity).
Inputs: the horizontal force on the cart ``u[0:2]`` and, with ``body_moment=True``, a
moment on the body in its own frame ``u[2:5]``. Nothing is hand-derived: the equations
come from the Lagrangian by :mod:`workbench.mechanics` (R-dot = R hat(Omega), the SO(3)
equation J Omega-dot + Omega x J Omega = ... in the body frame).

State factors, in storage order: ``x`` (R^2), ``v`` (R^2), ``R`` (SO3, column-major),
``Omega`` (R^3, body angular velocity). Invariants: ``energy``, the horizontal momentum
``p_x``, ``p_y`` and the angular momentum about the vertical ``L_z`` (all conserved when
``u = 0``).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench import S2, SO3, Model, ProductManifold, Rn, TargetSet, mechanics
from workbench.core import positive

__all__ = ["pendulum3d_cart", "at_rest", "inverted_at_origin", "E3"]

E3 = np.array([0.0, 0.0, 1.0])


def pendulum3d_cart(*, M: float = 1.0, m: float = 1.0,
                    J=((0.13, 0.0, 0.0), (0.0, 0.28, 0.0), (0.0, 0.0, 0.17)),
                    rho=(0.0, 0.0, 0.3), g: float = 9.81, body_moment: bool = False) -> Model:
    """Build the 3D pendulum on a planar cart.

    Parameters
    ----------
    M, m : float
        Masses of the cart and of the body [kg], positive.
    J : array-like, shape=(3, 3)
        Inertia of the body about the pivot, body frame [kg m^2]: symmetric positive
        definite, its principal moments satisfying the triangle inequalities.
    rho : array-like, shape=(3,)
        Pivot to centre of mass, body frame [m].
    g : float
        Gravitational acceleration [m/s^2], positive.
    body_moment : bool
        Also a moment on the body (body frame, 3 more inputs).

    Returns
    -------
    Model
    """
    s = mechanics.System("pendulum3d_cart")
    cart, body = s.rn("x", 2, velocity="v"), s.so3("R", velocity="Omega")
    M_, m_ = s.parameter("M", M, "cart mass [kg]", check=positive), s.parameter(
        "m", m, "body mass [kg]", check=positive)
    J_ = s.parameter("J", J, "inertia about the pivot, body frame [kg m^2]",
                     check=mechanics.inertia)
    rho_ = s.parameter("rho", rho, "pivot to centre of mass, body frame [m]")
    g_ = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    pivot = ca.vertcat(cart.x, 0)
    s.point_mass(M_, pivot, name="cart")
    s.rigid_body(m_, J_, body, origin=pivot, com=rho_, inertia_about="origin", name="body")
    s.gravity(g_)
    s.force(cart, s.input(2, "horizontal force on the cart [N]"))
    if body_moment:
        s.moment(body, s.input(3, "moment on the body, body frame [N m]"))
    s.momentum("p_x", translate={cart: [1.0, 0.0]})
    s.momentum("p_y", translate={cart: [0.0, 1.0]})
    s.momentum("L_z", rotate=[0.0, 0.0, 1.0], generators={cart: ca.vertcat(-cart.x[1], cart.x[0])})
    return s.model()


def at_rest(model: Model, R=None) -> np.ndarray:
    """The cart at the origin and the body at attitude ``R`` (default hanging), at rest.

    Parameters
    ----------
    model : Model
        A model from :func:`pendulum3d_cart`.
    R : array-like, shape=(3, 3), optional
        The body's attitude (checked to be a rotation); default the identity (hanging).

    Returns
    -------
    ndarray
        The state.
    """
    return model.state(x=[0, 0], v=[0, 0], R=np.eye(3) if R is None else R, Omega=[0, 0, 0])


def inverted_at_origin(model: Model) -> TargetSet:
    """The target set of a swing-up: cart at the origin at rest, body inverted at rest.

    ``R^T e3 = -e3`` leaves the rotation about the vertical free: the set is a circle of
    attitudes, imposed through the chart of ``(x, v, R^T e3, Omega_1, Omega_2)``. The yaw
    rate ``Omega_3`` is not imposed. With the cart force alone it is uncontrollable to
    first order at both equilibria and along every swing in a vertical plane (the PBH
    test of ``problems/pendulum3d_cart.py``): a swing-up from rest that stays planar has
    ``Omega_3 = 0`` throughout. Imposing ``Omega_3(T) = 0`` as well gives the NLP a
    terminal row that is linearly dependent on the dynamics (LICQ fails). Ipopt then
    works on a nearly singular, regularised KKT matrix and, depending on rounding, ends in
    the restoration phase (measured: ``Restoration_Failed`` after 34 iterations, against
    ``Solve_Succeeded`` in 31 without the row). A swing-up that leaves the plane could end
    with ``Omega_3 != 0``: check it in the solution (the problem does).

    Parameters
    ----------
    model : Model
        A model from :func:`pendulum3d_cart`.

    Returns
    -------
    TargetSet
    """
    e3 = ca.DM(E3)
    return TargetSet(
        map=lambda x: ca.vertcat(x[0:4], SO3.matrix(x[4:13]).T @ e3, x[13:15]),
        manifold=ProductManifold([("xv", Rn(4)), ("Gamma", S2()), ("Omega12", Rn(2))]),
        value=np.r_[0, 0, 0, 0, -E3, 0, 0],
        witness=at_rest(model, np.diag([1.0, -1.0, -1.0])),
        description="cart at the origin at rest, body inverted at rest (any yaw)")
