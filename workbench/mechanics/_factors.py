"""Configuration factors and their kinematics: R^k, S^1, S^2 and SO(3) with their velocities.

Each factor has a configuration ``c`` (stored in ambient coordinates) and a velocity
``nu``, related by kinematics linear in the velocity, ``c-dot = K(c) nu``; the same map
generates the virtual displacements, ``delta c = K(c) eta``:

=========  ==========================  =====================  ============================
factor     configuration, velocity     kinematics K(c) nu      K(c)^T applied to a covector
=========  ==========================  =====================  ============================
R^k        ``x`` (k), ``v`` (k)        ``x-dot = v``           ``g``
S^1        ``p`` (2), ``rate`` (1)     ``p-dot = rate J p``    ``(J p) . g = p1 g2 - p2 g1``
S^2        ``q`` (3), ``omega`` (3)    ``q-dot = omega x q``   ``q x g``
SO(3)      ``R`` (3x3), ``Omega`` (3)  ``R-dot = R hat(Omega)``  ``sum_i g_i x r_i``
=========  ==========================  =====================  ============================

On S^1 (an angle, a revolute joint) ``p = (cos theta, sin theta)`` is a unit 2-vector and
``J p = (-p2, p1)`` its quarter turn; no angle is stored, so there is no wrapping and no
singular coordinate: where a distance between two angles is taken (an equilibrium, a
target, a comparison) it is taken between unit vectors, modulo 2 pi by construction.

where, on SO(3), ``r_i`` and ``g_i`` are the *rows* of ``R`` and of the covector ``G``
(``R^T = [r_1 r_2 r_3]``), i.e. ``K^T G = vee(R^T G - G^T R)``; ``Omega`` is the body
angular velocity. On S^2 the angular velocity is kept normal to ``q`` (``q . omega = 0``);
the Lagrangian sees it through ``omega_eff = (q.q) omega - (q.omega) q`` (equal to
``omega`` on TS^2), so that ``q . dL/domega = 0`` identically and the equation on S^2 is
simply the projection of ``d/dt dL/domega = q x dL/dq + (forces)`` to the tangent plane.

Storage (the workbench's conventions): R^k -> two factors ``x`` and ``v`` (Rn(k) each);
S^1 -> an S1 factor storing ``p`` and an Rn(1) factor for the rate;
S^2 -> one TS2 factor storing ``(q, omega)``; SO(3) -> an SO3 factor (9 numbers, column
by column) and an Rn(3) factor for ``Omega`` (as ``models/pendulum3d.full``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from workbench.mechanics._engine import S1, SO3, TS2, ModelError, Rn, hat, sphere_basis, vee

__all__ = ["Factor", "RnFactor", "S1Factor", "S2Factor", "SO3Factor"]


@dataclass(eq=False)
class Factor:
    """A configuration factor with its velocity; base of :class:`RnFactor` etc.

    Attributes
    ----------
    name : str
        The factor's name (and its configuration's storage name).
    config_sym : casadi.SX, shape=(n_c, 1)
        Symbols of the stored configuration.
    velocity_sym : casadi.SX, shape=(n_v, 1)
        Symbols of the velocity.
    """

    name: str
    config_sym: ca.SX = field(repr=False)
    velocity_sym: ca.SX = field(repr=False)

    kind = "factor"

    # storage -------------------------------------------------------------------------------
    def storage(self) -> list[tuple[str, object]]:
        """``(name, manifold factor)`` pairs in storage order."""
        raise NotImplementedError

    def state_symbols(self) -> list[ca.SX]:
        """The stored symbols in storage order (one column per storage factor)."""
        raise NotImplementedError

    def state_rate(self, acc: ca.SX) -> list[ca.SX]:
        """Time derivative of the stored state, given the velocity's rate ``acc``."""
        raise NotImplementedError

    # mechanics -----------------------------------------------------------------------------
    def effective_velocity(self) -> ca.SX:
        """The velocity the Lagrangian sees (``omega_eff`` on S^2, else ``nu``)."""
        return self.velocity_sym

    def kinematics(self, nu: ca.SX) -> ca.SX:
        """Return ``K(c) nu``, the rate of the stored configuration for velocity ``nu``."""
        raise NotImplementedError

    def kt(self, cov: ca.SX) -> ca.SX:
        """Return ``K(c)^T cov``, a covector on the configuration as a generalised force."""
        raise NotImplementedError

    def gyroscopic(self, momentum: ca.SX) -> ca.SX:
        """The term added to ``d/dt dL/dnu`` (``Omega x Pi`` on SO(3), else 0)."""
        return ca.SX.zeros(momentum.shape[0], 1)

    def project(self, rhs: ca.SX) -> ca.SX:
        """The rows of the equation kept (tangent projection on S^2)."""
        return rhs

    def constraint_block(self) -> ca.SX | None:
        """Added to the mass matrix block to pin the gauge direction (S^2), or None."""
        return None

    def velocity_basis(self, config: np.ndarray) -> np.ndarray:
        """Columns spanning the admissible velocities at a numeric configuration."""
        return np.eye(self.velocity_sym.shape[0])

    def rotation_generator(self, axis: ca.SX) -> ca.SX:
        """Velocity of the factor under a world rotation about ``axis`` (unit speed)."""
        raise ModelError(
            f"factor {self.name!r} ({self.kind}) has no rotation of its own; give its "
            "generator explicitly (momentum(..., generators={...}))"
        )

    @property
    def velocity_names(self) -> str:
        """Readable name of the velocity, for messages."""
        return self.name

    def describe(self) -> str:
        """The factor in words for descriptions and exported headers, e.g. ``"S^2 link"``."""
        return f"{self.kind} {self.name}"


