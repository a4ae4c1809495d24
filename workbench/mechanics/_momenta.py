"""Declared and detected symmetries of a system, and their Noether momenta.

The part of :class:`~workbench.mechanics.System` that declares symmetries
(:meth:`~Momenta.momentum`) and finds them (:meth:`~Momenta.detect_momenta`, see
:mod:`._symmetry`). A symmetry is stored as its generator: the velocity ``eta_f`` of each
factor it moves, keyed by ``id(factor)``; its momentum is ``J = sum_f Pi_f . eta_f``.

=============  ===============================  =================================
factor         the group                        generator ``eta``
=============  ===============================  =================================
R^k            translation along ``d``           ``d``
S^1            shift ``theta -> theta + s c``    ``s`` (a rotation of ``p``)
S^2            world rotation about ``a``        ``a``
SO(3)          world rotation about ``a``        ``R^T a`` (body frame)
=============  ===============================  =================================
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._checks import as_expr, identifier
from workbench.mechanics._engine import RESERVED_NAMES, ModelError
from workbench.mechanics._equations import Derivation
from workbench.mechanics._factors import RnFactor, S1Factor, S2Factor, SO3Factor
from workbench.mechanics._model import _ingredients
from workbench.mechanics._symbols import CONFIG, PARAMETER
from workbench.mechanics._symmetry import check_options, detect

__all__ = ["Momenta"]


class Momenta:
    """Declaring and detecting symmetries: a part of :class:`~workbench.mechanics.System`.

    Uses the system's ``factors``, ``factor``, ``symbols``, ``momenta``, ``parameters``,
    ``values`` and ``name``.
    """

    name: str
    factors: list
    momenta: dict
    parameters: list
    values: dict
    symbols: Any
    factor: Callable[[Any], Any]

    def _shifts(self, shift: Any) -> dict[int, ca.SX]:
        """The generators of ``shift=``: S^1 factors, each at unit rate or a given rate."""
        items = (shift.items() if isinstance(shift, Mapping)
                 else [(ref, 1.0) for ref in shift] if isinstance(shift, Sequence)
                 and not isinstance(shift, str) else None)
        if items is None:
            raise ModelError(f"shift must be a sequence of S^1 factors or a mapping of S^1 "
                             f"factor to rate; got {shift!r}")
        gens = {}
        for ref, rate in items:
            f = self.factor(ref)
            if not isinstance(f, S1Factor):
                raise ModelError(f"shift acts on S^1 factors (angles); {f.name!r} is {f.kind}")
            gen = as_expr(rate, f"shift[{f.name!r}]", (1, 1))
            self.symbols.require(gen, f"shift[{f.name!r}]", (PARAMETER,))
            gens[id(f)] = gen * f.shift_generator()
        return gens

    def momentum(self, name: str, *, translate: Mapping[Any, Any] | None = None,
                 rotate: Any = None, shift: Sequence[Any] | Mapping[Any, Any] | None = None,
                 generators: Mapping[Any, Any] | None = None) -> None:
        """Declare a symmetry; its Noether momentum ``sum_f Pi_f . eta_f`` is an invariant.

        Parameters
        ----------
        name : str
            Name of the invariant (not ``"energy"``).
        translate : mapping of RnFactor to array-like, optional
            Translations of R^k factors (their ``eta`` is the given direction).
        rotate : array-like, shape=(3,), optional
            A world rotation axis: every S^2 factor turns (``eta = axis``) and every SO(3)
            factor turns (``eta = R^T axis``). S^1 factors do not know their plane: say
            with ``shift=`` which angles the rotation shifts.
        shift : sequence of S1Factor, or mapping of S1Factor to float, optional
            Angles the symmetry shifts, ``theta -> theta + s c`` (a rotation of ``p``):
            each at unit rate ``s = 1``, or at the given rate (e.g. ``{arm: 1.0}``,
            ``{a: 1.0, b: -1.0}``). Its momentum is an angular momentum about the joint.
        generators : mapping of factor to casadi.SX, optional
            Explicit velocities of factors under the symmetry (e.g. how a cart's R^2
            coordinates turn under a rotation about the vertical); override the above.
        """
        identifier(name, "momentum name")
        if name in RESERVED_NAMES:
            raise ModelError(f"momentum name must not be one of {sorted(RESERVED_NAMES)} "
                             f"(the model's own functions and their inputs); got {name!r}")
        if name == "energy" or name in self.momenta:
            raise ModelError(f"invariant name {name!r} is already used")
        gens: dict[int, ca.SX] = {}
        if rotate is not None:
            axis = as_expr(rotate, "rotate", (3, 1))
            for f in self.factors:
                if isinstance(f, (S2Factor, SO3Factor)):
                    gens[id(f)] = f.rotation_generator(axis)
        for ref, d in (translate or {}).items():
            f = self.factor(ref)
            if not isinstance(f, RnFactor):
                raise ModelError(f"translate acts on R^k factors; {f.name!r} is {f.kind}")
            gens[id(f)] = as_expr(d, f"translate[{f.name!r}]", (f.dim, 1))
        if shift is not None:
            gens.update(self._shifts(shift))
        for ref, g in (generators or {}).items():
            f = self.factor(ref)
            gen = as_expr(g, f"generators[{f.name!r}]", (f.velocity_sym.shape[0], 1))
            self.symbols.require(gen, f"generators[{f.name!r}]", (CONFIG, PARAMETER))
            gens[id(f)] = gen
        if not gens:
            raise ModelError(f"momentum {name!r} needs translate=, rotate=, shift= or "
                             "generators=")
        if all(ca.SX(g).is_zero() for g in gens.values()):
            raise ModelError(f"momentum {name!r}: its generator is zero (a zero axis, "
                             "translation or rate); it would declare the constant 0")
        self.momenta[name] = gens

    def detect_momenta(self, *, rtol: float = 1e-9, n_states: int = 3,
                       seed: int = 0) -> dict[str, str]:
        """Find the system's rotation, translation and angle symmetries; declare their momenta.

        Tries translations of R^k factors along their axes, shifts of S^1 angles
        (``theta -> theta + c``: each angle alone, then all together), and world rotations
        about ``e1``, ``e2``, ``e3`` (S^2 and SO(3) factors turn; each R^3 factor, and an
        R^2 factor about ``e3``, turns or stays; each angle shifts at rate +1 or -1 or
        stays); a candidate is declared only when its Noether momentum is verified conserved
        (``|dJ/dt| <= rtol |grad J| |f|`` at ``n_states`` seeded random states, zero input)
        and independent of the momenta declared so far. An angle's momentum is named
        ``angular_momentum_<angle>``. See :mod:`workbench.mechanics._symmetry`. The test
        runs at the current parameter values: a symmetry that holds only there (a spring
        constant that is zero now) is declared, so detect again after changing such a value.

        Parameters
        ----------
        rtol : float
            Relative tolerance of the conservation test, in (0, 1).
        n_states : int
            Random states every candidate must pass, >= 1.
        seed : int
            Seed of those states.

        Returns
        -------
        dict of str to str
            The momenta declared by this call: name -> what the symmetry does.
        """
        check_options(rtol, n_states, seed)
        if not self.factors:
            raise ModelError(f"system {self.name!r} has no factors; add rn(...), s1(...), "
                             "s2(...) or so3(...)")
        der = Derivation(_ingredients(self), self.name)
        p = (np.concatenate([np.asarray(self.values[q.name], dtype=float).reshape(-1)
                             for q in self.parameters]) if self.parameters else np.zeros(0))
        found = detect(self, der, p, rtol=float(rtol), n_states=n_states, seed=seed)
        for c in found:
            self.momenta[c.name] = c.generators
        return {c.name: c.description for c in found}
