"""Bodies: point masses and rigid bodies, and the kinetic energy they carry.

A body's velocity is never written by the user: positions and attitudes are expressions
of the configuration, and the layer differentiates them along the factors' kinematics
(``c-dot = K(c) nu``) with one forward-mode directional derivative (``casadi.jtimes``) for
all bodies at once, so a chain costs O(n) nodes, not O(n^2).

* point mass ``m`` at ``p(c)``: ``T = m |p-dot|^2 / 2``;
* rigid body with attitude ``R`` (body to world), mass ``m``, centre of mass at
  ``p0(c) + R rho`` and inertia ``J`` about the centre of mass (or ``J_O`` about ``p0``,
  converted by the parallel-axis theorem ``J = J_O - m (|rho|^2 I - rho rho^T)``):
  ``T = m |p_com-dot|^2 / 2 + Omega^T J Omega / 2`` with the body angular velocity
  ``Omega`` (the factor's own when ``R`` is an SO(3) factor, else ``vee(R^T R-dot)``).
  When ``R`` is an SO(3) factor (``R-dot = R hat(Omega)``) and the reference point is
  fixed, the same energy is written about it, ``T = Omega^T J_O Omega / 2``: the mass
  matrix is then ``J_O`` as given (or ``J + m (|rho|^2 I - rho rho^T)``), not
  ``J_O - m (...)`` plus ``m |R (Omega x rho)|^2`` (which cancels digits and sees the
  rounding of ``R^T R``: a relative error ``eps |J| / lambda_min(J)`` in the
  accelerations, 1e-8 at cond J = 1e8). With a moving reference point the
  centre-of-mass form is kept: it is positive definite for every ambient ``R`` (a sum of
  squares plus ``J``), which ambient optimisers need; the form about a moving point,
  ``m p0-dot . R (Omega x rho) + Omega^T J_O Omega / 2`` added to ``m |p0-dot|^2 / 2``,
  is not (its rotational block ``J_O - m rho-hat^T R^T R rho-hat`` turns indefinite
  off SO(3)).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from workbench.mechanics._engine import vee
from workbench.mechanics._factors import SO3Factor

__all__ = ["PointMass", "RigidBody", "kinetic_energy_of_bodies", "written_about_origin"]


@dataclass(eq=False)
class PointMass:
    """A point mass.

    Attributes
    ----------
    name : str
        Its name.
    mass : casadi.SX, shape=(1, 1)
        Mass, an expression of parameters.
    position : casadi.SX, shape=(d, 1)
        World position, an expression of the configuration (d = 1, 2 or 3).
    """

    name: str
    mass: ca.SX
    position: ca.SX

    @property
    def com(self) -> ca.SX:
        """Position of the centre of mass."""
        return self.position


@dataclass(eq=False)
class RigidBody:
    """A rigid body.

    Attributes
    ----------
    name : str
        Its name.
    mass : casadi.SX, shape=(1, 1)
        Mass.
    inertia : casadi.SX, shape=(3, 3)
        Inertia about the centre of mass, body frame.
    attitude : casadi.SX, shape=(3, 3)
        Rotation body -> world, an expression of the configuration.
    factor : SO3Factor or None
        The SO(3) factor when the attitude is one (its ``Omega`` is used directly).
    origin : casadi.SX, shape=(3, 1)
        World position of the body's reference point.
    com : casadi.SX, shape=(3, 1)
        Centre of mass relative to the reference point, body frame.
    inertia_origin : casadi.SX, shape=(3, 3), optional
        Inertia about the reference point when it was given there (kept as given); else
        found from ``inertia`` by the parallel-axis theorem.
    """

    name: str
    mass: ca.SX
    inertia: ca.SX
    attitude: ca.SX
    factor: SO3Factor | None
    origin: ca.SX
    com_offset: ca.SX
    inertia_origin: ca.SX | None = None

    def origin_inertia(self) -> ca.SX:
        """Inertia about the reference point, body frame."""
        if self.inertia_origin is not None:
            return self.inertia_origin
        rho = self.com_offset
        return self.inertia + self.mass * (ca.dot(rho, rho) * ca.SX.eye(3) - rho @ rho.T)

    @property
    def com(self) -> ca.SX:
        """World position of the centre of mass, ``origin + R com_offset``."""
        return self.origin + self.attitude @ self.com_offset

    def angular_velocity(self, c: ca.SX, cdot: ca.SX, nu_eff: dict[int, ca.SX]) -> ca.SX:
        """Body angular velocity along the configuration rate ``cdot``."""
        if self.factor is not None:
            return nu_eff[id(self.factor)]
        Rdot = ca.reshape(ca.jtimes(ca.vec(self.attitude), c, cdot), 3, 3)
        return vee(self.attitude.T @ Rdot)


def written_about_origin(b: PointMass | RigidBody, c: ca.SX) -> bool:
    """Whether the kinetic energy of ``b`` is written about its reference point.

    So it is for a rigid body on an SO(3) factor with a fixed reference point (its
    rotational energy is then ``Omega^T J_O Omega / 2`` and the inertia about the centre of
    mass does not enter); every other body is written about its centre of mass.

    Parameters
    ----------
    b : PointMass or RigidBody
        The body.
    c : casadi.SX
        All configuration symbols (or the whole state).

    Returns
    -------
    bool
    """
    # a fixed reference point only: with a moving one (a cart, a quadrotor) the form
    # about the reference point has the rotational block J_O - m rho-hat^T R^T R rho-hat
    # off SO(3), indefinite once R is stretched by |J_c| / (m |rho|^2) (20% for the
    # cart pendulum), where the ambient iterates of an optimiser go: its swing-up then
    # stalled at Ipopt's iteration limit (31 iterations with the centre-of-mass form)
    return (isinstance(b, RigidBody) and b.factor is not None
            and not ca.depends_on(b.origin, c))


def kinetic_energy_of_bodies(
    bodies: list, c: ca.SX, cdot: ca.SX, nu_eff: dict[int, ca.SX]
) -> ca.SX:
    """Total kinetic energy of point masses and rigid bodies.

    Parameters
    ----------
    bodies : list of PointMass or RigidBody
        The bodies.
    c : casadi.SX, shape=(n_c, 1)
        All configuration symbols.
    cdot : casadi.SX, shape=(n_c, 1)
        The configuration's rate ``K(c) nu_eff``.
    nu_eff : dict
        Effective velocity of each factor by ``id(factor)``.

    Returns
    -------
    casadi.SX, shape=(1, 1)
    """
    if not bodies:
        return ca.SX(0)

    def about_origin(b: PointMass | RigidBody) -> bool:
        return written_about_origin(b, c)

    points = ca.vertcat(*[b.origin if about_origin(b) else b.com for b in bodies])
    vel = ca.jtimes(points, c, cdot)
    T = ca.SX(0)
    k = 0
    for b in bodies:
        d = (b.origin if about_origin(b) else b.com).shape[0]
        vb = vel[k : k + d]
        k += d
        T = T + 0.5 * b.mass * ca.dot(vb, vb)
        if about_origin(b):
            W = b.angular_velocity(c, cdot, nu_eff)
            T = (T + b.mass * ca.dot(vb, b.attitude @ ca.cross(W, b.com_offset))
                 + 0.5 * ca.dot(W, b.origin_inertia() @ W))
        elif isinstance(b, RigidBody):
            W = b.angular_velocity(c, cdot, nu_eff)
            T = T + 0.5 * ca.dot(W, b.inertia @ W)
    return T
