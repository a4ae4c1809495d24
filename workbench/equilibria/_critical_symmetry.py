"""The continuous symmetries of a function on a configuration space, their orbits and flows.

The candidate actions on a product of configuration factors are, factor by factor:

=======  ==================================================  ================================
factor   candidate generators (velocity at ``c``)            flow
=======  ==================================================  ================================
R^k      translations ``e_i``                                ``x + theta v``
S^1      the shift of the angle, ``J p = (-p2, p1)``         rotation of ``p`` by ``theta``
S^2      world rotations about ``e_i``: ``e_i x q``          ``exp(theta hat(a)) q``
SO(3)    world rotations ``hat(e_i) R``, body rotations      ``exp(theta hat(a)) R
         ``R hat(e_i)``                                      exp(theta hat(b))``
=======  ==================================================  ================================

and every linear combination of them (a joint rotation of several factors, a rotation that
turns the world and the body together). Rotations of an R^k factor are not candidates (they
do not commute with its translations): a function invariant under them (a "Mexican hat"
``(|x|^2 - 1)^2``) has critical sets that are reported degenerate, not classified. The
infinitesimal symmetries of ``V`` among them are the combinations ``xi`` with
``dV . xi = 0`` everywhere; they form a Lie algebra ``s``, found as the null space of the
matrix ``dV(c_k) . xi_j(c_k)`` at seeded random configurations ``c_k`` (a linear
condition, so a handful more samples than candidates decide it).

When ``s`` splits into a compact part (rotations and shifts) and translations, and the
compact part is abelian, its group is a torus: every orbit of it is a torus ``T^d`` (a
compact connected abelian group modulo a stabiliser), and the translations sweep ``R^j``.
Commuting rotations of one factor part share one axis, so each compact generator is a
combination of unit rotations and shifts of period ``2 pi``; with rational ratios (found
to denominators ``<= MAX_DENOMINATOR``) they are scaled to an integer basis, whose flows
all have period ``2 pi``. That makes the orbit through a point an explicit image of
``[0, 2 pi)^d`` (:meth:`Symmetry.same_orbit`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import casadi as ca
import numpy as np

from workbench.core._evaluator import DenseEvaluator
from workbench.core.manifolds import S1, S2, SO3, ProductManifold, Rn, so3_exp
from workbench.core.types import Matrix, Vector

__all__ = ["Candidate", "Generator", "Symmetry", "candidates", "detect_symmetry",
           "MAX_DENOMINATOR"]

MAX_DENOMINATOR = 12
"""Ratios between the rates of a compact generator's rotations are accepted as rational up
to this denominator (joint rotations have ratios +-1)."""


@dataclass(frozen=True)
class Candidate:
    """One candidate generator: a unit rotation, shift or translation of one factor.

    Attributes
    ----------
    factor : str
        The factor's name.
    part : str
        ``"translate"``, ``"shift"``, ``"rotate"`` (S^2, about a world axis), ``"world"``
        or ``"body"`` (SO(3)).
    axis : int
        The coordinate axis (0-based).
    """

    factor: str
    part: str
    axis: int


def candidates(manifold: ProductManifold) -> list[Candidate]:
    """The candidate generators of a configuration manifold, in a fixed order."""
    out: list[Candidate] = []
    for name, f in manifold.factors:
        if isinstance(f, Rn):
            out += [Candidate(name, "translate", i) for i in range(f.dim)]
        elif isinstance(f, S1):
            out.append(Candidate(name, "shift", 0))
        elif isinstance(f, S2):
            out += [Candidate(name, "rotate", i) for i in range(3)]
        elif isinstance(f, SO3):
            out += [Candidate(name, part, i) for part in ("world", "body") for i in range(3)]
    return out


def _field_function(manifold: ProductManifold, cands: list[Candidate]) -> ca.Function:
    """``c -> [xi_1(c), ..., xi_n(c)]`` (ambient_dim x n), linear in ``c``."""
    c = ca.SX.sym("c", manifold.ambient_dim)
    cols = []
    for cand in cands:
        sl = manifold.slices[cand.factor]
        col = ca.SX.zeros(manifold.ambient_dim, 1)
        e = ca.DM(np.eye(3)[:, cand.axis]) if cand.part != "translate" else None
        part = c[sl]
        if cand.part == "translate":
            v = ca.SX.zeros(sl.stop - sl.start, 1)
            v[cand.axis] = 1
        elif cand.part == "shift":
            v = ca.vertcat(-part[1], part[0])
        elif cand.part == "rotate":
            v = ca.cross(ca.SX(e), part)
        else:
            R = ca.reshape(part, 3, 3)
            H = ca.skew(ca.SX(e))
            v = ca.vec(H @ R) if cand.part == "world" else ca.vec(R @ H)
        col[sl] = v
        cols.append(col)
    return ca.Function("candidate_fields", [c], [ca.densify(ca.horzcat(*cols))], ["c"],
                       ["xi"])


@dataclass
class Generator:
    """A generator of the symmetry group, as coefficients on the candidates.

    Attributes
    ----------
    coefficients : ndarray, shape=(n_candidates,)
    compact : bool
        A rotation/shift (periodic flow) or a translation.
    description : str
        What it moves, in words.
    """

    coefficients: Vector
    compact: bool
    description: str


@dataclass
class Symmetry:
    """The symmetry algebra of a function among the candidate actions (module docstring).

    Attributes
    ----------
    manifold : ProductManifold
    candidates : list of Candidate
    generators : list of Generator
        A basis: the compact ones (an integer basis when ``periodic``), then translations.
    abelian : bool
        The compact part is abelian (its group a torus).
    mixed : bool
        Some symmetry mixes a translation with a rotation (a screw): not split.
    periodic : bool
        The compact generators were scaled to an integer basis (all flows of period 2 pi).
    singular_values : ndarray
        Of the sampled matrix ``dV . xi``, largest first (the smallest ones define ``s``).
    notes : list of str
    """

    manifold: ProductManifold
    candidates: list[Candidate]
    generators: list[Generator]
    abelian: bool
    mixed: bool
    periodic: bool
    singular_values: Vector
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._fields = DenseEvaluator(_field_function(self.manifold, self.candidates))

    @property
    def coefficients(self) -> Matrix:
        """``(n_candidates, n_generators)``: the generators as columns."""
        if not self.generators:
            return np.zeros((len(self.candidates), 0))
        return np.column_stack([g.coefficients for g in self.generators])

    @property
    def classified(self) -> bool:
        """Orbits are tori times translations (abelian compact part, nothing mixed)."""
        return self.abelian and not self.mixed

    def candidate_fields(self, c: Vector) -> Matrix:
        """``(ambient_dim, n_candidates)``: every candidate's velocity at ``c``."""
        X = self._fields(np.asarray(c, dtype=float))[0]
        return X.reshape(self.manifold.ambient_dim, len(self.candidates), order="F")

    def fields(self, c: Vector) -> Matrix:
        """``(ambient_dim, n_generators)``: the generators' velocities at ``c``."""
        return self.candidate_fields(c) @ self.coefficients

    def describe(self) -> list[str]:
        """One line per generator."""
        return [g.description for g in self.generators]

    # flows --------------------------------------------------------------------------------
    def flow(self, c: Vector, coefficients: Vector, theta: float) -> Vector:
        """The point ``c`` moved for time ``theta`` along a combination of candidates.

        Exact for the compact part when its rotations of one factor part share an axis
        (always, for an abelian symmetry); translations add ``theta v``.
        """
        out = np.asarray(c, dtype=float).copy()
        coef = np.asarray(coefficients, dtype=float)
        by: dict[tuple[str, str], np.ndarray] = {}
        for cand, a in zip(self.candidates, coef):
            key = (cand.factor, cand.part)
            by.setdefault(key, np.zeros(3))[cand.axis] = a
        for name, f in self.manifold.factors:
            sl = self.manifold.slices[name]
            part = out[sl]
            if isinstance(f, Rn) and (name, "translate") in by:
                out[sl] = part + theta * by[(name, "translate")][: f.dim]
            elif isinstance(f, S1) and (name, "shift") in by:
                a = theta * by[(name, "shift")][0]
                ca_, sa = np.cos(a), np.sin(a)
                out[sl] = [ca_ * part[0] - sa * part[1], sa * part[0] + ca_ * part[1]]
            elif isinstance(f, S2) and (name, "rotate") in by:
                out[sl] = so3_exp(theta * by[(name, "rotate")]) @ part
            elif isinstance(f, SO3):
                R = part.reshape(3, 3, order="F")
                if (name, "world") in by:
                    R = so3_exp(theta * by[(name, "world")]) @ R
                if (name, "body") in by:
                    R = R @ so3_exp(theta * by[(name, "body")])
                out[sl] = R.reshape(9, order="F")
        return out

    def orbit_basis(self, c: Vector, *, rtol: float) -> tuple[list[int], list[int]]:
        """Generators whose velocities at ``c`` are independent: (compact, translations).

        Greedy in the order of :attr:`generators`; their number is the orbit's dimension.
        """
        X = self.fields(c)
        scale = max(1.0, float(np.max(np.abs(X)))) if X.size else 1.0
        chosen: list[int] = []
        for j in range(X.shape[1]):
            trial = X[:, chosen + [j]]
            if np.linalg.matrix_rank(trial, tol=rtol * scale) == len(chosen) + 1:
                chosen.append(j)
        comp = [j for j in chosen if self.generators[j].compact]
        return comp, [j for j in chosen if not self.generators[j].compact]

    def same_orbit(self, a: Vector, b: Vector, *, tol: float, rtol: float = 1e-8,
                   grid: int = 6, max_iterations: int = 30) -> bool:
        """Whether ``b`` lies on the orbit of ``a`` (to ``tol`` in the max-norm).

        Gauss-Newton on ``theta`` for ``exp(sum_k theta_k xi_k) a = b`` over the generators
        ``xi_k`` chosen by :meth:`orbit_basis` at ``a``, from a ``grid^d`` of starts covering
        ``[0, 2 pi)^d`` of the compact ones (period 2 pi when :attr:`periodic`; twice that
        range otherwise) and 0 for the translations. For an abelian symmetry the exponential
        is the composition of the generators' flows and its Jacobian their velocities; for
        a non-abelian one (a compact connected group: its exponential is onto) the Jacobian
        is taken by central differences.
        """
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        if float(np.max(np.abs(a - b))) <= tol:
            return True
        comp, trans = self.orbit_basis(a, rtol=rtol)
        gens = comp + trans
        if not gens:
            return False
        span = 2 * np.pi if self.periodic else 4 * np.pi
        axes = [np.arange(grid) * span / grid] * len(comp) + [np.zeros(1)] * len(trans)
        C = np.column_stack([self.generators[j].coefficients for j in gens])

        def jacobian(theta: Vector, p: Vector) -> Matrix:
            if self.abelian:
                return self.candidate_fields(p) @ C
            h = 1e-6
            return np.column_stack([
                (self.flow(a, C @ (theta + h * e), 1.0) - self.flow(a, C @ (theta - h * e), 1.0))
                / (2 * h) for e in np.eye(len(theta))])

        for start in np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(gens), -1).T:
            theta = start.copy()
            for _ in range(max_iterations):
                p = self.flow(a, C @ theta, 1.0)
                r = p - b
                if float(np.max(np.abs(r))) <= tol:
                    return True
                step = np.linalg.lstsq(jacobian(theta, p), -r, rcond=None)[0]
                theta = theta + step
                if float(np.max(np.abs(step))) < 1e-15:
                    break
        return False


