"""Integrator studies: sweeps, checks and figures around :mod:`workbench.simulation.accuracy`.

A work-precision study sets every integrator's error against its cost and checks the
measurements; these helpers are its reusable pieces:

* :func:`integrator_sweeps` -- cvodes over a range of tolerances, RK4, collocation and given
  geometric methods over steps;
* :func:`check_work_precision` -- the reference against an independent cvodes run, the
  fitted orders against the theoretical ones, the fastest method per accuracy;
* :func:`slowest_period` -- the period of the slowest small oscillation at an equilibrium,
  and :func:`long_time_periods` -- :func:`~workbench.simulation.accuracy.long_time` over a
  number of periods, sampled at a fixed spacing;
* :func:`compare_energy_growth`, :func:`compare_constraint` -- the long-time behaviour
  against what each method's structure predicts;
* :func:`per_step_costs` -- seconds per step against a baseline method, interpreted and jit;
* :func:`orders_figure` -- final error against step with the fitted points circled.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from workbench.core import Model
from workbench.simulation import Method, simulate
from workbench.simulation.accuracy import AccuracySweep, LongTime, WorkPrecision, long_time
from workbench.study._result import Result

__all__ = ["check_work_precision", "compare_constraint", "compare_energy_growth",
           "integrator_sweeps", "long_time_periods", "orders_figure", "per_step_costs",
           "slowest_period"]


def integrator_sweeps(steps: Sequence[float], geometric: Sequence[Method], *,
                      collocation_steps: Sequence[float], quick: bool) -> list[AccuracySweep]:
    """The sweeps of a work-precision study: cvodes, RK4, collocation, geometric methods.

    Parameters
    ----------
    steps : sequence of float
        Steps of RK4 and of the geometric methods.
    geometric : sequence of Method
        The geometric (fixed-step) methods, swept over ``steps``.
    collocation_steps : sequence of float
        Steps of casadi's Legendre collocation (degree 2), often fewer: it is costly.
    quick : bool
        cvodes at rtol 1e-3, 1e-5, .., 1e-11, 1e-12 instead of 1e-3, 1e-4, .., 1e-12.

    Returns
    -------
    list of AccuracySweep
        cvodes, RK4, collocation, then ``geometric`` in order.
    """
    rtols = [10.0**-k for k in range(3, 13)]
    if quick:
        rtols = rtols[::2] + [1e-12]
    out = [AccuracySweep(Method.CVODES, rtols),
           AccuracySweep(Method.RK, steps),
           AccuracySweep(Method.COLLOCATION, collocation_steps, {"degree": 2})]
    out += [AccuracySweep(m, steps) for m in geometric]
    return out


def check_work_precision(res: Result, wp: WorkPrecision, model: Model, x0: np.ndarray,
                         scene: str, *, reference_tolerance: float, order_tolerance: float,
                         accuracies: Sequence[float]) -> dict[str, Any]:
    """Check a work-precision result and pick the fastest methods.

    Compares the study's reference final state with cvodes at rtol = atol = 1e-13 (an
    independent method), and every fitted convergence order with the method's theoretical
    order.

    Parameters
    ----------
    res : Result
        Receives the comparisons, named after ``scene``.
    wp : WorkPrecision
        The study, from :func:`~workbench.simulation.accuracy.work_precision`.
    model : Model
        Its model.
    x0 : numpy.ndarray
        Its initial state.
    scene : str
        The scene's name in the comparisons.
    reference_tolerance : float
        Allowed max-norm difference between the reference and cvodes.
    order_tolerance : float
        Allowed difference between fitted and theoretical orders.
    accuracies : sequence of float
        Accuracies for which the fastest method is reported.

    Returns
    -------
    dict
        ``orders`` (:meth:`WorkPrecision.orders`) and ``fastest``
        (:meth:`WorkPrecision.winners`).
    """
    tr = simulate(model, x0, np.linspace(0, wp.horizon, 11), rtol=1e-13, atol=1e-13)
    dev = float(np.max(np.abs(tr.final - wp.reference.x_final)))
    res.compare(f"{scene}: {wp.reference.labels[0]} vs cvodes rtol 1e-13", 0.0, dev,
                tolerance=reference_tolerance, source="independent methods agree")
    orders = wp.orders()
    for lab, o in orders.items():
        if o["fitted"] is not None and o["theory"] is not None:
            res.compare(f"{scene}: fitted order of {lab} ({o['points']} steps)", o["theory"],
                        o["fitted"], tolerance=order_tolerance,
                        source="theoretical order of the method")
    return {"orders": orders, "fastest": wp.winners(accuracies)}


def slowest_period(model: Model, x_eq: np.ndarray) -> float:
    """Period ``2 pi / omega_min`` of the slowest oscillation at an equilibrium.

    The frequencies are the positive imaginary parts of the eigenvalues of the
    linearisation ``pinv(N) df/dx N`` (``N`` the tangent basis), from the model's graph; a
    natural time unit for long-time runs.

    Parameters
    ----------
    model : Model
        The model (inputs at zero).
    x_eq : numpy.ndarray
        An equilibrium with at least one oscillatory mode.

    Returns
    -------
    float
    """
    A = np.asarray(model.function("f_x")(x_eq, np.zeros(model.n_inputs), model.p))
    N = model.manifold.tangent_basis(x_eq)
    lam = np.linalg.eigvals(np.linalg.pinv(N) @ A @ N)
    freqs = lam.imag[lam.imag > 1e-9]
    return float(2 * np.pi / freqs.min())


def long_time_periods(res: Result, model: Model, x0: np.ndarray, period: float,
                      n_periods: int, settings: Sequence[AccuracySweep], *, name: str,
                      spacing: float) -> LongTime:
    """:func:`~workbench.simulation.accuracy.long_time` over ``n_periods`` periods, timed.

    The horizon is ``n_periods * period`` rounded to a multiple of ``spacing``, sampled
    every ``spacing``; the time goes to ``res.timings["long-time " + name]``.
    """
    horizon = round(n_periods * period / spacing) * spacing
    n_samples = int(round(horizon / spacing)) + 1
    with res.timed(f"long-time {name}"):
        return long_time(model, x0, horizon, settings, n_samples=n_samples)


def compare_energy_growth(res: Result, lt: LongTime, scene: str, n_periods: int,
                          expected: Sequence[tuple[str, float, float, str]]) -> None:
    """Compare the growth exponents of the energy errors with what the methods predict.

    Parameters
    ----------
    res : Result
        Receives one comparison per entry of ``expected``.
    lt : LongTime
        The long-time runs.
    scene : str
        The scene's name in the comparisons.
    n_periods : int
        The number of periods run (for the comparisons' names).
    expected : sequence of (label, tolerance, exponent, source)
        Per method label: the expected exponent (0 bounded, 1 linear drift), its tolerance
        and the reason.
    """
    rows = {r["label"]: r for r in lt.table()}
    for lab, tol_exp, ref_exp, src in expected:
        res.compare(f"{scene}, {lab}: growth exponent of the energy error over "
                    f"{n_periods} periods", ref_exp, rows[lab]["energy_exponent"],
                    tolerance=tol_exp, source=src)


def compare_constraint(res: Result, lt: LongTime, scene: str, labels: Sequence[str],
                       n_periods: int, *, tolerance: float, source: str) -> None:
    """Compare the largest constraint residual of the methods ``labels`` with 0."""
    rows = {r["label"]: r for r in lt.table()}
    for lab in labels:
        res.compare(f"{scene}, {lab}: constraint residual after {n_periods} periods",
                    0.0, rows[lab]["constraint_max"], tolerance=tolerance, source=source)


def per_step_costs(model: Model, x0: np.ndarray, steps: int, *,
                   methods: Sequence[str] = ("lgvi", "rkmk4"), baseline: str = "rk",
                   step: float = 0.01, repeats: int = 3) -> dict[str, dict[str, float]]:
    """Seconds per step of fixed-step methods against a baseline, same run.

    Each method runs in casadi's virtual machine and compiled (``jit=True``); the baseline in
    the virtual machine. Each is built (and compiled) first, then timed ``repeats`` times.

    Parameters
    ----------
    model : Model
        The model.
    x0 : numpy.ndarray
        Its initial state.
    steps : int
        Steps per timed run.
    methods : sequence of str
        The methods (``simulate``'s ``method``).
    baseline : str
        The method the others are set against.
    step : float
        The step.
    repeats : int
        Timed runs per method; the median is reported.

    Returns
    -------
    dict
        Per label (``baseline``, then each method and ``method + " jit"``):
        ``seconds_per_step`` and ``ratio_to_<baseline>``.
    """
    t = np.linspace(0.0, steps * step, 11)
    variants: list[tuple[str, Mapping[str, Any]]] = [(baseline, {"method": baseline})]
    for m in methods:
        variants += [(m, {"method": m}), (f"{m} jit", {"method": m, "jit": True})]
    out = {}
    for label, kw in variants:
        simulate(model, x0, t[:2], step=step, **kw)  # build (and compile) first
        walls = []
        for _ in range(repeats):
            tr = simulate(model, x0, t, step=step, **kw)
            walls.append(tr.cost["wall_seconds"] / tr.cost["steps"])
        out[label] = float(np.median(walls))
    return {k: {"seconds_per_step": v, f"ratio_to_{baseline}": v / out[baseline]}
            for k, v in out.items()}


def orders_figure(*wps: WorkPrecision) -> Any:
    """Final error against step for the fixed-step methods, one panel per study.

    The points the convergence order was fitted to are circled; the legend gives the fitted
    and the theoretical orders; a dotted line marks the reference's error estimate.
    """
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(wps), figsize=(5.5 * len(wps), 4))
    for ax, wp in zip(np.atleast_1d(axes), wps):
        for lab, o in wp.orders().items():
            rows = [r for r in wp.runs if r.label == lab and r.ok]
            line = ax.loglog([r.step for r in rows], [r.final_error for r in rows], "o-",
                             ms=4, label=f"{lab}: fitted {o['fitted']:.2f}, theory "
                             f"{o['theory']}" if o["fitted"] is not None else lab)[0]
            if o["fitted"] is not None:
                s = np.array(o["steps"])
                ax.loglog(s, np.array(o["errors"]), "o", mfc="none", ms=9,
                          color=line.get_color())
        ax.axhline(wp.reference.error_estimate, color="grey", ls=":", lw=1)
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("step h [s]")
        ax.set_ylabel("error at final time")
        ax.set_title(f"{wp.model}, T = {wp.horizon:g} s (circled: points fitted)")
        ax.legend(fontsize=7)
    fig.set_layout_engine("tight")  # laid out when drawn, once, at its final size
    return fig
