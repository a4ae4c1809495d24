"""Building an OCP's NLP: per-interval derivatives against casadi's flat ones, same run.

Issue 17 ("the exact-Hessian build of a collocation NLP takes ~30 s per ladder"): the
workbench now generates one interval's exact Jacobian and Lagrangian Hessian and maps them
over the intervals (:mod:`workbench.control.ocp.derivatives`). The baseline is casadi's
default, ``nlpsol`` differentiating the whole flat SX NLP (what the workbench did before).
For each scene the two builds are timed in turn (interleaved, ``--repeat`` rounds) and the
script prints the CPU-second medians, their ratio, the Hessian evaluation time of each (the
cost per Ipopt iteration) and the largest difference between the two Hessians and
Jacobians at a random point (both are exact: rounding only). The load average is printed
with the table: the 2 cores are shared.

Usage: python benchmarks/bench_ocp_build.py [--quick] [--repeat K]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import table  # noqa: E402

from problems import swingup_double_spherical_cart as dbl  # noqa: E402
from problems import swingup_drake_reference as drake  # noqa: E402
from workbench.control.ocp import Collocation, HermiteSimpson, ManifoldHandling  # noqa: E402
from workbench.control.ocp.transcription import Transcription  # noqa: E402
from workbench.core import Symbolic  # noqa: E402


class FlatTranscription(Transcription):
    """The baseline: casadi's own derivatives of the whole flat NLP."""

    def _build_nlp(self):  # noqa: D102
        nlp = super()._build_nlp()
        self._structure = None
        return nlp


def _build(cls, ocp, method, handling):
    t0 = time.process_time()
    tr = cls(ocp, method, handling, Symbolic.SX, {"print_level": 0})
    return tr, time.process_time() - t0


def _eval_ms(fn, args, n=5):
    t0 = time.process_time()
    for _ in range(n):
        fn(*args)
    return (time.process_time() - t0) / n * 1e3


def scene(name, ocp, method, handling, repeat):
    """Interleaved builds of both kinds; medians, ratio, evaluation times, differences."""
    times = {"interval": [], "flat": []}
    trs = {}
    for _ in range(repeat):
        for kind, cls in (("flat", FlatTranscription), ("interval", Transcription)):
            trs[kind], dt = _build(cls, ocp, method, handling)
            times[kind].append(dt)
    rng = np.random.default_rng(0)
    tr = trs["interval"]
    w, P = rng.normal(size=tr.nw), rng.normal(size=int(tr.nlp["p"].numel()))
    w[tr.iT] = 1.5
    lam = rng.normal(size=tr.ng)
    H = {k: t.solver({"print_level": 0}).get_function("nlp_hess_l") for k, t in trs.items()}
    J = {k: t.solver({"print_level": 0}).get_function("nlp_jac_g") for k, t in trs.items()}
    dH = float(np.max(np.abs(ca.densify(H["flat"](w, P, 1.0, lam) -
                                        H["interval"](w, P, 1.0, lam)))))
    dJ = float(np.max(np.abs(ca.densify(J["flat"](w, P)[1] - J["interval"](w, P)[1]))))
    med = {k: statistics.median(v) for k, v in times.items()}
    return {"scene": name, "variables": tr.nw,
            "flat build [s cpu]": f"{med['flat']:.2f}",
            "interval build [s cpu]": f"{med['interval']:.2f}",
            "ratio": f"{med['flat'] / med['interval']:.1f}x",
            "hess eval flat/interval [ms]":
                f"{_eval_ms(H['flat'], (w, P, 1.0, lam)):.1f} / "
                f"{_eval_ms(H['interval'], (w, P, 1.0, lam)):.1f}",
            "max |dH|, |dJ|": f"{dH:.1e}, {dJ:.1e}"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one round, small scenes")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    repeat = 1 if a.quick else a.repeat
    cart = drake.problem()
    scenes = [("Drake's problem, HS N=40, ambient", cart, HermiteSimpson(N=40),
               ManifoldHandling.AMBIENT),
              ("Drake's problem, HS N=40, Lie group", cart, HermiteSimpson(N=40),
               ManifoldHandling.LIE_GROUP)]
    if not a.quick:
        scenes.append(("double cart, Legendre d=3 N=20, Lie group", dbl.problem(),
                       Collocation(N=20), ManifoldHandling.LIE_GROUP))
    rows = [scene(*s, repeat) for s in scenes]
    print(table(rows, list(rows[0])))
    print(f"(medians of {repeat} interleaved builds, CPU seconds; load average "
          f"{os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
