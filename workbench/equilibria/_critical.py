"""All critical sets of a function on a configuration space, without guesses.

For a model made by :mod:`workbench.mechanics` whose forces at rest (velocities and inputs
0) all derive from its potential ``V``, the equilibria at rest with zero input are the
critical points of ``V`` on the configuration manifold ``Q`` (a product of S^1, S^2, SO(3)
and R^k), and the relative equilibria are the critical points of the amended potential of a
Routh reduction. Other forces at rest (a configuration-dependent torque that is not an input,
a spring written as a force) make the equilibria zeros of the whole force instead:
:func:`find_all_equilibria` refuses such a model (:mod:`._critical_loads`), but for loads of
configuration-independent weight, exact gradients of their work, which it adds to ``V``.
:func:`critical_points` searches for every critical set of any such function
(:class:`ConfigurationFunction`); :func:`find_all_equilibria` applies it to a model's
potential and returns full states at rest, usable by ``linearize``.

The method (details in :mod:`._critical_search`): the symmetries of ``V`` among the
rotations, shifts and translations of the factors are found first
(:mod:`._critical_symmetry`); a start function with known, isolated critical points (the
"sign patterns" of the gravity height functions: each link up or down) is deformed into
``V`` by continuation, the last correction fixing a gauge on the symmetry orbits; deflated
Newton from seeded random starts looks for sets the paths missed, until a run of starts
that grows with the sets found and the dimension finds nothing new
(:mod:`._critical_deflation`). Each distinct critical set is
classified by the Riemannian Hessian at a point of it: its index (negative eigenvalues),
its nullity, and the dimension of the symmetry orbit through it. When the nullity equals
the orbit's dimension the set is nondegenerate in the normal directions (Morse-Bott) and,
for an abelian symmetry, it *is* the orbit: a torus ``T^d``, times ``R^j`` for free
translations. The sets are then checked against the Morse-Bott inequalities
(:mod:`._critical_topology`).

**What the result vouches for.** Nothing here proves that every critical set was found.
The Morse-Bott inequalities are necessary for completeness, not sufficient: a missing pair
of sets whose indices differ by one (a saddle and a minimum born together, say) adds
``t^k (1 + t)`` to the critical sets' polynomial and leaves the inequalities holding. The
status CONSISTENT says that they hold (with equality for a perfect function, such as
gravity's height on the chains) *and* that the deflation stopped because new sets stopped
appearing, with a bound on the chance that one more random start would find a new set
(:class:`SearchEnd`), not because its budget ran out.

Free translations (the chain's cart: ``V`` does not depend on its position) are handled as a
quotient: the gauge fixes the free coordinates at 0, each critical set is
``(a critical point of the quotient) x R^j``, and as ``R^j`` is contractible the mod-2
Betti numbers of both the sets and ``Q`` are those of the quotient.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import ProductManifold
from workbench.core.status import raise_if
from workbench.core.types import ArrayLike, Vector
from workbench.core.validate import count as check_count
from workbench.core.validate import relative_tolerance
from workbench.core.validate import tolerance as check_tolerance
from workbench.equilibria._critical_deflation import deflation_stage
from workbench.equilibria._critical_function import ConfigurationFunction, potential_function
from workbench.equilibria._critical_loads import RestForces
from workbench.equilibria._critical_result import (
    CriticalPoints,
    CriticalSet,
    CriticalStatus,
)
from workbench.equilibria._critical_result import status as critical_status
from workbench.equilibria._critical_search import Homotopy, start_function, track
from workbench.equilibria._critical_symmetry import Symmetry, candidates, detect_symmetry
from workbench.equilibria._critical_topology import (
    MorseBottCheck,
    manifold_polynomial,
    morse_bott_check,
    topology_name,
    torus_polynomial,
)

__all__ = ["CriticalStatus", "CriticalSet", "CriticalPoints", "critical_points",
           "find_all_equilibria", "LIMITS"]

LIMITS = {"max_starts": 1 << 16, "deflation_starts": 10_000, "max_deflation_starts": 10_000,
          "deflation_rounds": 1000, "max_iterations": 1000}
"""Largest accepted value of each count option, checked before anything is allocated or
run: ``max_starts`` homotopy paths (each a continuation of Newton solves), seeded
deflation starts, solves per start and Newton iterations per solve."""

SCALE_RANGE = (1e-150, 1e150)
"""The function's scale (largest ``|dV|`` at the samples) must lie in this range: beyond
it the squares formed by Newton's least squares over- or underflow in double precision."""


