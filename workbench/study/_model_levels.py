"""The levels of a model for a scene: full, reduced, Routh, special cases, linearisation.

A :class:`Level` is one way of computing a scene's outputs (the quantities that matter, a
function of the full state), cheaper or not than the full model:

* :class:`FullLevel` -- the full model itself;
* :class:`ReductionLevel` -- a Lagrange-Poincare or Routh model made by
  :func:`workbench.mechanics.reduce`: the reduced model alone when the outputs are
  invariant under the symmetry (checked numerically), else the reconstruction (the reduced
  state, the horizontal configuration and the dynamic phase); a Routh level applies only
  when every state of the scene has the level's momentum value;
* :class:`SpecialCase` -- a model valid on an invariant set under assumptions on the
  parameters and the states (the Lagrange top, the spherical or planar pendulum), which
  its own numeric check accepts or refuses with the reason;
* :class:`LinearLevel` -- the linearisation at an equilibrium, applied when every state of
  the scene is within a stated distance of it (tangent coordinates of the chart): the flow
  ``z(t) = expm(A t) z(0)``, mapped back as ``x_e + N z(t)``;
* :class:`Unavailable` -- a level that could not be made, with the reason.

Each level says why it does not apply (:meth:`Level.refusal`), or prepares a run
(:meth:`Level.prepare`, timed as its build) that maps the scene's states to full states at
the scene's output times (the scene: :class:`workbench.study.Scene`). Every integration is
unforced (``u = 0``) and uses the knobs of :class:`workbench.study.Integration`.
:func:`workbench.study.compare_models` runs them.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
import scipy.linalg as sla

from workbench.core import validate
from workbench.core._model import Model
from workbench.core.errors import ModelError, ParameterError
from workbench.linear import linearize
from workbench.mechanics import Reduction, ReductionKind, reduce
from workbench.study._model_scene import Integration, Scene, _Flow

__all__ = ["LevelKind", "Level", "Prepared", "FullLevel", "ReductionLevel", "SpecialCase",
           "CaseMaps", "LinearLevel", "Unavailable", "default_levels", "output_invariance",
           "sequence_of"]


class LevelKind(str, Enum):
    """Kinds of model level, from the most to the least complete.

    Attributes
    ----------
    FULL
        The full model.
    LAGRANGE_POINCARE
        Reduced by a symmetry, every velocity kept in invariant form.
    ROUTH
        Reduced by a symmetry at one value of its momentum.
    SPECIAL_CASE
        A model valid under assumptions on the parameters and the states.
    LINEARISATION
        The linearisation at an equilibrium.
    """

    FULL = "full"
    LAGRANGE_POINCARE = "lagrange_poincare"
    ROUTH = "routh"
    SPECIAL_CASE = "special_case"
    LINEARISATION = "linearisation"


@dataclass
class Prepared:
    """A level ready to run on a scene.

    Attributes
    ----------
    run : callable
        ``run() -> list of ndarray``: for every state of the scene, the full states
        (shape ``(n_times, ambient_dim)``) at the scene's times; timed by
        :func:`~workbench.study.compare_models`.
    detail : str
        How the level runs (which model is integrated, how it maps back).
    """

    run: Callable[[], list[np.ndarray]]
    detail: str


class Level(ABC):
    """One way of computing a scene's outputs.

    Attributes
    ----------
    name : str
        The level's name (tables, figures).
    kind : LevelKind
        Its kind.
    derive_seconds : float
        CPU time spent deriving its model before :meth:`prepare` (by
        :func:`default_levels`; zero when made elsewhere), counted in its build time.
    """

    name: str
    kind: LevelKind
    derive_seconds: float = 0.0

    @abstractmethod
    def refusal(self, scene: Scene) -> str | None:
        """Why the level does not apply to ``scene`` (None when it applies)."""

    @abstractmethod
    def prepare(self, scene: Scene, knobs: Integration) -> Prepared:
        """Build what a run needs (integrators, maps); called only when it applies."""

    def _same_model(self, model: Model, scene: Scene) -> str | None:
        if model is not scene.model:
            return (f"the level belongs to the model {model.name!r}, the scene to "
                    f"{scene.model.name!r}")
        return None


class FullLevel(Level):
    """The full model, integrated from each of the scene's states.

    Parameters
    ----------
    model : Model
        The scene's model.
    name : str
        The level's name.
    """

    kind = LevelKind.FULL

    def __init__(self, model: Model, *, name: str = "full") -> None:
        self.model, self.name = model, name

    def refusal(self, scene: Scene) -> str | None:  # noqa: D102
        return self._same_model(self.model, scene)

    def prepare(self, scene: Scene, knobs: Integration) -> Prepared:  # noqa: D102
        flow = _Flow(self.model, scene.times, knobs)
        p = self.model.p
        return Prepared(lambda: [flow(x, p) for x in scene.states],
                        f"{self.model.name} on {self.model.manifold.describe()}")


def output_invariance(scene: Scene, act: Callable[[np.ndarray, float], np.ndarray], *,
                      seed: int = 0, n_random: int = 3) -> float:
    """Largest change of the outputs under a group action, relative to their size.

    At each of the scene's states and ``n_random`` seeded random states of the model,
    turned by three seeded random group elements (in ``[0.5, 3]``: angles or lengths).

    Parameters
    ----------
    scene : Scene
        The scene (its outputs and states).
    act : callable
        ``(x, theta) -> g_theta x`` on full states.
    seed : int
        Seed of the random states and group elements.
    n_random : int
        Random states besides the scene's.

    Returns
    -------
    float
        ``max |y(g x) - y(x)| / max(1, max |y(x)|)``.
    """
    rng = np.random.default_rng(seed)
    man = scene.model.manifold
    X = np.vstack([scene.states, *[man.random_point(rng) for _ in range(n_random)]])
    Y = scene.output(X)
    worst = 0.0
    for theta in rng.uniform(0.5, 3.0, 3):
        G = np.array([np.asarray(act(x, theta), dtype=float).ravel() for x in X])
        worst = max(worst, float(np.max(np.abs(scene.output(G) - Y))))
    return worst / max(1.0, float(np.max(np.abs(Y))))


class ReductionLevel(Level):
    """A Lagrange-Poincare or Routh model from :func:`workbench.mechanics.reduce`.

    When the outputs are invariant under the symmetry (:func:`output_invariance` at most
    ``invariance_tol``), the reduced model alone is integrated and its states lifted to
    full states on the section (the outputs do not see the difference); otherwise its
    reconstruction (reduced state, horizontal configuration, dynamic phase) is
    integrated and mapped to the full states. A Routh level applies only when every
    state of the scene has the level's momentum value (to ``momentum_tol * max(1,
    |mu|)``).

    Parameters
    ----------
    reduction : Reduction
        The reduction (its ``full`` must be the scene's model).
    name : str, optional
        Default ``"Routh (<symmetry>)"`` or ``"Lagrange-Poincare (<symmetry>)"``.
    momentum_tol, invariance_tol : float
        The tolerances above.
    seed : int
        Seed of the invariance check.
    """

    def __init__(self, reduction: Reduction, *, name: str | None = None,
                 momentum_tol: float = 1e-9, invariance_tol: float = 1e-9,
                 seed: int = 0) -> None:
        if not isinstance(reduction, Reduction):
            raise ParameterError(f"reduction must be a workbench.mechanics.Reduction; got "
                                 f"{type(reduction).__name__}")
        self.reduction = reduction
        routh = reduction.kind is ReductionKind.ROUTH
        self.kind = LevelKind.ROUTH if routh else LevelKind.LAGRANGE_POINCARE
        self.name = name or (f"Routh ({reduction.symmetry})" if routh else
                             f"Lagrange-Poincare ({reduction.symmetry})")
        self.momentum_tol = validate.tolerance("momentum_tol", momentum_tol)
        self.invariance_tol = validate.tolerance("invariance_tol", invariance_tol)
        self.seed = validate.count("seed", seed, minimum=0)

    def refusal(self, scene: Scene) -> str | None:  # noqa: D102
        red = self.reduction
        if (why := self._same_model(red.full, scene)) is not None:
            return why
        if self.kind is not LevelKind.ROUTH:
            return None
        mu = float(red.model.values[red.momentum_parameter])
        J = np.array([red.momentum_of(x) for x in scene.states])
        off = float(np.max(np.abs(J - mu)))
        if off > validate.scaled_tolerance(self.momentum_tol, mu):
            return (f"the scene's momentum {red.symmetry} is {_span(J)}, not the level's "
                    f"value {mu:.6g} (a Routh model is at one momentum value)")
        return None

    def prepare(self, scene: Scene, knobs: Integration) -> Prepared:  # noqa: D102
        red = self.reduction
        change = output_invariance(scene, lambda x, th: red.act(x, th), seed=self.seed)
        n, p_full, tol = scene.n_times, red.full.p, self.momentum_tol
        if change <= self.invariance_tol:
            model = red.model
            flow, p = _Flow(model, scene.times, knobs), model.p
            mu = float(model.values[red.momentum_parameter]) if self.kind is \
                LevelKind.ROUTH else 0.0
            lift = red.lift.map(n)

            def run() -> list[np.ndarray]:
                return [np.asarray(lift(flow(red.state_from_full(x, tol=tol), p).T, p_full, mu)).T
                        for x in scene.states]

            return Prepared(run, f"{model.name} alone on {model.manifold.describe()}, lifted "
                                 f"to the section (outputs invariant under {red.symmetry}: "
                                 f"change {change:.1e})")
        model = red.reconstruction
        flow, p = _Flow(model, scene.times, knobs), model.p

        def run_reconstructed() -> list[np.ndarray]:
            return [red.reconstruct(flow(red.reconstruction_state(x, tol=tol), p)).x
                    for x in scene.states]

        return Prepared(run_reconstructed,
                        f"{model.name} on {model.manifold.describe()} (outputs change by "
                        f"{change:.1e} under {red.symmetry}: reconstructed)")


@dataclass(frozen=True)
class CaseMaps:
    """A special case's model and its maps to and from the full model's states.

    Attributes
    ----------
    model : Model
        The special case's model (its parameters fixed for the scene).
    to_case : callable
        One full state (on the case's invariant set) to the case's state.
    to_full : callable
        The case's states, shape ``(n, case_dim)``, to full states ``(n, ambient_dim)``
        (exact, or exact up to the level's ``symmetry``).
    """

    model: Model
    to_case: Callable[[np.ndarray], np.ndarray]
    to_full: Callable[[np.ndarray], np.ndarray]


class SpecialCase(Level):
    """A model valid under assumptions on the parameters and the states.

    It applies when ``assumption(scene)`` (a numeric check of the full model's parameters
    and the scene's states, returning the reason it fails or None) accepts the scene,
    the outputs are invariant under ``symmetry`` (when ``to_full`` is exact only up to
    it), and the full states rebuilt from the case's initial states have the scene's
    outputs (to ``roundtrip_tol`` relative).

    Parameters
    ----------
    name : str
        The level's name.
    full : Model
        The full model it is a case of.
    assumption : callable
        ``scene -> str | None``.
    build : callable
        ``scene -> CaseMaps``, called only when the assumption holds.
    symmetry : callable, optional
        ``(x, theta) -> g_theta x`` on full states.
    roundtrip_tol, invariance_tol : float
        Tolerances of the two checks.
    seed : int
        Seed of the invariance check.
    """

    kind = LevelKind.SPECIAL_CASE

    def __init__(self, name: str, full: Model, *, assumption: Callable[[Scene], str | None],
                 build: Callable[[Scene], CaseMaps],
                 symmetry: Callable[[np.ndarray, float], np.ndarray] | None = None,
                 roundtrip_tol: float = 1e-9, invariance_tol: float = 1e-9,
                 seed: int = 0) -> None:
        for what, f in (("assumption", assumption), ("build", build)):
            if not callable(f):
                raise ParameterError(f"{what} must be callable; got {f!r}")
        self.name, self.full, self.assumption, self.build = name, full, assumption, build
        self.symmetry = symmetry
        self.roundtrip_tol = validate.tolerance("roundtrip_tol", roundtrip_tol)
        self.invariance_tol = validate.tolerance("invariance_tol", invariance_tol)
        self.seed = validate.count("seed", seed, minimum=0)

    def refusal(self, scene: Scene) -> str | None:  # noqa: D102
        if (why := self._same_model(self.full, scene)) is not None:
            return why
        if (why := self.assumption(scene)) is not None:
            return why
        if self.symmetry is not None:
            change = output_invariance(scene, self.symmetry, seed=self.seed)
            if change > self.invariance_tol:
                return (f"the outputs change by {change:.2g} (relative) under the symmetry "
                        "and the special case gives the state only up to it")
        maps = self.build(scene)
        back = maps.to_full(np.array([maps.to_case(x) for x in scene.states]))
        Y0 = scene.output(scene.states)
        dev = float(np.max(np.abs(scene.output(back) - Y0))) / max(1.0, float(np.max(
            np.abs(Y0))))
        if dev > self.roundtrip_tol:
            return (f"the scene's states are not on the special case's set: their outputs "
                    f"rebuilt from the case's states differ by {dev:.2g} (relative)")
        return None

    def prepare(self, scene: Scene, knobs: Integration) -> Prepared:  # noqa: D102
        maps = self.build(scene)
        flow, p = _Flow(maps.model, scene.times, knobs), maps.model.p
        return Prepared(lambda: [maps.to_full(flow(maps.to_case(x), p)) for x in scene.states],
                        f"{maps.model.name} on {maps.model.manifold.describe()}")


class LinearLevel(Level):
    """The linearisation of the full model at an equilibrium, in closed form.

    It applies when every state of the scene is within ``radius`` of the equilibrium:
    the max-norm of its chart coordinates ``z = chart(x_e, x)`` (the manifold's tangent
    coordinates: radians, rad/s, metres, m/s). The flow is ``z(t) = expm(A t) z(0)``,
    evaluated at the scene's (equally spaced) times by powers of ``expm(A dt)`` computed
    once (the build), and mapped back as ``x_e + N z(t)``: the linearisation in ambient
    coordinates, off the manifold at second order in the distance, the order of the
    linearisation's own error.

    Parameters
    ----------
    model : Model
        The full model.
    x_e : array-like, shape=(ambient_dim,)
        An equilibrium (checked by :func:`workbench.linearize`).
    radius : float
        The largest distance accepted.
    name : str
        The level's name.
    """

    kind = LevelKind.LINEARISATION

    def __init__(self, model: Model, x_e: Any, *, radius: float,
                 name: str = "linearisation") -> None:
        self.model, self.name = model, name
        self.radius = validate.positive("radius", radius)
        self.linear = linearize(model, x_e)

    def distance(self, x: np.ndarray) -> float:
        """Max-norm of the chart coordinates of ``x`` at the equilibrium."""
        z = self.model.manifold.chart(self.linear.x_e, np.asarray(x, dtype=float))
        return float(np.max(np.abs(z)))

    def refusal(self, scene: Scene) -> str | None:  # noqa: D102
        if (why := self._same_model(self.model, scene)) is not None:
            return why
        d = max(self.distance(x) for x in scene.states)
        if d > self.radius:
            return (f"the scene's states are up to {d:.3g} from the equilibrium (chart "
                    f"max-norm), beyond the radius {self.radius:g}")
        return None

    def prepare(self, scene: Scene, knobs: Integration) -> Prepared:  # noqa: D102
        lin, man = self.linear, self.model.manifold
        step = sla.expm(lin.A * (scene.times[1] - scene.times[0]))
        powers = np.empty((scene.n_times, lin.dim, lin.dim))
        powers[0] = np.eye(lin.dim)
        for k in range(1, scene.n_times):
            powers[k] = step @ powers[k - 1]
        N, xe = lin.basis, lin.x_e

        def run() -> list[np.ndarray]:
            return [xe + (powers @ man.chart(xe, x)) @ N.T for x in scene.states]

        return Prepared(run, f"closed-form flow of the linearisation (dimension {lin.dim}) "
                             f"at an equilibrium, x_e + N z(t); max distance "
                             f"{max(self.distance(x) for x in scene.states):.2g}")


class Unavailable(Level):
    """A level that could not be made for the scene, with the reason.

    Parameters
    ----------
    name : str
        The level's name.
    kind : LevelKind
        Its kind.
    reason : str
        Why it is not available.
    """

    def __init__(self, name: str, kind: LevelKind, reason: str) -> None:
        self.name, self.kind, self.reason = name, kind, reason

    def refusal(self, scene: Scene) -> str | None:  # noqa: D102
        return self.reason

    def prepare(self, scene: Scene, knobs: Integration) -> Prepared:  # noqa: D102
        raise ModelError(f"level {self.name!r} does not apply: {self.reason}")


def sequence_of(name: str, value: Any, kind: type | tuple[type, ...], what: str) -> list[Any]:
    """``value`` as a list, checked to be a sequence (not a str) of ``kind`` items.

    Raises
    ------
    ParameterError
        Naming ``name``, what was expected and what was got.
    """
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ParameterError(f"{name} must be a sequence (list or tuple) of {what}; got "
                             f"{type(value).__name__} {value!r:.80}")
    bad = [v for v in value if not isinstance(v, kind)]
    if bad:
        raise ParameterError(f"{name} must be a sequence of {what}; got {bad!r:.120}")
    return list(value)


def _span(values: np.ndarray) -> str:
    lo, hi = float(np.min(values)), float(np.max(values))
    return f"{lo:.6g}" if lo == hi else f"from {lo:.6g} to {hi:.6g}"


def _timed_reduce(full: Model, symmetry: str, **kw: Any) -> tuple[Reduction | None, str, float]:
    c0 = time.process_time()
    try:
        red = reduce(full, symmetry, breaking_inputs="hold_zero", **kw)
    except ModelError as exc:
        return None, str(exc), time.process_time() - c0
    return red, "", time.process_time() - c0


def default_levels(scene: Scene, *, symmetries: Sequence[str] | None = None,
                   equilibria: Sequence[Any] = (), radius: float = 0.05,
                   momentum_tol: float = 1e-9, seed: int = 0) -> list[Level]:
    """The levels the workbench derives for a scene of a mechanics model.

    The full model; for every symmetry, its Lagrange-Poincare model and its Routh model
    at the scene's momentum value (when every state has the same one), both by
    :func:`workbench.mechanics.reduce` with the symmetry-breaking inputs held at zero (the
    scene is unforced); the linearisation at each given equilibrium. A reduction that
    cannot be made is an :class:`Unavailable` level with the reason. Special cases need
    knowledge of the system and are added by the caller (:class:`SpecialCase`).

    Parameters
    ----------
    scene : Scene
        The scene.
    symmetries : sequence of str, optional
        Momenta to reduce by, each a declared or detected momentum of the model (default:
        every momentum of a mechanics model; none for another model).
    equilibria : sequence of array-like
        Equilibria of the full model to linearise at.
    radius : float
        The linearisation's radius (:class:`LinearLevel`).
    momentum_tol : float
        Equal momenta: to ``momentum_tol * max(1, |mu|)``.
    seed : int
        Seed of the reductions' and levels' numeric checks.

    Returns
    -------
    list of Level

    Raises
    ------
    ParameterError
        A symmetry that is not a momentum of the model (a misspelt name is refused, not
        reported as a level that does not apply), or bad ``radius``, ``equilibria``.
    """
    if not isinstance(scene, Scene):
        raise ParameterError(f"scene must be a workbench.study.Scene; got {type(scene).__name__}")
    momentum_tol = validate.tolerance("momentum_tol", momentum_tol)
    radius = validate.positive("radius", radius)
    seed = validate.count("seed", seed, minimum=0)
    equilibria = sequence_of("equilibria", equilibria, object, "equilibrium states")
    full = scene.model
    der = getattr(full, "mechanics", None)
    known = sorted(der.ing.momenta) if der is not None else []
    if symmetries is None:
        symmetries = known
    symmetries = sequence_of("symmetries", symmetries, str, "momentum names (str)")
    unknown = [s for s in symmetries if s not in known]
    if unknown:
        raise ParameterError(f"symmetries must name momenta of {full.name!r}; {unknown} are "
                             f"not among {known}" + ("" if der is not None else
                                                     " (not a workbench.mechanics model)"))
    levels: list[Level] = [FullLevel(full)]
    for sym in symmetries:
        lp, why, sec = _timed_reduce(full, sym, kind="lagrange_poincare", seed=seed)
        name = f"Lagrange-Poincare ({sym})"
        levels.append(_made(ReductionLevel(lp, name=name, seed=seed), sec) if lp else
                      Unavailable(name, LevelKind.LAGRANGE_POINCARE, why))
        name = f"Routh ({sym})"
        if lp is None:
            levels.append(Unavailable(name, LevelKind.ROUTH, why))
            continue
        J = np.array([lp.momentum_of(x) for x in scene.states])
        if np.ptp(J) > validate.scaled_tolerance(momentum_tol, float(np.max(np.abs(J)))):
            levels.append(Unavailable(name, LevelKind.ROUTH, (
                f"the scene's states have momenta {sym} {_span(J)}: a Routh model is at "
                "one value; give states of one momentum")))
            continue
        ro, why, sec = _timed_reduce(full, sym, momentum=float(J[0]), seed=seed)
        levels.append(_made(ReductionLevel(ro, name=name, momentum_tol=momentum_tol,
                                           seed=seed), sec) if ro else
                      Unavailable(name, LevelKind.ROUTH, why))
    if not equilibria:
        levels.append(Unavailable("linearisation", LevelKind.LINEARISATION,
                                  "no equilibrium given (pass equilibria=[x_e, ...])"))
    for k, xe in enumerate(equilibria):
        name = "linearisation" if len(equilibria) == 1 else f"linearisation {k + 1}"
        c0 = time.process_time()
        lin = LinearLevel(full, xe, radius=radius, name=name)
        levels.append(_made(lin, time.process_time() - c0))
    return levels


def _made(level: Level, seconds: float) -> Level:
    level.derive_seconds = seconds
    return level
