"""The search for critical points: a start with known critical points, homotopy, deflation.

**Start.** ``W(c) = A . c + (sigma / 2) |x|^2`` (``x`` the R^k coordinates): on every
S^1, S^2 and SO(3) factor a linear function, whose critical points are known in closed
form, and on R^k a bowl with its minimum at 0. ``A`` is the gradient of ``V`` at the
reference configuration (:func:`home_point`: hanging links, identity attitudes), so that
for a potential that is linear in each factor (gravity on chains of bodies written in
absolute attitudes) ``W`` has the same critical points as ``V``. Where that gradient does not
make ``W`` Morse it is completed: a fixed generic direction on S^1 and S^2 when ``V`` does
not depend on the factor there, and on SO(3), ``G = U diag(s) W^T`` becomes
``U diag(s + sigma (1/2, 1/4, 0)) W^T`` (distinct singular values). The critical points of
a linear function ``a . p`` on S^1 or ``a . q`` on S^2 are ``+- a/|a|``; of
``tr(G^T R)`` on SO(3), with ``G = U diag(s) W^T`` and distinct ``s``, the four rotations
``U S W^T`` with ``S = diag(+-1, +-1, +-1)``, ``det = +1``. The start points are their
products (the "sign patterns": ``2^n`` for ``n`` links, 16 for two rigid bodies).

**Homotopy.** ``H_t = (1 - t) W + t V``. From each start the critical point is followed in
``t`` by natural-parameter continuation (a tangent predictor ``dc/dt = -(dF/dc)^+ dF/dt``
and Newton on the manifold at the new ``t``, step halved on failure): a path that folds
(the critical point meets another one and both disappear) cannot reach ``t = 1``, so
nothing is gained by pseudo-arclength here; it is reported as ended, and the deflation
below looks for what it would have found.

**Gauge.** At ``t = 1`` the critical sets of an invariant ``V`` are orbits of its symmetry
(:mod:`._critical_symmetry`); the last correction solves ``dV = 0`` together with
``xi_j . dW = 0`` for every symmetry generator ``xi_j``: the critical points of ``W``
restricted to the orbit, which are isolated, and which are exactly the limits of the
homotopy's paths (``H_t = V + (1 - t)(W - V)`` and ``V`` is constant on the orbit). For a
translation symmetry that fixes the free R^k coordinates at 0: the quotient by the
translations.

**Deflation** (Farrell, Birkisson and Funke, "Deflation techniques for finding distinct
solutions of nonlinear partial differential equations", SIAM J. Sci. Comput. 37 (2015)
A2026-A2045). With the known solutions ``r_i`` of the gauge-fixed system ``G(c) = 0``, Newton
is applied to ``M(c) G(c)``, ``M(c) = prod_i (|c - r_i|^-2 + 1)``, from seeded random
configurations: the known solutions are no longer zeros, so a converged solve is a new one.
A deflated solve explores: its line search stops at the factor ``DEFLATION_MIN_DAMPING``
(1/32) rather than Newton's usual 1/1024, since a start that needs shorter steps is
stagnating far from any zero, and most starts are of that kind once every set is known
(this halves the cost of a search on the chains and the double 3D pendulum, with the same
sets found on the tests' functions); the polish of a converged solve is plain Newton.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import casadi as ca
import numpy as np

from workbench.core.errors import ParameterError
from workbench.core.manifolds import S1, S2, Rn
from workbench.core.types import Matrix, Vector
from workbench.equilibria._critical_function import (
    ConfigurationFunction,
    generalised_force,
    home_point,
)
from workbench.equilibria._critical_symmetry import Symmetry, _field_function
from workbench.equilibria._roots import DenseEvaluator, Root, newton_on_manifold

__all__ = ["Start", "Homotopy", "PathEnd", "start_function", "track", "deflate"]

GENERIC_S1 = np.array([0.6, 0.8])
"""Direction of the start's linear function on an S^1 factor that ``V`` does not move."""
GENERIC_S2 = np.array([0.36, 0.48, 0.8])
"""Direction of the start's linear function on an S^2 factor that ``V`` does not move."""
SO3_SPREAD = np.array([0.5, 0.25, 0.0])
"""Added (times the scale) to the singular values of the start's linear function on SO(3)."""
DEFLATION_MIN_DAMPING = 1.0 / 32
"""Smallest line-search factor of a deflated solve before it is declared stagnated."""


@dataclass
class Start:
    """The start function ``W = A . c + (sigma/2)|x|^2`` and its critical points.

    Attributes
    ----------
    A : ndarray, shape=(ambient_dim,)
    quadratic : ndarray, shape=(ambient_dim,)
        ``sigma`` on the R^k coordinates, 0 elsewhere.
    points : list of ndarray
        The critical points of ``W`` (products of the factors' ones).
    labels : list of str
        For each point, the factors' choices (``"R1: U diag(1, -1, -1) W^T"``, ``"+"``).
    """

    A: Vector
    quadratic: Vector
    points: list[Vector]
    labels: list[str]