def _as_function(target: Any, manifold: ProductManifold | None,
                 p: ArrayLike | None) -> ConfigurationFunction:
    if isinstance(target, ConfigurationFunction):
        if manifold is not None or p is not None:
            raise ModelError("manifold and p belong to a casadi.Function target; a "
                             "ConfigurationFunction carries its own")
        return target
    if isinstance(target, Model):
        if manifold is not None or p is not None:
            raise ModelError("manifold and p belong to a casadi.Function target; for a model "
                             "use model.with_parameters(...)")
        return potential_function(target)
    if isinstance(target, ca.Function):
        if manifold is None:
            raise ModelError("a casadi.Function target needs manifold= (its configuration "
                             "space)")
        return ConfigurationFunction(manifold, target, p=() if p is None else p)
    raise ModelError(f"target must be a Model made by workbench.mechanics, a "
                     f"ConfigurationFunction or a casadi.Function; got {type(target).__name__}")


def _classify(fn: ConfigurationFunction, sym: Symmetry, c: Vector, scale: float,
              hessian_rtol: float, rtol: float) -> CriticalSet:
    V, _, _, F, _ = fn.derivatives(c)
    H = fn.riemannian_hessian(c)
    lam = np.linalg.eigvalsh(H) if H.size else np.zeros(0)
    thr = hessian_rtol * max(float(np.max(np.abs(lam), initial=0.0)), scale)
    index = int(np.sum(lam < -thr))
    nullity = int(np.sum(np.abs(lam) <= thr))
    comp, trans = sym.orbit_basis(c, rtol=rtol)
    d_c, d_t = len(comp), len(trans)
    N = fn.manifold.tangent_basis(c)
    X = sym.fields(c)[:, comp + trans]
    inside = True
    if X.size:
        T = np.linalg.lstsq(N, X, rcond=None)[0]
        inside = bool(np.all(np.linalg.norm(H @ T, axis=0)
                             <= 10 * thr * np.maximum(np.linalg.norm(T, axis=0), 1e-300)))
    mb = nullity == d_c + d_t and inside
    known = mb and sym.classified
    return CriticalSet(
        point=c.copy(), state=fn.state(c), value=V, index=index, nullity=nullity,
        dimension=d_c + d_t if mb else nullity, orbit_dimension=d_c + d_t,
        compact_dimension=d_c, translation_dimension=d_t,
        orbit=[sym.generators[j].description for j in comp + trans], morse_bott=mb,
        topology=topology_name(d_c, d_t) if known else "unknown",
        betti=torus_polynomial(d_c) if known else None, hessian_eigenvalues=lam,
        residual=float(np.max(np.abs(F), initial=0.0)), points=[c.copy()])


def _add(sets: list[CriticalSet], new: CriticalSet, how: str, sym: Symmetry, *,
         value_tol: float, point_tol: float) -> bool:
    """Merge ``new`` into the set whose orbit holds it, or append it; True when new."""
    for s in sets:
        if (s.index, s.nullity) != (new.index, new.nullity) or \
                abs(s.value - new.value) > value_tol:
            continue
        if any(float(np.max(np.abs(q - new.point))) <= point_tol for q in s.points):
            s.found_by.append(how)
            return False
        if s.orbit_dimension and sym.same_orbit(s.point, new.point, tol=point_tol):
            s.points.append(new.point)
            s.found_by.append(how)
            return False
    new.found_by.append(how)
    sets.append(new)
    return True


def _morse_bott(man: ProductManifold, sets: list[CriticalSet]) -> MorseBottCheck | None:
    """The check, or None while some set is unclassified (or none was found)."""
    if any(s.betti is None for s in sets):
        return None
    return morse_bott_check(manifold_polynomial(man), [(s.index, s.betti) for s in sets])


def _failing(man: ProductManifold, sets: list[CriticalSet]) -> bool:
    """Whether the Morse-Bott inequalities fail for classified sets (False if unchecked)."""
    check = _morse_bott(man, sets)
    return check is not None and not check.holds


def _flag(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{name} must be True or False; got {type(value).__name__} "
                             f"{value!r:.80}")
    return bool(value)


