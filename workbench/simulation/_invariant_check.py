"""Which invariants a run must keep, and the first output where one did not.

The closed-loop field ``f`` (the model with the controller in the loop, in the direction
of integration) says what the exact flow does to an invariant ``I``: it changes at the
rate ``grad I . f``. :func:`classify` evaluates that rate at a fixed number of output
states (:data:`RATE_SAMPLES`, the checked ones among them) and sorts the invariants:

* **conserved**: ``|grad I . f| <= CONSERVED_RTOL |grad I| |f|`` at every sampled state
  (no controller that works on it, no dissipation, no load). It must not move, in either
  direction, by more than :data:`DRIFT_LIMIT` times its scale;
* **non-increasing**: ``grad I . f <= CONSERVED_RTOL |grad I| |f|`` at every sampled state,
  but not conserved (a dissipated energy with no input acting: no controller, or one whose
  power is non-positive there). Along the exact flow it can only fall; a *rise* by more
  than :data:`DRIFT_LIMIT` times its scale is an instability of the step (a fall is
  legitimate and never flagged).

Any other invariant is fed by the loop (a controller, a load) and its change is not
checked. The scale of ``I`` is ``max(|I(x0)|, |grad I(x0)| |x0|)``: for an energy that is
a quadratic form (Euler's relation ``grad I . x = 2 I``) it is at least ``2 |I(x0)|``.

An adaptive run (CVODES) has a tighter allowance, :func:`tolerance_allowance`: what its
tolerances let the invariant move. Along the exact flow a conserved ``I`` does not change,
so its change over a run is the sum over the steps of ``grad I . e_k``, ``e_k`` the local
error of step ``k`` (no amplification by the flow); a non-increasing one can rise by no
more. CVODES keeps the weighted norm ``sqrt(mean((e_i / (rtol |x_i| + atol))^2))`` of its
estimate of ``e_k`` below 1, so ``|grad I . e_k| <= sqrt(n) |grad I| (rtol |x|_inf +
atol)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from workbench.core._evaluator import evaluate_rows
from workbench.core._model import Model
from workbench.simulation._probe import Probe

__all__ = ["DRIFT_LIMIT", "CONSERVED_RTOL", "RATE_SAMPLES", "TOLERANCE_SAFETY", "Watch",
           "ROUNDOFF", "classify", "classify_projected", "confirm", "first_excess",
           "invariant_values", "projected", "roundoff_allowance", "tolerance_allowance"]

DRIFT_LIMIT = 1.0
"""Largest accepted change of a conserved invariant (either way), or rise of a
non-increasing one, in multiples of its scale ``max(|I(x0)|, |grad I(x0)| |x0|)``.