def _unit(v: Vector) -> Vector:
    return v / np.linalg.norm(v)


def start_function(fn: ConfigurationFunction, scale: float, *, max_starts: int) -> Start:
    """The start ``W`` for ``V`` (module docstring) and its critical points.

    Raises
    ------
    ParameterError
        When the product of the factors' counts exceeds ``max_starts``.
    """
    man = fn.manifold
    c0 = home_point(man)
    g = fn.gradient(c0)
    A = np.zeros(man.ambient_dim)
    quad = np.zeros(man.ambient_dim)
    choices: list[list[tuple[Vector, str]]] = []
    for name, f in man.factors:
        sl = man.slices[name]
        gf = g[sl]
        small = float(np.linalg.norm(gf)) <= 1e-12 * scale
        if isinstance(f, Rn):
            quad[sl] = scale
            choices.append([(np.zeros(f.dim), f"{name} = 0")])
        elif isinstance(f, (S1, S2)):
            a = scale * (GENERIC_S1 if isinstance(f, S1) else GENERIC_S2) if small else gf
            A[sl] = a
            u = _unit(a)
            choices.append([(-u, f"{name} low"), (u, f"{name} high")])
        else:
            G = gf.reshape(3, 3, order="F")
            U, s, Wt = np.linalg.svd(G)
            s2 = s + scale * SO3_SPREAD
            A[sl] = (U @ np.diag(s2) @ Wt).reshape(9, order="F")
            sign = np.sign(np.linalg.det(U) * np.linalg.det(Wt))
            opts = []
            for S in ([1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]):
                Sd = np.array(S, dtype=float) * np.array([1.0, 1.0, sign])
                R = U @ np.diag(Sd) @ Wt
                signs = ", ".join(f"{v:+.0f}" for v in Sd)
                opts.append((R.reshape(9, order="F"), f"{name} U diag({signs}) W^T"))
            choices.append(opts)
    count = int(np.prod([len(o) for o in choices]))
    if count > max_starts:
        raise ParameterError(f"the start function has {count} critical points (the product over "
                         f"the factors) > max_starts = {max_starts}; raise max_starts if "
                         "you mean it")
    points, labels = [], []
    for combo in _product(choices):
        points.append(np.concatenate([v for v, _ in combo]))
        labels.append(", ".join(lab for _, lab in combo))
    return Start(A, quad, points, labels)


def _product(choices: list[list[tuple[Vector, str]]]) -> list[list[tuple[Vector, str]]]:
    out: list[list[tuple[Vector, str]]] = [[]]
    for opts in choices:
        out = [prev + [o] for prev in out for o in opts]
    return out


class Homotopy:
    """``H_t = (1 - t) W + t V`` and the gauge rows ``xi_j . dW``, one casadi graph.

    Parameters
    ----------
    fn : ConfigurationFunction
    start : Start
    symmetry : Symmetry
    """

    def __init__(self, fn: ConfigurationFunction, start: Start, symmetry: Symmetry) -> None:
        man = fn.manifold
        self.manifold, self.fn = man, fn
        c, p = fn.c_sym, fn.p_sym
        t = ca.SX.sym("t")
        W = ca.dot(ca.DM(start.A), c) + 0.5 * ca.dot(ca.DM(start.quadratic) * c, c)
        H = (1 - t) * W + t * fn.V_sym
        F = generalised_force(man, c, ca.gradient(H, c))
        coef = symmetry.coefficients
        if coef.shape[1]:
            X = _field_function(man, symmetry.candidates)(c) @ ca.DM(coef)
            gauge = X.T @ ca.gradient(W, c)
        else:
            gauge = ca.SX.zeros(0, 1)
        self._ev = DenseEvaluator(ca.Function(
            "homotopy", [c, t, p],
            [ca.densify(e) for e in (F, ca.jacobian(F, c), ca.jacobian(F, t), gauge,
                                     ca.jacobian(gauge, c))]))
        self.evaluations = 0

    def at(self, c: Vector, t: float) -> tuple[Vector, Matrix, Vector]:
        """``F``, ``dF/dc N`` and ``dF/dt`` at ``(c, t)``."""
        self.evaluations += 1
        F, D, Ft, _, _ = self._ev(c, np.array([t]), self.fn.p)
        D = D.reshape(F.size, c.size)  # column outputs come back 1-D
        return F, D @ self.manifold.tangent_basis(c), Ft

    def gauged(self, c: Vector) -> tuple[Vector, Matrix]:
        """``G = [F(c, 1); xi . dW]`` and its tangent Jacobian."""
        G, A, _ = self.gauged_basis(c)
        return G, A

    def gauged_basis(self, c: Vector) -> tuple[Vector, Matrix, Matrix]:
        """``G``, its tangent Jacobian and the tangent basis ``N`` at ``c`` (used for both)."""
        self.evaluations += 1
        F, D, _, g, Dg = self._ev(c, np.array([1.0]), self.fn.p)
        D, Dg = D.reshape(F.size, c.size), Dg.reshape(g.size, c.size)
        N = self.manifold.tangent_basis(c)
        return np.concatenate([F, g]), np.vstack([D @ N, Dg @ N]) if g.size else D @ N, N


