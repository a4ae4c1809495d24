"""Symmetries of a declared system found numerically, and their Noether momenta.

A candidate symmetry is a one-parameter group acting on the factors: a world rotation about
``e1``, ``e2`` or ``e3`` (every S^2 and SO(3) factor turns; each R^3 factor either turns as
a vector in space or stays; an R^2 factor, the horizontal plane, turns about ``e3`` or
stays; an S^1 angle, whose plane the layer does not know, shifts at rate +1 or -1 or
stays), a translation of one R^k factor, or of every R^k factor of one dimension
together, along a coordinate axis, or a shift ``theta -> theta + c`` of one S^1 angle (a
rotation of its ``p``), or of every angle together. Its generator ``eta`` (the velocity of
each factor under the group at unit speed) gives the Noether momentum
``J = sum_f Pi_f . eta_f``. An angle's shift is a rotation, so its momentum is named an
angular momentum: ``angular_momentum_<angle>`` (``angular_momentum_<a>_<b>..`` for all
angles together).

A candidate is accepted only when it is *verified*: ``dJ/dt = grad J . f(x, 0)`` vanishes,
to ``rtol * |grad J| |f|``, at several seeded random states of the manifold (random
configurations and velocities spread over several decades of size, the system's parameter
values, zero input; sampled by :meth:`~workbench.mechanics.System.detect_momenta`), and
*established*: ``dJ/dt``, written without the solve (:func:`momentum_rate`, Noether's
identity), is zero in the graph or vanishes identically on the state manifold by an exact
evaluation (:mod:`._exact`). Samples alone miss a symmetry broken between them (a narrow
bump); a candidate with sampled evidence only is accepted on request, stated, and then
confirmed along short simulations. That is exactly the statement the user relies on
(``J`` is an invariant of the unforced motion); loads that do not vanish at ``u = 0``
(springs written as forces, dissipation) are part of the test.
Accepted generators are kept only while they are linearly independent of those declared
or accepted before (translations of single factors first, then joint translations, then
shifts of single angles, of all angles together, then rotations), so a cart's two
translations and the rotation about the vertical give three momenta, never a fourth
combination of them.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._engine import ModelError, solve_spd
from workbench.mechanics._equations import Derivation
from workbench.mechanics._exact import Verdict, identically_zero, unfolded
from workbench.mechanics._factors import RnFactor, S1Factor, S2Factor, SO3Factor
from workbench.mechanics._forces import load_covector

__all__ = ["Candidate", "detect", "configuration_action", "input_momentum_rates",
           "momentum_rate", "conservation_evidence", "invariance_evidence",
           "symmetry_evidence", "established",
           "MAX_ROTATING_CHOICES",
           "INPUT_MOMENTUM_TOL"]

MAX_ROTATING_CHOICES = 6
"""Up to ``2**MAX_ROTATING_CHOICES`` combinations of the R^2/R^3 factors' turn-or-stay and
the angles' +1/-1/stay are tried; above, only "all turn" (+1), "all turn" (-1) and "all
stay"."""

INPUT_MOMENTUM_TOL = 1e-10
"""An input changes a momentum when ``|dJ/du|`` exceeds this fraction of its absolute
evaluation (:func:`input_momentum_rates`): rounding leaves ~1e-16 of it, a real change is of
the order of it (a motor on the symmetry's own coordinate gives 1). A structural decision,
not a tolerance of the user's."""

AXES = (("e1", (1.0, 0.0, 0.0)), ("e2", (0.0, 1.0, 0.0)), ("e3", (0.0, 0.0, 1.0)))


@dataclass
class Candidate:
    """A candidate symmetry: its invariant's name, a description and its generators.

    Attributes
    ----------
    name : str
        Name of the momentum if accepted.
    description : str
        What the group does, in words.
    generators : dict of int to casadi.SX
        The velocity of each moved factor (keyed by ``id(factor)``).
    exact : bool
        Its conservation is established exactly (:func:`conservation_evidence`).
    evidence : str
        The evidence, in words.
    """

    name: str
    description: str
    generators: dict
    exact: bool = False
    evidence: str = ""


