"""Time-varying LQR along an optimal trajectory, handing over to the LQR of the target.

The controller is sampled-data: every ``dt`` seconds it measures the state, and holds

    u = u_ref,k - K_k chart(x_ref,k, x)                    on [t_k, t_k + dt)

where ``chart(x_ref,k, .)`` is the manifold's chart around the reference state at ``t_k``
(tangent coordinates in the basis ``N_k = tangent_basis(x_ref,k)``). The gains come from
the discrete Riccati equation, backward in time, in these tangent coordinates:

    A_k = N_{k+1}^+ dPhi/dx N_k,    B_k = N_{k+1}^+ dPhi/du,
    S_k = Q + A_k^T S_{k+1} (A_k - B_k K_k),  K_k = (R + B_k^T S_{k+1} B_k)^{-1} B_k^T S_{k+1} A_k,

with ``Phi`` the exact flow of the model over one sample (CVODES with forward
sensitivities of ``model.function("f")``) and ``N^+`` the pseudo-inverse of the tangent
basis, which is the derivative of the chart on tangent vectors. Each sample has its own
basis, so no smooth frame along the trajectory is needed: a change of basis between
samples is part of ``A_k``. The recursion starts from ``S_N = S_inf``, the solution of the
discrete algebraic Riccati equation of the target equilibrium, whose constant gain takes
over after ``T`` (the handover).

The reference of :func:`tvlqr_along` is the transcription's nodes (each interval integrated
from its own node when sub-sampled), not an open-loop re-simulation of the whole horizon,
which an unstable swing-up leaves exponentially.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg as sla

from workbench.control.ocp.stepper import Stepper
from workbench.core import validate
from workbench.core._model import Model
from workbench.core.errors import ParameterError, SolverError
from workbench.core.status import Record, StatusEnum, StatusResult
from workbench.core.types import ArrayLike
from workbench.simulation import cvodes_options

__all__ = ["TVLQR", "TVLQRCost", "TVLQRChecks", "tvlqr", "tvlqr_along", "ClosedLoopStatus",
           "ClosedLoopRun", "closed_loop", "perturbed_starts"]


@dataclass(frozen=True)
class TVLQRCost(Record):
    """What :func:`tvlqr` cost.

    Attributes
    ----------
    build_seconds, linearisation_seconds, riccati_seconds : float
        Building the stepper, linearising along the reference, the Riccati recursion.
    """

    build_seconds: float
    linearisation_seconds: float
    riccati_seconds: float


@dataclass(frozen=True)
class TVLQRChecks(Record):
    """What :func:`tvlqr` checked.

    Attributes
    ----------
    closed_loop_spectral_radius_eq : float
        Of the discrete closed loop of the handover LQR at the equilibrium (< 1).
    reference_end_gap : float
        Distance from the reference's end to the equilibrium, in the equilibrium's chart.
    """

    closed_loop_spectral_radius_eq: float
    reference_end_gap: float


@dataclass
class TVLQR:
    """Sampled-data time-varying LQR and the equilibrium LQR it hands over to.

    Attributes
    ----------
    model : Model
        The plant.
    dt : float
        Sample period.
    t : ndarray, shape=(K+1,)
        Sample times of the reference, ``0 .. T``.
    x_ref : ndarray, shape=(K+1, ambient_dim)
        Reference states (open-loop re-simulation of the optimal control).
    u_ref : ndarray, shape=(K, n_inputs)
        Reference inputs.
    gains : ndarray, shape=(K, n_inputs, dim)
        ``K_k`` in the tangent coordinates of ``x_ref,k``.
    S : ndarray, shape=(K+1, dim, dim)
        Cost-to-go matrices.
    x_eq, u_eq : ndarray
        Target equilibrium of the handover.
    gain_eq : ndarray, shape=(n_inputs, dim)
        Constant LQR gain at the equilibrium (discrete, same ``dt``).
    S_eq : ndarray, shape=(dim, dim)
        Its DARE solution (the terminal cost-to-go of the recursion).
    cost : TVLQRCost
        ``build_seconds``, ``linearisation_seconds``, ``riccati_seconds``.
    info : TVLQRChecks
        ``closed_loop_spectral_radius_eq``, ``reference_end_gap`` (distance from the
        reference's end to the equilibrium, in the equilibrium's chart); typed records
        that also read as mappings.
    """

    model: Model
    dt: float
    t: np.ndarray
    x_ref: np.ndarray
    u_ref: np.ndarray
    gains: np.ndarray
    S: np.ndarray
    x_eq: np.ndarray
    u_eq: np.ndarray
    gain_eq: np.ndarray
    S_eq: np.ndarray
    cost: TVLQRCost | dict[str, float] = field(default_factory=dict)
    info: TVLQRChecks | dict[str, Any] = field(default_factory=dict)

    @property
    def T(self) -> float:
        """End of the time-varying phase."""
        return float(self.t[-1])

    def control(self, k: int, x: ArrayLike) -> np.ndarray:
        """Input held on sample ``k`` (``k >= K``: the equilibrium LQR)."""
        man = self.model.manifold
        if k < len(self.u_ref):
            e = np.asarray(man.chart(self.x_ref[k], np.asarray(x, float)), float).ravel()
            return self.u_ref[k] - self.gains[k] @ e
        e = np.asarray(man.chart(self.x_eq, np.asarray(x, float)), float).ravel()
        return self.u_eq - self.gain_eq @ e


class _Flow:
    """Flow over one sample and its sensitivities (CVODES, Adams, functional iteration).

    Open loop over one sample the models are not stiff; casadi's defaults (BDF, Newton)
    are not needed (the Stepper row of ``benchmarks/bench_corrector.py`` times both on the
    same model).
    """

    def __init__(self, model: Model, rtol: float) -> None:
        S = model.sym
        x, u = S.sym("x", model.manifold.ambient_dim), S.sym("u", model.n_inputs)
        h, p = S.sym("h"), S.sym("p", model.n_params)
        F = ca.integrator("flow", "cvodes",
                          {"x": x, "p": ca.vertcat(u, h, p),
                           "ode": h * model.function("f")(x, u, p)},
                          0.0, 1.0, cvodes_options(rtol=rtol, atol=rtol))
        X, U = ca.MX.sym("X", x.shape[0]), ca.MX.sym("U", u.shape[0])
        H, P = ca.MX.sym("H"), ca.MX.sym("P", p.shape[0])
        xf = F(x0=X, p=ca.vertcat(U, H, P))["xf"]
        self.fn = ca.Function("flow_jac", [X, U, H, P],
                              [xf, ca.jacobian(xf, X), ca.jacobian(xf, U)])
        self.p = model.p

    def __call__(self, x: np.ndarray, u: np.ndarray, h: float) -> tuple[np.ndarray, ...]:
        try:
            xf, Fx, Fu = self.fn(x, u, h, self.p)
        except RuntimeError as exc:  # CVODES failed on this sample: a domain error
            raise SolverError(f"the flow over one sample (h = {h:.3g}) failed from x = "
                              f"{np.asarray(x).tolist()} with u = {np.asarray(u).tolist()}: "
                              f"{str(exc).strip().splitlines()[-1]}",
                              status="cvodes") from exc
        return (np.asarray(xf, float).ravel(), np.asarray(Fx, float), np.asarray(Fu, float))


def _weights(W: ArrayLike, n: int, name: str, *, definite: bool) -> np.ndarray:
    M = np.asarray(W, dtype=float)
    if not np.all(np.isfinite(M)):
        raise ParameterError(f"{name} must be finite; got {M.tolist()}")
    if M.ndim == 1 and M.size != n:
        raise ParameterError(f"{name} must be a scalar, a vector of {n} or a ({n}, {n}) "
                             f"matrix; got shape {M.shape}")
    if M.ndim == 0 or M.ndim == 1:
        M = np.diag(np.broadcast_to(M, (n,)).astype(float))
    if M.shape != (n, n) or not np.allclose(M, M.T, atol=1e-12 * max(1.0, np.abs(M).max())):
        raise ParameterError(f"{name} must be a symmetric ({n}, {n}) matrix, a vector of {n} "
                             f"or a scalar; got shape {np.shape(W)}")
    ev = np.linalg.eigvalsh(M)
    if (definite and ev.min() <= 0) or ev.min() < 0:
        kind = "positive definite" if definite else "positive semidefinite"
        raise ParameterError(f"{name} must be {kind}; got eigenvalues {ev.round(6).tolist()}")
    return M


@validate.arguments(model=validate.instance(Model, "a workbench Model"), rtol=validate.tolerance,
                    t=validate.array, x_ref=validate.array, u_ref=validate.array,
                    x_eq=validate.array, u_eq=validate.optional(validate.array),
                    Q=validate.array, R=validate.array)
def tvlqr(
    model: Model,
    t: ArrayLike,
    x_ref: ArrayLike,
    u_ref: ArrayLike,
    *,
    x_eq: ArrayLike,
    u_eq: ArrayLike | None = None,
    Q: ArrayLike = 1.0,
    R: ArrayLike = 1.0,
    rtol: float = 1e-10,
) -> TVLQR:
    """Design the time-varying LQR along a reference and the LQR of the target equilibrium.

    Parameters
    ----------
    model : Model
        The plant.
    t : array-like, shape=(K+1,)
        Equally spaced sample times from 0 to T.
    x_ref : array-like, shape=(K+1, ambient_dim)
        Reference states at ``t`` (a trajectory of the model under ``u_ref``).
    u_ref : array-like, shape=(K, n_inputs)
        Reference inputs, held on each sample.
    x_eq : array-like, shape=(ambient_dim,)
        The target equilibrium (``f(x_eq, u_eq) = 0``; checked).
    u_eq : array-like, optional
        Its input (default zero).
    Q : array-like
        State weight in tangent coordinates (scalar, diagonal or ``(dim, dim)``).
    R : array-like
        Input weight (scalar, diagonal or ``(n_inputs, n_inputs)``), positive definite.
    rtol : float
        CVODES tolerance of the flow and its sensitivities.

    Returns
    -------
    TVLQR

    Raises
    ------
    ParameterError
        For inconsistent shapes, non-finite samples or weights, a grid that is not
        increasing and uniform, or a target that is not an equilibrium.
    ManifoldError
        A reference state off the manifold by more than 1e-6 (loose: an integrated
        trajectory).
    SolverError
        If the equilibrium's DARE has no stabilising solution.
    """
    t0 = time.perf_counter()
    man = model.manifold
    tv = np.asarray(t, float).ravel()
    if tv.size < 2 or not np.all(np.isfinite(tv)) or not np.all(np.diff(tv) > 0):
        raise ParameterError(f"t must hold at least two finite, strictly increasing sample "
                             f"times; got {np.asarray(t).tolist()}")
    X = np.asarray(x_ref, float)
    U = np.asarray(u_ref, float)
    if U.size != (len(tv) - 1) * model.n_inputs or not np.all(np.isfinite(U)):
        raise ParameterError(f"u_ref must hold {len(tv) - 1} x {model.n_inputs} finite inputs "
                             f"(one per sample interval); got shape {U.shape}"
                             + ("" if U.size != (len(tv) - 1) * model.n_inputs
                                else " with non-finite entries"))
    U = U.reshape(len(tv) - 1, model.n_inputs)
    if X.shape != (len(tv), man.ambient_dim):
        raise ParameterError(f"x_ref must have shape ({len(tv)}, {man.ambient_dim}); "
                             f"got {X.shape}")
    for k, xk in enumerate(X):
        man.check(xk, name=f"x_ref[{k}]", tol=1e-6)  # an integrated reference: loose
    dts = np.diff(tv)
    dt = float(dts.mean())
    if not np.allclose(dts, dt, rtol=1e-9, atol=0):
        raise ParameterError("t must be equally spaced (one sample period)")
    xe = model.check_state(x_eq, name="x_eq")
    ue = np.zeros(model.n_inputs) if u_eq is None else np.asarray(u_eq, float).ravel()
    drift = float(np.max(np.abs(model.rhs(xe, ue))))
    if drift > 1e-8:
        raise ParameterError(f"x_eq is not an equilibrium under u_eq: |f(x_eq, u_eq)| = "
                             f"{drift:.3g}")
    n, m = man.dim, model.n_inputs
    Qm = _weights(Q, n, "Q", definite=False)
    Rm = _weights(R, m, "R", definite=True)
    flow = _Flow(model, rtol)
    build = time.perf_counter() - t0

    t1 = time.perf_counter()
    _, Fx, Fu = flow(xe, ue, dt)
    Ne = man.tangent_basis(xe)
    Ne_pinv = np.linalg.pinv(Ne)
    Ae, Be = Ne_pinv @ Fx @ Ne, Ne_pinv @ Fu
    As, Bs = [], []
    bases = [man.tangent_basis(x) for x in X]
    for k in range(len(U)):
        _, Fx, Fu = flow(X[k], U[k], dt)
        P = np.linalg.pinv(bases[k + 1])
        As.append(P @ Fx @ bases[k])
        Bs.append(P @ Fu)
    lin = time.perf_counter() - t1

    t2 = time.perf_counter()
    try:
        Se = sla.solve_discrete_are(Ae, Be, Qm, Rm)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise SolverError(f"no stabilising DARE solution at the target equilibrium: {exc}",
                          status="dare") from exc
    Ke = np.linalg.solve(Rm + Be.T @ Se @ Be, Be.T @ Se @ Ae)
    rho = float(np.max(np.abs(np.linalg.eigvals(Ae - Be @ Ke))))
    S = np.zeros((len(tv), n, n))
    gains = np.zeros((len(U), m, n))
    S[-1] = Se
    for k in range(len(U) - 1, -1, -1):
        A, B, Sn = As[k], Bs[k], S[k + 1]
        gains[k] = np.linalg.solve(Rm + B.T @ Sn @ B, B.T @ Sn @ A)
        Sk = Qm + A.T @ Sn @ (A - B @ gains[k])
        S[k] = 0.5 * (Sk + Sk.T)
    ric = time.perf_counter() - t2
    gap = float(np.max(np.abs(np.asarray(man.chart(xe, X[-1]), float))))
    return TVLQR(model, dt, tv, X, U, gains, S, xe, ue, Ke, Se,
                 cost=TVLQRCost(build_seconds=build, linearisation_seconds=lin,
                                riccati_seconds=ric),
                 info=TVLQRChecks(closed_loop_spectral_radius_eq=rho, reference_end_gap=gap))


MAX_SAMPLES = 1_000_000
"""Largest reference grid :func:`tvlqr_along` builds (``N * substeps`` samples)."""


def tvlqr_along(
    solution: Any,
    *,
    x_eq: ArrayLike,
    u_eq: ArrayLike | None = None,
    substeps: int = 1,
    Q: ArrayLike = 1.0,
    R: ArrayLike = 1.0,
    rtol: float = 1e-10,
) -> TVLQR:
    """:func:`tvlqr` along an OCP solution.

    The reference states are the solution's nodes and, with ``substeps > 1``, CVODES
    samples of each interval integrated *from its own node* with its control. An
    open-loop re-simulation of the whole horizon is no reference for an unstable swing-up:
    it leaves the optimal trajectory exponentially (by metres for the double cart). The
    reference thus jumps by the transcription's local defect at the nodes, a small
    disturbance the feedback absorbs.

    Parameters
    ----------
    solution : OCPSolution
        An optimal trajectory (piecewise-constant control on ``N`` intervals).
    x_eq, u_eq, Q, R, rtol
        As in :func:`tvlqr`.
    substeps : int
        Samples per interval of the solution (sample period ``T / (N substeps)``).
    """
    if not all(hasattr(solution, a) for a in ("ocp", "x", "u", "T")):
        raise ParameterError(f"solution must be an OCPSolution (from solve_ocp); got "
                             f"{type(solution).__name__}")
    sub = validate.count("substeps", substeps)
    if len(solution.u) * sub > MAX_SAMPLES:
        raise ParameterError(
            f"substeps = {sub} gives {len(solution.u) * sub} samples > {MAX_SAMPLES} (one "
            f"CVODES step and one Riccati step each); pass fewer substeps")
    model = solution.ocp.model
    h = solution.T / len(solution.u) / sub
    stepper = Stepper(model, rtol=rtol, atol=rtol) if sub > 1 else None
    X = []
    for k, uk in enumerate(solution.u):
        x = solution.x[k]
        X.append(x)
        for _ in range(sub - 1):
            x = stepper.step(x, uk, h)  # type: ignore[union-attr]
            X.append(x)
    X.append(solution.x[-1])
    t = np.arange(len(X)) * h
    u = np.repeat(solution.u, sub, axis=0)
    return tvlqr(model, t, np.array(X), u, x_eq=x_eq, u_eq=u_eq, Q=Q, R=R, rtol=rtol)


class ClosedLoopStatus(StatusEnum):
    """Outcome of :func:`closed_loop`; the value is a readable message."""

    REACHED = "ended within tol of the equilibrium (chart max-norm)"
    MISSED = "ended farther than tol from the equilibrium"
    INTEGRATION_FAILED = "the integration failed before the end of the run"

    @classmethod
    def successes(cls) -> frozenset[str]:  # noqa: D102
        return frozenset({"REACHED"})


@dataclass
class ClosedLoopRun(StatusResult):
    """One closed-loop simulation (a measurement: :func:`closed_loop` never raises on a miss).

    Attributes
    ----------
    t : ndarray, shape=(n,)
        Sample times.
    x : ndarray, shape=(n, ambient_dim)
        States at the samples.
    u : ndarray, shape=(n - 1, n_inputs)
        Inputs held.
    final_error : float
        Max-norm of ``chart(x_eq, x)`` at the end (``inf`` when the integration failed).
    status : ClosedLoopStatus
        REACHED (``final_error <= tol``), MISSED or INTEGRATION_FAILED.
    max_abs_u : float
        Largest input component applied.
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    final_error: float
    status: ClosedLoopStatus
    max_abs_u: float

    @property
    def success(self) -> bool:
        """``final_error <= tol`` (the same as ``ok``)."""
        return self.ok


