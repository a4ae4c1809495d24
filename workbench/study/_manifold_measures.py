"""Measures of a computed invariant manifold on TSO(3), for comparisons with a paper's words.

* :func:`so3_axis_observations` -- about which body axes the motions on a manifold turn,
  relative to the equilibrium's attitude, at several times, and how far body axis 3 moves;
* :func:`stop_summary` -- how many of the manifold's trajectories were stopped, and when.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from workbench.global_dynamics import InvariantManifold
from workbench.study._measures import axis_shares, body_axis_angle

__all__ = ["so3_axis_observations", "stop_summary"]


def so3_axis_observations(W: InvariantManifold, R_e: np.ndarray, times: Sequence[float]
                          ) -> dict[Any, Any]:
    """Body-axis shares of the rotations on a manifold away from its equilibrium.

    Parameters
    ----------
    W : InvariantManifold
        A manifold of a model with an SO(3) part ``"R"``.
    R_e : numpy.ndarray, shape=(3, 3)
        The equilibrium's attitude.
    times : sequence of float
        Times at which to measure (those beyond the manifold's last time, or with no
        trajectory still running, are left out).

    Returns
    -------
    dict
        Per time ``t`` (float keys): the number of running trajectories, the median and 10%
        quantile over them of the shares ``eta_i^2 / |eta|^2`` of ``eta = log(R_e^T R)``
        (:func:`~workbench.study.axis_shares`), and the median angle [deg] of body axis 3
        from its place at ``R_e``; and ``"max_axis3_angle_deg"``, that angle's maximum over
        every state of every running trajectory.
    """
    R = W.part("R")
    out: dict[Any, Any] = {}
    for t in (t for t in times if t <= W.t[-1]):
        k = W.index(t)
        run = W.running(t)
        if not run.any():
            continue
        sh = axis_shares(R[k][run], R_e)
        out[t] = {"running": int(run.sum()), "median_share": np.median(sh, axis=0).tolist(),
                  "q10_share": np.quantile(sh, 0.1, axis=0).tolist(),
                  "median_axis3_angle_deg": float(np.median(body_axis_angle(R[k][run], R_e,
                                                                           2)))}
    run = W.t[:, None] < W.stop_time[None, :]
    out["max_axis3_angle_deg"] = float(np.max(body_axis_angle(R[run], R_e, 2)))
    return out


def stop_summary(W: InvariantManifold) -> dict[str, Any]:
    """Trajectories stopped (by ``max_distance``) and the quantiles 0, 0.5, 1 of their stop times.

    Returns
    -------
    dict
        ``stopped`` (count) and ``stop_time_quantiles_of_stopped`` (empty if none stopped).
    """
    stopped = np.isfinite(W.stop_time)
    return {"stopped": int(np.sum(stopped)),
            "stop_time_quantiles_of_stopped": np.quantile(W.stop_time[stopped],
                                                          [0, 0.5, 1]).tolist()
            if stopped.any() else []}