def _norm(v: Vector) -> float:
    """``|v|`` without overflow of the squares (NaN or inf when an entry is)."""
    big = float(np.max(np.abs(v), initial=0.0))
    return big * float(np.linalg.norm(v / big)) if 0 < big < np.inf else big


def _relative(name: str, value: Any) -> float:
    """A relative tolerance: positive, finite and below 1 (1 or more accepts anything)."""
    return relative_tolerance(
        name, value, why="a relative tolerance of 1 or more accepts any point")


def critical_points(
    target: Any,
    *,
    manifold: ProductManifold | None = None,
    p: ArrayLike | None = None,
    tol: float = 1e-11,
    hessian_rtol: float = 1e-6,
    symmetry_rtol: float = 1e-9,
    max_starts: int = 4096,
    deflation_starts: int = 8,
    deflation_rounds: int = 8,
    max_deflation_starts: int = 2048,
    max_iterations: int = 50,
    seed: int = 0,
    raise_on_failure: bool = True,
) -> CriticalPoints:
    """Search for every critical set of a smooth function on a product of S^1, S^2, SO(3), R^k.

    No guess is needed: see the module docstring for the method, and for what the result
    vouches for (CONSISTENT is necessary for completeness, not a proof of it).

    Parameters
    ----------
    target : Model, ConfigurationFunction or casadi.Function
        A model made by :mod:`workbench.mechanics` (its potential), a
        :class:`ConfigurationFunction` (any function: an amended potential), or a
        ``casadi.Function`` ``(c, p) -> V`` with ``manifold`` (and ``p``).
    manifold : ProductManifold, optional
        The configuration space of a casadi.Function target.
    p : array-like, optional
        Parameter values of a casadi.Function target.
    tol : float
        Newton's residual tolerance, relative to the scale of ``V`` (the largest ``|dV|``
        at the sampled configurations), in (0, 1).
    hessian_rtol : float
        A Hessian eigenvalue is zero when below ``hessian_rtol`` times the largest one; in
        (0, 1).
    symmetry_rtol : float
        Tolerance of the symmetry detection (:func:`detect_symmetry`), in (0, 1).
    max_starts : int
        Refuse a start function with more critical points than this (``2^n`` for ``n``
        links); at most ``LIMITS["max_starts"]`` (65536), as the other counts are bounded
        by :data:`LIMITS`.
    deflation_starts : int
        The least patience of the deflation: it ends once this many seeded random starts
        in a row, and at least ``3 (n_sets + dim)`` (:mod:`._critical_deflation`), found
        no new set; 0 turns deflation off (the status is then at best UNSETTLED).
    deflation_rounds : int
        Solutions sought from each start (the solves from one start stop at its first
        failure or known point).
    max_deflation_starts : int
        The budget: at most this many starts in all (``deflation["starts"]``), at least
        ``deflation_starts``. While the Morse-Bott inequalities fail the patience is 4 times
        longer; a budget spent before the patience is reached gives UNSETTLED (or MISSED)
        and says so in ``search``.
    max_iterations : int
        Newton iterations per solve.
    seed : int
        Seed of the symmetry samples and of the deflation starts.
    raise_on_failure : bool
        Raise :class:`SolverError` unless the status is CONSISTENT.

    Returns
    -------
    CriticalPoints
        The sets by increasing value, the Morse-Bott check, the status, and ``search``:
        how the search ended (the start of the last new set, of how many). CONSISTENT means
        the inequalities hold and the search settled: necessary for completeness, not
        sufficient (see :class:`CriticalStatus`).

    Raises
    ------
    ModelError
        A target that is not one of the three kinds.
    ParameterError
        Bad options (a count above its bound in :data:`LIMITS`); a constant function
        (every point critical) or one whose gradient is not finite or is too large or small
        for double precision (:data:`SCALE_RANGE`); too many starts.
    SolverError
        When not CONSISTENT and ``raise_on_failure``.
    """
    return _search(_as_function(target, manifold, p), model=None, tol=tol,
                   hessian_rtol=hessian_rtol, symmetry_rtol=symmetry_rtol,
                   max_starts=max_starts, deflation_starts=deflation_starts,
                   deflation_rounds=deflation_rounds,
                   max_deflation_starts=max_deflation_starts, max_iterations=max_iterations,
                   seed=seed, field_tol=None, raise_on_failure=raise_on_failure)