def _rotation_generator(f: Any, axis: np.ndarray) -> ca.SX | None:
    """The velocity of ``f`` under the rotation about ``axis``, or None if it cannot turn."""
    a = ca.SX(ca.DM(axis))
    if isinstance(f, (S2Factor, SO3Factor)):
        return f.rotation_generator(a)
    if isinstance(f, RnFactor) and f.dim == 3:
        return ca.cross(a, f.x)
    if isinstance(f, RnFactor) and f.dim == 2 and axis[2] == 1.0:
        return ca.vertcat(-f.x[1], f.x[0])
    return None


def _rotations(factors: list) -> list[Candidate]:
    out = []
    angles = [f for f in factors if isinstance(f, S1Factor)]
    for label, axis in AXES:
        ax = np.array(axis)
        base = {id(f): g for f in factors if isinstance(f, (S2Factor, SO3Factor))
                for g in [_rotation_generator(f, ax)]}
        movable = [f for f in factors if isinstance(f, RnFactor)
                   and _rotation_generator(f, ax) is not None]
        options = [(1, 0)] * len(movable) + [(1, -1, 0)] * len(angles)
        if np.prod([len(o) for o in options]) <= 2**MAX_ROTATING_CHOICES:
            choices = itertools.product(*options)
        else:
            choices = iter([(1,) * len(options), (1,) * len(movable) + (-1,) * len(angles),
                            (0,) * len(options)])
        for choice in choices:
            gens = dict(base)
            gens.update({id(f): _rotation_generator(f, ax)
                         for f, c in zip(movable, choice) if c})
            if not gens:  # nothing but angles would move: that is a shift, tried before
                continue
            gens.update({id(f): ca.SX(c) * f.shift_generator()
                         for f, c in zip(angles, choice[len(movable):]) if c})
            names = [f.name for f in factors if id(f) in gens]
            out.append(Candidate(f"angular_momentum_{label}",
                                 f"rotation about {label} turning {', '.join(names)}", gens))
    return out


def _translations(factors: list) -> list[Candidate]:
    rn = [f for f in factors if isinstance(f, RnFactor)]
    single, joint = [], []
    for f in rn:
        for i in range(f.dim):
            d = np.zeros(f.dim)
            d[i] = 1.0
            single.append(Candidate(f"linear_momentum_{f.name}_{i + 1}",
                                    f"translation of {f.name} along its axis {i + 1}",
                                    {id(f): ca.SX(ca.DM(d))}))
    for k in sorted({f.dim for f in rn}):
        group = [f for f in rn if f.dim == k]
        if len(group) < 2:
            continue
        for i in range(k):
            d = ca.SX(ca.DM(np.eye(k)[:, i]))
            joint.append(Candidate(
                f"linear_momentum_{i + 1}",
                f"translation of {', '.join(f.name for f in group)} together along axis "
                f"{i + 1}", {id(f): d for f in group}))
    return single + joint


def _shifts(factors: list) -> list[Candidate]:
    angles = [f for f in factors if isinstance(f, S1Factor)]
    out = [Candidate(f"angular_momentum_{f.name}",
                     f"shift of the angle {f.name} (a rotation of its (cos, sin))",
                     {id(f): f.shift_generator()}) for f in angles]
    if len(angles) >= 2:
        names = [f.name for f in angles]
        out.append(Candidate(f"angular_momentum_{'_'.join(names)}",
                             f"shift of the angles {', '.join(names)} together",
                             {id(f): f.shift_generator() for f in angles}))
    return out