What a stable step does to an energy bounds it from below. RK4 within its range
(``|R(i y)| <= 1`` for ``|y| <= 2 sqrt 2``) never raises the energy of a linear
oscillation: each step multiplies the amplitude by ``|R| <= 1``. A variational step
(Stormer-Verlet on ``x'' = -w^2 x``) conserves the modified energy ``v^2 + w^2 (1 - c)
x^2``, ``c = (h w / 2)^2``, so the energy itself moves within a factor ``1 / (1 - c)``:
from a start at ``x = 0`` it peaks at ``I(x0) / (1 - c)``, a rise of ``c / (2 (1 - c))``
times its scale ``2 I(x0)``. That is at most 1 for ``c <= 2/3``, ``h w <= 1.63`` (82 % of
the stable range ``h w < 2``); closer to the edge the step is stable but the energy error
exceeds the energy itself (up to three times it), which is no usable answer. Damping only
shrinks these excursions. An unstable step, even one between outputs, amplifies some mode
by a factor above 1 every step, and its energy grows by orders of magnitude within a few
tens of steps (the stiff wall of the hostile review: x 1e7 in 23 RK4 steps, x 5e8 in 12
variational steps), far beyond the limit. It was 10, which let a conservative wall whose
RK4 energy grew 11- to 19-fold, and damped ones whose energy grew 4-fold, pass."""

CONSERVED_RTOL = 1e-8
"""``|grad I . f| <= CONSERVED_RTOL |grad I| |f|`` at every sampled state: the closed-loop
field conserves ``I`` (round-off is ~1e-16 of the terms); ``grad I . f <= CONSERVED_RTOL
|grad I| |f|``: it does not increase ``I``."""

TOLERANCE_SAFETY = 10.0
"""The factor on :func:`tolerance_allowance` beyond which a drift is refused. The bound it
multiplies is already a worst case (every local error at its largest, all aligned with
``grad I``); the factor covers the error estimate being asymptotic and CVODES'
interpolation to the output times. Measured drift over the bound on accurate CVODES runs
(``rtol = atol`` from 1e-3 to 1e-16, Adams; the pendulum, the chaotic 3D pendulum, the
3-link chain on a cart, the acrobot): at most 0.22, mostly 1e-3 to 1e-2; a run that jumped a
potential wall narrower than its step: 5e8 at ``rtol = 1e-10``, 54 at 1e-3."""

ROUNDOFF = 16.0
"""Round-off allowance of an invariant's change between two states, in units of ``eps``
times the sizes of its terms there (:func:`roundoff_allowance`)."""

RATE_SAMPLES = 32
"""Output states at which the rates ``grad I . f`` are evaluated (evenly spaced, the checked
ones among them; a fixed number, so that one mapped function serves every run): a loop
that feeds an invariant anywhere along the run is very unlikely to show a non-positive
rate at all of them."""


@dataclass(frozen=True)
class Watch:
    """The invariants a run must keep.

    Attributes
    ----------
    conserved : list of str
        Conserved by the closed-loop field at every sampled state.
    non_increasing : list of str
        Not increased by it at any sampled state (and not conserved).
    scale : dict
        ``max(|I(x0)|, |grad I(x0)| |x0|)`` of every watched invariant.
    at : tuple of int
        The output indices where the rates were evaluated.
    grad_norm : dict
        ``|grad I|`` at those states, ndarray shape=(len(at),), of every watched invariant.
    """

    conserved: list[str]
    non_increasing: list[str]
    scale: dict[str, float]
    at: tuple[int, ...] = ()
    grad_norm: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        """All watched invariants."""
        return [*self.conserved, *self.non_increasing]


def _rate_indices(n: int, idx: list[int]) -> list[int]:
    """Exactly :data:`RATE_SAMPLES` output indices: ``idx`` and evenly spaced ones.

    Repeated indices fill the list when there are fewer outputs; ``idx[0]`` comes first.
    """
    out = list(dict.fromkeys(idx))
    room = RATE_SAMPLES - len(out)
    if room > 0:
        out += [int(i) for i in np.linspace(0, n - 1, room).round()]
    return out[:RATE_SAMPLES]


def classify(probe: Probe, model: Model, x: np.ndarray, idx: list[int],
             initial: np.ndarray | None = None) -> Watch:
    """The conserved and the non-increasing invariants of a run.

    Parameters
    ----------
    probe : Probe
        The run's functions (its ``rates``: ``grad I . f``, ``|grad I|``, ``|f|``).
    model : Model
        The model.
    x : ndarray, shape=(n_times, ambient_dim)
        The output states.
    idx : list of int
        The checked output indices, ``idx[0] == 0`` (at most ``RATE_SAMPLES``).
    initial : ndarray, shape=(n_invariants,), optional
        The invariants at ``x[0]``, when already computed.

    Returns
    -------
    Watch
    """
    if probe.rates is None:
        return Watch([], [], {})
    at = _rate_indices(len(x), idx)
    rate, gn, fn = (np.asarray(v, dtype=float).reshape(-1, len(at))
                    for v in probe.mapped("rates", len(at))(x[at], model.p))
    tiny = np.finfo(float).tiny
    room = CONSERVED_RTOL * gn * fn + tiny
    conserved = np.all(np.abs(rate) <= room, axis=1)
    falling = np.all(rate <= room, axis=1) & ~conserved
    x0_norm = float(np.linalg.norm(x[0]))
    values = (np.asarray(model.function("invariants")(x[0], model.p), dtype=float).ravel()
              if initial is None else np.asarray(initial, dtype=float))
    names = model.invariant_names
    scale = {n: max(abs(float(values[k])), float(gn[k, 0]) * x0_norm, tiny)
             for k, n in enumerate(names) if conserved[k] or falling[k]}
    return Watch([n for n, k in zip(names, conserved) if k],
                 [n for n, k in zip(names, falling) if k], scale, tuple(at),
                 {n: gn[k] for k, n in enumerate(names) if n in scale})


def confirm(probe: Probe, model: Model, x: np.ndarray, watch: Watch) -> Watch:
    """``watch`` restricted to the invariants whose rates keep their class at every state.

    :func:`classify` samples :data:`RATE_SAMPLES` states; before a run is refused for an
    invariant, its rate is evaluated at all of ``x`` (a loop that feeds it at one of them
    drops it from the watch).

    Parameters
    ----------
    probe : Probe
        The run's functions.
    model : Model
        The model.
    x : ndarray, shape=(n_times, ambient_dim)
        The states.
    watch : Watch
        The invariants classified at the samples.

    Returns
    -------
    Watch
        With ``at`` every index of ``x`` and ``grad_norm`` there.
    """
    if not watch.names or probe.rates is None:
        return watch
    rate, gn, fn = (np.asarray(v, dtype=float).reshape(-1, len(x))
                    for v in probe.mapped("rates", len(x))(x, model.p))
    room = CONSERVED_RTOL * gn * fn + np.finfo(float).tiny
    names = model.invariant_names
    conserved = [n for n in watch.conserved
                 if np.all(np.abs(rate[names.index(n)]) <= room[names.index(n)])]
    falling = [n for n in watch.non_increasing
               if np.all(rate[names.index(n)] <= room[names.index(n)])]
    kept = {*conserved, *falling}
    return Watch(conserved, falling, {n: v for n, v in watch.scale.items() if n in kept},
                 tuple(range(len(x))), {n: gn[names.index(n)] for n in kept})


def tolerance_allowance(watch: Watch, x: np.ndarray, *, rtol: float, atol: float,
                        steps: int) -> dict[str, float]:
    """What an adaptive run's tolerances let every watched invariant move.

    ``steps * sqrt(n) * max_k |grad I(x_k)| ((rtol + 4 eps) |x_k|_inf + atol)`` over the
    states ``watch.at`` (``eps`` the machine epsilon: round-off in the state, which CVODES
    cannot go below), plus ``16 eps`` times the invariant's scale (round-off in evaluating
    it); see the module's notes.

    Parameters
    ----------
    watch : Watch
        The invariants, with ``|grad I|`` at ``watch.at``.
    x : ndarray, shape=(n_times, ambient_dim)
        The output states.
    rtol, atol : float
        The run's tolerances.
    steps : int
        The run's number of steps.

    Returns
    -------
    dict
        Per watched invariant, the allowance (absolute, in the invariant's units).
    """
    eps = np.finfo(float).eps
    size = np.max(np.abs(x[list(watch.at)]), axis=1) if watch.at else np.zeros(0)
    weight = (rtol + 4 * eps) * size + atol
    root_n = np.sqrt(x.shape[1])
    return {n: (max(steps, 1) * root_n * float(np.max(watch.grad_norm[n] * weight,
                                                        initial=0.0))
                + 16 * eps * watch.scale[n])
            for n in watch.names}


def roundoff_allowance(probe: Probe, model: Model, x: np.ndarray, values: np.ndarray
                       ) -> np.ndarray:
    """What round-off alone lets every invariant move between ``x[0]`` and each state.

    ``ROUNDOFF * eps * (s(x_j) + s(x_0))``, ``s(x) = max(|I(x)|, |grad I(x)| |x|)``: the
    size of the invariant's terms at the state, and the change of ``I`` under a relative
    perturbation ``eps`` of the state (which no tolerance goes below). It follows the state:
    on a run that grows (an inverted oscillator, ``x = x0 cosh t``) the kinetic and potential
    energies grow as ``x^2`` while their sum stays put, and the sum is then known only to
    ``eps`` times the terms, however small it is at ``x0``.

    Parameters
    ----------
    probe : Probe
        The run's functions (its ``rates``, for ``|grad I|``).
    model : Model
        The model.
    x : ndarray, shape=(n_times, ambient_dim)
        The states.
    values : ndarray, shape=(n_invariants, n_times)
        The invariants at ``x`` (:func:`invariant_values`).

    Returns
    -------
    ndarray, shape=(n_invariants, n_times)
        Zero without ``rates`` (no invariant is then watched).
    """
    if probe.rates is None:
        return np.zeros_like(values)
    gn = np.asarray(probe.mapped("rates", len(x))(x, model.p)[1],
                    dtype=float).reshape(-1, len(x))
    size = np.maximum(np.abs(values), gn * np.linalg.norm(x, axis=1))
    return ROUNDOFF * np.finfo(float).eps * (size + size[:, :1])


def invariant_values(model: Model, x: np.ndarray) -> np.ndarray:
    """Every invariant at every state, shape ``(n_invariants, n_states)``."""
    return evaluate_rows(model.function("invariants"), np.asarray(x, float), model.p)[0].T


def first_excess(watch: Watch, names: list[str], values: np.ndarray, initial: np.ndarray,
                 limits: dict[str, float] | None = None, roundoff: np.ndarray | None = None
                 ) -> tuple[str, int] | None:
    """The first state where a watched invariant left its allowance, and which one.

    Parameters
    ----------
    watch : Watch
        The watched invariants.
    names : list of str
        All the model's invariants, in the order of ``values``' rows.
    values : ndarray, shape=(n_invariants, n_states)
        Their values at consecutive states.
    initial : ndarray, shape=(n_invariants,)
        Their values at the run's start.
    limits : dict, optional
        The allowance of every watched invariant (absolute); default :data:`DRIFT_LIMIT`
        times its scale.
    roundoff : ndarray, shape=(n_invariants, n_states), optional
        Added to the allowance at every state (:func:`roundoff_allowance`).

    Returns
    -------
    (str, int) or None
        The invariant and the state's index (the earliest over all watched invariants); a
        non-finite value counts as an excess.
    """
    best: tuple[str, int] | None = None
    for name in watch.names:
        k = names.index(name)
        dev = values[k] - initial[k]
        if name in watch.conserved:
            dev = np.abs(dev)
        limit = DRIFT_LIMIT * watch.scale[name] if limits is None else limits[name]
        if roundoff is not None:
            limit = limit + roundoff[k]
        bad = ~(dev <= limit)
        if np.any(bad):
            j = int(np.argmax(bad))
            if best is None or j < best[1]:
                best = (name, j)
    return best


def projected(model: Model, x: np.ndarray) -> np.ndarray:
    """The states projected to the manifold, factor by factor, for classifying only.

    A run in ambient coordinates drifts off the manifold, where the ambient field need not
    conserve what it conserves on it (the rate off the manifold grows with the constraint
    residual): the rates that decide whether the field keeps an invariant are evaluated at
    the nearest points of the manifold. The run's states are never changed. A state whose
    projection fails is kept as is.

    Parameters
    ----------
    model : Model
        The model.
    x : ndarray, shape=(n, ambient_dim)
        States.

    Returns
    -------
    ndarray, shape=(n, ambient_dim)
    """
    out = np.array(x, dtype=float, copy=True)
    for i, xi in enumerate(out):
        try:
            out[i] = model.manifold.project(xi)
        except (ValueError, ArithmeticError):  # too far off for the projection: as is
            pass
    return out


def classify_projected(probe: Probe, model: Model, x: np.ndarray, idx: list[int],
                       initial: np.ndarray | None = None) -> Watch:
    """:func:`classify` at the sampled states projected to the manifold (:func:`projected`).

    Parameters are those of :func:`classify`; the returned ``at`` indexes ``x``.
    """
    at = _rate_indices(len(x), idx)
    watch = classify(probe, model, projected(model, x[at]), [0], initial)
    return Watch(watch.conserved, watch.non_increasing, watch.scale,
                 tuple(at[i] for i in watch.at), watch.grad_norm)