def find_all_equilibria(
    model: Model,
    *,
    params: dict[str, ArrayLike] | None = None,
    field_tol: float = 1e-9,
    raise_on_failure: bool = True,
    **options: Any,
) -> CriticalPoints:
    """Search for all equilibria at rest (zero input) of a mechanics model, without guesses.

    They are the critical sets of the potential on the configuration manifold
    (:func:`critical_points`) when every force at rest (velocities and inputs 0) derives from
    it. That is checked first, exactly, on the derivation's graph (:mod:`._critical_loads`):
    loads that vanish at rest (inputs, velocity-proportional ones), a Rayleigh dissipation
    and a kinetic energy without terms of degree 0 in the velocities pass; a load whose value
    at rest does not depend on the configuration (a constant force at a point, parameters
    allowed) is the gradient of its work ``-w . y(c)``, which is added to the potential
    (the sets' ``value`` is then that sum); anything else is refused with a
    :class:`ModelError` naming it, even a configuration-dependent load that happens to be a
    gradient (declare its energy with ``System.potential``). At every configuration the
    search starts from, the force at rest outside the potential is measured as well, from
    the model's own equations (a second line). Each set's ``state`` is a full model state
    with zero velocities, and its ``field_residual`` the model's ``max |f(x, 0)|`` there.
    The status CONSISTENT says the Morse-Bott inequalities hold and the search settled
    (``search``): necessary for having found them all, not sufficient.

    A set's ``index`` counts the negative eigenvalues of the potential's Hessian; for a
    kinetic energy quadratic in the velocities (with or without dissipation) it is the
    number of unstable modes of the linearisation. Terms linear in the velocities add
    gyroscopic forces to the linearisation: an odd index is still unstable, an even one
    may be stabilised (the message says so).

    Parameters
    ----------
    model : Model
        Made by :mod:`workbench.mechanics`.
    params : dict, optional
        Parameter values overriding the model's.
    field_tol : float
        Largest accepted ``max |f(x, 0)|`` at a representative (status NOT_EQUILIBRIA
        above: a third line, after the structural and sampled checks of the forces at rest).
    raise_on_failure : bool
        Raise unless CONSISTENT.
    **options
        Passed to :func:`critical_points` (``tol``, ``hessian_rtol``, ``seed``, ...).

    Returns
    -------
    CriticalPoints
        As :func:`critical_points`, with ``search`` saying how the search ended.

    Raises
    ------
    ModelError
        Whatever ``raise_on_failure``: a model not made by :mod:`workbench.mechanics`, or one
        with forces at rest its potential does not contain (named; find its equilibria with
        :func:`find_equilibrium` or :func:`enumerate_equilibria`).
    ParameterError
        Bad options.
    SolverError
        When not CONSISTENT and ``raise_on_failure``.
    """
    if not isinstance(model, Model):
        raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
    _flag("raise_on_failure", raise_on_failure)
    if params is not None and not isinstance(params, Mapping):
        raise ParameterError(f"params must be a dict of parameter names to values (or None); "
                             f"got {type(params).__name__} {params!r:.80}")
    if params:
        model = model.with_parameters(**params)
    field_tol = check_tolerance("field_tol", field_tol)
    unknown = set(options) - {"tol", "hessian_rtol", "symmetry_rtol", "max_starts",
                              "deflation_starts", "deflation_rounds", "max_iterations",
                              "max_deflation_starts", "seed"}
    if unknown:
        raise ParameterError(f"unknown options {sorted(unknown)} for find_all_equilibria")
    rest = RestForces(model)
    rest.refuse()
    return _search(rest.function, model=model, field_tol=field_tol, rest=rest,
                   raise_on_failure=raise_on_failure, **options)


