"""Mass-matrix solves written as L D L^T instead of QR: graph sizes and OCP solve times.

A model made by :mod:`workbench.mechanics` declares its linear solves symmetric positive
definite (``Model.spd_solves``: they are with the mass matrix). Its SX graphs then write
``A \\ b`` as ``casadi.ldl`` + ``casadi.ldl_solve`` (:func:`workbench.core.solve_spd`)
instead of the symbolic QR of ``casadi.solve``: the same function, fewer operations. The
script prints, for the n-link carts (``models.chain_cart``, an MX model whose solve the
OCP replays on SX), the instructions of the field and of the Hessian of ``lambda . f`` in
``(x, u)`` (what an exact-Hessian OCP evaluates at every collocation point), and then
times the double cart's swing-up at N = 80 (Lie group, from the N = 40 solution of the
problem's own ladder) with each replay, interleaved round by round: CPU-second medians,
their ratio, the iterations and the cost reached (the two must reach the same minimum),
and the load average.

Usage: python benchmarks/bench_spd_solve.py [--quick] [--repeat K]
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from pathlib import Path

import casadi as ca

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import interleaved_cpu, quick_repeat_arguments, table  # noqa: E402

from models.chain_cart import chain_cart  # noqa: E402
from problems import swingup_double_spherical_cart as dc  # noqa: E402
from workbench.control.ocp import Collocation, ManifoldHandling, coarse_to_fine  # noqa: E402
from workbench.control.ocp import solve as solve_ocp  # noqa: E402
from workbench.control.ocp.expand import sx_function  # noqa: E402
from workbench.control.ocp.study import pumping_guess  # noqa: E402


def graph_sizes(n: int) -> list[dict]:
    """Instructions of the n-link cart's field and of its Hessian, QR against L D L^T."""
    model = chain_cart(n)
    rows = []
    for spd in (False, True):
        f = sx_function(model.function("f"), spd=spd)
        x, u = ca.SX.sym("x", f.size1_in(0)), ca.SX.sym("u", f.size1_in(1))
        lam = ca.SX.sym("lam", f.size1_out(0))
        xu = ca.vertcat(x, u)
        H = ca.hessian(ca.dot(lam, f(x, u, model.p)), xu)[0]
        fh = ca.Function("h", [x, u, lam], [H])
        rows.append({"links": n, "solve": "L D L^T" if spd else "QR",
                     "f instructions": f.n_instructions(),
                     "Hessian instructions": fh.n_instructions()})
    return rows


def main(argv: list[str] | None = None) -> None:
    """Print the graph sizes and the interleaved solve times."""
    argv = sys.argv[1:] if argv is None else argv
    a = quick_repeat_arguments(__doc__, "N = 40 from the surrogate instead of N = 80",
                               argv, repeat=3)
    print(table([r for n in (1, 2, 3) for r in graph_sizes(n)],
                ["links", "solve", "f instructions", "Hessian instructions"]))
    ldl_ocp, qr_ocp = dc.problem(), dc.problem()
    if qr_ocp.model is ldl_ocp.model:
        raise RuntimeError("the two OCPs share a model; the baseline cannot be switched")
    qr_ocp.model.spd_solves = False  # the baseline: the replay writes casadi's QR
    lie = ManifoldHandling.LIE_GROUP
    sur = dc.surrogate()
    single, _ = coarse_to_fine(sur, [Collocation(N=20), Collocation(N=40)],
                               guess=pumping_guess(sur, half_swings=5, T=3.0), max_iter=150)
    guess = dc.lift(single, ldl_ocp)
    N = 40 if a.quick else 80
    if not a.quick:
        guess = solve_ocp(ldl_ocp, Collocation(N=40), guess=guess, handling=lie,
                          max_iter=300, defect_tol=None)
    ocps = {"QR": qr_ocp, "L D L^T": ldl_ocp}
    for ocp in ocps.values():  # build the transcriptions outside the timing
        solve_ocp(ocp, Collocation(N=N), guess=guess, handling=lie, max_iter=1,
                  raise_on_failure=False, defect_tol=None)
    last: dict[str, object] = {}

    def timed(name: str) -> Callable[[], None]:
        def run() -> None:
            last[name] = solve_ocp(ocps[name], Collocation(N=N), guess=guess, handling=lie,
                                   max_iter=300, defect_tol=None)
        return run

    medians = interleaved_cpu({k: timed(k) for k in ocps}, rounds=a.repeat)
    base = medians["QR"]
    rows = [{"solve": k, "N": N, "CPU median [s]": f"{v:.2f}", "ratio": f"{v / base:.2f}",
             "iterations": last[k].cost["iterations"], "cost": f"{last[k].objective:.8f}",
             "status": last[k].status.name} for k, v in medians.items()]
    print(table(rows, ["solve", "N", "CPU median [s]", "ratio", "iterations", "cost",
                       "status"]))
    print(f"rounds {a.repeat}, load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