@dataclass
class PathEnd:
    """Where a homotopy path from one start ended.

    Attributes
    ----------
    label : str
        The start's choices.
    start : ndarray
    reached : bool
        ``t = 1`` was reached and the gauge-fixed system solved.
    t : float
        The last ``t`` reached.
    point : ndarray
        The end point (a critical point of ``V`` when ``reached``).
    steps : int
        Accepted continuation steps.
    message : str
    """

    label: str
    start: Vector
    reached: bool
    t: float
    point: Vector
    steps: int
    message: str


def track(h: Homotopy, start: Vector, label: str, *, tol: float, max_iterations: int,
          min_step: float = 1.0 / 4096, max_jump: float = 0.5) -> PathEnd:
    """Follow the critical point of ``H_t`` from ``t = 0`` to ``t = 1`` (module docstring).

    ``max_jump`` bounds the corrector's move from the predicted point (max-norm), so that a
    step does not land on another path; ``min_step`` is the smallest ``t`` step tried.
    """
    man = h.manifold
    c, t, step, steps = np.asarray(start, dtype=float), 0.0, 1.0, 0
    last = ""
    while True:
        t1 = min(1.0, t + step)
        _, A, Ft = h.at(c, t)
        v = -np.linalg.lstsq(A, Ft, rcond=1e-10)[0]
        pred = man.retract(c, (t1 - t) * v)
        if t1 == 1.0:
            fun: Callable = h.gauged
        else:
            def fun(y: Vector, t1: float = t1) -> tuple[Vector, Matrix]:
                F, A1, _ = h.at(y, t1)
                return F, A1
        root = newton_on_manifold(fun, man, pred, tol=tol, max_iterations=max_iterations,
                                  step_tol=1e-15, diagnostics=False, raise_on_failure=False)
        jump = float(np.max(np.abs(root.x - pred)))
        if root.ok and jump <= max_jump:
            c, t, steps = root.x, t1, steps + 1
            if t == 1.0:
                return PathEnd(label, np.asarray(start), True, 1.0, c, steps,
                               f"reached t = 1 in {steps} steps")
            step = min(2 * step, 1.0)
            continue
        last = root.message if not root.ok else f"the corrector moved {jump:.2g} > {max_jump}"
        step *= 0.5
        if step < min_step:
            return PathEnd(label, np.asarray(start), False, t, c, steps,
                           f"ended at t = {t:.6g}: no step of {2 * step:.2g} or more "
                           f"converged ({last}); a fold, where the critical point meets "
                           "another one, or a singular point")


def deflate(h: Homotopy, known: list[Vector], c0: Vector, *, tol: float,
            max_iterations: int, power: float = 2.0, shift: float = 1.0) -> Root:
    """Newton on the deflated gauge-fixed system from ``c0`` (module docstring).

    The deflation factor is divided by its value at ``c0`` (Newton's steps do not change
    with a constant factor, and with thousands of known solutions the product would
    overflow); a converged deflated solve is polished by plain Newton on the gauge-fixed
    system, whose status is returned, so a returned CONVERGED is a zero of ``G`` to ``tol``.
    """
    man = h.manifold
    roots = np.array(known, dtype=float).reshape(len(known), -1)

    def log_factor(c: Vector) -> tuple[float, Vector]:
        if not roots.size:
            return 0.0, np.zeros_like(c)
        d = c - roots
        n2 = np.einsum("ij,ij->i", d, d)
        mi = n2 ** (-power / 2) + shift
        dmi = (-power * n2 ** (-power / 2 - 1))[:, None] * d
        return float(np.sum(np.log(mi))), (dmi / mi[:, None]).sum(axis=0)

    log0 = log_factor(np.asarray(c0, dtype=float))[0]

    def fun(c: Vector) -> tuple[Vector, Matrix]:
        G, A, N = h.gauged_basis(c)
        logm, dlog = log_factor(c)
        m = np.exp(logm - log0)
        return m * G, m * (A + np.outer(G, dlog @ N))

    root = newton_on_manifold(fun, man, c0, tol=tol, max_iterations=max_iterations,
                              min_damping=DEFLATION_MIN_DAMPING, step_tol=1e-15,
                              diagnostics=False, raise_on_failure=False)
    if not root.ok:
        return root
    return newton_on_manifold(h.gauged, man, root.x, tol=tol, max_iterations=max_iterations,
                              step_tol=1e-15, diagnostics=False, raise_on_failure=False)