def _search(fn: ConfigurationFunction, *, model: Model | None, field_tol: float | None,
            raise_on_failure: bool, rest: RestForces | None = None, tol: float = 1e-11,
            hessian_rtol: float = 1e-6, symmetry_rtol: float = 1e-9, max_starts: int = 4096,
            deflation_starts: int = 8, deflation_rounds: int = 8,
            max_deflation_starts: int = 2048, max_iterations: int = 50,
            seed: int = 0) -> CriticalPoints:
    t0 = time.perf_counter()
    _flag("raise_on_failure", raise_on_failure)
    tol = _relative("tol", tol)
    hessian_rtol = _relative("hessian_rtol", hessian_rtol)
    symmetry_rtol = _relative("symmetry_rtol", symmetry_rtol)
    max_starts = check_count("max_starts", max_starts, maximum=LIMITS["max_starts"])
    deflation_starts = check_count("deflation_starts", deflation_starts, minimum=0,
                                   maximum=LIMITS["deflation_starts"])
    deflation_rounds = check_count("deflation_rounds", deflation_rounds,
                                   maximum=LIMITS["deflation_rounds"])
    max_deflation_starts = check_count("max_deflation_starts", max_deflation_starts, minimum=0,
                                       maximum=LIMITS["max_deflation_starts"])
    if max_deflation_starts < deflation_starts:
        raise ParameterError(f"max_deflation_starts ({max_deflation_starts}) must be at least "
                             f"deflation_starts ({deflation_starts})")
    max_iterations = check_count("max_iterations", max_iterations,
                                 maximum=LIMITS["max_iterations"])
    seed = check_count("seed", seed, minimum=0)
    man = fn.manifold
    rng = np.random.default_rng(seed)
    n_samples = 2 * len(candidates(man)) + 6
    samples = [man.random_point(rng) for _ in range(n_samples)]
    scale = max(_norm(fn.gradient(c)) for c in samples)
    if not np.isfinite(scale):
        raise ParameterError(f"{fn.name} or its gradient is not finite at random "
                             f"configurations (largest |dV| = {scale}); check its parameter "
                             f"values p = {fn.p.tolist()!r:.120}")
    if not scale > 0:
        raise ParameterError(f"{fn.name} has zero gradient at {n_samples} random "
                             "configurations: it is constant, every configuration is critical")
    if not SCALE_RANGE[0] <= scale <= SCALE_RANGE[1]:
        raise ParameterError(
            f"{fn.name} has gradients up to |dV| = {scale:.3g} at random configurations, "
            f"outside [{SCALE_RANGE[0]:g}, {SCALE_RANGE[1]:g}] where Newton's least squares "
            f"over- or underflow; rescale it (V / {scale:.3g} has the same critical points; "
            f"p = {fn.p.tolist()!r:.120})")
    abs_tol = tol * scale

    def at_start(c: Vector, where: str) -> None:
        if rest is not None:  # a force at rest outside the potential refuses the search
            rest.check(c, where, abs_tol)

    for k, c in enumerate(samples):
        at_start(c, f"random sample {k + 1} (of the scale and symmetry)")
    sym = detect_symmetry(man, fn.gradient, samples, rtol=symmetry_rtol)
    start = start_function(fn, scale, max_starts=max_starts)
    hom = Homotopy(fn, start, sym)
    sets: list[CriticalSet] = []
    known: list[Vector] = []
    value_tol = 1e-7 * scale
    point_tol = 1e-6

    def add(c: Vector, how: str) -> bool:
        cs = _classify(fn, sym, c, scale, hessian_rtol, 1e-8)
        known.append(c)
        return _add(sets, cs, how, sym, value_tol=value_tol, point_tol=point_tol)

    paths = []
    for k, (c0, label) in enumerate(zip(start.points, start.labels)):
        at_start(c0, f"homotopy start {k} ({label})")
        end = track(hom, c0, label, tol=abs_tol, max_iterations=max_iterations)
        paths.append(end)
        if end.reached:
            add(end.point, f"continuation from start {k} ({label})")
    defl, ended = deflation_stage(
        hom, known, add, n_sets=lambda: len(sets),
        failing=lambda: _failing(man, sets), seed=seed,
        deflation_starts=deflation_starts, deflation_rounds=deflation_rounds,
        budget=max_deflation_starts, tol=abs_tol, max_iterations=max_iterations,
        point_tol=point_tol, at_start=at_start)
    sets.sort(key=lambda s: s.value)
    if model is not None:
        f = model.function("f")
        u0 = np.zeros(model.n_inputs)
        for s in sets:
            s.field_residual = float(np.max(np.abs(np.asarray(f(s.state, u0, model.p)))))
    check = _morse_bott(man, sets)
    status, message = critical_status(sets, check, paths, defl, ended, field_tol)
    if rest is not None and rest.notes:
        message = "; ".join([message, *rest.notes])
    result = CriticalPoints(fn.name, man, sets, check, status, message, sym.describe(),
                            sym.notes, paths, defl, hom.evaluations,
                            time.perf_counter() - t0, ended)
    return raise_if(result, raise_on_failure)
