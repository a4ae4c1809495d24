"""Finite-time Lyapunov exponents: regular versus chaotic orbits, measured.

The largest exponent is estimated by Benettin's method: the tangent vector follows the
linearised flow ``v-dot = (df/dx) v``, the product ``(df/dx) v`` taken by automatic
differentiation of the model graph (no hand-written variational equations), and is
renormalised at fixed intervals.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import ParameterError, SolverError
from workbench.core.status import Record
from workbench.core.types import ArrayLike
from workbench.global_dynamics._poincare import _positive, stabilized_field
from workbench.simulation._cvodes import Multistep, cvodes_options

__all__ = ["FTLECost", "LyapunovEstimate", "lyapunov_exponent"]


@dataclass(frozen=True)
class FTLECost(Record):
    """What :func:`lyapunov_exponent` cost.

    Attributes
    ----------
    wall_seconds : float
        Integration of the orbit with its tangent vector.
    steps : int
        CVODES steps, summed over the renormalisation intervals.
    """

    wall_seconds: float
    steps: int


@dataclass
class LyapunovEstimate:
    """Largest finite-time Lyapunov exponent of an orbit (Benettin renormalisation).

    Attributes
    ----------
    value : float
        ``sum(log |v_k|) / t_final`` [1/s].
    running : ndarray, shape=(n_intervals,)
        The running estimate after each renormalisation interval.
    times : ndarray, shape=(n_intervals,)
        Ends of the intervals.
    cost : FTLECost
        ``wall_seconds``, ``steps`` (a typed record that also reads as a mapping).
    """

    value: float
    running: np.ndarray
    times: np.ndarray
    cost: FTLECost | dict[str, Any] = field(default_factory=dict)


def lyapunov_exponent(
    model: Model, x0: ArrayLike, *, t_final: float, renormalize_every: float = 5.0,
    rtol: float = 1e-10, atol: float = 1e-10, multistep: Multistep = Multistep.ADAMS,
    stabilization: float = 0.0, direction: Sequence[float] | None = None,
) -> LyapunovEstimate:
    """Largest finite-time Lyapunov exponent along the orbit of ``x0``.

    The tangent vector obeys ``v-dot = (df/dx) v`` with the product from AD of the
    (stabilised) field; it starts tangent to the manifold (``direction`` in the
    manifold's tangent coordinates, all ones by default) and is renormalised every
    ``renormalize_every`` seconds. Regular (quasi-periodic) orbits give values that decay
    like ``log(t)/t``; chaotic orbits converge to a positive value.

    Parameters
    ----------
    model : Model
        Autonomous model.
    x0 : array-like
        Initial state on the manifold.
    t_final : float
        Horizon [s].
    renormalize_every : float
        Renormalisation interval [s].
    rtol, atol, multistep, stabilization
        As in :func:`poincare_map`.
    direction : sequence of float, optional
        Initial tangent vector in the coordinates of ``tangent_basis(x0)``.

    Returns
    -------
    LyapunovEstimate
    """
    t_final, every = _positive("t_final", t_final), _positive("renormalize_every",
                                                                renormalize_every)
    xc = model.check_state(x0, name="x0")
    N = model.manifold.tangent_basis(xc)
    d = np.ones(N.shape[1]) if direction is None else np.asarray(direction, float).ravel()
    if d.shape != (N.shape[1],) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        raise ParameterError(f"direction must be a non-zero {N.shape[1]}-vector; got "
                             f"{direction!r}")
    v = N @ d
    v /= np.linalg.norm(v)
    S = model.sym
    n = model.manifold.ambient_dim
    xs, vs, ps = S.sym("x", n), S.sym("v", n), S.sym("p", model.n_params)
    f = stabilized_field(model, gain=stabilization)(xs, ps)
    F = ca.integrator("tangent", "cvodes", {"x": ca.vertcat(xs, vs), "p": ps,
                                            "ode": ca.vertcat(f, ca.jtimes(f, xs, vs))},
                      0.0, every,
                      cvodes_options(multistep=multistep, rtol=rtol, atol=atol,
                                     max_steps=1_000_000, error=ParameterError))
    n_int = max(1, int(round(t_final / every)))
    z, total, running, steps = np.r_[xc, v], 0.0, [], 0
    t0 = time.perf_counter()
    for k in range(n_int):
        try:
            z = np.asarray(F(x0=z, p=model.p)["xf"]).ravel()
        except RuntimeError as exc:
            raise SolverError(f"cvodes failed on the tangent flow after t = {k * every:g}",
                              status="integrator") from exc
        steps += int(F.stats().get("nsteps", 0))
        nv = float(np.linalg.norm(z[n:]))
        total += np.log(nv)
        z[n:] /= nv
        running.append(total / ((k + 1) * every))
    return LyapunovEstimate(float(running[-1]), np.array(running),
                            every * np.arange(1, n_int + 1),
                            FTLECost(wall_seconds=time.perf_counter() - t0, steps=steps))
