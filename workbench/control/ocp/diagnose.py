"""What went wrong in a failed OCP solve, in numbers, and what to try next.

:func:`diagnose` reads the last iterate of a solve that did not succeed: Ipopt's primal and
dual infeasibility (unscaled, as its iteration log prints them), the manifold residual of
the nodes, and the worst constraint by name and knot (a collocation defect of interval
``k``, the continuity at knot ``k``, a path constraint at knot ``k``, the terminal
condition). From these it proposes the next thing to try, in words that name the knobs of
:func:`~workbench.control.ocp.solve`. The advice is a reading of the numbers, not a
guarantee; the default strategy (:class:`~workbench.control.ocp.auto.Auto`) already tries
structured guesses and continuation before it gives up.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from workbench.control.ocp.transcription import ManifoldHandling, Transcription

__all__ = ["diagnose", "describe_diagnosis", "judge_constraints", "BOUND_RELAX"]

BOUND_RELAX = 1e-8
"""Ipopt's default ``bound_relax_factor``: it relaxes every bound by ``1e-8 max(1, |b|)``,
so a converged control may exceed its bound by that much (5.00000005 for a bound of 5)."""

FAR_OFF_MANIFOLD = 1e-3
"""A node residual above this reads as "the iterates left the manifold"."""

POLISH_RESIDUAL = 1e-6
"""Largest node residual a converged on-manifold solve is polished from (see
:func:`workbench.control.ocp.solve._polish`): beyond it the nodes are off the manifold for a
reason a tighter tolerance does not fix."""

LARGE_DUAL = 1e3
"""A dual infeasibility above this reads as "badly scaled, singular, or far from a minimum"."""


def _where(kind: str, knot: int, N: int) -> str:
    if kind == "defect":
        return f"collocation defect of interval {knot} (t in [{knot}, {knot + 1}] T/{N})"
    if kind == "continuity":
        return f"continuity at knot {knot} of {N}"
    if kind in ("terminal", "terminal chart domain"):
        return f"{kind} condition (knot {N})"
    if kind == "gauge":
        return "gauge (phase condition of the symmetry)"
    return f"path constraint {kind!r} at knot {knot} of {N}"


def diagnose(sol: Any, tr: Transcription, args: dict[str, Any], *,
             tol: float = 0.0) -> dict[str, Any]:
    """The numbers of a failed solve and the advice they suggest.

    Parameters
    ----------
    sol : OCPSolution
        The solve's result (its ``error`` and ``cost`` already filled in).
    tr : Transcription
        Its transcription (row kinds and knots).
    args : dict
        The solver's arguments (``lbg``, ``ubg``).
    tol : float
        Violations at or below it are met (Ipopt's ``tol`` of the solve): the worst
        constraint is one violated by more.

    Returns
    -------
    dict
        ``primal_infeasibility``, ``dual_infeasibility`` (of the last iterate; None where
        Ipopt reported no iteration),
        ``manifold_residual``, ``worst_constraint`` (``{"where", "kind", "knot",
        "violation"}``) and ``advice`` (a list of sentences).
    """
    viol = (np.zeros(0) if sol.g is None else
            np.maximum(np.maximum(args["lbg"] - sol.g, sol.g - args["ubg"]), 0.0))
    worst: dict[str, Any] = {"where": "none", "kind": None, "knot": None, "violation": 0.0}
    if viol.size and np.any(viol > tol):
        i = int(np.argmax(viol))
        kind, knot = str(tr.g_kinds[i]), int(tr.g_knots[i])
        worst = {"where": _where(kind, knot, tr.N), "kind": kind, "knot": knot,
                 "violation": float(viol[i])}
    inf_pr = sol.cost.get("last_inf_pr")
    inf_du = sol.cost.get("last_inf_du")
    res = float(sol.error["manifold_residual"])
    advice = _advice(sol, tr, worst, inf_du, res)
    return {"primal_infeasibility": inf_pr, "dual_infeasibility": inf_du,
            "manifold_residual": res, "worst_constraint": worst, "advice": advice}


def judge_constraints(sol: Any, args: dict[str, Any], *, tol: float, relax: float) -> float:
    """Hold a converged solve's constraints to ``tol``, not to Ipopt's word alone.

    Ipopt declares convergence by its own tolerances, which ``ipopt_options`` may loosen at
    will (``constr_viol_tol = 1e300`` returned SUCCESS 0.9 from the target). Each NLP row's
    violation (unscaled, against its bounds: the terminal slack of a continuation step
    included) is allowed ``tol max(1, |bound|, max |x|)``; an inequality and a variable's
    bound also Ipopt's bound relaxation ``relax max(1, |bound|)`` (Ipopt keeps its iterates
    inside the relaxed bounds). Above it the status becomes CONSTRAINTS_VIOLATED.

    Parameters
    ----------
    sol : OCPSolution
        A converged solve (``g``, ``w``, ``x``); its ``status`` and
        ``error["constraint_limit"]`` (the allowance of the worst entry) are set here.
    args : dict
        The solver's arguments (``lbg``, ``ubg``, ``lbx``, ``ubx``).
    tol : float
        :func:`~workbench.control.ocp.solve`'s ``tol``.
    relax : float
        Ipopt's ``bound_relax_factor`` in force, at most :data:`BOUND_RELAX`.

    Returns
    -------
    float
        The allowance of the worst entry (violation over allowance largest).
    """
    from workbench.control.ocp.solution import OCPStatus

    xmax = float(np.max(np.abs(sol.x)))

    def allowance(v: np.ndarray, lo: np.ndarray, hi: np.ndarray, *, rows: bool
                  ) -> tuple[np.ndarray, np.ndarray]:
        viol = np.maximum(np.maximum(lo - v, v - hi), 0.0)
        b = np.where(lo - v > v - hi, lo, hi)  # the bound each entry is nearest to break
        scale = np.maximum(1.0, np.abs(np.where(np.isfinite(b), b, 0.0)))
        own = tol * (np.maximum(scale, xmax) if rows else scale)
        return viol, own + np.where(lo < hi, relax * scale, 0.0)

    vg, ag = allowance(np.zeros(0) if sol.g is None else sol.g, args["lbg"], args["ubg"],
                       rows=True)
    vw, aw = allowance(sol.w, args["lbx"], args["ubx"], rows=False)
    viol, allowed = np.r_[vg, vw], np.r_[ag, aw]
    if not viol.size:
        return tol
    worst = int(np.argmax(viol / allowed))
    sol.error["constraint_limit"] = float(allowed[worst])
    if not viol[worst] <= allowed[worst]:
        sol.status = OCPStatus.CONSTRAINTS_VIOLATED
    return float(allowed[worst])


def _advice(sol: Any, tr: Transcription, worst: dict[str, Any], inf_du: float | None,
            res: float) -> list[str]:
    name = sol.status.name
    out = []
    ambient = tr.handling is ManifoldHandling.AMBIENT
    if ambient and (name == "OFF_MANIFOLD" or res > FAR_OFF_MANIFOLD):
        out.append("the ambient nodes drift off the manifold by the scheme's local error: "
                   "solve with handling=PROJECTED (the default) or LIE_GROUP, whose nodes "
                   "stay on it")
    elif name == "OFF_MANIFOLD" and res > POLISH_RESIDUAL:
        out.append(f"the {tr.handling.value} nodes are on the manifold only up to the "
                   f"continuity constraints' final violation ({res:.1e}, too large to polish: "
                   f"Ipopt stopped at its acceptable level): more iterations (max_iter, "
                   f"Auto(attempt_max_iter=)) or a smaller ipopt_options "
                   f"'acceptable_constr_viol_tol'")
    elif name == "OFF_MANIFOLD":
        out.append(f"the {tr.handling.value} nodes are on the manifold only up to the "
                   f"continuity constraints' final violation ({res:.1e}), which a re-solve "
                   f"with constr_viol_tol = manifold_tol / 10 did not remove: a manifold_tol "
                   f"above it")
    if name == "CONSTRAINTS_VIOLATED":
        out.append("Ipopt stopped by tolerances looser than solve's tol (ipopt_options "
                   "'tol', 'constr_viol_tol', 'acceptable_*'): leave them to solve's tol, or "
                   "pass the tol you accept")
    if name == "INACCURATE":
        out.append("the transcription does not follow the dynamics: more intervals N or a "
                   "higher collocation degree")
    if worst["kind"] in ("terminal", "terminal chart domain"):
        out.append("the target is not reached: a longer horizon (T or its range), a larger "
                   "input bound, or more swings in the guess (the default strategy continues "
                   "in the bound and the terminal condition)")
    elif worst["kind"] == "continuity" and name == "INFEASIBLE" and \
            worst["knot"] >= 0.8 * tr.N:
        out.append(f"the trajectory cannot be closed near the end (knot {worst['knot']} of "
                   f"{tr.N}): the target may be out of reach within the horizon and the "
                   f"bounds: a longer horizon (T or its range) or a larger input bound")
    elif worst["kind"] == "defect":
        out.append(f"the dynamics are violated most on interval {worst['knot']}: more "
                   f"intervals N, or a guess closer to a trajectory of the model")
    elif worst["kind"] not in (None, "continuity", "gauge"):
        out.append(f"the path constraint {worst['kind']!r} binds at knot {worst['knot']}: "
                   f"check that it admits a trajectory from x0 to the target")
    if inf_du is not None and inf_du > LARGE_DUAL:
        out.append(f"the dual infeasibility is {inf_du:.1e}: the problem may be badly scaled "
                   f"(state or input units far from 1), have a singular direction (a "
                   f"symmetry: keep gauge=True), or the guess is far from a minimum (the "
                   f"default strategy's structured guesses)")
    if name == "MAX_ITERATIONS" and not out:
        out.append("raise max_iter (and, with the default strategy, "
                   "Auto(attempt_max_iter=)), or start closer (a coarse solve refined: "
                   "coarse_to_fine)")
    if name == "INFEASIBLE" and not out:
        out.append("Ipopt found no feasible point near this guess: another guess (the default "
                   "strategy's), a longer horizon or a larger input bound")
    return out or ["no specific advice: see the numbers above"]


def describe_diagnosis(d: dict[str, Any]) -> str:
    """One readable paragraph of a :func:`diagnose` result."""
    w = d["worst_constraint"]
    worst = ("none violated" if w["kind"] is None else
             f"{w['where']}, violated by {w['violation']:.2e}")
    def num(v: Any) -> str:
        return "not reported" if v is None else f"{v:.2e}"

    return (f"primal infeasibility {num(d['primal_infeasibility'])}, dual infeasibility "
            f"{num(d['dual_infeasibility'])}, node manifold residual "
            f"{d['manifold_residual']:.2e}; worst constraint: {worst}. Try next: "
            + "; ".join(d["advice"]) + ".")