@dataclass(eq=False)
class RnFactor(Factor):
    """R^k: position ``x`` and velocity ``v`` (stored as two Rn(k) factors).

    Attributes
    ----------
    x : casadi.SX, shape=(k, 1)
        Position symbols.
    v : casadi.SX, shape=(k, 1)
        Velocity symbols.
    velocity_name : str
        Storage name of the velocity factor.
    """

    velocity_name: str = "v"
    kind = "R^k"

    @property
    def x(self) -> ca.SX:  # noqa: D102
        return self.config_sym

    @property
    def v(self) -> ca.SX:  # noqa: D102
        return self.velocity_sym

    @property
    def dim(self) -> int:
        """K."""
        return int(self.config_sym.shape[0])

    def storage(self) -> list[tuple[str, object]]:  # noqa: D102
        return [(self.name, Rn(self.dim)), (self.velocity_name, Rn(self.dim))]

    def state_symbols(self) -> list[ca.SX]:  # noqa: D102
        return [self.config_sym, self.velocity_sym]

    def state_rate(self, acc: ca.SX) -> list[ca.SX]:  # noqa: D102
        return [self.velocity_sym, acc]

    def kinematics(self, nu: ca.SX) -> ca.SX:  # noqa: D102
        return nu

    def kt(self, cov: ca.SX) -> ca.SX:  # noqa: D102
        return cov

    @property
    def velocity_names(self) -> str:  # noqa: D102
        return f"{self.velocity_name} (velocity of {self.name})"

    def describe(self) -> str:  # noqa: D102
        return f"R^{self.dim} {self.name}"


@dataclass(eq=False)
class S1Factor(Factor):
    """S^1, an angle: the unit vector ``p = (cos theta, sin theta)`` and the rate theta-dot.

    Stored as an S1 factor ``p`` (named by the factor's name) and an Rn(1) factor for the
    rate (named by ``velocity=``); no angle is stored. Kinematics
    ``p-dot = theta-dot (-sin theta, cos theta)``; the angle's symmetry is the shift
    ``theta -> theta + c``, a rotation of ``p``, whose generator is the unit rate.

    Attributes
    ----------
    p : casadi.SX, shape=(2, 1)
        The unit vector ``(cos theta, sin theta)``.
    cos, sin : casadi.SX, shape=(1, 1)
        Its entries ``cos theta`` and ``sin theta``.
    perp : casadi.SX, shape=(2, 1)
        ``J p = (-sin theta, cos theta)``, the derivative of ``p`` by the angle.
    rate : casadi.SX, shape=(1, 1)
        The angle's rate theta-dot [rad/s] (stored under the name ``velocity_name``).
    p_dot : casadi.SX, shape=(2, 1)
        ``rate * perp``, the rate of ``p`` (for kinetic energies written directly).
    velocity_name : str
        Storage name of the rate.
    """

    velocity_name: str = "theta_dot"
    kind = "S^1"

    @property
    def p(self) -> ca.SX:  # noqa: D102
        return self.config_sym

    @property
    def cos(self) -> ca.SX:  # noqa: D102
        return self.config_sym[0]

    @property
    def sin(self) -> ca.SX:  # noqa: D102
        return self.config_sym[1]

    @property
    def perp(self) -> ca.SX:  # noqa: D102
        return ca.vertcat(-self.config_sym[1], self.config_sym[0])

    @property
    def rate(self) -> ca.SX:  # noqa: D102
        return self.velocity_sym

    @property
    def p_dot(self) -> ca.SX:  # noqa: D102
        return self.velocity_sym * self.perp

    def storage(self) -> list[tuple[str, object]]:  # noqa: D102
        return [(self.name, S1()), (self.velocity_name, Rn(1))]

    def state_symbols(self) -> list[ca.SX]:  # noqa: D102
        return [self.config_sym, self.velocity_sym]

    def state_rate(self, acc: ca.SX) -> list[ca.SX]:  # noqa: D102
        return [self.p_dot, acc]

    def kinematics(self, nu: ca.SX) -> ca.SX:  # noqa: D102
        return nu * self.perp

    def kt(self, cov: ca.SX) -> ca.SX:  # noqa: D102
        return ca.dot(self.perp, cov)

    def shift_generator(self) -> ca.SX:
        """The velocity of the factor under the shift ``theta -> theta + c`` at unit speed."""
        return ca.SX(1)

    def rotation_generator(self, axis: ca.SX) -> ca.SX:  # noqa: D102
        raise ModelError(
            f"factor {self.name!r} (S^1) is an angle whose plane the layer does not know; say "
            "how a rotation moves it with momentum(..., shift={angle: +1 or -1})")

    @property
    def velocity_names(self) -> str:  # noqa: D102
        return f"{self.velocity_name} (rate of the angle {self.name})"

    def describe(self) -> str:  # noqa: D102
        return f"S^1 {self.name} (cos, sin)"


