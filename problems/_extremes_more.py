"""Case groups of :mod:`problems.extremes`: motion, continuation, chains, optimisation, input.

Split from :mod:`problems.extremes` for module size; the conventions (Check, Cases,
outcomes, closed forms) are that module's.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy.special import ellipkm1

from models import pendulum3d as p3
from problems.extremes import J_CYL, MG, RHO_CYL, Cases, Check, prop9
from workbench.core.errors import SolverError
from workbench.core.manifolds import SO3, so3_exp
from workbench.study import Result

ROOT = Path(__file__).resolve().parent.parent
E3 = np.array([0.0, 0.0, 1.0])


def _gamma_1(ctx: Any) -> Any:
    """First component of the reduced attitude ``Gamma = R^T e3`` (a section builder)."""
    return (SO3.matrix(ctx["R"]).T @ E3)[0]

# ----------------------------------------------------------------------------------------
# fast and slow motion


def _richardson(model: Any, x0: np.ndarray, t: np.ndarray, method: str, step: float,
                order: int) -> tuple[Any, float]:
    """Run at ``step`` and ``step / 2``; return the finer run and its Richardson estimate."""
    from workbench import simulate

    a = simulate(model, x0, t, method=method, step=step, jit=True)
    b = simulate(model, x0, t, method=method, step=step / 2, jit=True)
    return b, float(np.max(np.abs(a.x[-1] - b.x[-1]))) / (2**order - 1)


def fast_and_slow(cases: Cases, res: Result, *, quick: bool) -> None:
    """Spin 1e3 rad/s (sleeping top), periods near the separatrix, 10^5 s horizons."""
    from workbench import simulate
    from workbench.simulation.accuracy import Sweep, long_time

    group = "fast_and_slow"
    # the sleeping top: J = diag(Jt, Jt, Ja), rho on the axis, hanging, omega = s e3;
    # exactly R(t) = exp(s t e3-hat)
    Jt, Ja, rs, spin, T = 0.2, 0.05, 0.3, 1e3, 1.0
    top = p3.full(J=np.diag([Jt, Jt, Ja]), rho=[0.0, 0.0, rs])
    x0 = top.state(R=np.eye(3), omega=[0.0, 0.0, spin])
    t = np.linspace(0.0, T, 11)
    R_exact = so3_exp([0.0, 0.0, spin * T])

    def cvodes() -> Check:
        a = simulate(top, x0, t, rtol=1e-10, atol=1e-10)
        b = simulate(top, x0, t, rtol=1e-12, atol=1e-12)
        err = float(np.max(np.abs(b.part("R")[-1] - R_exact)))
        est = float(np.max(np.abs(a.x[-1] - b.x[-1]))) * 1e-2  # rtol ratio 100
        res.compare("sleeping top at 1e3 rad/s, |R(1 s) - exp(s t e3^)|, cvodes", 0.0, err,
                    tolerance=1e-7, source="closed form of the steady spin")
        return Check(f"cvodes rtol 1e-12: {b.cost['steps']} steps; estimate from rtol 1e-10 "
                     f"{est:.1e}", err, "|R(T) - exp(s T e3^)| (closed form)", 1e-7)

    cases.run(group, "spin 1e3 rad/s (160 turns): cvodes", cvodes)

    for method, step, order in (("lgvi", 2e-5, 2), ("rkmk4", 2e-4, 4)):
        def run(method: str = method, step: float = step, order: int = order) -> Check:
            b, est = _richardson(top, x0, t, method, step, order)
            err = float(np.max(np.abs(b.part("R")[-1] - R_exact)))
            return Check(f"{method} h = {step / 2:g} (h s = {spin * step / 2:g}): error "
                         f"{err:.1e}, Richardson estimate {est:.1e}, energy error "
                         f"{b.diagnostics['invariant_drift']['energy']['max_rel']:.1e}, "
                         f"constraint {b.diagnostics['constraint_residual']['R']:.1e}",
                         err, "|R(T) - exp(s T e3^)|; correct if <= 3 x Richardson estimate",
                         3 * est + 1e-12)

        cases.run(group, f"spin 1e3 rad/s: {method}", run)

    def lgvi_too_long() -> Check:
        simulate(top, x0, t, method="lgvi", step=1e-3)
        raise AssertionError("unreachable")  # pragma: no cover

    cases.run(group, "spin 1e3 rad/s: lgvi h = 1e-3 (h s = 1)", lgvi_too_long,
              expect_failure=True)

    # periods near the separatrix of the inverted equilibrium (planar motion, Prop. 7):
    # T = 4 sqrt(Jt / (m g rs)) K(k), k = sin(theta0 / 2), measured between crossings of
    # the bottom (Gamma_1 = 0, transversal) located by poincare_map; near the separatrix
    # dT/dE = 4 / (lambda m g rs d^2), so an energy error dE moves T by that much, and the
    # orbit may cross the separatrix once dE reaches m g rs d^2 / 2
    from workbench.global_dynamics import Section, poincare_map

    lam = np.sqrt(MG * rs / Jt)
    bottom = Section("bottom", _gamma_1, description="Gamma_1 = 0 (pendulum at the bottom)")
    for d in (1e-2, 1e-4, 1e-6):
        def period(d: float = d) -> Check:
            x = top.state(R=so3_exp([0.0, np.pi - d, 0.0]), omega=[0.0, 0.0, 0.0])
            T_cf = 4 / lam * float(ellipkm1(np.sin(d / 2) ** 2))
            runs = {}
            for rtol in (1e-10, 1e-12):
                o = poincare_map(top, x, bottom, n_crossings=3, t_max=1.5 * T_cf, rtol=rtol,
                                 atol=rtol, sample_step=0.01)
                if o.n < 3:
                    raise SolverError(f"poincare_map found {o.n} crossings of the bottom in "
                                      f"1.5 T ({o.status.name})", status="crossings")
                runs[rtol] = (o.t[2] - o.t[0], o.diagnostics["max_invariant_error"])
            T, dE = runs[1e-12]
            gap = MG * rs * d * d / 2  # energy distance to the separatrix
            if dE >= gap / 2:
                raise SolverError(
                    f"energy error {dE:.1e} of cvodes at rtol 1e-12 is not small against the "
                    f"distance {gap:.1e} to the separatrix: the computed orbit can cross it, no "
                    f"period is measurable at this tolerance (measured T = {T:.6g} s, closed "
                    f"form {T_cf:.6g} s)", status="separatrix")
            est = max(abs(runs[1e-10][0] - T) / 99, 4 * dE / (lam * MG * rs * d * d))
            err = abs(T - T_cf)
            res.compare(f"period at pi - {d:g} rad [s]", T_cf, T, tolerance=3 * est,
                        source="4 sqrt(Jt/(m g rs)) K(sin(theta0/2))")
            return Check(f"poincare_map (cvodes rtol 1e-12) crossings of the bottom: T = "
                         f"{T:.10g} s, energy error {dE:.1e}; estimate max(rtol 1e-10 vs "
                         f"1e-12, 4 dE/(lambda m g rs d^2)) = {est:.1e} s", err,
                         "|T - closed form| [s]; correct if <= 3 x estimate", 3 * est)

        cases.run(group, f"separatrix: theta0 = pi - {d:g}", period)

    # long horizons of the geometric integrators
    horizon = 1e3 if quick else 1e5
    body = p3.full(J=J_CYL, rho=RHO_CYL)
    xb = body.state(R=np.eye(3), omega=[1.0, 1.0, 1.0])
    from models.chain_cart import link_state
    from models.spherical import spherical_pendulum

    sph = spherical_pendulum()
    xs = sph.state(q=link_state(np.array([np.sin(1.0), 0.0, np.cos(1.0)]), [0.0, 1.5, 0.0]))
    for model, x, method, step in ((body, xb, "lgvi", 0.02), (body, xb, "rkmk4", 0.02),
                                   (sph, xs, "s2_variational", 0.02)):
        def long(model: Any = model, x: np.ndarray = x, method: str = method,
                 step: float = step) -> Check:
            lt = long_time(model, x, horizon, [Sweep(method, (step,), {"jit": True})],
                           n_samples=1001)
            s = lt.runs[0].summary()
            if s["status"] != "ok":
                raise SolverError(s["status"], status="long_time")
            symplectic = method != "rkmk4"
            bounded = s["energy_exponent"] is not None and s["energy_exponent"] < 0.5
            ok = s["constraint_max"] <= 1e-10 and (bounded or not symplectic)
            return Check(f"long_time {horizon:g} s, h = {step:g} ({s['steps']} steps): energy "
                         f"error max {s['energy_max']:.1e} (early {s['energy_early']:.1e}, late "
                         f"{s['energy_late']:.1e}, growth exponent "
                         f"{s['energy_exponent']:.2f}), constraint drift "
                         f"{s['constraint_max']:.1e}", s["constraint_max"] if ok else np.inf,
                         "constraint drift" + ("; energy error bounded (exponent < 0.5)"
                                               if symplectic else "; energy drift measured"),
                         1e-10)

        cases.run(group, f"{horizon:.0e} s: {method} ({model.name})", long)


# ----------------------------------------------------------------------------------------
# continuation near the singular points of Prop. 9


def continuation(cases: Cases, res: Result, *, quick: bool) -> None:
    """Relative equilibria at alpha within 1e-12 of 0 (branches) and of 1/J_i (slices)."""
    from models.relative_equilibria import (
        alpha,
        limit_at_infinity,
        rotation_problem,
        slice_zeros,
        sphere_points,
        static_equilibria,
    )
    from models.relative_families import RelativeEquilibria, at_alpha
    from workbench.equilibria import StepControl, continue_branch

    group = "continuation"
    model = p3.reduced(J=J_CYL, rho=RHO_CYL)
    problem = rotation_problem(model)
    static = static_equilibria(model)
    ez = np.array([0.0, 0.0, 0.0, 1.0])
    branches, origins = [], []
    for name, eq in static.items():
        for sign in (1.0, -1.0):
            branches.append(continue_branch(problem, np.append(eq.x[:3], 0.0),
                                            direction=sign * ez, bounds={"k": (-0.5, 0.5)},
                                            control=StepControl(), max_points=200))
            origins.append(f"{name} {'+' if sign > 0 else '-'}k")
    atlas = RelativeEquilibria(problem, static, branches, origins, [], [], 0.5, 0, 0.0)
    for a in (1e-12, -1e-12):
        def near_zero(a: float = a) -> Check:
            found = at_alpha(atlas, a)
            g_cf, k_cf = prop9(J_CYL, RHO_CYL, a)
            errs = []
            for sp in found["points"]:
                gam, k = sp.y[:3], sp.y[3]
                errs.append(max(np.linalg.norm(gam - g_cf), abs(abs(k) - abs(k_cf)) / abs(k_cf)))
            if len(errs) != 2:
                raise SolverError(f"at_alpha({a:g}): {found['message']}", status="count")
            res.compare(f"|k| at alpha = {a:g} [rad/s]", abs(k_cf), abs(found["points"][0].y[3]),
                        tolerance=1e-6, relative=True, source="Prop. 9 (erratum)")
            side = "hanging" if a > 0 else "inverted"
            return Check(f"at_alpha on the branches through the statics: 2 points (+-k) near "
                         f"the {side} attitude, |k| = {abs(k_cf):.4g}, corrector residual "
                         f"{max(sp.residual for sp in found['points']):.1e}", max(errs),
                         "max(|Gamma - Prop. 9|, relative error of |k|)", 1e-6)

        cases.run(group, f"alpha = {a:+g}", near_zero)
    cases.run(group, "alpha = 0", lambda: at_alpha(atlas, 0.0), expect_failure=True)

    guesses = sphere_points(32 if quick else 64)
    for i in range(3):
        for side in (1.0, -1.0):
            a = 1.0 / J_CYL[i, i] + side * 1e-12

            def near_axis(a: float = a, i: int = i) -> Check:
                g_cf, k_cf = prop9(J_CYL, RHO_CYL, a)
                zs, failed = slice_zeros(problem, k_cf, guesses)
                if not zs:
                    raise SolverError(f"no zero on the slice k = {k_cf:.6g} ({failed} failures)",
                                      status="count")
                z = min(zs, key=lambda z: np.linalg.norm(z.y[:3] - g_cf))
                mon = problem.monitors(z.y)
                a_wb = float(alpha(mon["k"], mon["k1"]))
                err = max(np.linalg.norm(z.y[:3] - g_cf), abs(a_wb - a))
                return Check(f"slice_zeros at k = {k_cf:.6g} rad/s (closed form): {len(zs)} "
                             f"zeros, the nearest has alpha - 1/J{i + 1} = "
                             f"{a_wb - 1 / J_CYL[i, i]:+.2e}, residual {z.root.residual:.1e}",
                             err, "max(|Gamma - Prop. 9|, |alpha - alpha_cf|)", 1e-13)

            cases.run(group, f"alpha = 1/J{i + 1} {'+' if side > 0 else '-'} 1e-12", near_axis)

        def at_infinity(i: int = i) -> Check:
            zs, _ = slice_zeros(problem, 100.0, guesses)
            end = min(zs, key=lambda z: np.linalg.norm(np.abs(z.y[:3]) - np.eye(3)[i]))
            lim = limit_at_infinity(problem, end.y)
            err = abs(lim["alpha"] - 1.0 / J_CYL[i, i])
            res.compare(f"alpha at |k| -> infinity near e{i + 1}", 1 / J_CYL[i, i], lim["alpha"],
                        tolerance=max(10 * lim["change"], 1e-12), source="Sec. 4.3: 1/J_i")
            return Check(f"limit_at_infinity from k = 100 near e{i + 1}: alpha = "
                         f"{lim['alpha']:.12g}, last Richardson change {lim['change']:.1e}", err,
                         "|alpha_inf - 1/J_i|; correct if <= 10 x the Richardson change",
                         max(10 * lim["change"], 1e-12))

        cases.run(group, f"|k| -> infinity near e{i + 1}", at_infinity)


# ----------------------------------------------------------------------------------------
# large chains, one subprocess per case (peak resident memory per case)


def chain_case(n: int, horizon: float) -> dict[str, Any]:
    """Build, linearise, PBH, LQR and simulate the n-link chain; times and peak RSS.

    Runs in the calling process; :func:`large_chains` calls it in a fresh subprocess.
    """
    import resource

    from models.chain_cart import chain_cart, link_state
    from workbench import lqr, pbh, simulate
    from workbench.linear import linearize, mechanical_order

    stages: dict[str, float] = {}
    t0 = time.perf_counter()
    model = chain_cart(n)
    model.function("f")
    stages["build f"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    model.function("f_x")
    model.function("f_u")
    stages["build Jacobians"] = time.perf_counter() - t0
    x_e = np.concatenate([np.zeros(4)] + [link_state([0.0, 0.0, 1.0]) for _ in range(n)])
    t0 = time.perf_counter()
    lin = linearize(model, x_e)
    stages["linearize"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    test = pbh(lin)
    stages["pbh"] = time.perf_counter() - t0
    pos, vel = mechanical_order(model, {"x": "v"})
    Q = np.diag(np.r_[8.0, 8.0, np.ones(2 * n), 8.0, 8.0, np.ones(2 * n)])
    t0 = time.perf_counter()
    design = lqr(lin.permuted(pos + vel), Q, np.eye(2))
    stages["lqr"] = time.perf_counter() - t0
    dx = 1e-3 * np.random.default_rng(n).standard_normal(model.manifold.dim)
    x0 = model.manifold.retract(x_e, dx)
    t0 = time.perf_counter()
    tr = simulate(model, x0, np.linspace(0.0, horizon, 21), rtol=1e-8, atol=1e-10)
    stages["simulate"] = time.perf_counter() - t0
    finite = bool(np.all(np.isfinite(lin.A)) and np.all(np.isfinite(design.K))
                  and np.all(np.isfinite(tr.x)))
    return {"n": n, "horizon": horizon, "stages": stages, "dim": lin.dim,
            "controllable": test.controllable, "pbh_margin": test.margin,
            "riccati_residual": design.riccati_residual,
            "max_closed_loop_real": float(design.closed_loop_eigenvalues.real.max()),
            "energy_drift": tr.diagnostics["invariant_drift"]["energy"]["max_rel"],
            "constraint": max(tr.diagnostics["constraint_residual"].values()),
            "steps": tr.cost["steps"], "finite": finite,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _in_subprocess(n: int, horizon: float) -> dict[str, Any]:
    code = ("import json, sys; from problems._extremes_more import chain_case; "
            f"print('RESULT ' + json.dumps(chain_case({n}, {horizon!r})))")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=3600, check=False)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    if proc.returncode != 0 or not lines:
        tail = (proc.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise SolverError(f"chain n = {n} subprocess failed (exit {proc.returncode}): {tail}",
                          status=f"exit {proc.returncode}")
    return json.loads(lines[-1][len("RESULT "):])


def large_chains(cases: Cases, res: Result, *, quick: bool) -> None:
    """Chains of n = 20 (and 50 unless quick) links: build, linearise, PBH, LQR, simulate 2 s."""
    group = "large_chains"
    for n in ((20,) if quick else (20, 50)):
        def run(n: int = n) -> Check:
            out = _in_subprocess(n, 2.0)
            err = max(out["riccati_residual"], out["energy_drift"], out["constraint"])
            st = out["stages"]
            if not (out["finite"] and out["controllable"]):
                raise SolverError(f"chain n = {n}: finite {out['finite']}, controllable "
                                  f"{out['controllable']}", status="chain")
            return Check(
                f"dim {out['dim']}: build f {st['build f']:.2f} s, Jacobians "
                f"{st['build Jacobians']:.2f} s, linearize {st['linearize']:.2f} s, pbh "
                f"{st['pbh']:.2f} s (margin {out['pbh_margin']:.1e}), lqr {st['lqr']:.2f} s "
                f"(max Re {out['max_closed_loop_real']:.3g}), simulate 2 s "
                f"{st['simulate']:.2f} s ({out['steps']} steps); all finite", err,
                "max(Riccati residual, energy drift, constraint residual)", 1e-8,
                {"peak RSS [MB]": out["peak_rss_mb"]})

        cases.run(group, f"chain n = {n}", run)


# ----------------------------------------------------------------------------------------
# optimisation extremes (the swing-up OCP)


def optimisation(cases: Cases, res: Result, *, quick: bool) -> None:
    """Swing-up of the spherical pendulum on a cart at extreme bounds and horizons.

    The problem of :mod:`problems.swingup_spherical_cart` (|u_i| <= u_max, T free in
    [0.5, 3] s, Legendre collocation of degree 3, geodesic guess). A converged solve is
    correct when its local defect (each node integrated over its interval by CVODES against
    the next node, ``OCPSolution.error["local_defect"]``) is at most 1e-2, which every solve
    also demands through ``defect_tol``; the open-loop re-simulation error is shown too (it
    grows with the instability of the inverted target, which is what TVLQR is for).
    Failures carry Ipopt's status.
    """
    from problems.swingup_spherical_cart import problem
    from workbench.control.ocp import Collocation, continuation, solve

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
        sol, path = continuation(problem(u_max=2.0), Collocation(N=40), guess=ref,
                                 steps=[{"u_lower": -b, "u_upper": b} for b in (6, 4, 3, 2)],
                                 defect_tol=tol)
        return check(sol, f"continuation 10 -> 6 -> 4 -> 3 -> 2 N ({len(path)} solves)")

    plan: list[tuple[str, Any]] = [
        ("reference: |u| <= 10 N, T in [0.5, 3] s", run),
        ("|u| <= 1 N", lambda: run(1.0, max_iter=300)),
        ("T = 0.05 s fixed (too short)", lambda: run(T=0.05, N=20, max_iter=300)),
        ("T = 100 s fixed on N = 20 (too coarse)", lambda: run(T=100.0, N=20, max_iter=500)),
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


# ----------------------------------------------------------------------------------------
# a sample of bad input (the full table is tests/extremes/test_extreme_bad_input.py)


def bad_inputs(cases: Cases) -> None:
    """A few bad calls and the messages they give."""
    from models.chain_cart import chain_cart
    from workbench import linearize, lqr, simulate, so3_log

    full = p3.full(J=J_CYL, rho=RHO_CYL)
    x0 = full.state(R=np.eye(3), omega=np.zeros(3))
    sample = {
        "J with a negative eigenvalue": lambda: p3.full(J=np.diag([1.0, 1.0, -1.0]),
                                                        rho=RHO_CYL),
        "rho with NaN": lambda: p3.full(J=J_CYL, rho=[np.nan, 0.0, 0.0]),
        "mass 0": lambda: p3.full(J=J_CYL, rho=RHO_CYL, m=0.0),
        "chain with 1.5 links": lambda: chain_cart(1.5),
        "initial attitude 2 I": lambda: simulate(full, np.r_[2 * np.eye(3).ravel(), 0, 0, 0],
                                                 [0, 1]),
        "output times not monotone": lambda: simulate(full, x0, [0.0, 2.0, 1.0]),
        "unknown method": lambda: simulate(full, x0, [0, 1], method="euler"),
        "log of a reflection": lambda: so3_log(np.diag([1.0, 1.0, -1.0])),
        "linearise off equilibrium": lambda: linearize(
            full, full.state(R=np.eye(3), omega=[1.0, 0, 0])),
        "LQR of an uncontrollable pair": lambda: lqr(np.eye(2), np.eye(2), np.eye(1),
                                                     B=np.array([[1.0], [0.0]])),
        "unknown parameter": lambda: full.with_parameters(mass=2.0),
        "off-manifold state to SO3().check": lambda: SO3().check(np.ones((3, 3))),
    }
    for name, call in sample.items():
        cases.run("bad_input", name, call, expect_failure=True)
