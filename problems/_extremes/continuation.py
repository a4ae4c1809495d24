"""Extremes, continuation near the singular points alpha = 0 and 1/J_i of Prop. 9."""

from __future__ import annotations

import numpy as np

from models import pendulum3d as p3
from problems._extremes.common import J_CYL, RHO_CYL, prop9
from workbench.core.errors import SolverError
from workbench.study import Cases, Check, Result


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