@dataclass(eq=False)
class S2Factor(Factor):
    """S^2: unit vector ``q`` and angular velocity ``omega`` normal to it (one TS2 factor).

    Attributes
    ----------
    q : casadi.SX, shape=(3, 1)
        The direction.
    omega : casadi.SX, shape=(3, 1)
        Its angular velocity, ``q-dot = omega x q``, ``q . omega = 0``.
    """

    kind = "S^2"

    @property
    def q(self) -> ca.SX:  # noqa: D102
        return self.config_sym

    @property
    def omega(self) -> ca.SX:  # noqa: D102
        return self.velocity_sym

    def storage(self) -> list[tuple[str, object]]:  # noqa: D102
        return [(self.name, TS2())]

    def state_symbols(self) -> list[ca.SX]:  # noqa: D102
        return [ca.vertcat(self.config_sym, self.velocity_sym)]

    def state_rate(self, acc: ca.SX) -> list[ca.SX]:  # noqa: D102
        return [ca.vertcat(ca.cross(self.velocity_sym, self.config_sym), acc)]

    def effective_velocity(self) -> ca.SX:  # noqa: D102
        q, w = self.config_sym, self.velocity_sym
        return ca.dot(q, q) * w - ca.dot(q, w) * q

    def kinematics(self, nu: ca.SX) -> ca.SX:  # noqa: D102
        return ca.cross(nu, self.config_sym)

    def kt(self, cov: ca.SX) -> ca.SX:  # noqa: D102
        return ca.cross(self.config_sym, cov)

    def project(self, rhs: ca.SX) -> ca.SX:  # noqa: D102
        q = self.config_sym
        return ca.dot(q, q) * rhs - ca.dot(q, rhs) * q

    def constraint_block(self) -> ca.SX:  # noqa: D102
        q = self.config_sym
        return q @ q.T

    def velocity_basis(self, config: np.ndarray) -> np.ndarray:  # noqa: D102
        return sphere_basis(np.asarray(config, dtype=float).reshape(3))

    def rotation_generator(self, axis: ca.SX) -> ca.SX:  # noqa: D102
        return axis

    @property
    def velocity_names(self) -> str:  # noqa: D102
        return f"omega of {self.name}"


@dataclass(eq=False)
class SO3Factor(Factor):
    """SO(3): rotation ``R`` (body to world) and body angular velocity ``Omega``.

    Attributes
    ----------
    R : casadi.SX, shape=(3, 3)
        The attitude, ``R-dot = R hat(Omega)``.
    Omega : casadi.SX, shape=(3, 1)
        Body angular velocity (alias ``omega``).
    velocity_name : str
        Storage name of the angular velocity factor.
    """

    velocity_name: str = "omega"
    kind = "SO(3)"

    @property
    def R(self) -> ca.SX:  # noqa: D102, N802
        return ca.reshape(self.config_sym, 3, 3)

    @property
    def Omega(self) -> ca.SX:  # noqa: D102, N802
        return self.velocity_sym

    @property
    def omega(self) -> ca.SX:  # noqa: D102
        return self.velocity_sym

    def storage(self) -> list[tuple[str, object]]:  # noqa: D102
        return [(self.name, SO3()), (self.velocity_name, Rn(3))]

    def state_symbols(self) -> list[ca.SX]:  # noqa: D102
        return [self.config_sym, self.velocity_sym]

    def state_rate(self, acc: ca.SX) -> list[ca.SX]:  # noqa: D102
        return [ca.vec(self.R @ hat(self.velocity_sym)), acc]

    def kinematics(self, nu: ca.SX) -> ca.SX:  # noqa: D102
        return ca.vec(self.R @ hat(nu))

    def kt(self, cov: ca.SX) -> ca.SX:  # noqa: D102
        R, G = self.R, ca.reshape(cov, 3, 3)
        return vee(R.T @ G - G.T @ R)

    def gyroscopic(self, momentum: ca.SX) -> ca.SX:  # noqa: D102
        return ca.cross(self.velocity_sym, momentum)

    def rotation_generator(self, axis: ca.SX) -> ca.SX:  # noqa: D102
        return self.R.T @ axis

    @property
    def velocity_names(self) -> str:  # noqa: D102
        return f"{self.velocity_name} (body angular velocity of {self.name})"
