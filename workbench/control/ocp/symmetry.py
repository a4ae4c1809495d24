"""Continuous symmetries of an OCP, detected numerically, and the gauge that removes them.

A rotation ``g`` about a fixed axis ``a`` acts linearly on the ambient state and on the
input: unit vectors and tangent vectors of ``S^2``/``TS^2`` factors rotate (``q -> Q q``),
rotation matrices are rotated in space (``R -> Q R``), 3-vectors rotate or stay (body-frame
quantities), planar factors (``R^2``, ``S^1``) and a planar input rotate about ``e3`` as
the plane orthogonal to it, or stay. If, for one such candidate action ``(G_x, G_u)``,

* the vector field is equivariant, ``f(G_x x, G_u u) = G_x f(x, u)``,
* the running cost, the terminal cost and every path constraint are invariant,
* the initial state is fixed, ``G_x x0 = x0``, and the target set is invariant: a target
  point is fixed, a target map is equivariant, ``phi(G_x x) = H phi(x)`` with ``H y* = y*``
  for a rotation ``H`` of the target manifold about the same axis (tried like ``G_x``),

then every rotated trajectory of a feasible one is feasible at the same cost: the optima
of the OCP come in circles, and the reduced Hessian of the NLP is singular along them
(Ipopt then regularises and crawls). :func:`detect_symmetry` tries the candidates (axes
``e3``, ``e1``, ``e2``; each factor rotated or fixed) and accepts the first one that
passes every check at seeded random points of the manifold, random inputs and random
angles, to a relative tolerance. A candidate is accepted only when it is *verified*; an
unusual model (an ``R^2`` factor that is not the horizontal plane) fails the test and is
simply not gauged.

The control bounds are not part of the test: a box ``|u_i| <= b`` is invariant under
quarter turns only. Where the box is inactive along a solution the continuous symmetry
holds locally and the gauge is harmless; where it is active the gauge may bind. The
solve therefore reads the gauge's multiplier: a binding gauge (nonzero multiplier) is
reported, and :func:`~workbench.control.ocp.solve.solve` re-solves without it, warm-started.

The gauge is a *phase condition* (as in the continuation of relative periodic orbits):
the solution is sought in the slice through the guess ``w0`` orthogonal to its group
orbit, ``<A w0, w - w0> = 0`` with ``A`` the generator acting on the node states and
controls. ``<A w0, w0> = 0`` because ``A`` is skew, so the condition is linear,
``<A w0, w> = 0``, transversal to the orbit wherever ``A w0 != 0``, and it picks the
member of each circle of optima nearest the guess.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from scipy.linalg import expm

from workbench.core.manifolds import S1, S2, SO3, TS2, Rn

__all__ = ["Symmetry", "detect_symmetry"]

AXES = {"e3": np.array([0.0, 0.0, 1.0]), "e1": np.array([1.0, 0.0, 0.0]),
        "e2": np.array([0.0, 1.0, 0.0])}


@dataclass(frozen=True)
class Symmetry:
    """A verified rotation symmetry of an OCP.

    Attributes
    ----------
    axis : str
        ``"e3"``, ``"e1"`` or ``"e2"``.
    Ax : ndarray, shape=(ambient_dim, ambient_dim)
        Skew generator of the action on the ambient state.
    Au : ndarray, shape=(n_inputs, n_inputs)
        Skew generator of the action on the input.
    actions : dict
        Per factor (and ``"u"``): ``"rotated"`` or ``"fixed"``.
    residual : float
        Largest relative invariance residual found in the checks.
    """

    axis: str
    Ax: np.ndarray = field(repr=False)
    Au: np.ndarray = field(repr=False)
    actions: dict[str, str]
    residual: float

    def describe(self) -> str:
        """E.g. ``"rotation about e3 (rotates x, v, link1, u)"``."""
        moved = [k for k, v in self.actions.items() if v == "rotated"]
        return f"rotation about {self.axis} (rotates {', '.join(moved)})"

    def act(self, theta: float) -> tuple[np.ndarray, np.ndarray]:
        """The matrices ``(G_x, G_u)`` of the rotation by ``theta``."""
        return expm(theta * self.Ax), expm(theta * self.Au)


def _planar() -> np.ndarray:
    return np.array([[0.0, -1.0], [1.0, 0.0]])


def _factor_options(f: Any, axis: str) -> list[tuple[str, np.ndarray | None]]:
    """Candidate generators of one factor: ``("rotated", A)`` or ``("fixed", None)``."""
    hat = ca.DM(ca.skew(ca.DM(AXES[axis]))).full()
    fixed: list[tuple[str, np.ndarray | None]] = [("fixed", None)]
    n = f.ambient_dim
    if isinstance(f, (S2,)) or (isinstance(f, Rn) and n == 3):
        return [("rotated", hat)] + fixed
    if isinstance(f, TS2):
        return [("rotated", np.kron(np.eye(2), hat))] + fixed
    if isinstance(f, SO3):  # R -> Q R on column-major storage: each column rotates
        return [("rotated", np.kron(np.eye(3), hat))] + fixed
    if isinstance(f, (S1,)) or (isinstance(f, Rn) and n == 2):
        return ([("rotated", _planar())] if axis == "e3" else []) + fixed
    return fixed


def _input_options(nu: int, axis: str) -> list[tuple[str, np.ndarray | None]]:
    if nu == 3:
        return [("rotated", ca.DM(ca.skew(ca.DM(AXES[axis]))).full()), ("fixed", None)]
    if nu == 2 and axis == "e3":
        return [("rotated", _planar()), ("fixed", None)]
    return [("fixed", None)]


def _block(mats: list[tuple[int, np.ndarray | None]]) -> np.ndarray:
    n = sum(k for k, _ in mats)
    A = np.zeros((n, n))
    i = 0
    for k, M in mats:
        if M is not None:
            A[i: i + k, i: i + k] = M
        i += k
    return A


class _Checks:
    """Numeric functions of an OCP and the seeded sample points of the invariance test."""

    def __init__(self, ocp: Any, samples: int, seed: int) -> None:
        m = ocp.model
        nx, nu = m.manifold.ambient_dim, m.n_inputs
        x, u, T = ca.SX.sym("x", nx), ca.SX.sym("u", nu), ca.SX.sym("T")
        f = m.function("f")
        p = m.p
        self.f = lambda xv, uv: np.asarray(f(xv, uv, p), float).ravel()
        scalars = []
        if ocp.running_cost is not None:
            scalars.append(ca.vec(ocp.running_cost(x, u)))
        for c in ocp.path_constraints:
            scalars.append(ca.vec(c.function(x, u)))
        if ocp.terminal_cost is not None:
            scalars.append(ca.vec(ocp.terminal_cost(x, T)))
        body = ca.vertcat(*scalars) if scalars else ca.SX.zeros(0, 1)
        self.g = ca.Function("invariants", [x, u, T], [body])
        rng = np.random.default_rng(seed)
        self.points = [(m.manifold.random_point(rng), rng.standard_normal(nu),
                        float(rng.uniform(0.5, 3.0)), float(rng.uniform(0.3, 2.8)))
                       for _ in range(samples)]
        self.x0 = np.asarray(ocp.x0, float)
        self.target = ocp.target
        self.phi = (None if ocp.target.phi(x) is x  # a target point
                    else ca.Function("phi", [x], [ca.vec(ocp.target.phi(x))]))

    def target_residual(self, Ax: np.ndarray, axis: str) -> float:
        """Smallest residual of ``phi(G x) = H phi(x)``, ``H y* = y*`` over candidate ``H``."""
        if self.phi is None:
            return 0.0
        P = self.target.manifold
        best = float("inf")
        for combo in itertools.product(*[_factor_options(f, axis) for _, f in P.factors]):
            Ay = _block([(f.ambient_dim, M) for (_, f), (_, M) in zip(P.factors, combo)])
            worst = 0.0
            for x, _, _, theta in self.points:
                Gx, H = expm(theta * Ax), expm(theta * Ay)
                y = np.asarray(self.phi(x), float).ravel()
                worst = max(worst, _rel(np.asarray(self.phi(Gx @ x), float).ravel(), H @ y),
                            _rel(H @ self.target.value, self.target.value))
            best = min(best, worst)
        return best

    def residual(self, Ax: np.ndarray, Au: np.ndarray, axis: str) -> float:
        """Largest relative residual of every check under this generator (inf: refused)."""
        worst = 0.0
        for k, (x, u, T, theta) in enumerate(self.points):
            Gx, Gu = expm(theta * Ax), expm(theta * Au)
            if k == 0:
                worst = max(worst, _rel(Gx @ self.x0, self.x0))
                wit = np.asarray(self.target.witness, float)
                worst = max(worst, self.target.distance(Gx @ wit))
                if worst > 1e-6:
                    return float("inf")
                worst = max(worst, self.target_residual(Ax, axis))
            worst = max(worst, _rel(self.f(Gx @ x, Gu @ u), Gx @ self.f(x, u)))
            a = np.asarray(self.g(Gx @ x, Gu @ u, T), float).ravel()
            b = np.asarray(self.g(x, u, T), float).ravel()
            worst = max(worst, _rel(a, b))
        return worst


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    if a.size == 0:
        return 0.0
    return float(np.max(np.abs(a - b)) / (1.0 + np.max(np.abs(b))))


def detect_symmetry(ocp: Any, *, samples: int = 4, seed: int = 0,
                    tol: float = 1e-9) -> Symmetry | None:
    """The first verified rotation symmetry of ``ocp`` (see the module docstring), or None.

    Parameters
    ----------
    ocp : OCP
        The problem.
    samples : int
        Random points (and angles) of the test.
    seed : int
        Seed of the points.
    tol : float
        Largest accepted relative residual.

    Returns
    -------
    Symmetry or None
    """
    man, nu = ocp.model.manifold, ocp.model.n_inputs
    checks: _Checks | None = None
    for axis in AXES:
        per_factor = [_factor_options(f, axis) for _, f in man.factors]
        for combo in itertools.product(*per_factor, _input_options(nu, axis)):
            states, inp = combo[:-1], combo[-1]
            if all(a == "fixed" for a, _ in states):
                continue  # acts on the input only: moves no trajectory
            Ax = _block([(f.ambient_dim, M) for (_, f), (_, M) in zip(man.factors, states)])
            Au = _block([(nu, inp[1])])
            checks = checks or _Checks(ocp, samples, seed)
            res = checks.residual(Ax, Au, axis)
            if res <= tol:
                actions = {name: a for (name, _), (a, _) in zip(man.factors, states)}
                actions["u"] = inp[0]
                return Symmetry(axis, Ax, Au, actions, res)
    return None
