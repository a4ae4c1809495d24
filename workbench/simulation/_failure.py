"""Why a simulation failed: the last good state, the kinetic energy there, the step.

An integrator that fails (non-finite states, a Newton iteration that does not converge,
CVODES out of steps) reports where it stopped, not why. :func:`kinetic_energy_error`
runs the model's state check (a mechanics model's ``state_check``: its kinetic energy
positive definite) on the last states the run reached, so that a run that met a
singular kinetic energy says so, with the state and the time, instead of advising a
smaller step or more Newton iterations. :func:`cvodes_reach` finds the last state CVODES
can reach when it failed (casadi keeps nothing of a failed call): it walks forward with
restarts of a bounded number of steps each, halving the stride where one fails.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.core._feedback import feedback_function
from workbench.core._model import Model
from workbench.core.errors import ModelError, SolverError
from workbench.simulation._stability import StepCheck
from workbench.simulation.integrators.common import field_failure

__all__ = ["kinetic_energy_error", "cvodes_reach", "casadi_non_finite", "geometric_failure",
           "REACH_STEPS", "REACH_TRIES", "STALL_STRIDE", "KINETIC_ENERGY_STATUS"]

REACH_STEPS = 2000
"""CVODES steps allowed to each restart of :func:`cvodes_reach`."""

REACH_TRIES = 80
"""Restarts of :func:`cvodes_reach` (at most ``REACH_STEPS * REACH_TRIES`` steps: about a
second for a small model)."""

STALL_STRIDE = 1e-6
"""CVODES stalls (:func:`cvodes_reach`) where the strides it can still take are below this
fraction of the time it travelled."""

KINETIC_ENERGY_STATUS = "kinetic_energy_not_definite"
"""Status of the SolverError of a run that reached a state where the kinetic energy is not
positive definite."""


def _text(x: np.ndarray) -> str:
    return np.array2string(np.asarray(x), precision=4, max_line_width=10_000)


def kinetic_energy_error(model: Model, method: str, states: np.ndarray, times: np.ndarray,
                         what: str) -> SolverError | None:
    """The SolverError for a run that failed where its kinetic energy is not definite.

    Parameters
    ----------
    model : Model
        The model; without a ``state_check`` (not a mechanics model) nothing is checked.
    method : str
        The method's name, for the message.
    states : ndarray, shape=(n, ambient_dim)
        The last states the run reached, in order (finite).
    times : ndarray, shape=(n,)
        Their times.
    what : str
        How the run failed, for the message.

    Returns
    -------
    SolverError or None
        Status :data:`KINETIC_ENERGY_STATUS`, naming the state and the time (None: the
        kinetic energy is definite at every state, or the model has no state check).
    """
    check = getattr(model, "state_check", None)
    states = np.atleast_2d(np.asarray(states, dtype=float))
    keep = np.all(np.isfinite(states), axis=1)
    if check is None or not np.any(keep):
        return None
    try:
        check(model, states[keep], t=np.asarray(times, dtype=float).ravel()[keep],
              what="the states the run reached before failing")
    except ModelError as exc:
        return SolverError(
            f"{method} failed integrating {model.name} ({what}), at a state where the "
            f"kinetic energy is not positive definite: {exc}. No step size or iteration "
            f"count helps there: the equations of motion are singular (the mass matrix "
            f"cannot be inverted); the model's coordinates or its kinetic energy must be "
            f"changed, or the motion kept away from that state", status=KINETIC_ENERGY_STATUS)
    return None


def casadi_non_finite(model: Model, controller: ca.Function | None, check: StepCheck | None,
                      method: str, tv: np.ndarray, xs: np.ndarray) -> SolverError:
    """The SolverError for non-finite states of casadi's ``rk`` or ``collocation``.

    The field or the controller not finite at the last finite output; else the interval
    stepped again (``rk``) to the last finite state, where the kinetic energy is checked
    and the step linearised; else what is known.
    """
    bad = int(np.argmin(np.all(np.isfinite(xs), axis=1)))
    a = bad - 1  # the last finite output (x0 is finite)
    where = f"between t = {tv[a]:g} and t = {tv[bad]:g}"
    nan_field = field_failure(model, controller, xs[a], float(tv[a]))
    if nan_field is not None:
        return SolverError(f"{method} integrating {model.name}: the states became "
                           f"non-finite {where}: {nan_field}", status="non_finite_field")
    last_t, last_x = float(tv[a]), xs[a]
    if check is not None and check.linearised:
        loc = check.locate(float(tv[a]), xs[a], float(tv[bad]))
        last_t, last_x = loc.last_t, loc.last_x
        singular = kinetic_energy_error(model, method, np.vstack([xs[: a + 1], loc.states]),
                                        np.concatenate([tv[: a + 1], loc.times]),
                                        f"its states became non-finite {where}")
        if singular is not None:
            return singular
        fnd, _ = check.find_unstable(xs, [0, a])  # at the outputs: the persistent test
        if fnd is not None:
            return check.unstable_error(fnd, xs[fnd.index], float(tv[fnd.index]),
                                        what=f" (its states became non-finite {where})")
        if loc.finding is not None:  # before the field: it is not finite where it exploded
            return check.unstable_error(loc.finding, loc.x, loc.t,
                                        what=f", between outputs (its states became "
                                             f"non-finite {where})")
        nan_field = field_failure(model, controller, last_x, last_t)
        if nan_field is not None:
            return SolverError(f"{method} integrating {model.name}: the states became "
                               f"non-finite {where}: {nan_field}", status="non_finite_field")
    else:
        singular = kinetic_energy_error(model, method, xs[: a + 1], tv[: a + 1],
                                        f"its states became non-finite {where}")
        if singular is not None:
            return singular
    linear = " and the linearised step is stable there" if check and check.linearised else ""
    return SolverError(
        f"{method} produced non-finite states for {model.name} {where}; the field and the "
        f"control are finite at the last finite state (t = {last_t:.6g}, x = "
        f"{_text(last_x)}){linear}: a step left the field's domain, or jumped over a "
        f"singularity of the field", status="non-finite")


def _without_status(err: SolverError) -> str:
    """The message of a SolverError without its ``[status: ...]`` suffix."""
    text = str(err)
    suffix = f" [status: {err.status}]"
    return text[: -len(suffix)] if err.status and text.endswith(suffix) else text


def geometric_failure(model: Model, check: StepCheck, err: SolverError, x0: np.ndarray,
                      tv: np.ndarray) -> SolverError:
    """The SolverError to raise for a failed step of a geometric method (``err``).

    The kinetic energy first, at the outputs reached and the steps after the last of them
    (stepped again): a singular one is the cause, not the step. Then the linearised step
    at the start and at the failing step's start (beyond the stable range: the estimate
    of the stable step); else ``err`` itself.
    """
    state = getattr(err, "state", None)
    if state is None or err.status == "non_finite_field":
        return err
    outputs = getattr(err, "outputs", np.asarray(x0, dtype=float)[None, :])
    t_out = float(tv[len(outputs) - 1])
    states, times = outputs, tv[: len(outputs)]
    if getattr(model, "state_check", None) is not None and err.time != t_out:
        loc = check.locate(t_out, outputs[-1], float(err.time))
        states, times = np.vstack([states, loc.states]), np.concatenate([times, loc.times])
    singular = kinetic_energy_error(model, check.method, np.vstack([states, state]),
                                    np.append(times, err.time),
                                    f"step {err.step_index + 1} failed: {err.status}")
    if singular is not None:
        return singular
    t0 = float(tv[0])
    # a step that failed (non-finite, no solution, Newton): beyond the stable range?
    xs = np.vstack([x0, state])
    fnd, _ = check.find_unstable(xs, [0, 1])
    if fnd is None:
        return err
    t_bad = float(t0 if fnd.index == 0 else err.time)
    if err.status == "non-finite":  # the state exploded: the instability is the cause
        return check.unstable_error(fnd, xs[fnd.index], t_bad,
                                    what=f" (step {err.step_index + 1} failed)", cause=str(err))
    # the step's own failure stays the status; the estimate says what to do about it
    unstable = check.unstable_error(fnd, xs[fnd.index], t_bad)
    return SolverError(f"{_without_status(err)} Besides, {_without_status(unstable)}",
                       status=err.status)


def cvodes_reach(model: Model, controller: ca.Function | None, x0: np.ndarray,
                 tv: np.ndarray, opts: dict[str, Any]) -> tuple[float, np.ndarray, bool]:
    """The last time and state CVODES reaches from ``x0`` along ``tv`` (after a failure).

    Restarts of at most :data:`REACH_STEPS` steps each, :data:`REACH_TRIES` of them: a
    stride that succeeds is taken and doubled, one that fails is halved, until the stride
    no longer moves ``t``.

    Parameters
    ----------
    model : Model
        The model.
    controller : casadi.Function or None
        The feedback in the loop.
    x0 : ndarray, shape=(ambient_dim,)
        The initial state.
    tv : ndarray, shape=(n_times,)
        The run's output times (forward or backward).
    opts : dict
        The run's CVODES options (its tolerances and multistep method).

    Returns
    -------
    (float, ndarray, bool)
        The time reached, the state there, and whether CVODES stalls there (the last
        stride below :data:`STALL_STRIDE` times the time travelled).
    """
    S = model.sym
    x, p, tau = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params), S.sym("tau")
    u = feedback_function(model, controller)(x, p)
    ode = tau * model.function("f")(x, u, p)  # tau signed: forward or backward
    reach = ca.integrator("reach", "cvodes", {"x": x, "p": ca.vertcat(p, tau), "ode": ode},
                          0.0, 1.0, {**opts, "max_num_steps": REACH_STEPS})
    span, sign = abs(float(tv[-1] - tv[0])), 1.0 if tv[-1] > tv[0] else -1.0
    done, xa, stride = 0.0, np.asarray(x0, dtype=float), abs(float(tv[1] - tv[0]))
    for _ in range(REACH_TRIES):
        stride = min(stride, span - done)
        if stride <= 4 * np.finfo(float).eps * (abs(float(tv[0])) + done):
            break  # a stride that no longer moves t
        try:
            xb = np.asarray(reach(x0=xa, p=np.append(model.p, sign * stride))["xf"],
                            dtype=float).ravel()
        except RuntimeError:
            xb = None
        if xb is not None and np.all(np.isfinite(xb)):
            done, xa, stride = done + stride, xb, 2.0 * stride
        else:
            stride *= 0.5
    # a stall: the strides that still succeed have shrunk to a millionth of the time
    # travelled (towards a singular time); a long horizon keeps strides of its own scale
    stalled = done < span and stride < STALL_STRIDE * done
    return float(tv[0] + sign * done), xa, stalled