def _rationalise(row: Vector) -> Vector | None:
    """Scale a row to small integers (ratios rational to MAX_DENOMINATOR), or None."""
    nz = np.abs(row) > 1e-9 * max(1.0, float(np.max(np.abs(row))))
    if not np.any(nz):
        return None
    ref = row[np.argmax(np.abs(row))]
    fr = [Fraction(float(v / ref)).limit_denominator(MAX_DENOMINATOR) if z else Fraction(0)
          for v, z in zip(row, nz)]
    if any(abs(float(f) - v / ref) > 1e-7 for f, v, z in zip(fr, row, nz) if z):
        return None
    lcm = 1
    for f in fr:
        lcm = lcm * f.denominator // np.gcd(lcm, f.denominator)
    return np.array([float(f * lcm) for f in fr])


def _describe(manifold: ProductManifold, cands: list[Candidate], coef: Vector) -> str:
    words = {"translate": "translation of {f} along {v}", "shift": "shift of the angle {f} "
             "at rate {v}", "rotate": "world rotation of {f} about {v}", "world": "world "
             "rotation of {f} about {v}", "body": "body rotation of {f} about {v}"}
    by: dict[tuple[str, str], np.ndarray] = {}
    for cand, a in zip(cands, coef):
        by.setdefault((cand.factor, cand.part), np.zeros(3))[cand.axis] = a
    out = []
    for (name, part), v in by.items():
        if np.max(np.abs(v)) <= 1e-12:
            continue
        k = manifold.factor(name).dim if part == "translate" else (1 if part == "shift" else 3)
        vec = np.round(v[:k], 6) + 0.0  # no "-0.0"
        out.append(words[part].format(f=name, v=vec[0] if k == 1 else vec.tolist()))
    return " + ".join(out)