def _generator_matrix(der: Derivation, cands: list, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Rows: each candidate's generator stacked over all velocities, at the state ``x``."""
    rows = []
    for c in cands:
        parts = []
        for f, sl in zip(der.ing.factors, der.slices):
            n = sl.stop - sl.start
            parts.append(c.generators.get(id(f), ca.SX.zeros(n, 1)))
        rows.append(ca.vertcat(*parts).T)
    if not rows:
        return np.zeros((0, der.n_nu))
    fn = ca.Function("eta", [der.x, der.ing.p], [ca.vertcat(*rows)])
    return np.asarray(fn(x, p), dtype=float)


def momentum_rate(der: Derivation, generators: dict) -> ca.SX:
    """``dJ/dt`` at zero input as a graph without the equations' solve (Noether's identity).

    With ``J = Pi . eta(c)``: ``dJ/dt = eta^T M nu-dot + eta . (dPi/dc) c-dot + Pi .
    (d eta/dc) c-dot`` and ``M nu-dot = b`` along ``eta`` (the S^2 gauge rows drop out), so
    on an R^k or S^1 factor (``b = -(dPi/dc) c-dot + K^T (dL/dc + Q) - dD/dnu``) the
    factor's share is ``eta . (K^T (dL/dc + Q) - dD/dnu)``: the Lie derivative of the
    Lagrangian along the group plus the loads' virtual power. Nothing the group moves in
    the Lagrangian or the loads, nothing in the graph: zero structurally.

    Parameters
    ----------
    der : Derivation
        The derived equations.
    generators : dict of int to casadi.SX
        The symmetry's generator on each moved factor, keyed by ``id(factor)``.

    Returns
    -------
    casadi.SX, shape=(1, 1)
        An expression of ``der.x`` and ``der.ing.p``.
    """
    ing = der.ing
    u0 = ca.SX.zeros(ing.u.shape[0])
    cov = ca.gradient(der.T - der.V, der.c) + ca.substitute(
        load_covector(ing.loads, der.c), ing.u, u0)
    q_nu = -ca.gradient(der.D, der.nu)
    general = None
    rate, kc, etas = ca.SX(0), 0, []
    for f, sl in zip(ing.factors, der.slices):
        cs = slice(kc, kc + f.config_sym.shape[0])
        kc = cs.stop
        eta = generators.get(id(f))
        etas.append(ca.SX.zeros(sl.stop - sl.start, 1) if eta is None else eta)
        if eta is None:
            continue
        if isinstance(f, (RnFactor, S1Factor)):
            rate = rate + ca.dot(eta, f.kt(cov[cs]) + q_nu[sl])
        else:  # S^2 (its projection) and SO(3) (the gyroscopic term): b as derived
            if general is None:
                general = ca.substitute(der.b, ing.u, u0) + ca.jtimes(der.Pi, der.c, der.cdot)
            rate = rate + ca.dot(eta, general[sl])
    moving = ca.jtimes(ca.vertcat(*etas), der.c, der.cdot)
    return rate + ca.dot(der.Pi, moving) if moving.nnz() else rate


def conservation_evidence(der: Derivation, candidates: list, p: np.ndarray, *,
                          seed: int = 0) -> list[tuple[bool, str]]:
    """Whether each candidate's ``dJ/dt`` vanishes identically on the state manifold.

    Zero in the graph (:func:`momentum_rate`), or an identity of the graph's exact
    evaluation at random points of the manifold (:mod:`._exact`): the momentum is
    conserved, proved. Otherwise the evidence is the caller's samples, stated.

    Parameters
    ----------
    der : Derivation
        The derived equations.
    candidates : list of Candidate
        Their generators.
    p : ndarray
        Parameter values.
    seed : int
        Seed of the exact test's points.

    Returns
    -------
    list of (bool, str)
        Per candidate: exact or not, and the evidence in words.
    """
    rates = [momentum_rate(der, c.generators) for c in candidates]
    structural = (True, "dJ/dt is zero in the derived graph itself (what the group moves "
                        "does not enter the Lagrangian or the loads, or cancels as written)")
    out: list[tuple[bool, str] | None] = [structural if ca.SX(r).is_zero() else None
                                          for r in rates]
    left = [k for k, o in enumerate(out) if o is None]
    if left:
        exact_der, k = unfolded(der)  # the declaration's constants exact, none folded
        fn = ca.Function("momentum_rates", [exact_der.x, exact_der.ing.p], [ca.vertcat(*[
            momentum_rate(exact_der, candidates[j].generators) for j in left])])
        verdicts, why = identically_zero(fn, list(der.ing.factors), np.r_[p, k], seed=seed)
        for j, v in zip(left, verdicts):
            out[j] = (True, "dJ/dt vanishes identically on the state manifold (its "
                            "graph evaluated exactly, modulo two primes, at random points of "
                            "the manifold)") if v is Verdict.ZERO else (
                False, "dJ/dt is not identically zero (nonzero at a point of the "
                       "manifold), only small at the sampled states") \
                if v is Verdict.NONZERO else (
                False, f"whether dJ/dt vanishes everywhere is not decided exactly "
                       f"({why or 'a stand-in value kept it nonzero'})")
    return [o for o in out if o is not None]


def invariance_evidence(der: Derivation, act: ca.Function, p: np.ndarray, *,
                        seed: int = 0) -> tuple[bool, str]:
    """Whether the field at zero input is invariant under a group, established exactly.

    Invariance, ``f(g x) = g_* f(x)``, is the vanishing of the bracket ``[X, f] = Df X -
    DX f`` with the group's generator ``X = d/dtheta act(x, theta)`` at ``theta = 0``:
    zero in the graph, or an identity of its exact evaluation at random points of the
    manifold (:mod:`._exact`; the field written with the symbolic L D L^T solve, a
    rational graph, from the equations derived with the declaration's constants
    unfolded). Conservation of the momentum does not imply it (a load across the
    symmetry that depends on the group coordinate does no work along it).

    Parameters
    ----------
    der : Derivation
        The derived equations.
    act : casadi.Function
        ``(x, theta) -> g_theta x`` on full states (SX).
    p : ndarray
        Parameter values.
    seed : int
        Seed of the exact test's points.

    Returns
    -------
    (bool, str)
        Established or not, and the evidence in words.
    """
    exact_der, k = unfolded(der)
    x, ing = exact_der.x, exact_der.ing
    b = ca.substitute(exact_der.b, ing.u, ca.SX.zeros(ing.u.shape[0]))
    f = exact_der.rates()(x, solve_spd(exact_der.A, b))
    theta = ca.SX.sym("theta")
    X = ca.substitute(ca.jacobian(act(x, theta), theta), theta, ca.SX(0))
    bracket = ca.jtimes(f, x, X) - ca.jtimes(X, x, f)
    if ca.SX(bracket).is_zero():
        return True, "the bracket [X, f] is zero in the derived graph"
    fn = ca.Function("bracket", [x, ing.p], [bracket])
    verdicts, why = identically_zero(fn, list(der.ing.factors), np.r_[p, k], seed=seed)
    if all(v is Verdict.ZERO for v in verdicts):
        return True, ("the bracket [X, f] of the generator with the field vanishes "
                      "identically on the state manifold (evaluated exactly, modulo a "
                      "prime, at random points of the manifold)")
    if any(v is Verdict.NONZERO for v in verdicts):
        return False, ("the bracket [X, f] of the generator with the field is not "
                       "identically zero (nonzero at a point of the manifold)")
    return False, (f"whether the bracket [X, f] of the generator with the field vanishes "
                   f"everywhere is not decided exactly "
                   f"({why or 'a stand-in value kept it nonzero'})")


def symmetry_evidence(der: Derivation, generators: dict, act: ca.Function, p: np.ndarray,
                      *, seed: int = 0) -> tuple[bool, str]:
    """What a reduction relies on: ``J`` conserved and ``f`` invariant, exactly or not.

    See :func:`conservation_evidence` and :func:`invariance_evidence`.

    Returns
    -------
    (bool, str)
        Both established, and the evidence in words.
    """
    (conserved, why_j), = conservation_evidence(der, [Candidate("", "", generators)], p,
                                                seed=seed)
    invariant, why_f = invariance_evidence(der, act, p, seed=seed)
    if conserved and invariant:
        return True, f"exact: {why_j}; {why_f}"
    return False, "; ".join(w for ok, w in ((conserved, why_j), (invariant, why_f))
                            if not ok)


def established(der: Derivation, symmetry: str, act: ca.Function, model: Any, *, seed: int,
                n_states: int, accept_sampled: bool) -> str:
    """:func:`symmetry_evidence` for a reduction: refused unless exact or accepted.

    Returns
    -------
    str
        The evidence.

    Raises
    ------
    ModelError
        Not established exactly and ``accept_sampled`` false (a UserWarning when true).
    """
    exact, evidence = symmetry_evidence(der, der.ing.momenta[symmetry], act, model.p,
                                        seed=seed)
    if not exact:
        what = (f"the symmetry {symmetry!r} of {model.name!r} is not established exactly: "
                f"{evidence}")
        if not accept_sampled:
            raise ModelError(f"{what}; the checks at {n_states} random states cannot see a "
                             "symmetry broken between them; pass accept_sampled=True to "
                             "reduce on their evidence")
        warnings.warn(f"reduce: {what}; reduced on the evidence of {n_states} random "
                      "states", UserWarning, stacklevel=3)
    return evidence


def detect(system: Any, der: Derivation, p: np.ndarray, *, rtol: float,
           states: list[np.ndarray], xdots: list[np.ndarray],
           accept_sampled: bool = False) -> list[Candidate]:
    """The verified, independent symmetries of ``system`` not already declared.

    Parameters
    ----------
    system : System
        The declared system (its factors and declared momenta).
    der : Derivation
        Its derived equations.
    p : ndarray
        Parameter values in storage order.
    rtol : float
        Relative tolerance of ``|dJ/dt| <= rtol |grad J| |f|``.
    states : list of ndarray, shape=(n_x,)
        The states every candidate must pass (at least one; the caller samples them at
        the system's scales).
    xdots : list of ndarray, shape=(n_x,)
        The field ``f(x, 0)`` at each state.
    accept_sampled : bool
        Also accept candidates whose conservation is not established exactly
        (:func:`conservation_evidence`), on the samples' evidence.

    Returns
    -------
    list of Candidate
        Accepted candidates, in order of preference, with their evidence; names not yet
        used.
    """
    factors = list(system.factors)
    cands = _translations(factors) + _shifts(factors) + _rotations(factors)
    if not cands:
        return []
    grads = ca.Function("grads", [der.x, der.ing.p], [ca.vertcat(*[
        ca.gradient(der.momentum(c.generators)(der.x, der.ing.p), der.x).T for c in cands])])
    verified = np.ones(len(cands), dtype=bool)
    for x, xdot in zip(states, xdots):
        G = np.asarray(grads(x, p), dtype=float)
        rate = np.abs(G @ xdot)
        scale = np.linalg.norm(G, axis=1) * np.linalg.norm(xdot)
        verified &= (rate <= rtol * scale) & (np.linalg.norm(G, axis=1) > 0)
    passed = [k for k, ok in enumerate(verified) if ok]
    for k, (exact, evidence) in zip(passed, conservation_evidence(
            der, [cands[k] for k in passed], p)):
        cands[k].exact, cands[k].evidence = exact, evidence
        verified[k] = exact or accept_sampled
    declared = [Candidate(n, "declared", g) for n, g in system.momenta.items()]
    basis = _generator_matrix(der, declared, states[0], p)
    rank = np.linalg.matrix_rank(basis) if basis.size else 0
    accepted, used = [], set(system.momenta)
    for c, ok in zip(cands, verified):
        if not ok:
            continue
        trial = np.vstack([basis, _generator_matrix(der, [c], states[0], p)])
        r = np.linalg.matrix_rank(trial)
        if r > rank:
            basis, rank = trial, r
            name, k = c.name, 2
            while name in used:
                name, k = f"{c.name}_{k}", k + 1
            used.add(name)
            accepted.append(Candidate(name, c.description, c.generators, c.exact,
                                      c.evidence))
    return accepted


def check_options(rtol: Any, n_states: Any, seed: Any = 0) -> None:
    """Refuse a bad tolerance, state count or seed (inputs, never adjusted)."""
    if isinstance(rtol, bool) or not isinstance(rtol, (int, float)) or not 0 < rtol < 1:
        raise ModelError(f"rtol must be a number in (0, 1); got {rtol!r}")
    if isinstance(n_states, bool) or not isinstance(n_states, int) or n_states < 1:
        raise ModelError(f"n_states must be an integer >= 1; got {n_states!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ModelError(f"seed must be an integer >= 0; got {seed!r}")


def configuration_action(der: Derivation, name: str, generators: dict) -> ca.Function:
    """``(x, p) -> delta x``: a symmetry's infinitesimal action on the stored configuration.

    Each moved factor's configuration changes at the rate ``K(c) eta`` (its kinematics for
    the generator's velocity ``eta``); velocities are left unchanged, which is exact at a
    state at rest (where the linearised orbit direction is meant to be read).

    Parameters
    ----------
    der : Derivation
        The derived equations (for the state layout).
    name : str
        The momentum's name (names the function).
    generators : dict of int to casadi.SX
        The generator's velocity of each moved factor, keyed by ``id(factor)``.

    Returns
    -------
    casadi.Function
    """
    parts = []
    for f in der.ing.factors:
        syms = f.state_symbols()
        eta = generators.get(id(f))
        dc = (ca.SX.zeros(f.config_sym.shape[0], 1) if eta is None
              else ca.vec(f.kinematics(eta)))
        if len(syms) == 2:  # configuration and velocity stored apart
            parts += [dc, ca.SX.zeros(syms[1].shape[0], 1)]
        else:  # one TS2 block (q, omega)
            parts.append(ca.vertcat(dc, ca.SX.zeros(f.velocity_sym.shape[0], 1)))
    return ca.Function(f"action_{name}", [der.x, der.ing.p], [ca.vertcat(*parts)],
                       ["x", "p"], ["dx"])


def input_momentum_rates(der: Derivation, generators: dict) -> tuple[ca.Function, list[bool]]:
    """How fast each input changes a momentum: ``dJ/du``, without the equations' solve.

    ``J = Pi . eta`` changes with the input only through the accelerations, ``dJ/du =
    eta^T M d(nu-dot)/du = eta^T db/du`` (S^2 rows: on the sphere), and the input enters
    ``b`` only through the loads' weights ``w_l(c, nu, u)`` (Noether with forcing):

        dJ/du_k = sum_l (dy_l/dc K eta) . dw_l/du_k,

    the virtual power of each load along the group's motion of its target ``y_l``. Its
    absolute evaluation ``sum_l (|dy_l/dc| |K eta|) . |dw_l/du_k|`` is the scale rounding
    works at: a column whose rate stays within :data:`INPUT_MOMENTUM_TOL` of it keeps the
    momentum, whatever tolerance the caller's other checks use.

    Parameters
    ----------
    der : Derivation
        The derived equations.
    generators : dict of int to casadi.SX
        The symmetry's generator on each moved factor, keyed by ``id(factor)``.

    Returns
    -------
    rates : casadi.Function
        ``(x, u, p) -> (rate, scale)``, each shape=(1, n_u).
    structural : list of bool
        Per input column: its rate is zero in the graph itself (no load both driven by
        the column and moved by the group), so the column keeps the momentum at every
        state.
    """
    ing, c = der.ing, der.c
    n_u = ing.u.shape[0]
    moved = ca.vertcat(*[
        ca.vec(f.kinematics(generators[id(f)])) if id(f) in generators
        else ca.SX.zeros(f.config_sym.shape[0], 1) for f in ing.factors])
    rate, scale = ca.SX.zeros(1, n_u), ca.SX.zeros(1, n_u)
    for load in ing.loads:
        w_u = ca.jacobian(load.weight, ing.u)
        if w_u.nnz() == 0:
            continue
        jac = ca.jacobian(load.target, c)
        rate = rate + ca.mtimes(ca.mtimes(jac, moved).T, w_u)
        scale = scale + ca.mtimes(ca.mtimes(ca.fabs(jac), ca.fabs(moved)).T, ca.fabs(w_u))
    structural = [bool(ca.SX(rate[0, k]).is_zero()) for k in range(n_u)]
    fn = ca.Function("input_momentum_rates", [der.x, ing.u, ing.p], [rate, scale],
                     ["x", "u", "p"], ["rate", "scale"])
    return fn, structural
