"""The checks of a finished CVODES run: growth, the manifold, the invariants.

Part of :mod:`workbench.simulation._cvodes` (re-exported there): see that module's docstring
for why an adaptive run needs them and what they cannot see.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.core._model import Model
from workbench.core.errors import SolverError
from workbench.core.status import StatusEnum
from workbench.simulation._invariant_check import (
    DRIFT_LIMIT,
    ROUNDOFF,
    TOLERANCE_SAFETY,
    Watch,
    classify,
    classify_projected,
    confirm,
    first_excess,
    invariant_values,
    projected,
    roundoff_allowance,
    tolerance_allowance,
)
from workbench.simulation._probe import Probe
from workbench.simulation._stability import GROWTH_LIMIT, StepCheck

__all__ = ["CvodesCheck", "RunCheck", "AGAIN_STEPS", "AGAIN_RTOL"]

AGAIN_STEPS = 100
"""Before a run is refused for an invariant, the output interval where it left its
allowance is integrated again with ``max_step`` this fraction of the interval."""

AGAIN_RTOL = 1e-2
"""A state beyond the growth allowance is the flow's when the output interval integrated
again with the step bounded (``AGAIN_STEPS``) reproduces it to what the tolerances allow,
and never worse than this fraction of its size (an exploded state is off by orders of
magnitude)."""

class CvodesCheck(StatusEnum):
    """Outcome of the checks of a finished CVODES run (the ``status`` of its SolverError)."""

    PASSED = ("no state grew beyond the flow's bound or left the manifold, and no kept "
              "invariant moved beyond what the tolerances allow")
    EXPLODED = "a state grew by orders of magnitude beyond what the flow allows from x0"
    LEFT_MANIFOLD = "a state left the manifold by more than the constraint's scale"
    INVARIANT_DRIFT = ("an invariant the closed-loop field conserves (or does not increase) "
                       "moved (or rose) beyond what the tolerances allow")

    @classmethod
    def successes(cls) -> frozenset[str]:
        """Only ``PASSED``."""
        return frozenset({"PASSED"})


def _text(x: np.ndarray) -> str:
    return np.array2string(np.asarray(x), precision=4, max_line_width=10_000)


def _without(watch: Watch, limits: dict[str, float], name: str
             ) -> tuple[Watch, dict[str, float]]:
    """``watch`` and ``limits`` without the invariant ``name``."""
    return (Watch([n for n in watch.conserved if n != name],
                  [n for n in watch.non_increasing if n != name], watch.scale, watch.at,
                  watch.grad_norm), {n: v for n, v in limits.items() if n != name})


@dataclass(frozen=True)
class RunCheck:
    """The after-the-fact checks of one CVODES run (what applies of the fixed-step ones).

    CVODES controls an *estimate* of its local error; where the estimate is wrong (a
    feature of the field between two stages, tolerances too loose for the problem) the
    run can be wrong with no error from CVODES. :meth:`run` refuses, in order:

    * **growth**: a state larger than ``GROWTH_LIMIT`` (1e4) times what the flow allows
      from ``x0`` (the fixed-step methods' bound,
      :meth:`~workbench.simulation._stability.StepCheck._check_growth`) that a rerun of
      its output interval with the step bounded does not reproduce (a reproduced one is
      the flow's, and the bound starts again from it);
    * **the manifold**: a constraint residual that moved by more than ``DRIFT_LIMIT`` (1)
      times the constraint's scale ``max(|h(x0)|, |dh(x0)| |x0|)`` (2 for a unit vector's
      ``|q|^2 - 1``): the state is nowhere near the manifold;
    * **invariants**: one the closed-loop field (the controller, if any, in the loop)
      conserves at every sampled state (or at their projections to the manifold, when
      that keeps more of them: off it the ambient field need not conserve them) that
      moved, or one it does not increase that rose, by more than
      :func:`~workbench.simulation._invariant_check.tolerance_allowance` times
      ``TOLERANCE_SAFETY`` (what the tolerances allow), capped at ``DRIFT_LIMIT`` times
      its scale (the fixed-step bound), plus the round-off at the state
      (:func:`~workbench.simulation._invariant_check.roundoff_allowance`: ``ROUNDOFF eps``
      times the size of its terms there). An invariant the loop feeds at one sampled
      state (a controller working on it, a load) is not checked. Before a refusal, the
      class is confirmed at every output up to it, and the output interval
      is integrated again with the step bounded by ``1 / AGAIN_STEPS`` of it; an
      invariant that moves along that run too is moved by the field itself (it is not
      smooth there) and is not refused.

    Only the output states are seen: a step across a narrow feature that lands where the
    invariant has its old value (a potential wall passed between two outputs, at equal
    energy on both sides) is not detectable here; ``max_step`` is the remedy.

    Attributes
    ----------
    model : Model
        The model.
    probe : Probe
        Its functions (:func:`~workbench.simulation._probe.probe_for`).
    options : dict
        The run's CVODES options (:func:`~workbench.simulation._cvodes.cvodes_options`).
    steps : int
        CVODES' steps.
    unforced : bool
        No controller in the loop (for the messages; the invariants are classified by the
        closed-loop field either way).
    """

    model: Model
    probe: Probe
    options: dict[str, Any]
    steps: int
    unforced: bool

    @property
    def rtol(self) -> float:
        """The run's relative tolerance."""
        return float(self.options["reltol"])

    @property
    def atol(self) -> float:
        """The run's absolute tolerance."""
        return float(self.options["abstol"])

    @property
    def _advice(self) -> str:
        step = self.options.get("max_step_size")
        bound = "unbounded" if step is None else f"{step:g}"
        return (f"CVODES' error estimate missed the error of its steps. An adaptive step sees "
                f"the field only at its stages: a feature of the field narrower than a step (a "
                f"wall, a pulse) can be stepped over unseen. Pass max_step below that "
                f"feature's width (now {bound}), or a tighter rtol (now {self.rtol:g}) and atol "
                f"(now {self.atol:g})")

    def run(self, t: np.ndarray, x: np.ndarray, xdot: np.ndarray | None = None,
            drift: dict[str, Any] | None = None, residual: dict[str, float] | None = None
            ) -> dict[str, Any]:
        """All the checks on a finished run; raise SolverError, or return the diagnostics.

        Parameters
        ----------
        t : ndarray, shape=(n_times,)
            Output times.
        x : ndarray, shape=(n_times, ambient_dim)
            States (finite).
        xdot : ndarray, shape=(n_times, ambient_dim), optional
            The field at the states, when already computed.
        drift : dict, optional
            The run's ``invariant_drift`` diagnostics, when already computed.
        residual : dict, optional
            The run's ``constraint_residual`` diagnostics (the largest per factor), when
            already computed (a factor whose residual is far within its allowance is then
            not evaluated again).

        Returns
        -------
        dict
            ``{"checks": {...}}``: ``status`` (``"passed"``), ``conserved_invariants`` and
            ``non_increasing_invariants`` (those checked) and
            ``drift_allowance`` (per checked invariant, the drift it was allowed).

        Raises
        ------
        SolverError
            Status ``exploded``, ``left_manifold`` or ``invariant_drift``
            (:class:`CvodesCheck`), naming the time and the state.
        """
        self._check_growth(t, x, xdot)
        self._check_manifold(t, x, residual)
        watch, limits = self._check_invariants(t, x, drift)
        return {"checks": {
            "status": CvodesCheck.PASSED.code,
            "conserved_invariants": watch.conserved,
            "non_increasing_invariants": watch.non_increasing,
            "drift_allowance": limits,
        }}

    def _check_growth(self, t: np.ndarray, x: np.ndarray, xdot: np.ndarray | None) -> None:
        """Refuse states grown beyond ``GROWTH_LIMIT`` times what the flow allows.

        The allowance is that of the fixed-step methods from the run's start: its scale,
        its drift at the initial speed and acceleration, and the growth of the linearised
        field there. A motion can enter an unstable region later (rolling off a hill
        that is flat at ``x0``), so before a refusal the output interval that left the
        allowance is integrated again from its start with the step bounded
        (:meth:`_again`): where that run reproduces the state (:meth:`_reproduced`), the
        state is the flow's, and the check goes on from it with its own allowance (the
        linearisation there). A state the bounded run does not reproduce is refused.
        """
        size = np.max(np.abs(x), axis=1)
        start = 0
        while True:
            found = self._first_growth(t[start:], x[start:], None if xdot is None else
                                       xdot[start:], size[start:])
            if found is None:
                return
            k, allowed_k, alpha = found
            k += start
            again, bound = self._again(float(t[k - 1]), x[k - 1], float(t[k]))
            if again is not None and self._reproduced(again, x[k]):
                start = k
                continue
            rerun = (f"integrating again from t = {t[k - 1]:.6g} with max_step = {bound:.3g} "
                     + ("failed" if again is None else
                        f"gives x = {_text(again)}, not the run's state to "
                        f"{AGAIN_RTOL:g} of its size"))
            raise SolverError(
                f"cvodes integrating {self.model.name}: the state grew to max |x| = "
                f"{size[k]:.3g} by t = {t[k]:.6g} (x = {_text(x[k])}), more than "
                f"{GROWTH_LIMIT:.0e} times what the flow allows from the state at t = "
                f"{t[start]:.6g}, {allowed_k:.3g} (max(|x0|, |t - t0| |f(x0)|, |t - "
                f"t0|^2 |A f(x0)| / 2) times the growth exp(alpha t) of the linearised field "
                f"there, alpha = {alpha:.3g}); {rerun}. {self._advice}",
                status=CvodesCheck.EXPLODED.code)

    def _growth_allowance(self, t: np.ndarray, x: np.ndarray, xdot: np.ndarray | None
                          ) -> tuple[np.ndarray, float]:
        """The fixed-step methods' growth allowance from ``x[0]`` (with the growth rate)."""
        step = StepCheck(self.model, self.probe, "cvodes", None, False, 0.0)
        return step._growth_allowance(t, x, xdot, rate=True)

    def _first_growth(self, t: np.ndarray, x: np.ndarray, xdot: np.ndarray | None,
                      size: np.ndarray) -> tuple[int, float, float] | None:
        """The first output beyond ``GROWTH_LIMIT`` times the allowance from ``x[0]``.

        Returns ``(k, allowance at k, alpha)`` (the growth rate of the field linearised at
        ``x[0]``), or None.
        """
        # the allowance's first two terms, without the field's Jacobian (which a scene that
        # only simulates need not build)
        f0 = (np.asarray(xdot[0], dtype=float) if xdot is not None else
              np.asarray(self.probe.field(x[0], self.model.p)[0], dtype=float).ravel())
        base = np.maximum(np.max(np.abs(x[0])), np.abs(t - t[0]) * np.max(np.abs(f0)))
        if np.all(size <= GROWTH_LIMIT * base):
            return None
        step = StepCheck(self.model, self.probe, "cvodes", None, False, 0.0)
        allowed, _ = step._growth_allowance(t, x, xdot, rate=False)
        if np.all(size <= GROWTH_LIMIT * allowed):
            return None
        allowed, alpha = self._growth_allowance(t, x, xdot)
        bad = np.flatnonzero(~(size <= GROWTH_LIMIT * allowed))
        return (int(bad[0]), float(allowed[bad[0]]), alpha) if bad.size else None

    def _reproduced(self, again: np.ndarray, x: np.ndarray) -> bool:
        """Whether the bounded run's state ``again`` reproduces the run's ``x``.

        ``|again - x| <= min(AGAIN_RTOL, TOLERANCE_SAFETY (steps + AGAIN_STEPS) sqrt(n)
        rtol) max(|again|, |x|) + TOLERANCE_SAFETY (steps + AGAIN_STEPS) sqrt(n) atol``
        (max-norms): each of the two runs moves the state by at most its local errors
        (weighted norm below 1 per step); the cap keeps loose tolerances from accepting a
        state unlike the flow's (an exploded one is off by orders of magnitude).
        """
        size = max(float(np.max(np.abs(again))), float(np.max(np.abs(x))))
        k = TOLERANCE_SAFETY * (self.steps + AGAIN_STEPS) * np.sqrt(len(x))
        return bool(np.max(np.abs(again - x))
                    <= min(AGAIN_RTOL, k * self.rtol) * size + k * self.atol)

    def _check_manifold(self, t: np.ndarray, x: np.ndarray,
                        residual: dict[str, float] | None = None) -> None:
        """Refuse a constraint residual moved by more than ``DRIFT_LIMIT`` times its scale."""
        man = self.model.manifold
        for name, factor in man.factors:
            fns = factor.constraint_functions()
            if fns is None:
                continue
            block = x[:, man.slices[name]]
            h0 = np.asarray(fns[0](block[0]), dtype=float).ravel()
            jac = np.asarray(fns[1](block[0]), dtype=float).reshape(len(h0), -1)
            scale = np.maximum(np.maximum(np.abs(h0), np.linalg.norm(jac, axis=1)
                                          * np.linalg.norm(block[0])), np.finfo(float).tiny)
            if residual is not None and residual.get(name, np.inf) + np.max(np.abs(h0)) \
                    <= DRIFT_LIMIT * np.min(scale):  # |h(x) - h(x0)| <= |h(x)| + |h(x0)|
                continue
            h = np.asarray(fns[0](block.T), dtype=float).reshape(-1, len(x))
            moved = np.abs(h - h[:, :1]) / scale[:, None]
            bad = np.flatnonzero(~np.all(moved <= DRIFT_LIMIT, axis=0))
            if not bad.size:
                continue
            k = int(bad[0])
            j = int(np.argmax(np.where(np.isfinite(moved[:, k]), moved[:, k], np.inf)))
            raise SolverError(
                f"cvodes integrating {self.model.name}: the state left the manifold: the "
                f"constraint residual of factor {name!r} (component {j}) is {h[j, k]:.3g} at t = "
                f"{t[k]:.6g} (x = {_text(x[k])}) moved from {h[j, 0]:.3g} at t = {t[0]:g} by "
                f"more than {DRIFT_LIMIT:g} times its scale {scale[j]:.3g} (max(|h(x0)|, "
                f"|dh(x0)| |x0|)). {self._advice}", status=CvodesCheck.LEFT_MANIFOLD.code)

    def _limits(self, watch: Watch, x: np.ndarray) -> dict[str, float]:
        allow = tolerance_allowance(watch, x, rtol=self.rtol, atol=self.atol, steps=self.steps)
        return {n: float(min(TOLERANCE_SAFETY * allow[n], DRIFT_LIMIT * watch.scale[n]))
                for n in watch.names}

    def _again(self, t0: float, x0: np.ndarray, t1: float) -> tuple[np.ndarray | None, float]:
        """The state at ``t1`` from ``x0`` at ``t0``, the step bounded, and the bound.

        The bound is ``|t1 - t0| / AGAIN_STEPS`` (or the run's, if smaller); the run's other
        options are kept. The state is None where CVODES fails.
        """
        bound = min(abs(t1 - t0) / AGAIN_STEPS, self.options.get("max_step_size", np.inf))
        model = self.model
        xs = model.sym.sym("x", model.manifold.ambient_dim)
        ps = model.sym.sym("p", model.n_params)
        again = ca.integrator("cvodes_check_again", "cvodes",
                              {"x": xs, "p": ps, "ode": self.probe.field(xs, ps)[0]}, 0.0,
                              abs(t1 - t0), {**self.options, "max_step_size": bound})
        try:
            return np.asarray(again(x0=x0, p=model.p)["xf"], dtype=float).ravel(), bound
        except RuntimeError:
            return None, bound

    def _check_invariants(self, t: np.ndarray, x: np.ndarray, drift: dict[str, Any] | None
                          ) -> tuple[Watch, dict[str, float]]:
        """Refuse a kept invariant moved beyond its allowance; return the watch and limits.

        The invariants are classified at sampled output states, or at their projections
        to the manifold when that keeps more of them (off the manifold the ambient field
        need not conserve them). Before a refusal the class is confirmed at every output
        state up to the excess (the allowance then takes ``|grad I|`` at all of them), and
        the output interval is integrated again from its start with the step bounded
        (:meth:`_again`): where the invariant moves along that run too, the field itself
        moves it there (an invariant that is not smooth, which the rates at the states
        cannot show), and it is no longer watched.
        """
        model = self.model
        names = model.invariant_names
        initial = None if drift is None else np.array(
            [float(drift[n]["initial"]) for n in names])
        watch = classify(self.probe, model, x, [0], initial)
        on_manifold = False
        if len(watch.scale) < len(names) and model.manifold.dim < model.manifold.ambient_dim:
            found = classify_projected(self.probe, model, x, [0], initial)
            if len(found.scale) > len(watch.scale):
                watch, on_manifold = found, True
        limits = self._limits(watch, x)
        known = drift or {}
        if all(n in known and float(known[n]["max_abs"]) <= limits[n] for n in watch.names):
            return watch, limits  # the common case: nothing moved beyond its allowance
        values = invariant_values(model, x)
        confirmed: set[str] = set()
        roundoff: np.ndarray | None = None
        while (hit := first_excess(watch, names, values, values[:, 0], limits, roundoff)
               ) is not None:
            name, j = hit
            if roundoff is None:  # round-off at every state, by the size of the terms there
                roundoff = roundoff_allowance(self.probe, model, projected(model, x)
                                              if on_manifold else x, values)
                continue
            if name not in confirmed:  # its class at every output state up to the excess
                confirmed.add(name)
                upto = x[: j + 1]
                kept = confirm(self.probe, model, projected(model, upto) if on_manifold
                               else upto, watch)
                if name not in kept.scale:  # fed somewhere: not checked
                    watch, limits = _without(watch, limits, name)
                else:
                    limits[name] = max(limits[name], self._limits(kept, upto)[name])
                continue
            k = names.index(name)
            rising = name in watch.non_increasing
            again, bound = self._again(float(t[j - 1]), x[j - 1], float(t[j]))
            if again is not None:
                v_again = float(invariant_values(model, again[None, :])[k, 0])
                moved = v_again - values[k, j - 1]
                if not (moved if rising else abs(moved)) <= limits[name] + roundoff[k, j]:
                    # the field moves it
                    watch, limits = _without(watch, limits, name)
                    continue
                again_text = (f"; integrated again from t = {t[j - 1]:.6g} with max_step = "
                              f"{bound:.3g}, it is {v_again:.10g} at t = {t[j]:.6g} (x = "
                              f"{_text(again)})")
            else:
                again_text = (f"; integrating again from t = {t[j - 1]:.6g} with max_step = "
                              f"{bound:.3g} failed")
            raise self._drift_error(t, x, values, watch, limits, name, j,
                                    again_text, float(roundoff[k, j]))
        return watch, limits

    def _drift_error(self, t: np.ndarray, x: np.ndarray, values: np.ndarray, watch: Watch,
                     limits: dict[str, float], name: str, j: int, again: str,
                     roundoff: float) -> SolverError:
        """The SolverError for the invariant ``name`` beyond its allowance at output ``j``."""
        k = self.model.invariant_names.index(name)
        change = values[k, j] - values[k, 0]
        bound = (f"{abs(change) / limits[name]:.3g} times what the tolerances allow, "
                 f"{limits[name]:.3g} ({TOLERANCE_SAFETY:g} x {self.steps} steps x sqrt(n) x "
                 f"max |grad I| (rtol |x| + atol): each step's error moves it by at most its "
                 f"part along grad I, and CVODES keeps that error below the tolerances)"
                 if limits[name] < DRIFT_LIMIT * watch.scale[name] else
                 f"more than {DRIFT_LIMIT:g} times its scale {watch.scale[name]:.3g} "
                 f"(max(|I(x0)|, |grad I(x0)| |x0|))")
        bound += (f", plus {roundoff:.3g} for round-off ({ROUNDOFF:g} eps times max(|I|, "
                  f"|grad I| |x|) at x0 and at the state)")
        return SolverError(
            f"cvodes integrating {self.model.name}: the invariant {name!r}, which the "
            f"{'field (no controller)' if self.unforced else 'closed-loop field'} "
            + ("does not increase at any output state (it can only fall along the exact "
               "flow), rose" if name in watch.non_increasing else
               "conserves at every output state, changed")
            + f" from {values[k, 0]:.10g} to {values[k, j]:.10g} by t = {t[j]:.6g} (x = "
            f"{_text(x[j])}), a drift of {change:.3g}: {bound}{again}. {self._advice}. A step "
            f"across such a feature that lands where the invariant has its old value (a wall "
            f"crossed between two outputs, with equal energy on both sides) is not detectable "
            f"at the outputs", status=CvodesCheck.INVARIANT_DRIFT.code)
