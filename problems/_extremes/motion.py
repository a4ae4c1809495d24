"""Extremes, fast and slow motion: spin 1e3 rad/s, periods near the separatrix, 10^5 s."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.special import ellipkm1

from models import pendulum3d as p3
from problems._extremes.common import E3, J_CYL, MG, RHO_CYL
from workbench.core.errors import SolverError
from workbench.core.manifolds import SO3, so3_exp
from workbench.study import Cases, Check, Result


def _gamma_1(ctx: Any) -> Any:
    """First component of the reduced attitude ``Gamma = R^T e3`` (a section builder)."""
    return (SO3.matrix(ctx["R"]).T @ E3)[0]


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
    from workbench.simulation.accuracy import AccuracySweep, long_time

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
            lt = long_time(model, x, horizon, [AccuracySweep(method, (step,), {"jit": True})],
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