def detect_symmetry(manifold: ProductManifold, gradient: callable, samples: list[Vector], *,
                    rtol: float) -> Symmetry:
    """The symmetry algebra of a function among the candidates (module docstring).

    Parameters
    ----------
    manifold : ProductManifold
        Configuration factors only.
    gradient : callable
        ``gradient(c) -> dV/dc`` (ambient), at a numeric point.
    samples : list of ndarray
        Seeded random configurations (more than the number of candidates).
    rtol : float
        A combination is a symmetry when its sampled ``|dV . xi|`` is below ``rtol`` times
        the largest ``|dV| |xi|`` over the samples.

    Returns
    -------
    Symmetry
    """
    cands = candidates(manifold)
    n = len(cands)
    empty = Symmetry(manifold, cands, [], True, False, True, np.zeros(0))
    if n == 0:
        return empty
    probe = empty
    rows, scale = [], 0.0
    for c in samples:
        g = np.asarray(gradient(c), dtype=float)
        X = probe.candidate_fields(c)
        rows.append(g @ X)
        scale = max(scale, float(np.linalg.norm(g)) * float(np.max(np.linalg.norm(X, axis=0))))
    M = np.array(rows)
    _, s, Vt = np.linalg.svd(M)
    s_full = np.concatenate([s, np.zeros(n - s.size)]) if s.size < n else s
    S = Vt[s_full <= rtol * scale * np.sqrt(len(samples))].T  # (n, r)
    if S.shape[1] == 0:
        return Symmetry(manifold, cands, [], True, False, True, s)
    is_t = np.array([c.part == "translate" for c in cands])
    notes: list[str] = []

    def sub(mask: np.ndarray) -> Matrix:  # elements of span(S) vanishing on ~mask rows
        if not np.any(~mask):
            return S
        _, sv, Wt = np.linalg.svd(S[~mask], full_matrices=True)
        k = int(np.sum(sv > 1e-9))
        return S @ Wt[k:].T

    Sc, St = sub(~is_t), sub(is_t)
    mixed = Sc.shape[1] + St.shape[1] < S.shape[1]
    if mixed:
        notes.append("a symmetry mixes a translation with a rotation (a screw): orbits not "
                     "classified")
    groups: dict[tuple[str, str], list[int]] = {}
    for j, cand in enumerate(cands):
        if cand.part in ("rotate", "world", "body"):
            groups.setdefault((cand.factor, cand.part), []).append(j)
    abelian, periodic = True, True
    units: list[np.ndarray] = []  # unit generators (candidate coefficients)
    for (fname, part), idx in groups.items():
        P = Sc[idx]
        if np.max(np.abs(P), initial=0.0) <= 1e-9:
            continue
        u, sv, _ = np.linalg.svd(P)
        if sv.size > 1 and sv[1] > 1e-7 * sv[0]:
            abelian = False
            notes.append(f"the rotations of {fname} ({part}) that leave the function "
                         "invariant do not commute: orbits not classified")
            continue
        unit = np.zeros(n)
        unit[idx] = u[:, 0]
        units.append(unit)
    for j, cand in enumerate(cands):
        if cand.part == "shift" and np.max(np.abs(Sc[j]), initial=0.0) > 1e-9:
            unit = np.zeros(n)
            unit[j] = 1.0
            units.append(unit)
    gens: list[Generator] = []
    if abelian and Sc.shape[1]:
        U = np.column_stack(units)
        lam = np.linalg.lstsq(U, Sc, rcond=None)[0]  # unit coordinates of the basis
        basis = _rref(lam.T)
        for row in basis:
            ints = _rationalise(row)
            if ints is None:
                periodic = False
                ints = row / np.max(np.abs(row))
            coef = U @ ints
            coef = coef * np.sign(coef[np.argmax(np.abs(coef))])
            gens.append(Generator(coef, True, _describe(manifold, cands, coef)))
    elif Sc.shape[1]:
        periodic = False
        for k in range(Sc.shape[1]):
            gens.append(Generator(Sc[:, k], True, _describe(manifold, cands, Sc[:, k])))
    for k in range(St.shape[1]):
        v = St[:, k] / np.max(np.abs(St[:, k]))
        gens.append(Generator(v, False, _describe(manifold, cands, v)))
    return Symmetry(manifold, cands, gens, abelian, mixed, periodic, s, notes)


def _rref(A: Matrix, tol: float = 1e-9) -> Matrix:
    """Reduced row echelon form of a full-row-rank matrix (rows spanning the same space)."""
    A = np.array(A, dtype=float)
    r = 0
    for col in range(A.shape[1]):
        if r == A.shape[0]:
            break
        piv = r + int(np.argmax(np.abs(A[r:, col])))
        if abs(A[piv, col]) <= tol:
            continue
        A[[r, piv]] = A[[piv, r]]
        A[r] /= A[r, col]
        for i in range(A.shape[0]):
            if i != r:
                A[i] -= A[i, col] * A[r]
        r += 1
    return A[:r]
