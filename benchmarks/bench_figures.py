"""Drawing curves on the sphere: segments per colour against drawing time and colour error.

Issue 18 (the report's time): the manifold figures of paper 002 draw up to 40 000
segments per panel, each its own polyline coloured by ``|Omega|``; matplotlib's drawing
time grows with the number of polylines (one ``Path`` per polyline, per draw), and the
figures of ``stable_manifolds_so3`` took about 2.5 s CPU each to write as SVG.
:func:`workbench.study.sphere_curves` now draws up to ``colour_run`` consecutive segments
as one polyline of one colour (their mean), when their values differ by at most
``colour_tol`` of the colour range. The baseline is ``colour_run = 1`` (every segment its
own colour, the previous drawing), timed in the same run: the settings are timed in turn,
round by round (interleaved), building the figure and writing it as the report does
(:func:`workbench.app.report.collect.figure_svg`), and the script prints CPU-second
medians, the ratio to the baseline, the polylines drawn and the price in colour: the
largest difference between the colour a segment is drawn in and its own value, on the
normalised colour scale (what is rendered; 0 for the baseline), and its 99th percentile.
The load average is printed with the table: the 2 cores are shared.

The scene is shaped like ``so3_manifold_figure`` (4 panels, 200 trajectories of the three
body axes each, 40 000 segments per panel, the speed growing like e^(r t) along each, r
drawn from [0.5, 2], the colour range fixed from 0 to the largest speed as in the manifold
figures).

Usage: python benchmarks/bench_figures.py [--quick] [--repeat K]
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parent.parent))
from _timing import interleaved_cpu, quick_repeat_arguments, table  # noqa: E402

from workbench.core.manifolds import so3_exp  # noqa: E402
from workbench.study import MAX_SEGMENTS, sphere_axes, sphere_curves  # noqa: E402

VMAX = 0.05 * np.exp(6.0)
"""Top of the colour range: the largest speed of the scene (as the manifold figures fix it)."""


def scene(n_traj: int, n_t: int, seed: int = 0) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Body-axis curves of ``n_traj`` rotations R(t) = R0 exp(theta(t) a^), speed ~ e^(r t)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 3.0, n_t)
    curves, values = [], []
    for _ in range(n_traj):
        a = rng.standard_normal(3)
        a /= np.linalg.norm(a)
        R0 = so3_exp(rng.standard_normal(3))
        rate = rng.uniform(0.5, 2.0)  # speed ~ e^(rate t), from 0.05 to at most VMAX
        theta = 0.05 * (np.exp(rate * t) - 1.0) / rate
        R = np.array([R0 @ so3_exp(th * a) for th in theta])
        speed = 0.05 * np.exp(rate * t)
        for i in range(3):
            curves.append(R[:, :, i])
            values.append(speed)
    return curves, values


def draw(curves, values, run: int, tol: float, panels: int):  # noqa: ANN001, ANN201
    """The figure: ``panels`` sphere panels with the curves and a colorbar, as SVG text."""
    import matplotlib.pyplot as plt

    from workbench.app.report.collect import figure_svg

    fig = plt.figure(figsize=(8.0, 4.0 * ((panels + 1) // 2)))
    colls = []
    for k in range(panels):
        ax = sphere_axes(fig, (((panels + 1) // 2), 2, k + 1))
        coll = sphere_curves(ax, curves, values, vmin=0.0, vmax=VMAX,
                             max_segments=MAX_SEGMENTS, colour_run=run, colour_tol=tol)
        fig.colorbar(coll, ax=ax, shrink=0.6, pad=0.0, label="|Omega| [rad/s]")
        colls.append(coll)
    fig.tight_layout()
    svg = figure_svg(fig, salt=f"bench{run}_{tol}")
    plt.close(fig)
    return colls[0], svg


def colour_error(coll, reference) -> tuple[float, float]:  # noqa: ANN001
    """Largest and 99th-percentile |drawn colour - segment's own| on the normalised scale."""
    seg_values = np.asarray(reference.get_array(), dtype=float)
    drawn = np.repeat(np.asarray(coll.get_array(), dtype=float),
                      [len(p) - 1 for p in coll._segments3d])
    err = np.abs(np.asarray(coll.norm(drawn)) - np.asarray(reference.norm(seg_values)))
    return float(np.max(err)), float(np.percentile(err, 99))


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    a = quick_repeat_arguments(__doc__, "one round, one panel",
                               sys.argv[1:] if __name__ == "__main__" else [])
    rounds, panels = (1, 1) if a.quick else (a.repeat, 4)
    curves, values = scene(200, 400)
    settings = [(1, 0.0), (4, 1.0), (8, 0.0), (8, 0.01), (8, 0.02), (8, 0.05)]
    drawn = {k: draw(curves, values, *k, panels) for k in settings}  # untimed: compared
    med = interleaved_cpu({k: (lambda k=k: draw(curves, values, *k, panels))
                           for k in settings}, rounds=rounds)
    ref = drawn[(1, 0.0)][0]
    base = med[(1, 0.0)]
    rows = []
    for k in settings:
        coll, svg = drawn[k]
        worst, p99 = colour_error(coll, ref)
        rows.append({"colour_run": k[0], "colour_tol": "-" if k[0] == 1 else f"{k[1]:g}",
                     "polylines per panel": len(coll._segments3d),
                     "figure + SVG [s cpu]": f"{med[k]:.2f}", "ratio to 1": f"{base / med[k]:.1f}x",
                     "SVG [kB]": len(svg) // 1000, "max colour error": f"{worst:.1e}",
                     "99th percentile": f"{p99:.1e}"})
    print(table(rows, list(rows[0])))
    n_seg = sum(len(p) - 1 for p in ref._segments3d)
    print(f"({panels} panel(s) of {len(curves)} curves, {n_seg} segments drawn per panel "
          f"(budget {MAX_SEGMENTS}); colour error on the normalised scale; medians of "
          f"{rounds} interleaved rounds, CPU seconds; load average "
          f"{os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()
