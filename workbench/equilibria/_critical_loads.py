"""The forces at rest of a mechanics model beyond its potential: when equilibria are critical.

A model made by :mod:`workbench.mechanics` accelerates at rest (velocities 0) with zero input
by ``A(c)^-1 b(c, 0, 0)``, ``A`` positive definite and ``b`` its generalised force
(:mod:`workbench.mechanics._equations`). Its equilibria at rest are the zeros of
``b(c, 0, 0)``, and they are the critical points of a potential ``V`` only when

    b(c, 0, 0) = -K(c)^T dV/dc       for every configuration c,                    (*)

``K(c)^T`` taking an ambient covector to a generalised force factor by factor
(:func:`generalised_force`). Besides ``-K^T dV``, ``b`` at rest holds

* the loads (``System.force``, ``force_at``, ``moment``): a covector ``(dy/dc)^T w`` each, its
  weight ``w`` evaluated with velocities and inputs 0 (``w0``);
* the dissipation, ``-dD/dnu`` at ``nu = 0`` (zero for a Rayleigh function, least at rest);
* the inertial terms at rest: ``K^T dT0/dc`` for the part ``T0`` of the kinetic energy of
  degree 0 in the velocities (a rotating frame); the rest vanishes at rest.

**The structural test** (exact, made once on the derivation's casadi graph): each of these
with ``nu = 0`` and ``u = 0`` substituted is *structurally* zero (``casadi.SX.is_zero``:
inputs, velocity-proportional loads, a Rayleigh dissipation, a kinetic energy quadratic in the
velocities), or else

* a load whose ``w0`` does not depend on the configuration (a constant world force at a point,
  a constant force on an R^k factor, parameters allowed) is *exactly* the gradient of its
  work potential: ``(dy/dc)^T w0 = d/dc (w0 . y(c))``. It is added to the potential,
  ``V_eff = V - w0 . y(c)``, whose critical points are then the equilibria;
* anything else refuses the search (:func:`refuse`). A configuration-dependent weight can be
  a gradient (a torque ``-K sin 2 theta`` is ``-d/dtheta (K sin^2 theta)``; a spring written
  as a force) but nothing here integrates a covector: such a load is to be declared by its
  energy with ``System.potential``. Constant torques on an angle, constant moments on a link
  or a body are not gradients at all (their work around a closed loop is not zero), and
  their equilibria are no function's critical points.

**The sampled check** (a second line, independent of the above): at every configuration the
search starts from, ``|b(c, 0, 0) + K^T dV_eff/dc|`` must be within the search's Newton
tolerance (:meth:`RestForces.check`), evaluated from the derivation's ``b`` itself, so that a
force at rest this module does not know of refuses the search too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._evaluator import DenseEvaluator
from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.types import Vector
from workbench.equilibria._critical_function import ConfigurationFunction, generalised_force

__all__ = ["RestForce", "RestForces", "rest_forces"]

_HOOKS = ("name", "ing", "c", "nu", "b", "b_inertial", "T", "D", "V",
          "configuration_manifold", "potential_function", "rest_state")


@dataclass(frozen=True)
class RestForce:
    """A force at rest (velocities and inputs 0) that the potential does not contain.

    Attributes
    ----------
    source : str
        What declares it (``"torque on th (load 1 of 1)"``, ``"dissipation"``,
        ``"kinetic energy"``).
    expression : str
        Its generalised force at rest, as casadi prints it (shortened).
    """

    source: str
    expression: str

    def describe(self) -> str:
        """``source: expression``."""
        return f"{self.source}: {self.expression}"


def _short(expr: ca.SX, limit: int = 160) -> str:
    text = " ".join(str(expr).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


class RestForces:
    """The forces at rest of a mechanics model, sorted against its potential (module docs).

    Parameters
    ----------
    model : Model
        Made by :mod:`workbench.mechanics` (it carries its derivation as ``model.mechanics``).

    Attributes
    ----------
    offending : list of RestForce
        Forces at rest that are neither structurally zero nor folded into the potential:
        when not empty, the potential's critical points are not the equilibria.
    folded : list of str
        The loads of configuration-independent weight whose work potential was added.
    function : ConfigurationFunction
        ``V_eff``: the potential plus the work potentials of ``folded``, on the configuration;
        its ``state(c)`` is the model state at rest.
    notes : list of str
        What the result's message should say: a kinetic energy with terms linear in the
        velocities makes the index a count of the Hessian only (gyroscopic forces can
        stabilise an even index), not the linearisation's unstable count.

    Raises
    ------
    ModelError
        When the model carries no mechanics derivation, or its potential depends on the
        velocities.
    """

    def __init__(self, model: Model) -> None:
        if not isinstance(model, Model):
            raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
        der = getattr(model, "mechanics", None)
        if der is None or not all(hasattr(der, h) for h in _HOOKS):
            raise ModelError(
                f"model {model.name!r} was not made by workbench.mechanics (it carries no "
                "derivation of its forces at rest); find its equilibria with "
                "find_equilibrium or enumerate_equilibria")
        self.model_name = model.name
        der.potential_function()  # refuses a potential that depends on the velocities
        ing = der.ing
        c, p = der.c, ing.p
        self.manifold = der.configuration_manifold()

        def at_rest(e: ca.SX) -> ca.SX:
            return ca.substitute([e], [der.nu, ing.u],
                                 [ca.SX.zeros(der.nu.shape), ca.SX.zeros(ing.u.shape)])[0]

        self.offending: list[RestForce] = []
        self.folded: list[str] = []
        work = ca.SX(0)
        n = len(ing.loads)
        for k, ld in enumerate(ing.loads):
            w0 = at_rest(ld.weight)
            if w0.is_zero():
                continue
            force = generalised_force(self.manifold, c, ca.jtimes(ld.target, c, w0, True))
            if force.is_zero():  # acts at a point that does not move
                continue
            label = f"{ld.label} (load {k + 1} of {n})"
            if not ca.depends_on(w0, c):
                work = work + ca.dot(w0, ld.target)
                self.folded.append(label)
            else:
                self.offending.append(RestForce(label, _short(force)))
        drag = at_rest(-ca.gradient(der.D, der.nu))
        if not drag.is_zero():
            self.offending.append(RestForce("dissipation (-dD/dnu at rest)", _short(drag)))
        inertial = at_rest(der.b_inertial)
        if not inertial.is_zero():
            self.offending.append(RestForce(
                "kinetic energy (its terms of degree 0 in the velocities, T at rest = "
                f"{_short(at_rest(der.T), 80)}: a rotating frame? its equilibria at rest are "
                "the critical points of V - T0, critical_points(ConfigurationFunction."
                "from_state(model, V - T0)))", _short(inertial)))
        self.notes: list[str] = []
        if not getattr(der, "quadratic", True):
            self.notes.append(
                "the kinetic energy has terms linear in the velocities: their gyroscopic forces "
                "act on the linearisation, so an index is the potential's (an odd one is "
                "unstable) but an even one may be gyroscopically stable")
        V = der.V - work
        name = f"potential of {model.name}"
        if self.folded:
            name += f" with the work potential of {', '.join(self.folded)}"
        rest = DenseEvaluator(der.rest_state())
        self.function = ConfigurationFunction(
            self.manifold, ca.Function(f"{der.name}_effective_potential", [c, p], [V]),
            p=model.p, name=name, state=lambda cv: rest(np.asarray(cv, dtype=float))[0])
        # (*)'s residual from the derivation's own b: zero wherever nothing is offending
        residual = at_rest(der.b) + generalised_force(self.manifold, c, ca.gradient(V, c))
        self._residual = DenseEvaluator(ca.Function(f"{der.name}_rest_residual", [c, p],
                                                    [ca.densify(residual)]))
        self._p = np.asarray(model.p, dtype=float).ravel()

    def refuse(self) -> None:
        """Raise unless the potential's critical points are the equilibria at rest.

        Raises
        ------
        ModelError
            Naming every force at rest outside the potential.
        """
        if not self.offending:
            return
        what = "; ".join(f.describe() for f in self.offending)
        raise ModelError(
            f"find_all_equilibria cannot search model {self.model_name!r}: it has forces at "
            f"rest (velocities and inputs 0) that its potential does not contain: {what}. Its "
            "equilibria are the zeros of the whole force at rest, not the critical points of "
            "the potential, which would miss some and misclassify others. A force that derives "
            "from an energy U (a spring written as a force, a torque -dU/dtheta) is to be "
            "declared as System.potential(U); otherwise find the equilibria with "
            "find_equilibrium (Newton from a guess) or enumerate_equilibria (from many "
            "guesses). Only loads whose value at rest does not depend on the configuration "
            "(a constant force at a point) are taken into the potential, as their work.")

    def residual(self, c: Any) -> Vector:
        """``b(c, 0, 0) + K^T dV_eff/dc``: the force at rest outside ``V_eff``, per factor.

        Parameters
        ----------
        c : array-like, shape=(config_ambient_dim,)
            A configuration (on the manifold).

        Returns
        -------
        ndarray, shape=(n_velocities,)
        """
        return self._residual(np.asarray(c, dtype=float).ravel(), self._p)[0]

    def check(self, c: Vector, where: str, tol: float) -> None:
        """Refuse the search when the force at rest outside ``V_eff`` exceeds ``tol`` at ``c``.

        Parameters
        ----------
        c : ndarray, shape=(config_ambient_dim,)
            A configuration the search starts from.
        where : str
            Which start it is, for the message.
        tol : float
            Absolute: the search's Newton tolerance on the generalised force.

        Raises
        ------
        ModelError
            Naming the configuration and the size of the force.
        """
        r = self.residual(c)
        big = float(np.max(np.abs(r), initial=0.0))
        if not big <= tol:
            raise ModelError(
                f"find_all_equilibria cannot search model {self.model_name!r}: at {where}, "
                f"configuration {np.round(c, 6).tolist()!r:.200}, the force at rest (velocities "
                f"and inputs 0) differs from the potential's by {big:.3g} > {tol:.3g} (the "
                "search's Newton tolerance), so the potential's critical points are not its "
                "equilibria; find them with find_equilibrium or enumerate_equilibria")


def rest_forces(model: Model) -> RestForces:
    """The forces at rest of a mechanics model against its potential (:class:`RestForces`)."""
    return RestForces(model)
