"""Mechanical systems from their Lagrangians, coordinate-free, by automatic differentiation.

Declare configuration factors (R^k, S^1, S^2, SO(3)), parameters, inputs, bodies (point masses,
rigid bodies), energies (kinetic written directly or carried by bodies, potentials,
gravity), loads (forces at points, moments, forces on coordinates, Rayleigh dissipation)
and symmetries; :meth:`System.model` derives the Lagrange-d'Alembert equations on each
factor and returns an ordinary :class:`workbench.Model` (energy and momenta as invariants,
parameters as graph inputs), accepted by every analysis of the workbench.

Example, the n-link chain on a cart (paper 003) in a few lines::

    import casadi as ca
    from workbench import mechanics

    s = mechanics.System("chain")
    cart = s.rn("x", 2, velocity="v")
    m, g = s.parameter("m", 0.5), s.parameter("g", 9.81)
    ms, ls = s.parameter("masses", [0.1, 0.1]), s.parameter("lengths", [0.1, 0.2])
    p = ca.vertcat(cart.x, 0)
    s.point_mass(m, p)
    for i in range(2):
        p = p + ls[i] * s.s2(f"link{i + 1}").q
        s.point_mass(ms[i], p)
    s.gravity(g)
    s.force(cart, s.input(2, "horizontal force on the cart [N]"))
    model = s.model()
"""

from workbench.mechanics._bodies import PointMass, RigidBody
from workbench.mechanics._checks import inertia
from workbench.mechanics._factors import Factor, RnFactor, S1Factor, S2Factor, SO3Factor
from workbench.mechanics._model import check_kinetic_energy
from workbench.mechanics._reduction import (
    BreakingInputs,
    Reconstructed,
    Reduction,
    ReductionKind,
    reduce,
)
from workbench.mechanics._system import E3, System

__all__ = [
    "System",
    "Factor",
    "RnFactor",
    "S1Factor",
    "S2Factor",
    "SO3Factor",
    "PointMass",
    "RigidBody",
    "inertia",
    "check_kinetic_energy",
    "E3",
    "reduce",
    "Reduction",
    "ReductionKind",
    "BreakingInputs",
    "Reconstructed",
]
