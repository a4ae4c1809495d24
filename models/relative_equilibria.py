"""Relative equilibria of a rigid body about a vertical symmetry axis, by continuation.

For a reduced rigid-body model on ``S^2 x R^3`` (reduced attitude ``Gamma = R^T e3``,
body angular velocity ``omega``; paper 000 (4.3)-(4.4)) an equilibrium needs
``Gamma x omega = 0``, so ``omega = k Gamma`` (4.8): the body turns steadily about the
vertical at rate ``k``, a relative equilibrium of the full model. The unknowns are
``y = (Gamma, k)`` on ``S^2 x R``, and the residual is the model's own vector field at
``(Gamma, k Gamma)`` with ``u = 0``, taken from its graph (:func:`rotation_problem`).
Its zero set is a union of curves (the families of paper 000 Prop. 9), which
:func:`models.relative_families.trace_relative_equilibria` follows by pseudo-arclength
continuation from

* the static equilibria (the zeros with ``k = 0``, :func:`static_equilibria`), in both
  directions of ``k``;
* the ends at infinity: the zeros on the slice ``|k| = k_max`` (a family whose ``|k|``
  grows without bound approaches a principal axis, where ``alpha -> 1/J_i``);
* the other branch at every simple branch point (where two families cross, as for a
  zero component of ``rho``, paper 000 Prop. 9 cases 6-7).

Monitors along the branches, all from the graph: ``k``; the momentum ``mu = h`` (the
model's invariant, (5.22)); the energy; and ``k1 = Gamma . (k grad_Gamma h - grad_Gamma E)``,
the multiplier of the sphere constraint in ``k^2 J Gamma + m g rho = k1 Gamma`` (4.14),
from automatic differentiation of the invariants. The family parameter of the paper is
``alpha = k^2 / k1`` (:func:`alpha`): ``alpha -> 0`` at the static equilibria (``k = 0``),
``alpha -> +-infinity`` where ``k1 = 0`` (the two equilibria (4.10)).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import Model
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import S2, ProductManifold, Rn
from workbench.core.types import ArrayLike, Vector
from workbench.equilibria import (
    Equilibrium,
    Root,
    ZeroProblem,
    find_equilibrium,
    newton_on_manifold,
)

__all__ = [
    "rotation_problem",
    "alpha",
    "sphere_points",
    "SliceZero",
    "slice_zeros",
    "static_equilibria",
    "stability_label",
    "describe_stability",
    "limit_at_infinity",
]


def sphere_points(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors (Fibonacci lattice), deterministic.

    Parameters
    ----------
    n : int
        Number of points, at least 1.

    Returns
    -------
    ndarray, shape=(n, 3)
    """
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = np.pi * (1.0 + 5**0.5) * i
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def alpha(k: ArrayLike, k1: ArrayLike) -> np.ndarray:
    """Family parameter ``alpha = k^2 / k1`` of paper 000 (4.15); ``+-inf`` where ``k1 = 0``.

    Parameters
    ----------
    k, k1 : array-like
        Rotation rate and sphere multiplier (monitors of :func:`rotation_problem`).

    Returns
    -------
    ndarray
    """
    k, k1 = np.asarray(k, dtype=float), np.asarray(k1, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = k * k / k1
    return np.where(k1 == 0.0, np.copysign(np.inf, k1) if np.ndim(k1) else np.inf, a)


def _check_rigid_body(model: Model, attitude: str, velocity: str, energy: str,
                      momentum: str) -> None:
    if not isinstance(model, Model):
        raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
    man = model.manifold
    if man.names != [attitude, velocity] or not isinstance(man.factor(attitude), S2) or \
            not isinstance(man.factor(velocity), Rn) or man.factor(velocity).dim != 3:
        raise ModelError(
            f"relative equilibria need a model on S2 x R^3 with factors "
            f"[{attitude!r} (S2), {velocity!r} (R^3)]; model {model.name!r} has "
            f"{man.describe()}"
        )
    for name in (energy, momentum):
        if name not in model.invariant_names:
            raise ModelError(
                f"model {model.name!r} has no invariant {name!r} (needed for the monitors); "
                f"its invariants are {model.invariant_names}"
            )


def rotation_problem(
    model: Model,
    *,
    attitude: str = "Gamma",
    velocity: str = "omega",
    energy: str = "energy",
    momentum: str = "h",
) -> ZeroProblem:
    """The zero problem of relative equilibria ``omega = k Gamma`` of a reduced model.

    Parameters
    ----------
    model : Model
        A model on ``S^2 x R^3`` (factors ``attitude``, ``velocity``) with an energy and a
        vertical-momentum invariant, e.g. :func:`models.pendulum3d.reduced`.
    attitude, velocity : str
        Factor names.
    energy, momentum : str
        Invariant names.

    Returns
    -------
    ZeroProblem
        Unknowns ``y = (Gamma, k)`` on ``S^2 x R``; residual ``f((Gamma, k Gamma), 0)``;
        monitors ``k``, ``k1``, ``mu``, ``energy``; ``state(y) = (Gamma, k Gamma)``. The
        graphs are built once per model (shared by :meth:`Model.with_parameters`) and
        appear in its build log.
    """
    _check_rigid_body(model, attitude, velocity, energy, momentum)
    S = model.sym
    key = f"relative_equilibria[{attitude},{velocity},{energy},{momentum}]"

    def build() -> ca.Function:
        y, p = S.sym("y", 4), S.sym("p", model.n_params)
        u = S.sym("u", 0)
        gam, k = y[0:3], y[3]
        x = ca.vertcat(gam, k * gam)  # the attitude is first (_check_rigid_body)
        F = model.function("f")(x, ca.DM.zeros(model.n_inputs), p)
        xs = S.sym("x", model.manifold.ambient_dim)
        att = model.manifold.slices[attitude]
        grad = ca.Function(
            "grads", [xs, p],
            [ca.gradient(model.function(momentum)(xs, p), xs)[att],
             ca.gradient(model.function(energy)(xs, p), xs)[att]])
        gh, ge = grad(x, p)
        k1 = ca.dot(gam, k * gh - ge)
        return ca.Function(
            "relative_equilibria", [y, u, p],
            [F, ca.jacobian(F, y), k, k1, model.function(momentum)(x, p),
             model.function(energy)(x, p)],
            ["y", "u", "p"], ["F", "D", "k", "k1", "mu", "energy"],
            {"cse": True} if model.symbolic == "SX" else {},
        )

    fn = model._build(key, build)  # noqa: SLF001 - cached and logged with the model's graphs
    att = model.manifold.slices[attitude]

    def state(yv: Vector) -> Vector:
        x = np.zeros(6)
        x[att] = yv[:3]
        x[model.manifold.slices[velocity]] = yv[3] * yv[:3]
        return x

    return ZeroProblem(
        name=f"relative equilibria of {model.name} (omega = k Gamma)",
        manifold=ProductManifold([(attitude, S2()), ("k", Rn(1))]),
        function=fn,
        u=np.zeros(0),
        p=model.p,
        monitor_names=("k", "k1", "mu", "energy"),
        state=state,
        model=model,
    )


# ----------------------------------------------------------------------------------------
# slices k = const


@dataclass
class SliceZero:
    """A zero of the relative-equilibrium problem with ``k`` held fixed.

    Attributes
    ----------
    y : ndarray, shape=(4,)
        ``(Gamma, k)``.
    root : Root
        The Newton solve on ``S^2`` (status, residual, iterations).
    local_dimension : int
        Dimension of the zero set of the slice near ``y`` (0: isolated; the zero set of
        the full problem then is a curve through ``y``; 1 or more: a surface of zeros).
    """

    y: Vector
    root: Root
    local_dimension: int


def slice_zeros(
    problem: ZeroProblem,
    k: float,
    guesses: ArrayLike,
    *,
    tol: float = 1e-11,
    max_iterations: int = 40,
    rank_rtol: float = 1e-8,
    distinct_tol: float = 1e-7,
) -> tuple[list[SliceZero], int]:
    """Zeros on the slice ``k = const`` from a set of attitude guesses.

    Parameters
    ----------
    problem : ZeroProblem
        From :func:`rotation_problem`.
    k : float
        The fixed rotation rate.
    guesses : array-like, shape=(n, 3)
        Unit vectors (e.g. :func:`sphere_points`).
    tol, max_iterations, rank_rtol
        Newton settings.
    distinct_tol : float
        Zeros closer than this are the same.

    Returns
    -------
    zeros : list of SliceZero
        Distinct converged zeros.
    failures : int
        Number of guesses from which Newton did not converge (kept as a count: a guess in
        no basin is not an error).
    """
    sphere = ProductManifold([("Gamma", S2())])

    def fun(g: Vector) -> tuple[Vector, np.ndarray]:
        F, A, _ = problem.linearization(np.append(g, k))
        return F, A[:, :2]

    zeros: list[SliceZero] = []
    failures = 0
    for g in np.atleast_2d(np.asarray(guesses, dtype=float)):
        root = newton_on_manifold(fun, sphere, g, tol=tol, max_iterations=max_iterations,
                                  rank_rtol=rank_rtol, step_tol=1e-15,
                                  raise_on_failure=False)
        if not root.ok:
            failures += 1
            continue
        if any(float(np.max(np.abs(z.y[:3] - root.x))) <= distinct_tol for z in zeros):
            continue
        zeros.append(SliceZero(np.append(root.x, k), root, root.local_dimension))
    return zeros, failures


def static_equilibria(
    model: Model,
    *,
    guesses: ArrayLike | None = None,
    tol: float = 1e-12,
    attitude: str = "Gamma",
    velocity: str = "omega",
    offset: str | None = None,
) -> dict[str, Equilibrium]:
    """The hanging and inverted equilibria of a reduced rigid-body pendulum.

    The zeros with ``k = 0`` are found on the sphere from ``guesses``, then confirmed as
    equilibria of the model itself by :func:`find_equilibrium`; the one of lower energy
    is the hanging equilibrium.

    Parameters
    ----------
    model : Model
        A model accepted by :func:`rotation_problem`.
    guesses : array-like, shape=(n, 3), optional
        Attitude guesses (default 26 :func:`sphere_points`).
    tol : float
        Residual tolerance, relative to the size of the field on the slice (``max |F|``
        over the guesses) when that is below 1: the field scales with ``m g |rho|``, and
        for a nearly balanced body an absolute tolerance would accept attitudes far from
        the equilibria (at ``|rho| = 1e-10`` an absolute ``1e-12`` means about 1e-4 rad).
        The slice solves also stop when the Newton step is below 1e-15 (the residual is
        then at its rounding level, which for an ill-conditioned inertia, ``cond J >=
        1e6``, lies above ``1e-12``); the confirming :func:`find_equilibrium` accepts
        that level.
    attitude, velocity : str
        Factor names.
    offset : str, optional
        Name of the model's parameter holding the centre-of-mass offset, quoted with its
        value when the body is balanced. Default: ``"rho"`` if the model has such a
        parameter (as :func:`models.pendulum3d.reduced`), else none is quoted.

    Returns
    -------
    dict
        ``{"hanging": Equilibrium, "inverted": Equilibrium}``.

    Raises
    ------
    ParameterError
        For a balanced body (centre of mass at the pivot): every attitude is then a static
        equilibrium and the hanging and inverted attitudes are undefined.
    ModelError
        ``offset`` is not a parameter of the model (or the model is not a reduced rigid
        body, see :func:`rotation_problem`).
    SolverError
        If the zeros found are not exactly two isolated ones.
    """
    problem = rotation_problem(model, attitude=attitude, velocity=velocity)
    names = [p.name for p in model.parameters]
    if offset is not None and offset not in names:
        raise ModelError(
            f"offset must name the parameter of {model.name!r} holding the centre-of-mass "
            f"offset (one of {names}), or be None; got {offset!r}"
        )
    if offset is None and "rho" in names:
        offset = "rho"
    gs = sphere_points(26) if guesses is None else guesses
    scale = max(float(np.max(np.abs(problem.residual(np.append(g, 0.0)))))
                for g in np.atleast_2d(np.asarray(gs, dtype=float)))
    if 0.0 < scale < 1.0:
        tol = tol * scale
    zeros, _ = slice_zeros(problem, 0.0, gs, tol=tol)
    surface = [z for z in zeros if z.local_dimension > 0]
    if surface:
        what = ("the body is balanced" if offset is None else
                f"parameter {offset!r} = {np.asarray(model.values[offset]).tolist()} makes "
                f"the body balanced")
        raise ParameterError(
            f"{what}: every attitude is a static equilibrium of {model.name!r} (the zeros "
            f"with k = 0 form a set of dimension {surface[0].local_dimension}), so the "
            f"hanging and inverted attitudes (along +-the centre-of-mass offset) are "
            f"undefined; give the centre of mass an offset from the pivot"
        )
    if len(zeros) != 2:
        raise SolverError(
            f"static_equilibria({model.name}): expected two isolated static equilibria, "
            f"found {len(zeros)} from {len(np.atleast_2d(gs))} guesses", status="count")
    eqs = [find_equilibrium(model, problem.state(z.y), tol=max(tol, 2 * z.root.residual))
           for z in zeros]
    energies = [problem.monitor("energy", z.y) for z in zeros]
    lo = int(np.argmin(energies))
    return {"hanging": eqs[lo], "inverted": eqs[1 - lo]}


def limit_at_infinity(
    problem: ZeroProblem,
    y_end: ArrayLike,
    *,
    factors: Sequence[float] = (1.0, 2.0, 4.0, 8.0),
    tol: float = 1e-11,
) -> dict[str, Any]:
    """Where a family that ends at ``|k| -> infinity`` goes: ``alpha`` and ``Gamma`` limits.

    From an end point ``(Gamma, k)`` of a branch at large ``|k|``, the zeros on the slices
    ``k * factors`` are followed by Newton (each from the previous one), and ``alpha`` and
    ``Gamma``, which converge like ``1/k^2``, are extrapolated to ``1/k^2 = 0`` by
    Richardson's rule (a polynomial in ``1/k^2`` through the slices).

    Parameters
    ----------
    problem : ZeroProblem
        From :func:`rotation_problem`.
    y_end : array-like, shape=(4,)
        The end point, a zero.
    factors : sequence of float
        Increasing multiples of ``k``; the first is usually 1.
    tol : float
        Newton tolerance on the slices.

    Returns
    -------
    dict
        ``alpha`` and ``Gamma`` (extrapolated), ``k``, ``alphas`` and ``Gammas`` on the
        slices, and ``change`` (the size of the last Richardson correction, an error
        estimate).

    Raises
    ------
    SolverError
        If a slice solve fails.
    """
    y = np.asarray(y_end, dtype=float).ravel()
    ks, alphas, gammas = [], [], []
    g = y[:3]
    for f in factors:
        kk = float(y[3] * f)
        zeros, _ = slice_zeros(problem, kk, g[None, :], tol=tol)
        if not zeros:
            raise SolverError(f"limit_at_infinity: no zero on the slice k = {kk:g} near "
                              f"Gamma = {g.tolist()}", status="slice")
        g = zeros[0].y[:3]
        mon = problem.monitors(zeros[0].y)
        ks.append(kk)
        alphas.append(float(alpha(mon["k"], mon["k1"])))
        gammas.append(g)
    x = 1.0 / np.square(ks)
    V = np.vander(x, len(x), increasing=True)
    a_lim = float(np.linalg.solve(V, np.array(alphas))[0])
    G_lim = np.linalg.solve(V, np.array(gammas))[0]
    if len(x) > 1:
        V2 = np.vander(x[:-1], len(x) - 1, increasing=True)
        change = abs(a_lim - float(np.linalg.solve(V2, np.array(alphas[:-1]))[0]))
    else:
        change = float("nan")
    return {"alpha": a_lim, "Gamma": G_lim, "k": ks, "alphas": alphas,
            "Gammas": [gg.tolist() for gg in gammas], "change": change}


# ----------------------------------------------------------------------------------------
# stability


def stability_label(model: Model, x: ArrayLike, *, tol: float | None = None) -> tuple[int, int]:
    """Spectral stability of an equilibrium from the model's linearisation.

    Parameters
    ----------
    model : Model
    x : array-like
        An equilibrium.
    tol : float, optional
        Real-part tolerance (default :func:`workbench.linear._eigen.default_tol`,
        ``1e-7 max(1, |D^-1 A D|_2)`` of the balanced matrix, the convention of
        :func:`workbench.linear._eigen.eigenstructure`;
        only the eigenvalues are computed here, since the classification is evaluated at
        every point of a branch and near the changes, where eigenvalues sit at the
        tolerance).

    Returns
    -------
    (int, int)
        Number of eigenvalues with positive real part, and how many of them are complex
        (``(0, 0)``: spectrally stable; ``(1, 0)``: a real saddle direction; ``(2, 2)``:
        a complex quadruplet, after a Krein collision).
    """
    from workbench.linear import default_tol, linearize

    A = linearize(model, x).A
    t = default_tol(A) if tol is None else tol
    ev = np.linalg.eigvals(A)
    unstable = ev.real > t
    return int(np.sum(unstable)), int(np.sum(unstable & (np.abs(ev.imag) > t)))


def describe_stability(label: tuple[int, int]) -> str:
    """Words for a :func:`stability_label` (number of unstable eigenvalues, of which complex).

    Parameters
    ----------
    label : (int, int)
        From :func:`stability_label`.

    Returns
    -------
    str
    """
    n, c = label
    if n == 0:
        return "spectrally stable (all eigenvalues on the imaginary axis)"
    kind = "a complex quadruplet" if c else "real"
    return f"unstable: {n} eigenvalue(s) with positive real part ({kind})"
