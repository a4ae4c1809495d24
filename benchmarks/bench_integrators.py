"""Per-step cost of the geometric integrators against casadi's RK4 and cvodes, same run.

For the 3D pendulum (paper 000 Sec. 5.6 body, c = 4), the spherical pendulum and the
chain of three links on a cart: the median over repeated runs of the integration wall
time per step of casadi ``rk`` (the baseline), cvodes (rtol 1e-8, per internal step), and
the workbench's LGVI, S^2 variational integrator and RKMK4, each in casadi's virtual
machine and compiled (``jit=True``, SX models only). Construction and compilation are
done before timing. Printed: microseconds per step and the ratio to RK4 in the same run.

Usage: python benchmarks/bench_integrators.py [--quick]
"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import table  # noqa: E402

from models import pendulum3d as p3  # noqa: E402
from models.spherical import spherical_pendulum  # noqa: E402
from problems.work_precision import BODY, C_CHAOTIC, chain_cart, chain_initial_state  # noqa: E402
from workbench.simulation import simulate


def per_step(model, x0, t, kw, repeat: int) -> float:
    simulate(model, x0, t[:2], **kw)  # build / compile
    samples = []
    for _ in range(repeat):
        tr = simulate(model, x0, t, **kw)
        samples.append(tr.cost["wall_seconds"] / tr.cost["steps"])
    return statistics.median(samples)


def scene(name, model, x0, h, n_steps, methods, repeat) -> list[dict]:
    t = np.linspace(0.0, n_steps * h, 11)
    base = per_step(model, x0, t, {"method": "rk", "step": h}, repeat)
    rows = [{"scene": name, "method": "rk (baseline)", "us/step": f"{base * 1e6:.2f}",
             "ratio": "1.00"}]
    for label, kw in methods:
        kw = {"step": h, **kw} if kw.get("method") != "cvodes" else kw
        s = per_step(model, x0, t, kw, repeat)
        rows.append({"scene": name, "method": label, "us/step": f"{s * 1e6:.2f}",
                     "ratio": f"{s / base:.2f}"})
    return rows


def main() -> None:
    quick = "--quick" in sys.argv
    repeat = 3 if quick else 7
    n = 2000 if quick else 20000
    rows = []
    body = p3.full(**BODY)
    x0 = body.state(R=np.eye(3), omega=C_CHAOTIC * np.ones(3))
    rows += scene("3D pendulum", body, x0, 0.01, n, [
        ("cvodes rtol 1e-8", {"method": "cvodes", "rtol": 1e-8, "atol": 1e-8}),
        ("lgvi", {"method": "lgvi"}), ("lgvi jit", {"method": "lgvi", "jit": True}),
        ("rkmk4", {"method": "rkmk4"}), ("rkmk4 jit", {"method": "rkmk4", "jit": True}),
    ], repeat)
    sph = spherical_pendulum()
    q = np.array([np.sin(2.0), 0.0, np.cos(2.0)])
    s0 = sph.state(q=np.concatenate([q, np.cross(q, [0.0, 2.0, 0.0])]))
    rows += scene("spherical", sph, s0, 0.02, n, [
        ("s2_variational", {"method": "s2_variational"}),
        ("s2_variational jit", {"method": "s2_variational", "jit": True}),
        ("rkmk4", {"method": "rkmk4"}),
    ], repeat)
    chain = chain_cart(3)
    rows += scene("chain n=3 (MX)", chain, chain_initial_state(chain), 0.0005, n // 10, [
        ("cvodes rtol 1e-8", {"method": "cvodes", "rtol": 1e-8, "atol": 1e-8}),
        ("rkmk4", {"method": "rkmk4"}),
    ], repeat)
    print(table(rows, ["scene", "method", "us/step", "ratio"]))
    print("(medians of", repeat, "runs; ratio = per-step time / casadi rk per-step time, "
          "same run; cvodes per internal step)")


if __name__ == "__main__":
    main()