def closed_loop(
    controller: TVLQR,
    x0: ArrayLike,
    *,
    hold: float = 2.0,
    tol: float = 1e-3,
    u_bounds: tuple[ArrayLike, ArrayLike] | None = None,
    rtol: float = 1e-9,
    stepper: Stepper | None = None,
) -> ClosedLoopRun:
    """Simulate the sampled-data closed loop from ``x0`` (CVODES between samples).

    Parameters
    ----------
    controller : TVLQR
        The controller.
    x0 : array-like, shape=(ambient_dim,)
        Initial state (on the manifold; checked).
    hold : float
        Time after ``T`` under the equilibrium LQR.
    tol : float
        Success threshold on ``|chart(x_eq, x_end)|`` (max-norm).
    u_bounds : (array-like, array-like), optional
        Actuator saturation, applied explicitly when given (and reported by
        ``max_abs_u``); no saturation by default.
    rtol : float
        CVODES tolerance.
    stepper : Stepper, optional
        A prebuilt stepper (reuse across runs).

    Returns
    -------
    ClosedLoopRun
    """
    model = controller.model
    x = model.check_state(x0, name="x0", tol=1e-8)
    stepper = stepper or Stepper(model, rtol=rtol, atol=rtol)
    n_hold = int(np.ceil(hold / controller.dt - 1e-9))
    K = len(controller.u_ref) + n_hold
    xs, us = [x], []
    for k in range(K):
        u = controller.control(k, x)
        if u_bounds is not None:
            u = np.clip(u, u_bounds[0], u_bounds[1])
        try:
            x = stepper.step(x, u, controller.dt)
        except SolverError:
            break
        us.append(u)
        xs.append(x)
    X = np.array(xs)
    Uarr = np.array(us) if us else np.zeros((0, model.n_inputs))
    err = float(np.max(np.abs(np.asarray(model.manifold.chart(controller.x_eq, X[-1]))))) \
        if len(xs) == K + 1 else float("inf")
    status = (ClosedLoopStatus.INTEGRATION_FAILED if len(xs) != K + 1
              else ClosedLoopStatus.REACHED if err <= tol else ClosedLoopStatus.MISSED)
    return ClosedLoopRun(
        t=np.arange(len(xs)) * controller.dt, x=X, u=Uarr, final_error=err,
        status=status, max_abs_u=float(np.max(np.abs(Uarr))) if len(us) else 0.0,
    )


def perturbed_starts(model: Model, x0: ArrayLike, *, n: int, scale: ArrayLike,
                     seed: int = 0) -> np.ndarray:
    """Seeded initial states ``retract(x0, v)`` with ``v ~ N(0, diag(scale^2))``.

    Parameters
    ----------
    model : Model
        The model (for its manifold).
    x0 : array-like, shape=(ambient_dim,)
        Nominal initial state.
    n : int
        Number of starts.
    scale : float or array-like, shape=(dim,)
        Standard deviations of the tangent coordinates.
    seed : int
        Seed of the generator.

    Returns
    -------
    ndarray, shape=(n, ambient_dim)
        States exactly on the manifold (the retraction lands on it).
    """
    man = model.manifold
    rng = np.random.default_rng(seed)
    sc = np.broadcast_to(np.asarray(scale, float), (man.dim,))
    x0 = man.check(x0, name="x0")
    return np.array([man.retract(x0, sc * rng.standard_normal(man.dim)) for _ in range(n)])
