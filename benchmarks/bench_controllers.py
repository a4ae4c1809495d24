"""Controllers, Lyapunov derivatives and domain-of-attraction tools (issue 5).

Medians of repeated runs, each against a baseline measured in the same run:

* one controller evaluation ``u = k(x, p)`` against one evaluation of the plant's field
  ``f(x, u, p)`` (both through the buffered :class:`~workbench.core._model.Evaluator`): what a
  feedback law costs relative to the model it drives;
* a closed-loop simulation against the open-loop simulation of the same model, horizon
  and tolerances (how much the controller adds to integration);
* V-dot of (30) from the graph, mapped over 10^4 states, against the paper's formula
  ``-omega^T Psi(omega)`` in vectorised numpy (and their largest difference);
* the Monte-Carlo convergence check, per sample, against one call of ``simulate`` per
  sample (the check builds one integrator and reuses it);
* the two Ipopt steps of the certified domain of attraction of paper 003.

Targets (not asserted): a controller costs less than the field; the closed loop is less
than 2x the open loop; the Monte-Carlo check is faster per sample than ``simulate``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _timing import median_time, table  # noqa: E402

from models import controllers as ctl  # noqa: E402
from models import pendulum3d as p3  # noqa: E402
from models.chain_cart import chain_cart  # noqa: E402
from workbench.control import Constraint, check_convergence, level_in_domain, optimize_lyapunov
from workbench.core import Evaluator
from workbench.simulation import simulate

J7 = np.array([[30.0, 20, 7], [20, 40, 0], [7, 0, 50]])
BODY = {"J": J7, "rho": np.array([0.0, 0.0, 0.2]), "m": 100.0, "g": 10.0}
P, K_SAT = np.diag([5.0, 10.0, 15.0]), 10.0
GAINS = {"k_y": 4.0, "k_ydot": 2.8, "k_w": 1.0, "k_q": 14.0}
E3 = np.array([0.0, 0.0, 1.0])


def _eval_rows(rng: np.random.Generator) -> list[dict]:
    full = p3.full(**BODY)
    cart = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    q = np.array([0.6, -0.6, -0.53])
    q /= np.linalg.norm(q)
    cases = [
        ("saturated (34), full", full, ctl.saturated_velocity_feedback(full, P=P, k=K_SAT),
         full.manifold.random_point(rng)),
        ("so3_pd, full", full, ctl.so3_pd(full, np.eye(3), k_R=1.0, k_Omega=1.0, G=[0.9, 1.0, 1.1]),
         full.manifold.random_point(rng)),
        ("cart (21)+(26), n = 1", cart, ctl.cart_inverted_feedback(cart, **GAINS),
         np.r_[0.2, 0.1, 0.0, 0.1, q, 0.0, 0.0, 0.0]),
    ]
    out = []
    for name, model, k, x in cases:
        ek, ef = Evaluator(k), Evaluator(model.function("f"))
        u = ek(x, model.p)
        t_k = median_time(lambda ek=ek, x=x, model=model: ek(x, model.p), number=2000)
        t_f = median_time(lambda ef=ef, x=x, u=u, model=model: ef(x, u, model.p), number=2000)
        out.append({"controller": name, "u=k(x,p) [us]": f"{1e6 * t_k:.2f}",
                    "field f [us]": f"{1e6 * t_f:.2f}", "ratio": f"{t_k / t_f:.2f}"})
    return out


def _simulation_rows() -> list[dict]:
    red = p3.reduced(**BODY)
    k = ctl.saturated_velocity_feedback(red, P=P, k=K_SAT)
    x0 = np.r_[np.array([0.0, 0.0141, -0.9999]) / np.linalg.norm([0.0, 0.0141, -0.9999]),
               0.0, 0.0, 0.0]
    t = np.linspace(0.0, 60.0, 601)
    cart = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    kc = ctl.cart_inverted_feedback(cart, **GAINS)
    q = np.array([0.64, -0.64, -0.42]) / np.linalg.norm([0.64, -0.64, -0.42])
    xc = np.r_[0.2, 0.1, 0.0, 0.1, q, 0.0, 0.0, 0.0]
    tc = np.linspace(0.0, 3.0, 301)  # open loop falls; keep it short
    out = []
    for name, model, ctrl, x, tt in (("pendulum reduced, 60 s", red, k, x0, t),
                                     ("cart n = 1, 3 s", cart, kc, xc, tc)):
        t_cl = median_time(lambda m=model, c=ctrl, x=x, tt=tt: simulate(
            m, x, tt, controller=c, rtol=1e-9, atol=1e-9), repeat=5)
        t_ol = median_time(lambda m=model, x=x, tt=tt: simulate(m, x, tt, rtol=1e-9,
                                                                 atol=1e-9), repeat=5)
        out.append({"simulation": name, "closed loop [ms]": f"{1e3 * t_cl:.1f}",
                    "open loop [ms]": f"{1e3 * t_ol:.1f}", "ratio": f"{t_cl / t_ol:.2f}"})
    return out


def _lyapunov_row(rng: np.random.Generator) -> dict:
    red = p3.reduced(**BODY)
    k = ctl.saturated_velocity_feedback(red, P=P, k=K_SAT)
    V = ctl.velocity_feedback_lyapunov(red)
    n = 10_000
    g = rng.standard_normal((n, 3))
    X = np.c_[g / np.linalg.norm(g, axis=1, keepdims=True), rng.standard_normal((n, 3))]
    V.derivative(k)

    def by_hand() -> np.ndarray:
        W = X[:, 3:]
        PW = W @ P.T
        return -np.einsum("ij,ij->i", W, K_SAT * PW / (1 + np.linalg.norm(PW, axis=1,
                                                                          keepdims=True)))

    diff = float(np.max(np.abs(V.derivative_values(X, k) - by_hand())))
    t_g = median_time(lambda: V.derivative_values(X, k), repeat=5)
    t_h = median_time(by_hand, repeat=5)
    return {"V-dot (30), 10^4 states": "graph (jtimes) vs numpy formula",
            "graph [ms]": f"{1e3 * t_g:.2f}", "numpy [ms]": f"{1e3 * t_h:.2f}",
            "ratio": f"{t_g / t_h:.2f}", "max |difference|": f"{diff:.2e}"}


def _monte_carlo_row(rng: np.random.Generator) -> dict:
    red = p3.reduced(**BODY)
    k = ctl.saturated_velocity_feedback(red, P=P, k=K_SAT)
    n = 10
    g = rng.standard_normal((n, 3))
    X = np.c_[g / np.linalg.norm(g, axis=1, keepdims=True), rng.standard_normal((n, 3))]
    x, p = ca.SX.sym("x", 6), ca.SX.sym("p", red.n_params)
    d = ca.Function("d", [x, p], [ca.norm_2(x[0:3] - ca.DM(E3)) + ca.norm_2(x[3:6])])
    t_mc = median_time(lambda: check_convergence(red, k, X, distance=d, horizon=100.0,
                                                 tolerance=1e-4), repeat=3) / n
    t_sim = median_time(lambda: [simulate(red, x0, [0.0, 100.0], controller=k, rtol=1e-8,
                                          atol=1e-10) for x0 in X], repeat=3) / n
    return {"Monte-Carlo per sample, 100 s": "check_convergence vs simulate",
            "check [ms]": f"{1e3 * t_mc:.2f}", "simulate [ms]": f"{1e3 * t_sim:.2f}",
            "ratio": f"{t_mc / t_sim:.2f}"}


def _certification_row(rng: np.random.Generator) -> dict:
    cart = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    V = ctl.cart_lyapunov(cart, **GAINS)
    b = ctl.cart_domain(cart, k_w=1.0, k_q=14.0)
    s = ctl.CartGains(**GAINS).s
    starts = []
    while len(starts) < 6:
        q = rng.standard_normal(3)
        q /= np.linalg.norm(q)
        if q[2] < -s:
            w = rng.uniform(-3, 3, 3)
            starts.append(np.r_[rng.uniform(-2, 2, 4), q, w - (w @ q) * q])
    x, p = ca.MX.sym("x", 10), ca.MX.sym("p", cart.n_params)
    rest = Constraint(ca.Function("r", [x, p], [ca.vertcat(x[0:4], x[7:10])]), 0.0, 0.0)
    t0 = time.perf_counter()
    s1 = optimize_lyapunov(V, starts, maximize=True, constraints=[rest, Constraint(b, -np.inf,
                                                                                   0.0)])
    s2 = level_in_domain(V, b, starts)
    wall = time.perf_counter() - t0
    return {"certified DOA, paper 003": "step 1 + step 2, 6 Ipopt starts each",
            "wall [ms]": f"{1e3 * wall:.0f}",
            "iterations": s1.cost["iterations"] + s2.cost["iterations"],
            "K": f"{s2.value / s1.value:.6f}"}


def main() -> None:
    """Print the tables."""
    rng = np.random.default_rng(5)
    er = _eval_rows(rng)
    print(table(er, list(er[0])))
    print()
    sr = _simulation_rows()
    print(table(sr, list(sr[0])))
    print()
    for row in (_lyapunov_row(rng), _monte_carlo_row(rng), _certification_row(rng)):
        print(table([row], list(row)))
        print()


if __name__ == "__main__":
    main()
