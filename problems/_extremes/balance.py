"""Extremes, near-balanced pendulum: |rho| from 1e-2 to 0 (equilibria, spectra, LQR)."""

from __future__ import annotations

import numpy as np

from models import pendulum3d as p3
from problems._extremes.common import J_CYL, RHO_HAT, frequencies, rotation_taking, spectrum_error
from workbench.study import Cases, Check, Result


def near_balanced(cases: Cases, res: Result, scales: list[float]) -> None:
    """Equilibria, spectra (3.22)-(3.28) and LQR for rho = s * rho_hat of the cylinder."""
    from models.relative_equilibria import static_equilibria
    from workbench import linearize, lqr

    group = "near_balanced"
    for s in scales:
        rho = s * RHO_HAT
        tag = f"|rho| = {s:g}"

        def equilibria(rho: np.ndarray = rho, s: float = s) -> Check:
            st = static_equilibria(p3.reduced(J=J_CYL, rho=rho))
            err = max(np.linalg.norm(st["hanging"].x[:3] - RHO_HAT),
                      np.linalg.norm(st["inverted"].x[:3] + RHO_HAT))
            res.compare(f"hanging/inverted Gamma at |rho| = {s:g}", 0.0, err, tolerance=1e-12,
                        source="(3.8)-(3.9): Gamma = +-rho/|rho|")
            return Check(f"static_equilibria: hanging and inverted, residual "
                         f"{st['hanging'].residual:.1e}, local dimension "
                         f"{st['hanging'].local_dimension} (rank_rtol 1e-8)",
                         err, "|Gamma - (+-rho/|rho|)|", 1e-12)

        cases.run(group, f"{tag}: static equilibria", equilibria, expect_failure=s == 0)

        def spectra(rho: np.ndarray = rho, s: float = s) -> Check:
            model = p3.full(J=J_CYL, rho=rho)
            errs, kinds = [], []
            for inverted in (False, True):
                target = np.array([0.0, 0.0, -1.0 if inverted else 1.0])
                R = rotation_taking(RHO_HAT, target) if s > 0 else np.eye(3)
                lin = linearize(model, model.state(R=R, omega=np.zeros(3)))
                ev = np.linalg.eigvals(lin.A)
                if s > 0:
                    w = frequencies(J_CYL, rho)
                    errs.append(spectrum_error(ev, w, inverted=inverted))
                    res.compare(f"{'inverted' if inverted else 'hanging'} |lambda|max at "
                                f"|rho| = {s:g}", w.max(), np.abs(ev).max(), tolerance=1e-9,
                                relative=True, source="paper 000 (3.22)-(3.28)")
                else:  # balanced: A is nilpotent, every eigenvalue 0
                    errs.append(float(np.abs(ev).max()))
                from workbench.linear import eigenstructure

                kinds.append(eigenstructure(lin).stability.value)
            return Check(f"linearize (full, dim 6) at hanging/inverted: {kinds[0]} / "
                         f"{kinds[1]}", max(errs),
                         "relative error of eigenvalues vs +-i sqrt(mgl_i), +-sqrt(mgl_i)"
                         if s > 0 else "max |eigenvalue| (closed form: all 0)", 1e-9)

        cases.run(group, f"{tag}: spectra", spectra)

        def regulator(rho: np.ndarray = rho, s: float = s) -> Check:
            model = p3.reduced(J=J_CYL, rho=rho)
            lin = linearize(model, model.state(Gamma=-RHO_HAT, omega=np.zeros(3)))
            d = lqr(lin, np.eye(5), np.eye(3))
            return Check(f"lqr at the inverted attitude, Q = I, R = I: max Re(A - BK) = "
                         f"{d.closed_loop_eigenvalues.real.max():.4g}, PBH margin "
                         f"{d.controllability.margin:.2g}", d.riccati_residual,
                         "relative Riccati residual", 1e-12)

        cases.run(group, f"{tag}: LQR", regulator)


