"""CVODES' corrector: functional (fixed-point) iteration against Newton, same run.

Issue 18 (the report's time): with Adams, ``simulate`` used casadi's Newton corrector,
which forms and factorises the field's dense Jacobian; the ``Stepper`` (re-simulation,
sampled closed loops) and the TVLQR flows used casadi's defaults, BDF with Newton. The
workbench now defaults to Adams with functional iteration for these non-stiff integrations
(:class:`workbench.simulation.Corrector`). The baseline is Newton, the previous default,
timed in the same run: each scene is run with both correctors in turn (interleaved,
``--repeat`` rounds) and the script prints CPU-second medians, their ratio, the internal
steps of each, and the price in accuracy: each result's largest error against a reference
run at a 1000 times tighter tolerance (Newton; skipped for the 50-link chain, whose
reference would take minutes), so time and error stand side by side.
The load average is printed with the table: the 2 cores are shared.

Usage: python benchmarks/bench_corrector.py [--quick] [--repeat K]
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import quick_repeat_arguments, table  # noqa: E402

import workbench as wb  # noqa: E402
from models import pendulum3d as p3  # noqa: E402
from models.chain_cart import chain_cart  # noqa: E402
from models.chain_cart_reference import equilibrium  # noqa: E402
from workbench.control.ocp.stepper import Stepper  # noqa: E402


def chain_scene(n: int, horizon: float):
    """The extremes case: n-link chain near hanging, 2 s at rtol 1e-8 (21 outputs)."""
    model = chain_cart(n)
    x_e = equilibrium(n, (1.0,) * n)
    x0 = model.manifold.retract(
        x_e, 1e-3 * np.random.default_rng(n).standard_normal(model.manifold.dim))
    t = np.linspace(0.0, horizon, 21)

    def run(corrector, scale=1.0):
        tr = wb.simulate(model, x0, t, rtol=1e-8 * scale, atol=1e-10 * scale,
                         corrector=corrector)
        return tr.x, tr.cost["steps"]
    return f"simulate: chain n = {n}, {horizon:g} s, rtol 1e-8", run


def pendulum_scene():
    """The 3D pendulum swinging (energy below the inverted one), 10 s at rtol 1e-10."""
    model = p3.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0.0, 0.0, 0.3])
    x0 = model.state(R=wb.so3_exp([0.6, 0.3, 0.1]), omega=[0.5, 0.2, 1.0])
    t = np.linspace(0.0, 10.0, 101)

    def run(corrector, scale=1.0):
        tr = wb.simulate(model, x0, t, rtol=1e-10 * scale, atol=1e-10 * scale,
                         corrector=corrector)
        return tr.x, tr.cost["steps"]
    return "simulate: 3D pendulum swinging, 10 s, rtol 1e-10", run


def stepper_scene():
    """Sampled steps of the double cart near hanging (as in closed loops): 150 x 0.01 s."""
    model = chain_cart(2, m=0.5, masses=0.1, lengths=0.1)
    x_e = equilibrium(2, (1.0, 1.0))
    x0 = model.manifold.retract(
        x_e, 1e-1 * np.random.default_rng(0).standard_normal(model.manifold.dim))
    u = np.array([0.3, -0.2])
    steppers = {}

    def stepper(corrector, scale):
        multistep = "adams" if corrector == "functional" else "bdf"  # the old default: BDF
        key = (multistep, corrector, scale)
        if key not in steppers:
            steppers[key] = Stepper(model, rtol=1e-9 * scale, atol=1e-9 * scale,
                                    multistep=multistep, corrector=corrector)
        return steppers[key]

    for c in ("newton", "functional"):  # built before any timing: the build is not timed
        stepper(c, 1.0)

    def run(corrector, scale=1.0):
        st = stepper(corrector, scale)
        x, X = x0, [x0]
        for _ in range(150):
            x = st.step(x, u, 0.01)
            X.append(x)
        return np.array(X), None
    return "Stepper: double cart, 150 x 0.01 s (before BDF+Newton, now Adams+functional)", run


def measure(name, run, repeat, reference=True):
    times = {"newton": [], "functional": []}
    out = {}
    for k in range(repeat):  # the order alternates round by round
        for c in (("newton", "functional") if k % 2 == 0 else ("functional", "newton")):
            t0 = time.process_time()
            out[c] = run(c)
            times[c].append(time.process_time() - t0)
    med = {k: statistics.median(v) for k, v in times.items()}
    (xn, sn), (xf, sf) = out["newton"], out["functional"]
    err = "-"
    if reference:
        xr = run("newton", 1e-3)[0]
        err = (f"{float(np.max(np.abs(xn - xr))):.1e} / "
               f"{float(np.max(np.abs(xf - xr))):.1e}")
    return {"scene": name, "before (Newton) [s cpu]": f"{med['newton']:.3f}",
            "now (functional) [s cpu]": f"{med['functional']:.3f}",
            "ratio": f"{med['newton'] / med['functional']:.1f}x",
            "steps before/now": "-" if sn is None else f"{sn} / {sf}",
            "max error before/now": err}


def main() -> None:
    a = quick_repeat_arguments(__doc__, "one round, small scenes",
                               sys.argv[1:] if __name__ == "__main__" else [])
    repeat = 1 if a.quick else a.repeat
    scenes = [(*chain_scene(20, 2.0), True), (*pendulum_scene(), True),
              (*stepper_scene(), True)]
    if not a.quick:
        scenes.append((*chain_scene(50, 2.0), False))
    rows = [measure(name, run, repeat, ref) for name, run, ref in scenes]
    print(table(rows, list(rows[0])))
    print(f"(medians of {repeat} interleaved runs, CPU seconds; load average "
          f"{os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
