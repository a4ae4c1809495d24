"""Paper 002 Section III-D read in numbers: the stable manifolds of PD's saddles on SO(3).

:func:`compare_saddle_observations` sets the measured body-axis shares of the motions on the
stable manifold of each saddle exp(pi e_i^) (:func:`workbench.study.so3_axis_observations`)
against the paper's description of its Figs. 2, 4 and 5.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from workbench.study import Result

__all__ = ["compare_saddle_observations"]


def compare_saddle_observations(res: Result, name: str, obs: dict[Any, Any]) -> None:
    """Compare the body-axis observations of a saddle's stable manifold with Sec. III-D.

    Parameters
    ----------
    res : Result
        Receives the comparisons, named after ``name``.
    name : {"e1", "e2", "e3"}
        The saddle exp(pi e_i^).
    obs : dict
        :func:`workbench.study.so3_axis_observations` of its stable manifold at t = 5, 8,
        10, 12, 14 (and later).

    Notes
    -----
    The paper's statements, read from its Figs. 2, 4, 5: 1) exp(pi e1^): rotations about e3
    for t <= 15, the e1 share above the e2 share (|lambda1| > |lambda2|), body axis 3 at -e3
    until it leaves later; 2) exp(pi e2^): rotations about e2 and e3 only, the e2 share
    growing and leading from t = 10 ((18)); 3) exp(pi e3^): rotations about e3 throughout,
    body axis 3 fixed ((19)).
    """
    src = "paper 002 Sec. III-D"
    med = {t: np.array(o["median_share"]) for t, o in obs.items() if isinstance(t, float)}
    if name == "e1":
        res.compare("e1: min over t in [8, 14] of the median e3 share", 1.0,
                    min(med[t][2] for t in (8.0, 10.0, 12.0, 14.0)), tolerance=0.05,
                    source=src + " 1) (rotations about e3 for t <= 15)")
        res.compare("e1: e1 share above e2 share (median) at t = 5, 8, 10", 1,
                    int(all(med[t][0] > med[t][1] for t in (5.0, 8.0, 10.0))), tolerance=0,
                    source=src + " 1) (|lambda1| > |lambda2|)")
        res.compare("e1: median angle of body axis 3 from -e3 at t = 12 [deg]", 0.0,
                    obs[12.0]["median_axis3_angle_deg"], tolerance=1.0, source=src + " 1)")
        res.compare("e1: body axis 3 leaves -e3 later (max angle > 30 deg)", 1,
                    int(obs["max_axis3_angle_deg"] > 30.0), tolerance=0, source=src + " 1)")
    elif name == "e2":
        res.compare("e2: max over t in [5, 14] of the median e1 share", 0.0,
                    max(med[t][0] for t in (5.0, 8.0, 10.0, 12.0, 14.0)), tolerance=0.01,
                    source=src + " 2) (rotations about e2 and e3)")
        res.compare("e2: median e2 share grows over t = 5 .. 14", 1,
                    int(np.all(np.diff([med[t][1] for t in (5.0, 8.0, 10.0, 12.0, 14.0)]) > 0)),
                    tolerance=0, source=src + " 2), (18): -1 < -0.9472")
        res.compare("e2: e2 share leads (median) at t = 10, 12, 14", 1,
                    int(all(med[t][1] > med[t][2] for t in (10.0, 12.0, 14.0))), tolerance=0,
                    source=src + " 2)")
    else:
        late = [t for t in (8.0, 10.0, 12.0) if t in obs]
        res.compare(f"e3: min over t in {late} of the 10% quantile of the e3 share", 1.0,
                    min(obs[t]["q10_share"][2] for t in late), tolerance=0.01,
                    source=src + " 3) (rotations about e3 throughout)")
        res.compare("e3: max angle of body axis 3 from e3 over all states [deg]", 0.0,
                    obs["max_axis3_angle_deg"], tolerance=1.0, source=src + " 3)")
