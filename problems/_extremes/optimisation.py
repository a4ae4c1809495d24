"""Extremes, optimisation: the swing-up OCP at nearly infeasible bounds and horizons."""

from __future__ import annotations

from typing import Any

from workbench.study import Cases, Check, Result


def optimisation(cases: Cases, res: Result, *, quick: bool) -> None:
    """Swing-up of the spherical pendulum on a cart at extreme bounds and horizons.

    The problem of :mod:`problems.swingup_spherical_cart` (|u_i| <= u_max, T free in
    [0.5, 3] s, Legendre collocation of degree 3), solved from the defaults (the Auto
    strategy: structured starts, relaxation and polish, continuation; ``max_iter`` caps
    each of its solves). A converged solve is
    correct when its local defect (each node integrated over its interval by CVODES against
    the next node, ``OCPSolution.error["local_defect"]``) is at most 1e-2, which every solve
    also demands through ``defect_tol``; the open-loop re-simulation error is shown too (it
    grows with the instability of the inverted target, which is what TVLQR is for).
    Failures carry Ipopt's status.
    """
    from problems.swingup_spherical_cart import problem
    from workbench.control.ocp import Collocation, homotopy, solve

    group = "optimisation"
    tol = 1e-2

    def check(sol: Any, what: str) -> Check:
        sim = sol.resimulate()
        return Check(f"{what}: {sol.status.name} (Ipopt {sol.ipopt_status}, "
                     f"{sol.cost['iterations']} iterations), cost {sol.objective:.5g}, T = "
                     f"{sol.T:.4g} s; open-loop re-simulation misses the target by "
                     f"{sim['target_residual']:.1e}", sol.error["local_defect"],
                     "local defect of the transcription (CVODES per interval)", tol)

    def run(u_max: float = 10.0, T: Any = (0.5, 3.0), N: int = 40, **kw: Any) -> Check:
        sol = solve(problem(u_max=u_max, T=T), Collocation(N=N), defect_tol=tol, **kw)
        return check(sol, f"solve N = {N}")

    def continued() -> Check:
        ref = solve(problem(), Collocation(N=40), defect_tol=tol)
        sol, path = homotopy(problem(u_max=2.0), Collocation(N=40), guess=ref,
                                 steps=[{"u_lower": -b, "u_upper": b} for b in (6, 4, 3, 2)],
                                 defect_tol=tol)
        return check(sol, f"continuation 10 -> 6 -> 4 -> 3 -> 2 N ({len(path)} solves)")

    # the hopeless cases get 40, 60 and 60 iterations per solve in quick mode, 150, 300 and
    # 300 in full; none converges at the full cap, so a smaller one ends in the same status;
    # |u| <= 1 N, which ran out of iterations from the geodesic guess, is solved by the
    # default strategy's structured starts
    cap = (40, 60, 60) if quick else (150, 300, 300)
    plan: list[tuple[str, Any]] = [
        ("reference: |u| <= 10 N, T in [0.5, 3] s", run),
        ("|u| <= 1 N", lambda: run(1.0, max_iter=cap[0])),
        ("T = 0.05 s fixed (too short)", lambda: run(T=0.05, N=20, max_iter=cap[2])),
        ("T = 100 s fixed on N = 20 (too coarse)", lambda: run(T=100.0, N=20,
                                                               max_iter=cap[1])),
    ]
    if not quick:
        plan += [
            ("|u| <= 3 N, N = 20", lambda: run(3.0, N=20)),
            ("|u| <= 3 N, N = 40", lambda: run(3.0, max_iter=500)),
            ("|u| <= 2 N by continuation in the bound", continued),
            ("T = 0.4 s fixed (too short)", lambda: run(T=0.4, N=20, max_iter=300)),
            ("T = 30 s fixed, N = 20", lambda: run(T=30.0, N=20, max_iter=200)),
            ("T = 10 s fixed, N = 200", lambda: run(T=10.0, N=200)),
            ("T free in [0.5, 100] s, N = 20", lambda: run(T=(0.5, 100.0), N=20,
                                                          max_iter=500)),
        ]
    for name, fn in plan:
        cases.run(group, name, fn)


