"""The largest momentum value a Routh reduction can carry in double precision.

The Routh lift puts the group velocity ``xi = (mu - J0) / I`` (``I`` the locked inertia)
along the generator ``eta`` on top of the shape velocities: the full state's velocities are
``nu = nu_shape + xi eta``. The quotient map then recovers the shape velocities from ``nu``,
with an absolute rounding error of about ``eps |xi| |eta|`` (``eps`` the machine epsilon).
At the states where :func:`reduce` checks the lift the reduced velocities are of order 1,
so they survive to the relative tolerance ``rtol`` only while

    |mu| |eta| / I <= rtol / eps,   i.e.   |mu| <= (rtol / eps) min(I / |eta|),

the minimum over the shape space (sampled). Beyond it the lift's quotient is no longer the
reduced state (for ``mu = 1e300`` not even the energy ``mu^2 / (2 I)`` is finite), so such a
momentum is refused before anything is built, with the bound and the scales it comes from.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from workbench.core.errors import ModelError
from workbench.core.manifolds import ProductManifold

__all__ = ["MomentumScale", "momentum_scale", "check_momentum", "SCALE_SAMPLES"]

SCALE_SAMPLES = 16
"""Seeded shape-space samples at which the locked inertia and the generator are measured."""

EPS = float(np.finfo(float).eps)


@dataclass(frozen=True)
class MomentumScale:
    """The scales that bound a Routh momentum value (module docstring).

    Attributes
    ----------
    bound : float
        ``(rtol / eps) min(I / |eta|)``: the largest accepted ``|mu|`` (inf when the
        locked inertia is not positive and finite at the samples: nothing to measure).
    inertia : float
        The smallest locked inertia ``I`` at the samples.
    speed_per_momentum : float
        ``max |eta| / I``: the largest speed the lift adds per unit of momentum.
    energy : float
        The largest ``|energy|`` of the full model at the samples (zero momentum, reduced
        velocities of order 1): the system's energy scale, for comparison with the
        rotation energy ``mu^2 / (2 I)``.
    rtol : float
    """

    bound: float
    inertia: float
    speed_per_momentum: float
    energy: float
    rtol: float


def momentum_scale(red: Any, p: np.ndarray, rtol: float, *, seed: int = 0) -> MomentumScale:
    """Measure :class:`MomentumScale` of a Routh reduction at parameter values ``p``.

    Parameters
    ----------
    red : Reduction
        Its ``lift``, ``eta``, ``locked_inertia_full`` and full model are used.
    p : ndarray
        The full model's parameter values.
    rtol : float
        The relative tolerance the reduced states must be kept to.
    seed : int
        Of the shape-space samples (a stream of its own: the reduction's checks are not
        changed).

    Returns
    -------
    MomentumScale
    """
    rng = np.random.default_rng([seed, 2])
    man = ProductManifold(red.storage)
    energy_fn = red.full.function("energy")
    inertia, speed, energy = np.inf, 0.0, 0.0
    for _ in range(SCALE_SAMPLES):
        x = np.asarray(red.lift(man.random_point(rng), p, 0.0), dtype=float).ravel()
        locked = float(red.locked_inertia_full(x, p))
        eta = float(np.max(np.abs(np.asarray(red.eta(x, p), dtype=float)), initial=0.0))
        e = abs(float(energy_fn(x, p)))
        if not (np.isfinite(locked) and locked > 0 and np.isfinite(eta)):
            return MomentumScale(np.inf, locked, np.nan, e, rtol)
        inertia, speed = min(inertia, locked), max(speed, eta / locked)
        energy = max(energy, e) if np.isfinite(e) else energy
    bound = rtol / EPS / speed if speed > 0 else np.inf
    return MomentumScale(bound, inertia, speed, energy, rtol)


def check_momentum(name: str, mu: float, scale: MomentumScale) -> None:
    """Refuse ``|mu|`` above ``scale.bound``, naming ``name`` and the scales.

    Raises
    ------
    ModelError
        With the bound, the locked inertia, the speed the lift would add and the rotation
        energy against the system's energies.
    """
    if abs(mu) <= scale.bound:
        return
    with np.errstate(over="ignore", divide="ignore"):
        rotation = mu * mu / (2 * scale.inertia)
        kept = max(0.0, -float(np.log10(abs(mu) * scale.speed_per_momentum * EPS)))
    raise ModelError(
        f"{name} = {mu:.6g} is too large for the Routh lift in double precision: it adds "
        f"speeds up to |{name}| max|eta| / I = {abs(mu) * scale.speed_per_momentum:.3g} "
        f"(locked inertia I down to {scale.inertia:.3g}) beside reduced velocities of order 1"
        f", which then keep only {kept:.1f}"
        f" of the {-np.log10(scale.rtol):.0f} digits rtol = {scale.rtol:g} asks for; "
        f"|{name}| must be at most (rtol / eps) min(I / |eta|) = {scale.bound:.3g} here, a "
        f"rotation energy {name}^2 / (2 I) of at most "
        f"{scale.bound ** 2 / (2 * scale.inertia):.3g} against the system's energies up to "
        f"{scale.energy:.3g} (this one: {rotation:.3g}); rescale the units of the model if "
        "the value is meant")
