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

import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._checks import as_expr, identifier
from workbench.mechanics._engine import RESERVED_NAMES, ModelError, ProductManifold
from workbench.mechanics._equations import Derivation
from workbench.mechanics._factors import RnFactor, S1Factor, S2Factor, SO3Factor
from workbench.mechanics._model import _ingredients
from workbench.mechanics._state_check import check_kinetic_energy
from workbench.mechanics._symbols import CONFIG, PARAMETER
from workbench.mechanics._symmetry import check_options, detect

__all__ = ["Momenta", "CONFIRM_RTOL"]

CONFIRM_RTOL = 1e-6
"""Default tolerance of the simulation that confirms a detected momentum: ``max |J(t) -
J(0)| <= CONFIRM_RTOL * integral |grad J| |f| dt`` (CVODES at rtol 1e-10 leaves ~1e-9)."""

CONFIRM_SAMPLES = 40
"""Output times of each confirming simulation."""


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

    def detect_momenta(self, *, rtol: float = 1e-9, n_states: int = 8, seed: int = 0,
                       scales: tuple[float, float] | None = None, confirm: bool = True,
                       confirm_rtol: float = CONFIRM_RTOL,
                       accept_sampled: bool = False) -> dict[str, str]:
        """Find the system's rotation, translation and angle symmetries; declare their momenta.

        Tries translations of R^k factors along their axes, shifts of S^1 angles
        (``theta -> theta + c``: each angle alone, then all together), and world rotations
        about ``e1``, ``e2``, ``e3`` (S^2 and SO(3) factors turn; each R^3 factor, and an
        R^2 factor about ``e3``, turns or stays; each angle shifts at rate +1 or -1 or
        stays). A candidate is declared only when

        * its Noether momentum is conserved pointwise, ``|dJ/dt| <= rtol |grad J| |f|``,
          at ``n_states`` seeded states (zero input) whose positions and velocities are
          spread log-uniformly over ``scales``: a symmetry broken only far out (a wall at
          ``x > 5``) or only very close is seen;
        * its conservation is *established*: ``dJ/dt`` at zero input, written without the
          equations' solve (:func:`~workbench.mechanics._symmetry.momentum_rate`), is zero
          in the graph (nothing the group moves enters the Lagrangian or the loads: a
          free cart's translation, a free angle) or vanishes identically on the state
          manifold, tested by evaluating the graph exactly (modulo two primes) at random
          points of the manifold (:mod:`workbench.mechanics._exact`: the Furuta arm's
          angle, rotations about gravity, translations of coupled masses). Samples can
          miss a narrow bump of the potential between them; this cannot. A candidate
          that passes the samples only (its graph holds ``exp``, ``fmax``... whose
          identity the exact test cannot decide) is declared only with
          ``accept_sampled=True``, then with its evidence in its description and a
          UserWarning;
        * it is independent of the momenta declared so far; and
        * (``confirm``, sampled candidates only) ``J`` stays constant along short
          simulations (CVODES, rtol 1e-10) from the three sample states of smallest,
          middle and largest scale: ``max |J(t) - J(0)| <= confirm_rtol * integral
          |grad J| |f| dt`` (the change the flow could have made); a candidate that
          drifts is not declared.

        An angle's momentum is named ``angular_momentum_<angle>``. See
        :mod:`workbench.mechanics._symmetry`. The test runs at the current parameter
        values: a symmetry that holds only there (a spring constant that is zero now) is
        declared, so detect again after changing such a value.

        Parameters
        ----------
        rtol : float
            Relative tolerance of the pointwise test, in (0, 1).
        n_states : int
            Sample states every candidate must pass, >= 1.
        seed : int
            Seed of their directions.
        scales : (float, float), optional
            The smallest and largest size of the sampled positions (R^k factors) and
            velocities, ``0 < lo <= hi`` (default: from ``min(1e-3, |p|_min / 10)`` to
            ``max(1e3, 10 |p|_max)`` over the nonzero parameter values, within
            ``[1e-6, 1e6]``). Positions take the sizes in increasing order, velocities in a
            seeded shuffle of them.
        confirm : bool
            Confirm every candidate accepted on sampled evidence along short simulations.
        confirm_rtol : float
            Relative tolerance of that confirmation, in (0, 1).
        accept_sampled : bool
            Also declare the momenta whose conservation rests on the samples alone.

        Returns
        -------
        dict of str to str
            The momenta declared by this call: name -> what the symmetry does (for one
            accepted on sampled evidence, followed by that evidence in brackets).

        Raises
        ------
        ModelError
            Bad options; a sample state where the kinetic energy is not positive definite
            (named) or the field is not finite; a confirming simulation that fails.
        """
        check_options(rtol, n_states, seed)
        for flag, value in (("confirm", confirm), ("accept_sampled", accept_sampled)):
            if not isinstance(value, bool):
                raise ModelError(f"{flag} must be True or False; got {value!r}")
        if isinstance(confirm_rtol, bool) or not isinstance(confirm_rtol, (int, float)) \
                or not 0 < confirm_rtol < 1:
            raise ModelError(f"confirm_rtol must be a number in (0, 1); got {confirm_rtol!r}")
        if not self.factors:
            raise ModelError(f"system {self.name!r} has no factors; add rn(...), s1(...), "
                             "s2(...) or so3(...)")
        der = Derivation(_ingredients(self), self.name)
        p = (np.concatenate([np.asarray(self.values[q.name], dtype=float).reshape(-1)
                             for q in self.parameters]) if self.parameters else np.zeros(0))
        lo, hi = _scales(scales, p)
        states, sizes = _sample(self.factors, n_states, seed, lo, hi)
        xdots = _fields(self, der, p, states, sizes)
        found = detect(self, der, p, rtol=float(rtol), states=states, xdots=xdots,
                       accept_sampled=accept_sampled)
        sampled = [c for c in found if not c.exact]
        if confirm and sampled:
            picks = sorted({0, len(states) // 2, len(states) - 1})
            kept = _confirmed(self, der, p, sampled, [states[k] for k in picks],
                              [xdots[k] for k in picks], float(confirm_rtol))
            found = [c for c in found if c.exact or any(c is k for k in kept)]
        out = {}
        for c in found:
            self.momenta[c.name] = c.generators
            out[c.name] = c.description
            if not c.exact:
                where = (f"|dJ/dt| <= {rtol:g} |grad J| |f| at {len(states)} states"
                         + (" and J constant along 3 simulations" if confirm else ""))
                out[c.name] = f"{c.description} [sampled evidence only: {c.evidence}; {where}]"
                warnings.warn(f"detect_momenta: {c.name!r} ({c.description}) is declared on "
                              f"sampled evidence only: {c.evidence}; {where}",
                              UserWarning, stacklevel=2)
        return out


def _scales(scales: Any, p: np.ndarray) -> tuple[float, float]:
    """The sampled sizes' range: given, or spanning the parameters' magnitudes and 1e-3..1e3."""
    if scales is None:
        mags = np.abs(p[np.isfinite(p) & (p != 0)])
        lo = min(1e-3, 0.1 * float(mags.min())) if mags.size else 1e-3
        hi = max(1e3, 10.0 * float(mags.max())) if mags.size else 1e3
        return max(lo, 1e-6), min(hi, 1e6)
    try:
        lo, hi = (float(v) for v in scales)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"scales must be a pair (lo, hi) of positive numbers; got "
                         f"{scales!r}") from exc
    if any(isinstance(v, bool) for v in scales) or not (
            np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= hi):
        raise ModelError(f"scales must be a pair (lo, hi) with 0 < lo <= hi < inf; got "
                         f"{scales!r}")
    return lo, hi


def _sample(factors: list, n: int, seed: int, lo: float, hi: float
            ) -> tuple[list[np.ndarray], list[tuple[float, float]]]:
    """``n`` states: random directions, positions and velocities of log-spaced sizes."""
    rng = np.random.default_rng(seed)
    manifold = ProductManifold([s for f in factors for s in f.storage()])
    sizes = np.geomspace(lo, hi, n) if n > 1 else np.array([np.sqrt(lo * hi)])
    vsizes = rng.permutation(sizes)
    states, used = [], []
    for size, vsize in zip(sizes, vsizes):
        x = np.asarray(manifold.random_point(rng), dtype=float)
        k = 0
        for f in factors:
            nc, nv = f.config_sym.shape[0], f.velocity_sym.shape[0]
            if isinstance(f, RnFactor):
                x[k : k + nc] *= size / max(np.sqrt(nc), 1.0)
            x[k + nc : k + nc + nv] *= vsize / max(np.sqrt(nv), 1.0)
            k += nc + nv
        states.append(x)
        used.append((float(size), float(vsize)))
    return states, used


def _fields(system: Any, der: Derivation, p: np.ndarray, states: list[np.ndarray],
            sizes: list[tuple[float, float]]) -> list[np.ndarray]:
    """``f(x, 0)`` at each state; a named ModelError where T is not definite or f not finite."""
    asm, rates, mass = der.assembly(), der.rates(), der.mass_matrix()
    u0 = np.zeros(der.ing.u.shape[0])
    out = []
    for x, (size, vsize) in zip(states, sizes):
        where = (f"detect_momenta, at a sample state (positions of size {size:.3g}, "
                 f"velocities {vsize:.3g}; pass scales= to sample elsewhere)")
        try:
            check_kinetic_energy(der, system.factors, x, p, mass_matrix=mass)
        except ModelError as exc:
            raise ModelError(f"{where}: {exc}") from exc
        A, b = (np.asarray(m, dtype=float) for m in asm(x, u0, p))
        try:
            acc = np.linalg.solve(A, b)
        except np.linalg.LinAlgError as exc:
            raise ModelError(f"{where}: the equations' matrix is singular at x = "
                             f"{x.tolist()} ({exc}); the accelerations are not defined "
                             "there") from exc
        xdot = np.asarray(rates(x, acc), dtype=float).ravel()
        if not np.all(np.isfinite(xdot)):
            raise ModelError(f"{where}: the field f(x, u=0) is not finite at x = {x.tolist()}")
        out.append(xdot)
    return out


def _confirmed(system: Any, der: Derivation, p: np.ndarray, found: list,
               starts: list[np.ndarray], xdots: list[np.ndarray], tol: float) -> list:
    """The candidates whose momentum stays constant along short simulations from ``starts``."""
    x, ps = ca.MX.sym("x", der.x.shape[0]), ca.MX.sym("p", der.ing.p.shape[0])
    A, b = der.assembly()(x, ca.MX.zeros(der.ing.u.shape[0]), ps)
    ode = der.rates()(x, ca.solve(A, b))
    field = ca.Function("f", [x, ps], [ode])
    momenta = [der.momentum(c.generators) for c in found]
    J = ca.Function("J", [der.x, der.ing.p], [ca.vertcat(*[m(der.x, der.ing.p)
                                                          for m in momenta])])
    flux = ca.Function("flux", [der.x, der.ing.p], [ca.vertcat(*[
        ca.norm_2(ca.gradient(m(der.x, der.ing.p), der.x)) for m in momenta])])
    # one integrator for every start: time scaled to s in [0, 1], the horizon a parameter
    horizon = ca.MX.sym("T")
    grid = np.linspace(0.0, 1.0, CONFIRM_SAMPLES + 1)
    sim = ca.integrator("confirm", "cvodes", {"x": x, "p": ca.vertcat(ps, horizon),
                                              "ode": horizon * ode}, 0.0, grid[1:],
                        {"abstol": 1e-12, "reltol": 1e-10, "max_num_steps": 100_000})
    keep = np.ones(len(found), dtype=bool)
    for x0, f0 in zip(starts, xdots):
        pace = float(np.linalg.norm(f0)) / max(float(np.linalg.norm(x0)), 1e-300)
        T = 1.0 if pace <= 1.0 else 1.0 / pace  # the state changes by about its own size
        try:
            X = np.column_stack([x0, np.asarray(sim(x0=x0, p=np.r_[p, T])["xf"],
                                                dtype=float)])
        except RuntimeError as exc:
            raise ModelError(
                f"detect_momenta: the simulation confirming the momenta "
                f"{[c.name for c in found]} failed from x = {x0.tolist()} over [0, {T:.3g}] "
                f"({str(exc).strip().splitlines()[-1]}); pass confirm=False to rely on the "
                "pointwise test alone") from exc
        Jt = np.asarray(J(X, p), dtype=float)  # one column per time
        speed = np.linalg.norm(np.asarray(field(X, p), dtype=float), axis=0)
        most = np.asarray(flux(X, p), dtype=float) * speed[None, :]  # |grad J| |f|
        budget = np.sum(0.5 * (most[:, 1:] + most[:, :-1]) * np.diff(T * grid), axis=1)
        drift = np.max(np.abs(Jt - Jt[:, :1]), axis=1)
        keep &= drift <= tol * budget
    return [c for c, ok in zip(found, keep) if ok]
