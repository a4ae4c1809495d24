"""Geometric phase of an S^1 reduction about e3: reconstruction against a curvature integral.

The curvature density is the model's (for the 3D pendulum, paper 000 (5.15), in
:func:`models.pendulum3d.phase_density`); the engine integrates it over surfaces bounded
by reduced curves and compares with the holonomy of the reconstruction.

For ``mu = 0`` the rotation about the vertical accumulated by the pendulum along a closed
curve ``Gamma(t)`` of the reduced attitude is the holonomy of the mechanical connection
(paper 000, Prop. 18):

    R(t2) = exp(theta_geo e3-hat) R(t1),
    theta_geo = int_B F dA,  F(Gamma) = (2 |J Gamma|^2 - tr(J) Gamma.J Gamma) / (Gamma.J Gamma)^2

with ``B`` a surface on S^2 bounded by the curve (5.15). The horizontal lift of Prop. 17
(5.10)-(5.11) depends on the curve only, so for ``mu != 0`` the same angle is the holonomy
of ``R_hor``, and ``R`` adds the dynamic phase (5.12).

Conventions, made explicit here and checked by the tests:

* **Orientation.** ``B`` carries the orientation whose boundary is the curve as
  traversed, with S^2 oriented by its outward normal ``Gamma`` (Stokes). A curve running
  counterclockwise about its outward normal encloses positive area.
* **Surface.** :func:`cone_integral` integrates over the cone of great-circle arcs from
  an apex ``a`` to the curve: a 2-chain whose boundary is the curve for any closed curve
  (simple or not). The apex inside a simple loop gives its cap; the antipodal apex gives
  the complementary cap. Two apexes give surfaces differing by a multiple of the sphere,
  and ``int_{S^2} F dA = -4 pi`` for every ``J`` (the circle bundle SO(3) -> S^2 has
  Euler number 2), so the two integrals differ by a multiple of ``4 pi``.
* **The 2 pi ambiguity.** ``theta_geo`` lives in S^1; angles are compared through
  :func:`wrap_angle`, the representative in ``(-pi, pi]``.

The closed curve comes from one orbit of a Routh-plus-reconstruction model: its first
self-intersection ``Gamma(t1) = Gamma(t2)`` (a simple loop), located on a sampled orbit
and refined by Newton on ``(t1, t2)`` (two equations, two unknowns: generic and
isolated, unlike ``Gamma(T) = Gamma(0)``). The paper's formula is an independent check;
the reconstruction is integrated from the model graph.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Evaluator, Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import SO3, sphere_basis
from workbench.core.status import Record
from workbench.core.types import ArrayLike
from workbench.global_dynamics._poincare import _positive, _rk_flow, stabilized_field
from workbench.simulation._cvodes import cvodes_options

__all__ = [
    "PhaseCost",
    "cone_integral",
    "holonomy_angle",
    "wrap_angle",
    "first_self_intersection",
    "PhaseCheck",
    "geometric_phase_check",
]

E3 = np.array([0.0, 0.0, 1.0])


def cone_integral(
    gamma: ArrayLike, gamma_dot: ArrayLike, weights: ArrayLike, *, apex: ArrayLike,
    density: Callable[[np.ndarray], np.ndarray] | None = None, radial_nodes: int = 48,
) -> float:
    """``int_B density dA`` over the cone of great-circle arcs from ``apex`` to a closed curve.

    In geodesic polar coordinates ``(r, psi)`` about the apex ``a``, ``dA = sin r dr dpsi``,
    and along the curve ``psi-dot = a . (Gamma x Gamma-dot) / |a x Gamma|^2``, so

        int_B F dA = int dt psi-dot(t) phi(t) int_0^1 F(Sigma(s, t)) sin(s phi(t)) ds,

    ``phi = angle(a, Gamma(t))`` and ``Sigma(s, t) = cos(s phi) a + sin(s phi) e(t)`` the
    arc (``e`` the unit vector orthogonal to ``a`` towards ``Gamma``): Gauss-Legendre in
    ``s``, the caller's quadrature in ``t``. The chain's boundary is the curve in its
    direction of travel (area counted positive counterclockwise about the outward normal),
    for simple and self-intersecting curves alike.

    Parameters
    ----------
    gamma, gamma_dot : array-like, shape=(n, 3)
        The closed curve and its velocity at the quadrature nodes in ``t``.
    weights : array-like, shape=(n,)
        Quadrature weights in ``t``.
    apex : array-like, shape=(3,)
        Unit vector; neither it nor its antipode may lie on the curve.
    density : callable, optional
        ``F(gamma)`` vectorised over ``(..., 3)``; ``None`` integrates the area form
        (signed solid angle).
    radial_nodes : int
        Gauss-Legendre nodes along each arc.

    Returns
    -------
    float
    """
    G = np.asarray(gamma, float).reshape(-1, 3)
    Gd = np.asarray(gamma_dot, float).reshape(-1, 3)
    w_t = np.asarray(weights, float).ravel()
    a = np.asarray(apex, float).ravel()
    if Gd.shape != G.shape or w_t.shape != (len(G),):
        raise ParameterError(f"gamma, gamma_dot and weights must have shapes (n, 3), (n, 3), "
                             f"(n,); got {G.shape}, {Gd.shape}, {w_t.shape}")
    if a.shape != (3,) or abs(np.linalg.norm(a) - 1) > 1e-12:
        raise ParameterError(f"apex must be a unit 3-vector; got {apex!r}")
    axg = np.cross(a, G)
    sin_phi = np.linalg.norm(axg, axis=1)
    if np.min(sin_phi) < 1e-6:
        raise ParameterError("apex and its antipode must stay off the curve (min |a x Gamma| = "
                             f"{np.min(sin_phi):.3g})")
    phi = np.arctan2(sin_phi, G @ a)
    e = (G - np.cos(phi)[:, None] * a) / sin_phi[:, None]
    psi_dot = np.einsum("k,nk->n", a, np.cross(G, Gd)) / sin_phi**2
    s, w_s = np.polynomial.legendre.leggauss(int(radial_nodes))
    s, w_s = 0.5 * (s + 1), 0.5 * w_s
    r = s[None, :] * phi[:, None]  # (n, m)
    sig = np.cos(r)[..., None] * a + np.sin(r)[..., None] * e[:, None, :]
    f = density(sig) if density is not None else 1.0
    inner = np.sum(w_s[None, :] * f * np.sin(r), axis=1) * phi
    return float(np.sum(w_t * psi_dot * inner))


def wrap_angle(angle: float) -> float:
    """The representative of an angle in ``(-pi, pi]``."""
    w = float(np.mod(angle + np.pi, 2 * np.pi) - np.pi)
    return np.pi if w == -np.pi else w


def holonomy_angle(R_start: ArrayLike, R_end: ArrayLike) -> tuple[float, float]:
    """Angle ``theta`` with ``R_end = exp(theta e3-hat) R_start``, and the fibre residual.

    Parameters
    ----------
    R_start, R_end : array-like, shape=(3, 3)
        Rotations over the same reduced attitude (``R^T e3`` equal).

    Returns
    -------
    theta : float
        In ``(-pi, pi]``.
    residual : float
        ``|M e3 - e3|`` for ``M = R_end R_start^T`` (0 when both lie in one fibre).
    """
    Rs = SO3.matrix(SO3().check(R_start, name="R_start", tol=1e-6))
    Re = SO3.matrix(SO3().check(R_end, name="R_end", tol=1e-6))
    M = Re @ Rs.T
    return wrap_angle(float(np.arctan2(M[1, 0], M[0, 0]))), float(np.linalg.norm(M @ E3 - E3))


def first_self_intersection(
    gamma: ArrayLike, *, min_gap: int = 2
) -> tuple[int, int, float, float] | None:
    """First crossing of a sampled curve on S^2 with itself (chords as segments).

    Returns ``(i, j, s, u)`` with ``j`` the smallest index such that the chord
    ``gamma[j] -> gamma[j+1]`` crosses an earlier chord ``gamma[i] -> gamma[i+1]``
    (``i <= j - min_gap``) at fractions ``s`` (of chord i) and ``u`` (of chord j); the loop
    between them is then simple. Chords are compared in the tangent plane at
    ``gamma[j]`` (only chords on the same hemisphere). ``None`` if there is none.
    """
    G = np.asarray(gamma, float)
    if G.ndim != 2 or G.shape[1] != 3 or not np.all(np.isfinite(G)):
        raise ParameterError(f"gamma must be a finite array of shape (n, 3); got shape "
                             f"{G.shape}")
    for j in range(min_gap, len(G) - 1):
        c, d = G[j], G[j + 1]
        B = sphere_basis(c)
        a_, b_ = G[: j - min_gap + 1], G[1 : j - min_gap + 2]
        near = a_ @ c > 0.5
        if not np.any(near):
            continue
        A, Bv, D = (a_ - c) @ B, (b_ - c) @ B, (d - c) @ B
        r = Bv - A
        den = r[:, 0] * D[1] - r[:, 1] * D[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (A[:, 1] * D[0] - A[:, 0] * D[1]) / den
            u = (A[:, 1] * r[:, 0] - A[:, 0] * r[:, 1]) / den
        hit = near & (den != 0) & (s >= 0) & (s < 1) & (u >= 0) & (u < 1)
        if np.any(hit):
            i = int(np.flatnonzero(hit)[0])
            return i, j, float(s[i]), float(u[i])
    return None


def _apex(G: np.ndarray, *, n_sub: int = 64) -> np.ndarray:
    """A unit vector far from the curve points and from their antipodes.

    Candidates are the normalised mean and the normalised midpoints of pairs of (up to
    ``n_sub``) curve points; the one maximising ``min_k |a x Gamma_k|`` wins, so both cone
    integrals (from ``a`` and ``-a``) have integrands far from their singularity.
    """
    sub = G[np.linspace(0, len(G) - 1, min(n_sub, len(G))).astype(int)]
    i, j = np.triu_indices(len(sub), k=1)
    cand = np.vstack([G.mean(axis=0), sub[i] + sub[j]])
    norms = np.linalg.norm(cand, axis=1)
    cand = cand[norms > 1e-6] / norms[norms > 1e-6, None]
    dist = np.min(np.linalg.norm(np.cross(cand[:, None, :], G[None, :, :]), axis=2), axis=1)
    return cand[int(np.argmax(dist))]


@dataclass(frozen=True)
class PhaseCost(Record):
    """What :func:`geometric_phase_check` cost.

    Attributes
    ----------
    wall_seconds : float
        The whole check.
    newton_iterations : int
        Newton iterations locating the return times.
    n_nodes : int
        Quadrature nodes of the cap integrals.
    orbit_steps : int
        CVODES steps along the orbit.
    """

    wall_seconds: float
    newton_iterations: int
    n_nodes: int
    orbit_steps: int


@dataclass
class PhaseCheck:
    """Geometric phase along a closed reduced curve: reconstruction versus (5.15).

    Attributes
    ----------
    t1, t2 : float
        ``Gamma(t1) = Gamma(t2)``: the loop.
    closure : float
        ``|Gamma(t2) - Gamma(t1)|`` after refinement.
    theta_reconstruction : float
        Holonomy of ``R_hor`` over the loop, in ``(-pi, pi]``.
    fibre_residual : float
        ``|M e3 - e3|``, ``M = R_hor(t2) R_hor(t1)^T`` (0 when both lie in one fibre).
    theta_formula : float
        (5.15) over the cone from the apex (the point farthest from the loop and from
        its antipode, among midpoints of loop points: inside a small loop), not wrapped.
    theta_formula_complement : float
        (5.15) over the cone from the antipodal apex (the other cap), not wrapped.
    apex : ndarray, shape=(3,)
        The apex.
    difference : float
        ``wrap(theta_reconstruction - theta_formula)``.
    caps_differ_by : float
        ``(theta_formula - theta_formula_complement) / (4 pi)``: an integer, +-1 when the
        apex lies inside a simple loop (the two integrals are then the two caps), 0 when
        it lies outside (a thin loop).
    quadrature_error : float
        Largest change of either cap integral when the panels are halved.
    signed_area : float
        Solid angle enclosed (signed by the orientation of travel).
    dynamic_phase : float
        ``theta_dyn(t2) - theta_dyn(t1)`` of (5.12) (0 for ``mu = 0``).
    cost : PhaseCost
        ``wall_seconds``, ``newton_iterations``, ``n_nodes``, ``orbit_steps`` (a typed
        record that also reads as a mapping).
    """

    t1: float
    t2: float
    closure: float
    theta_reconstruction: float
    fibre_residual: float
    theta_formula: float
    theta_formula_complement: float
    difference: float
    caps_differ_by: float
    quadrature_error: float
    signed_area: float
    dynamic_phase: float
    apex: np.ndarray
    cost: PhaseCost | dict[str, Any] = field(default_factory=dict)


MAX_SAMPLES = 10**8
"""Largest number of stored samples (``t_max / sample_step``) of a phase check."""


@validate.arguments(
    model=validate.instance(Model, "a workbench Model"), t_max=validate.positive,
    rtol=validate.tolerance, atol=validate.tolerance
)
def geometric_phase_check(
    model: Model, x0: ArrayLike, *, density: Callable[[np.ndarray], np.ndarray],
    t_max: float, sample_step: float = 0.01,
    min_loop_time: float = 0.5, rtol: float = 1e-12, atol: float = 1e-12,
    stabilization: float = 10.0, panels: int = 64, nodes: int = 8, radial_nodes: int = 48,
    refine_substeps: int = 16, factor: str = "Gamma", lift: str = "R_hor", phase: str =
    "theta",
) -> PhaseCheck:
    """Close a reduced curve at its first self-intersection and compare the two phases.

    Parameters
    ----------
    model : Model
        A reconstruction model with a TS2 factor ``factor`` = ``(Gamma, Gamma-dot)``, an
        SO3 factor ``lift`` (the horizontal lift, ``R_hor^T e3 = Gamma``) and an R^1
        factor ``phase`` (the dynamic phase).
    x0 : array-like
        Initial state.
    density : callable
        The curvature ``F(gamma)`` of the mechanical connection, vectorised over
        ``gamma`` of shape ``(..., 3)`` (for the 3D pendulum: paper 000 (5.15),
        :func:`models.pendulum3d.phase_density` of the model's ``J``).
    t_max : float
        Longest orbit searched for a loop [s].
    sample_step : float
        Output grid of the orbit.
    min_loop_time : float
        Shortest loop accepted [s] (skips near-degenerate loops).
    rtol, atol, stabilization
        As in :func:`workbench.global_dynamics._poincare.poincare_map`.
    panels, nodes : int
        Composite Gauss-Legendre quadrature along the loop.
    radial_nodes : int
        Gauss-Legendre nodes across the cone.
    refine_substeps : int
        RK4 steps from a sample to an off-grid time.
    factor, lift, phase : str
        Factor names.

    Returns
    -------
    PhaseCheck
    """
    t0 = time.perf_counter()
    for name in (factor, lift, phase):
        if name not in model.manifold.names:
            raise ModelError(f"model {model.name!r} has no factor {name!r}; factors: "
                             f"{model.manifold.names}")
    t_max, sample_step = _positive("t_max", t_max), _positive("sample_step", sample_step)
    if t_max / sample_step > MAX_SAMPLES:
        raise ParameterError(f"t_max / sample_step = {t_max / sample_step:.3g} samples > "
                             f"MAX_SAMPLES = {MAX_SAMPLES:.0e}; use a shorter t_max or a "
                             f"larger sample_step")
    xc = model.check_state(x0, name="x0")
    sl = model.manifold.slices
    gs, ls, ps_ = sl[factor], sl[lift], sl[phase]
    off = float(np.linalg.norm(SO3.matrix(xc[ls]).T @ E3 - xc[gs][:3]))
    if off > 1e-9:
        raise ParameterError(
            f"x0: the lift {lift!r} must lie over {factor!r} (R^T e3 = Gamma); got "
            f"|R^T e3 - Gamma| = {off:.3g} (choose R0 with R0^T e3 = Gamma0)")
    if not callable(density):
        raise ParameterError(f"density must be a callable F(gamma); got {type(density).__name__}")
    S = model.sym
    xs, ps, tau = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params), S.sym("t")
    fld = stabilized_field(model, gain=stabilization)
    n = int(round(t_max / sample_step))
    integ = ca.integrator("orbit", "cvodes", {"x": xs, "p": ps, "ode": fld(xs, ps)}, 0.0,
                          sample_step * np.arange(1, n + 1),
                          cvodes_options(rtol=rtol, atol=atol, max_steps=1_000_000,
                                         error=ParameterError))
    try:
        X = np.vstack([xc, np.asarray(integ(x0=xc, p=model.p)["xf"]).T])
    except RuntimeError as exc:
        raise SolverError(f"cvodes failed integrating {model.name}", status="integrator") from exc
    flow = Evaluator(_rk_flow(fld, xs, ps, tau, int(refine_substeps)))
    f_num = Evaluator(fld)

    def state(t: float) -> np.ndarray:
        k = min(int(np.floor(t / sample_step)), n - 1)
        return flow(X[k], t - k * sample_step, model.p)

    gap = max(2, int(np.ceil(min_loop_time / sample_step)))
    hit = first_self_intersection(X[:, gs][:, :3], min_gap=gap)
    if hit is None:
        raise SolverError(f"no self-intersection of Gamma(t) with a loop of at least "
                          f"{min_loop_time} s within t_max = {t_max}", status="no loop")
    i, j, s_, u_ = hit
    t1, t2 = (i + s_) * sample_step, (j + u_) * sample_step
    its, converged, step = 0, False, np.full(2, np.inf)
    for its in range(1, 30):  # noqa: B007
        x1, x2 = state(t1), state(t2)
        B = sphere_basis(x1[gs][:3])
        r = B.T @ (x1[gs][:3] - x2[gs][:3])
        Jm = np.column_stack([B.T @ x1[gs][3:6], -B.T @ x2[gs][3:6]])
        try:
            step = np.linalg.solve(Jm, -r)
        except np.linalg.LinAlgError as exc:
            raise SolverError(
                f"Newton on the self-intersection times (t1, t2) = ({t1:.6g}, {t2:.6g}) met a "
                f"singular Jacobian (the curve is tangent to itself there)", status="newton"
            ) from exc
        t1, t2 = t1 + step[0], t2 + step[1]
        if np.max(np.abs(step)) < 1e-14:
            converged = True
            break
    if not converged:
        raise SolverError(
            f"Newton on the self-intersection times did not converge in {its} iterations "
            f"(last step {np.max(np.abs(step)):.3g} s, tolerance 1e-14 s)", status="newton"
        )
    x1, x2 = state(t1), state(t2)
    closure = float(np.linalg.norm(x1[gs][:3] - x2[gs][:3]))
    theta_rec, fibre = holonomy_angle(SO3.matrix(x1[ls]), SO3.matrix(x2[ls]))

    def quadrature(n_panels: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        xg, wg = np.polynomial.legendre.leggauss(int(nodes))
        edges = np.linspace(t1, t2, n_panels + 1)
        half = 0.5 * np.diff(edges)
        tq = (edges[:-1, None] + half[:, None] * (xg[None, :] + 1)).ravel()
        wq = (half[:, None] * wg[None, :]).ravel()
        Xq = np.array([state(t) for t in tq])
        Gq, Gdq = Xq[:, gs][:, :3], np.array([f_num(x, model.p)[gs][:3] for x in Xq])
        return Gq, Gdq, wq

    Gq, Gdq, wq = quadrature(panels)
    apex = _apex(Gq)
    theta_a = cone_integral(Gq, Gdq, wq, apex=apex, density=density, radial_nodes=radial_nodes)
    theta_b = cone_integral(Gq, Gdq, wq, apex=-apex, density=density,
                            radial_nodes=radial_nodes)
    area = cone_integral(Gq, Gdq, wq, apex=apex, radial_nodes=radial_nodes)
    Gh, Gdh, wh = quadrature(max(1, panels // 2))
    quad_err = max(abs(cone_integral(Gh, Gdh, wh, apex=sign * apex, density=density,
                                     radial_nodes=radial_nodes) - ref)
                   for sign, ref in ((1, theta_a), (-1, theta_b)))
    return PhaseCheck(
        t1=float(t1), t2=float(t2), closure=closure, theta_reconstruction=theta_rec,
        fibre_residual=fibre, theta_formula=theta_a, theta_formula_complement=theta_b,
        difference=wrap_angle(theta_rec - theta_a),
        caps_differ_by=(theta_a - theta_b) / (4 * np.pi),
        quadrature_error=quad_err, signed_area=area,
        dynamic_phase=float(x2[ps_][0] - x1[ps_][0]), apex=apex,
        cost=PhaseCost(wall_seconds=time.perf_counter() - t0, newton_iterations=its,
                       n_nodes=len(wq), orbit_steps=int(integ.stats().get("nsteps", 0))),
    )
