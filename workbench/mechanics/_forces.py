"""Potentials and loads: gravity, forces at points, moments, forces on R^k, dissipation.

Every load is a *covector on the configuration*: a pair (target expression ``y(c)``,
weight ``w``) whose virtual work is ``w . delta y``; the generalised force on a factor's
velocity is ``K(c)^T (dy/dc)^T w`` (see :mod:`._factors`). All loads are reduced with one
reverse-mode product ``(dy/dc)^T w`` (``casadi.jtimes``, the weights as seeds):

=====================================  =====================  =======================
load                                   target ``y(c)``        weight ``w``
=====================================  =====================  =======================
world force ``F`` at point ``p(c)``    ``p``                  ``F``
body-frame force ``F_b`` at ``p(c)``   ``p``                  ``R F_b``
body moment ``M_b`` on attitude ``R``  ``vec(R)``             ``vec(R hat(M_b) / 2)``
world moment ``tau`` on an S^2 ``q``   ``q``                  ``tau x q / |q|^2``
force ``F`` on an R^k factor ``x``     ``x``                  ``F``
torque ``tau`` on an S^1 angle ``p``   ``p``                  ``tau J p / |p|^2``
=====================================  =====================  =======================

(``M_b . vee(R^T delta R) = <R hat(M_b), delta R> / 2``; off SO(3) the body moment's
generalised force on ``Omega`` is ``vee((R^T R hat(M_b) + hat(M_b) R^T R) / 2)``, so at the
stages of a collocation, which leave SO(3) by the local error, it differs from ``M_b`` by
that much. The exact weight ``R^-T hat(M_b) / 2`` (and its polynomial approximation
``R (2I - R^T R) hat(M_b) / 2``) was tried: it made the full and reduced 3D
pendulum transcriptions agree to 1e-9, but the quadrotor's transport OCP then took 779
Ipopt iterations and failed instead of converging in 41, so the weight stays linear in
``R``; ``q x (tau x q) / |q|^2`` is the
part of ``tau`` normal to ``q``, for every ``|q|``: the moment's virtual work on a rotation
``delta q = eta x q`` is ``tau . (I - q q^T/|q|^2) eta`` off the sphere as on it, so its
authority does not fade when an optimiser's ambient iterate has ``|q| < 1``; with the
weight ``tau x q`` it would scale like ``|q|^2`` and swing-ups in ambient coordinates
collapsed to ``q -> 0``. The torque on an angle is scaled alike: ``J p . tau J p / |p|^2 =
tau`` for every ``p != 0``.) A Rayleigh function ``D(c, nu) >= 0`` adds ``-dD/dnu``.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from workbench.mechanics._engine import hat

__all__ = ["Load", "force_at", "body_moment", "sphere_moment", "angle_torque",
           "coordinate_force", "gravity_potential", "load_covector"]


@dataclass(eq=False)
class Load:
    """A generalised force as a covector on the configuration (see the module table).

    Attributes
    ----------
    label : str
        What it is, for the build log and messages.
    target : casadi.SX, shape=(d, 1)
        An expression of the configuration.
    weight : casadi.SX, shape=(d, 1)
        The covector's weight (may depend on state, velocity, input and parameters).
    """

    label: str
    target: ca.SX
    weight: ca.SX


def force_at(label: str, point: ca.SX, force: ca.SX, attitude: ca.SX | None = None) -> Load:
    """A force at a point, world frame (or body frame when ``attitude`` is given)."""
    world = force if attitude is None else attitude @ force
    return Load(label, point, world)


def body_moment(label: str, attitude: ca.SX, moment: ca.SX) -> Load:
    """A moment on a rigid body, body frame."""
    return Load(label, ca.vec(attitude), ca.vec(0.5 * attitude @ hat(moment)))


def sphere_moment(label: str, q: ca.SX, moment: ca.SX) -> Load:
    """A world moment on an S^2 factor's direction (only its part normal to ``q`` acts).

    The weight ``moment x q / |q|^2`` gives the generalised force ``(I - q q^T/|q|^2) moment``
    for every ambient ``q != 0`` (equal to ``moment x q`` on the sphere).
    """
    return Load(label, q, ca.cross(moment, q) / ca.dot(q, q))


def angle_torque(label: str, p: ca.SX, torque: ca.SX) -> Load:
    """A torque about an S^1 factor's joint (virtual work ``torque * delta theta``).

    The weight ``torque J p / |p|^2`` (``J p = (-p2, p1)``) gives the generalised force
    ``torque`` on the rate for every ambient ``p != 0``.
    """
    perp = ca.vertcat(-p[1], p[0])
    return Load(label, p, torque * perp / ca.dot(p, p))


def coordinate_force(label: str, x: ca.SX, force: ca.SX) -> Load:
    """A force on the coordinates of an R^k factor."""
    return Load(label, x, force)


def gravity_potential(bodies: list, g: ca.SX, direction: ca.SX) -> ca.SX:
    """``V = -g sum_k m_k direction . p_com,k`` (``direction`` is where gravity pulls)."""
    V = ca.SX(0)
    for b in bodies:
        com = b.com
        d = direction[: com.shape[0]]
        V = V - g * b.mass * ca.dot(d, com)
    return V


def load_covector(loads: list[Load], c: ca.SX) -> ca.SX:
    """``sum_k (d y_k / dc)^T w_k`` with one reverse sweep, shape=(n_c, 1)."""
    if not loads:
        return ca.SX.zeros(c.shape[0], 1)
    targets = ca.vertcat(*[ld.target for ld in loads])
    weights = ca.vertcat(*[ld.weight for ld in loads])
    return ca.jtimes(targets, c, weights, True)
