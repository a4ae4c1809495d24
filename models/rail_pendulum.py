"""A spherical pendulum hanging from a slider on a spring-loaded rail, on R^1 x TS^2.

A slider of mass ``M`` runs without friction along a horizontal rail, the world's ``e1``
axis through the origin; a linear spring of stiffness ``k`` pulls it back to the origin.
A bob, a point mass ``m``, hangs from the slider on a massless rod of length ``l`` and
swings freely in 3D: the rod's direction is a unit vector ``q`` on S^2 with angular
velocity ``omega`` (``q-dot = omega x q``, ``q . omega = 0``). The input is one force on
the slider along the rail [N] (virtual work ``u delta x``); its bound is the problem's
to choose. Nothing is hand-derived: :mod:`workbench.mechanics` derives the equations
from the Lagrangian

    L = (M + m) v^2 / 2 + m l v e1 . (omega x q) + m l^2 |omega|^2 / 2
        - k x^2 / 2 + m g l e3 . q.

Conventions. ``e3`` points down, along gravity (the workbench's convention): ``q = e3``
hangs (stable), ``q = -e3`` is inverted. Units SI.

Controllability. The force acts along ``e1`` only. The swing in the ``e1``-``e3`` plane
(``omega`` along ``e2``) couples to the spring-loaded slider; the swing across the rail
(``q`` moving along ``e2``, ``omega`` along ``e1``) does not, to first order: at hanging
(and at inverted) the linearisation has an uncontrollable pair ``lambda^2 = -g/l``
(``+g/l`` inverted), the swing across the rail with ``omega = sqrt(g/l)``, independent of
``M`` and ``k``. The reflection ``e2 -> -e2`` is a symmetry of the system with the
input, so the plane of the rail, ``q . e2 = 0`` and ``omega`` along ``e2``, is invariant:
a swing that starts in it stays in it. Inverted, the swing across the rail is unstable
and no linear feedback of the force stabilises it.

Invariants: ``energy`` (conserved when ``u = 0``). The spring breaks the translation and
gravity the rotation about the rail: there is no momentum.

State factors, in storage order: ``x`` (R^1, the slider's position along ``e1`` [m]),
``v`` (R^1, its velocity [m/s]), ``q`` (TS2, ``(q, omega)``: the rod's direction and its
angular velocity [rad/s], world frame).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from workbench import Model, mechanics
from workbench.core import positive
from workbench.core.errors import ModelError

__all__ = ["rail_pendulum", "hanging", "inverted", "upright", "DEFAULTS"]

DEFAULTS = {"M": 1.0, "m": 0.5, "l": 0.5, "k": 5.0, "g": 9.81}
"""Default parameters: slider 1 kg, bob 0.5 kg, rod 0.5 m, spring 5 N/m, g 9.81 m/s^2."""


def rail_pendulum(*, M: float = 1.0, m: float = 0.5, l: float = 0.5,  # noqa: N803, E741
                  k: float = 5.0, g: float = 9.81) -> Model:
    """Build the spherical pendulum on a spring-loaded rail from its Lagrangian.

    Parameters
    ----------
    M : float
        Slider mass [kg], positive.
    m : float
        Bob mass [kg], positive (a point mass).
    l : float
        Rod length, slider to bob [m], positive (the rod is massless).
    k : float
        Spring stiffness [N/m], positive; the spring is relaxed with the slider at the
        origin.
    g : float
        Gravitational acceleration [m/s^2], positive, along ``e3`` (down).

    Returns
    -------
    Model
        Factors ``x``, ``v`` (R^1) and ``q`` (TS2); input: the force on the slider along
        the rail [N]; invariant ``energy`` (conserved when ``u = 0``). All five values
        are parameters of the graph (sweeps need no rebuild).
    """
    s = mechanics.System("rail_pendulum")
    slider, rod = s.rn("x", 1, velocity="v"), s.s2("q")
    M_ = s.parameter("M", M, "slider mass [kg]", check=positive)  # noqa: N806
    m_ = s.parameter("m", m, "bob mass [kg]", check=positive)
    l_ = s.parameter("l", l, "rod length [m]", check=positive)
    k_ = s.parameter("k", k, "spring stiffness [N/m]", check=positive)
    g_ = s.parameter("g", g, "gravitational acceleration [m/s^2]", check=positive)
    pivot = ca.vertcat(slider.x, 0, 0)  # on the rail, the e1 axis
    s.point_mass(M_, pivot, name="slider")
    s.point_mass(m_, pivot + l_ * rod.q, name="bob")
    s.potential(0.5 * k_ * slider.x**2)
    s.gravity(g_)
    s.force(slider, s.input(1, "force on the slider along the rail [N]"))
    return s.model()


def _at(model: Model, q: np.ndarray) -> np.ndarray:
    if not isinstance(model, Model) or set(model.manifold.names) != {"x", "v", "q"} or \
            model.manifold.ambient_dim != 8:
        raise ModelError(f"model must be a rail pendulum from "
                         f"models.rail_pendulum.rail_pendulum(); got {model!r}")
    return model.state(x=[0.0], v=[0.0], q=np.r_[q, 0.0, 0.0, 0.0])


def hanging(model: Model) -> np.ndarray:
    """The bob hanging at rest below the slider at the origin (``q = e3``), stable."""
    return _at(model, np.array([0.0, 0.0, 1.0]))


def inverted(model: Model) -> np.ndarray:
    """The bob inverted at rest above the slider at the origin (``q = -e3``)."""
    return _at(model, np.array([0.0, 0.0, -1.0]))


def upright(model: Model) -> np.ndarray:
    """The same state as :func:`inverted` (the name the other swing-up models use)."""
    return inverted(model)
