"""Linearise + PBH + LQR for the chain on a cart, n = 5, 10, 20 (issue 3).

At the hanging equilibrium of the chain (m = 0.5, m_i = 0.1, l_i = 0.1) with the paper's
Q = diag[8 I2, I_2n, 8 I2, I_2n], R = I2, the median time of:

* ``linearize`` (automatic derivatives of the graph, projected on the tangent basis),
  against the baseline of central finite differences of the field in the chart
  (2 dim evaluations of f, the natural alternative), with the accuracy of both;
* the first-order PBH test (one SVD per distinct eigenvalue), against the baseline of the
  Kalman rank (one SVD, but a condition number that makes it unusable from n = 3 on);
* ``lqr`` (weights validated, PBH, Riccati by python-control/scipy, residual), against
  the baseline of a bare ``scipy.linalg.solve_continuous_are``;
* the whole pipeline linearise + PBH + LQR (target: under 1 s at n = 10), and the one-off
  graph build (f, f_x, f_u) it needs the first time.

BLAS runs single-threaded here (OPENBLAS_NUM_THREADS=1 set before numpy is imported): on
this shared two-core machine multi-threaded OpenBLAS made each 84 x 86 complex SVD of the
n = 20 PBH test take 0.03-1.4 s instead of 1 ms.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy.linalg as sla  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _timing import median_time, table  # noqa: E402

from models.chain_cart import chain_cart, link_state  # noqa: E402
from workbench.core import Evaluator
from workbench.linear import kalman_rank, linearize, lqr, mechanical_order, pbh

E3 = np.array([0.0, 0.0, 1.0])


def fd_linearization(model, x_e, h: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Baseline: central differences of z -> pinv(N) f(retract(x_e, z)) and of u."""
    N = model.manifold.tangent_basis(x_e)
    L = np.linalg.pinv(N)
    f = Evaluator(model.function("f"))
    dim, p, u0 = N.shape[1], model.p, np.zeros(model.n_inputs)
    A = np.empty((dim, dim))
    for j in range(dim):
        e = np.zeros(dim)
        e[j] = h
        A[:, j] = L @ (f(model.manifold.retract(x_e, e), u0, p)
                       - f(model.manifold.retract(x_e, -e), u0, p)) / (2 * h)
    B = np.empty((dim, model.n_inputs))
    for j in range(model.n_inputs):
        e = np.zeros(model.n_inputs)
        e[j] = h
        B[:, j] = L @ (f(x_e, e, p) - f(x_e, -e, p)) / (2 * h)
    return A, B


def rows(ns=(5, 10, 20)) -> list[dict]:
    out = []
    lqr(np.diag([-1.0, 1.0]), np.eye(2), np.eye(1), B=np.ones((2, 1)))  # import control once
    for n in ns:
        repeat = {5: 7, 10: 5, 20: 3}.get(n, 3)
        t0 = time.perf_counter()
        model = chain_cart(n)
        for name in ("f", "f_x", "f_u"):
            model.function(name)
        build = time.perf_counter() - t0
        x_e = np.concatenate([np.zeros(4)] + [link_state(E3) for _ in range(n)])
        pos, vel = mechanical_order(model, {"x": "v"})
        Q = np.diag(np.r_[8.0, 8.0, np.ones(2 * n), 8.0, 8.0, np.ones(2 * n)])
        R = np.eye(2)

        def lin_paper():
            return linearize(model, x_e).permuted(pos + vel)

        lp = lin_paper()
        A_fd, _ = fd_linearization(model, x_e)
        A_fd = A_fd[np.ix_(pos + vel, pos + vel)]
        t_lin = median_time(lin_paper, repeat=repeat)
        t_fd = median_time(lambda: fd_linearization(model, x_e), repeat=repeat)
        t_pbh = median_time(lambda: pbh(lp), repeat=repeat)
        t_kal = median_time(lambda: kalman_rank(lp), repeat=repeat)
        t_lqr = median_time(lambda: lqr(lp, Q, R), repeat=repeat)
        t_care = median_time(lambda: sla.solve_continuous_are(lp.A, lp.B, Q, R),
                             repeat=repeat)
        t_all = median_time(lambda: lqr(lin_paper(), Q, R), repeat=repeat)
        test, design, kal = pbh(lp), lqr(lp, Q, R), kalman_rank(lp)
        out.append({
            "n": n, "dim": lp.dim,
            "build [s]": f"{build:.3f}",
            "linearize [ms]": f"{1e3 * t_lin:.2f}",
            "FD [ms]": f"{1e3 * t_fd:.2f}",
            "lin/FD": f"{t_lin / t_fd:.2f}",
            "|A_FD - A|/|A|": f"{np.max(np.abs(A_fd - lp.A)) / np.max(np.abs(lp.A)):.1e}",
            "PBH [ms]": f"{1e3 * t_pbh:.2f}",
            "PBH/Kalman": f"{t_pbh / t_kal:.1f}",
            "PBH margin": f"{test.margin:.1e}",
            "Kalman cond": f"{kal.condition:.1e}",
            "LQR [ms]": f"{1e3 * t_lqr:.2f}",
            "LQR/CARE": f"{t_lqr / t_care:.2f}",
            "Riccati res": f"{design.riccati_residual:.1e}",
            "lin+PBH+LQR [s]": f"{t_all:.3f}",
        })
    return out


def main() -> None:
    print(__doc__.split("\n\n")[0])
    print("medians of repeated runs (7 at n = 5, 5 at n = 10, 3 at n = 20); ratios are "
          "against baselines timed in the same run")
    r = rows()
    print(table(r, ["n", "dim", "build [s]", "linearize [ms]", "FD [ms]", "lin/FD",
                    "|A_FD - A|/|A|"]))
    print(table(r, ["n", "PBH [ms]", "PBH/Kalman", "PBH margin", "Kalman cond", "LQR [ms]",
                    "LQR/CARE", "Riccati res", "lin+PBH+LQR [s]"]))
    at10 = next(float(x["lin+PBH+LQR [s]"]) for x in r if x["n"] == 10)
    print(f"target: linearise + PBH + LQR under 1 s at n = 10: {at10:.3f} s "
          f"({'met' if at10 < 1.0 else 'NOT met'}; excluding the one-off graph build)")


if __name__ == "__main__":
    main()
