"""Controllability of linearisations: PBH tests (first and second order) and Kalman rank.

First order (Popov-Belevitch-Hautus): ``(A, B)`` is controllable iff
``rank [A - lambda I, B] = n`` at every eigenvalue ``lambda`` of ``A``. The rank is decided
by the smallest singular value relative to the largest,
``sigma_min / sigma_max <= tol`` meaning rank deficient; the tolerance, every mode's ratio
(its distance to uncontrollability) and, for a deficient mode, the left eigenvector ``w``
with ``w^H [A - lambda I, B] ~ 0`` (the uncontrollable mode) are reported. Eigenvalues that
agree to ``cluster_tol`` are tested once, at their mean, which is accurate even for a
Jordan block whose computed eigenvalues spread by ``O(sqrt(eps))``.

Second order, for ``M x'' + G x = B u`` (paper 003 (16)): controllable iff
``rank [lambda^2 M + G, B] = n`` at every root of ``det(lambda^2 M + G) = 0``
(paper 003 (40); (18) for the chain's reduced system). :func:`second_order_form` obtains
``M``, ``G`` and ``B`` from the model's graphs: ``M`` and ``G`` are the blocks of the
Riemannian Hessian of the energy invariant at the equilibrium (constrained Hessian
``N^T (d^2E - sum_k lambda_k d^2 h_k) N`` with Lagrange multipliers of the constraints
``h``), and ``B = M B_v`` with ``B_v`` the velocity rows of the first-order linearisation.
The stiffness ``-M A_vq`` of the linearised field is checked against the energy's ``G``.

The Kalman rank of ``[B, AB, ..., A^(n-1) B]`` is a cross-check; its condition number is
reported because it grows quickly with ``n`` and makes the rank decision fragile.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg as sla

from workbench.core import validate
from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.types import ArrayLike, Matrix, Vector
from workbench.linear._linearize import LinearModel, linearize, mechanical_order

__all__ = [
    "ModeTest",
    "PBHResult",
    "KalmanResult",
    "SecondOrderForm",
    "pbh",
    "pbh_second_order",
    "kalman_rank",
    "second_order_form",
    "PBH_TOL",
]

PBH_TOL = 1e-8
"""Default relative rank tolerance ``sigma_min / sigma_max`` of the PBH tests."""


@dataclass(frozen=True)
class ModeTest:
    """The PBH rank test at one (cluster of) eigenvalue(s).

    Attributes
    ----------
    eigenvalue : complex
        ``lambda`` (first order) or ``lambda^2`` (second order: the pencil's ``mu``).
    multiplicity : int
        Number of computed eigenvalues in the cluster.
    ratio : float
        ``sigma_min / sigma_max`` of the tested matrix (distance to uncontrollability).
    deficiency : int
        Number of singular values ``<= tol * sigma_max``.
    left_vectors : ndarray of complex, shape=(n, deficiency)
        Left null vectors ``w`` of the tested matrix (the uncontrollable modes).
    """

    eigenvalue: complex
    multiplicity: int
    ratio: float
    deficiency: int
    left_vectors: np.ndarray

    @property
    def controllable(self) -> bool:
        """Whether the tested matrix has full row rank."""
        return self.deficiency == 0


@dataclass(frozen=True)
class PBHResult:
    """Outcome of a PBH test.

    Attributes
    ----------
    controllable : bool
        Full rank at every eigenvalue.
    tol : float
        The relative rank tolerance used.
    modes : list of ModeTest
        One per distinct eigenvalue, in the order of increasing real part.
    order : int
        1 for ``[A - lambda I, B]``, 2 for ``[lambda^2 M + G, B]``.
    labels : tuple of str
        Coordinate names (for messages).
    """

    controllable: bool
    tol: float
    modes: list[ModeTest]
    order: int = 1
    labels: tuple[str, ...] = ()

    @property
    def uncontrollable(self) -> list[ModeTest]:
        """The rank-deficient modes."""
        return [m for m in self.modes if not m.controllable]

    @property
    def margin(self) -> float:
        """Smallest ``sigma_min / sigma_max`` over the modes."""
        return min((m.ratio for m in self.modes), default=float("inf"))

    def describe_mode(self, mode: ModeTest) -> str:
        """Readable account of one mode: eigenvalue, ratio, dominant coordinates of ``w``."""
        what = "lambda" if self.order == 1 else "lambda^2"
        txt = f"{what} = {_fmt_complex(mode.eigenvalue)} (sigma_min/sigma_max = " \
              f"{mode.ratio:.2g}, tol {self.tol:g})"
        if mode.deficiency:
            w = mode.left_vectors[:, 0]
            idx = np.argsort(-np.abs(w))[:4]
            names = self.labels or tuple(f"z{i + 1}" for i in range(w.size))
            parts = [f"{names[i]}: {_fmt_complex(w[i])}" for i in idx if abs(w[i]) > 1e-3]
            txt += f"; left eigenvector w with largest entries {', '.join(parts)}"
        return txt

    def summary(self) -> dict[str, Any]:
        """Plain JSON-serialisable account."""
        return {
            "controllable": self.controllable,
            "order": self.order,
            "tol": self.tol,
            "margin": self.margin,
            "n_modes_tested": len(self.modes),
            "uncontrollable": [self.describe_mode(m) for m in self.uncontrollable],
        }


def _fmt_complex(z: complex) -> str:
    z = complex(z)
    if abs(z.imag) <= 1e-12 * max(1.0, abs(z.real)):
        return f"{z.real:.6g}"
    return f"{z.real:.6g}{z.imag:+.6g}i"


def _clusters(ev: np.ndarray, ctol: float) -> list[tuple[complex, int]]:
    """Group eigenvalues closer than ``ctol`` (greedy, after sorting); return means."""
    order = np.lexsort((ev.imag, ev.real))
    rest = list(ev[order])
    out: list[tuple[complex, int]] = []
    while rest:
        head = rest[0]
        grp = [z for z in rest if abs(z - head) <= ctol]
        rest = [z for z in rest if abs(z - head) > ctol]
        out.append((complex(np.mean(grp)), len(grp)))
    return out


def _rank_test(Mat: np.ndarray, tol: float) -> tuple[float, int, np.ndarray]:
    U, s, _ = np.linalg.svd(Mat)
    n = Mat.shape[0]
    smax = float(s[0]) if s.size else 0.0
    if smax == 0.0:
        return 0.0, n, U
    sv = np.zeros(n)
    sv[: s.size] = s
    deficient = int(np.sum(sv <= tol * smax))
    return float(sv[-1] / smax), deficient, U[:, n - deficient:]


def _matrices(system: Any, B: ArrayLike | None) -> tuple[Matrix, Matrix, tuple[str, ...]]:
    if isinstance(system, LinearModel):
        if B is not None:
            raise ModelError("pass B only with a bare matrix A, not with a LinearModel")
        return system.A, system.B, tuple(system.labels)
    if system is None or isinstance(system, (str, bytes)) or not validate.is_real_array_like(
            system):
        raise ModelError(f"system must be a LinearModel (from linearize) or a real numeric "
                         f"matrix A; got {type(system).__name__} {system!r:.60}")
    if B is None:
        raise ModelError("B is required when A is given as a matrix")
    try:
        A, Bm = np.asarray(system, dtype=float), np.asarray(B, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"A and B must be numeric matrices; got A = {system!r}, "
                         f"B = {B!r}") from exc
    if Bm.ndim == 1:
        Bm = Bm[:, None]
    if A.ndim != 2 or A.shape[0] != A.shape[1] or Bm.shape[0] != A.shape[0]:
        raise ModelError(
            f"A must be square (n, n) and B (n, m); got A {A.shape} and B {Bm.shape}"
        )
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(Bm))):
        raise ModelError("A and B must be finite")
    return A, Bm, ()


def _check_tols(tol: float, cluster_tol: float) -> None:
    for name, v in (("tol", tol), ("cluster_tol", cluster_tol)):
        if not (np.isfinite(v) and 0 < v < 1):
            raise ModelError(f"{name} must be in (0, 1); got {v!r}")


@validate.arguments(error=ModelError, tol=validate.tolerance, cluster_tol=validate.tolerance)
def pbh(
    system: Any,
    B: ArrayLike | None = None,
    *,
    tol: float = PBH_TOL,
    cluster_tol: float = 1e-6,
) -> PBHResult:
    """First-order PBH test: ``rank [A - lambda I, B] = n`` at every eigenvalue.

    Parameters
    ----------
    system : LinearModel or array-like, shape=(n, n)
        The linearisation, or ``A``.
    B : array-like, shape=(n, m), optional
        Input matrix when ``system`` is a matrix.
    tol : float
        Relative rank tolerance on ``sigma_min / sigma_max``.
    cluster_tol : float
        Eigenvalues closer than ``cluster_tol * max(1, |A|)`` are tested once, at their
        mean.

    Returns
    -------
    PBHResult
    """
    A, Bm, labels = _matrices(system, B)
    _check_tols(tol, cluster_tol)
    n = A.shape[0]
    scale = max(1.0, float(np.linalg.norm(A, 2))) if n else 1.0
    modes = []
    for lam, mult in _clusters(np.linalg.eigvals(A), cluster_tol * scale):
        ratio, deficient, W = _rank_test(np.hstack([A - lam * np.eye(n), Bm]), tol)
        modes.append(ModeTest(lam, mult, ratio, deficient, W))
    return PBHResult(all(m.controllable for m in modes), tol, modes, 1, labels)


@dataclass(frozen=True)
class KalmanResult:
    """Rank of the (scaled) Kalman controllability matrix.

    Attributes
    ----------
    rank : int
        Numerical rank at ``tol``.
    n : int
        State dimension.
    condition : float
        ``sigma_max / sigma_n`` (inf if rank deficient): how fragile the decision is.
    tol : float
        Relative rank tolerance.
    singular_values : ndarray
        All singular values, descending.
    """

    rank: int
    n: int
    condition: float
    tol: float
    singular_values: Vector

    @property
    def controllable(self) -> bool:
        """Whether the rank is full."""
        return self.rank == self.n


@validate.arguments(error=ModelError, tol=validate.tolerance)
def kalman_rank(
    system: Any, B: ArrayLike | None = None, *, tol: float = 1e-10
) -> KalmanResult:
    """Kalman rank of ``[B, AB, ..., A^(n-1) B]`` (cross-check of :func:`pbh`).

    Each block ``A^k B`` is scaled by ``1 / max(1, |A|)^k`` (the rank is unchanged) to keep
    the numbers finite.

    Parameters
    ----------
    system : LinearModel or array-like, shape=(n, n)
        The linearisation, or ``A``.
    B : array-like, shape=(n, m), optional
        Input matrix when ``system`` is a matrix.
    tol : float
        Relative rank tolerance on the singular values.

    Returns
    -------
    KalmanResult
    """
    A, Bm, _ = _matrices(system, B)
    if not (np.isfinite(tol) and 0 < tol < 1):
        raise ModelError(f"tol must be in (0, 1); got {tol!r}")
    n = A.shape[0]
    a = max(1.0, float(np.linalg.norm(A, 2))) if n else 1.0
    blocks, blk = [], Bm.copy()
    for _ in range(n):
        blocks.append(blk)
        blk = (A @ blk) / a
    Cm = np.hstack(blocks) if blocks else np.zeros((0, 0))
    s = np.linalg.svd(Cm, compute_uv=False) if Cm.size else np.zeros(0)
    rank = int(np.sum(s > tol * s[0])) if s.size and s[0] > 0 else 0
    cond = float(s[0] / s[n - 1]) if s.size >= n and n and s[n - 1] > 0 else float("inf")
    return KalmanResult(rank, n, cond, tol, s)


# ----------------------------------------------------------------------------------------
# second-order (mechanical) form


@dataclass(frozen=True)
class SecondOrderForm:
    """``M x'' + D x' + G x = B u`` of a mechanical model at an equilibrium at rest.

    Attributes
    ----------
    M : ndarray, shape=(k, k)
        Mass matrix: the energy's Hessian in the velocity coordinates.
    G : ndarray, shape=(k, k)
        Stiffness: the energy's Riemannian Hessian in the configuration coordinates.
    B : ndarray, shape=(k, m)
        ``M`` times the velocity rows of the first-order input matrix.
    D : ndarray, shape=(k, k)
        Damping ``-M A_vv`` (zero for a conservative open loop).
    positions, velocities : list of int
        Indices of the configuration / velocity coordinates in the linearisation.
    linear : LinearModel
        The first-order linearisation it came from.
    checks : dict of str to float
        ``kinematics`` (``max |A_qq|, |A_qv - I|, |B_q|``), ``stiffness_mismatch``
        (``|G - (-M A_vq)| / max(1, |G|)``), ``energy_stationarity`` (``|grad E|`` on the
        tangent space), ``cross_hessian`` (``|H_qv|``): all zero up to rounding for a
        mechanical system with the energy as its Hamiltonian.
    """

    M: Matrix
    G: Matrix
    B: Matrix
    D: Matrix
    positions: list[int]
    velocities: list[int]
    linear: LinearModel
    checks: dict[str, float] = field(default_factory=dict)


def _energy_derivatives(model: Model, energy: str) -> ca.Function:
    """``(x, p, lam) -> (grad E, hess E, hess (lam . h), dh/dx)``, built once per model graphs.

    Cached and logged with the model's own functions (shared by
    :meth:`Model.with_parameters`, released with the model).
    """

    def make() -> ca.Function:
        E = model.function(energy)
        S = model.sym
        x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
        # the residual is built on SX and called on x (Rn factors return SX(0, 1) even
        # for MX input, which casadi cannot concatenate with MX)
        xs = ca.SX.sym("x", model.manifold.ambient_dim)
        h = ca.Function("h", [xs], [model.manifold.residual(xs)])(x)
        lam = S.sym("lam", h.shape[0])
        e = E(x, p)
        grad = ca.gradient(e, x)
        return ca.Function(
            "energy_hessian", [x, p, lam],
            [grad, ca.hessian(e, x)[0], ca.hessian(ca.dot(lam, h), x)[0], ca.jacobian(h, x)],
            ["x", "p", "lam"], ["grad", "hess", "hess_lh", "dh"],
        )

    return model._build(f"{energy}_hessian", make)  # noqa: SLF001 - the model's graph cache


@validate.arguments(
    error=ModelError, model=validate.instance(Model, "a workbench Model"),
    tol=validate.tolerance
)
def second_order_form(
    model: Model,
    x_e: ArrayLike,
    u_e: ArrayLike | None = None,
    *,
    pairs: Mapping[str, str] | None = None,
    energy: str = "energy",
    tol: float = 1e-8,
) -> SecondOrderForm:
    """``M``, ``G``, ``B`` (and ``D``) of a mechanical model at an equilibrium at rest.

    Parameters
    ----------
    model : Model
        A mechanical model with an energy invariant (open loop).
    x_e : array-like, shape=(ambient_dim,)
        An equilibrium with zero velocity.
    u_e : array-like, shape=(n_inputs,), optional
        Input at the equilibrium.
    pairs : mapping of str to str, optional
        Configuration -> velocity factor names (see
        :func:`~workbench.linear._linearize.mechanical_order`); TS2 factors split themselves.
    energy : str
        Name of the model's energy invariant.
    tol : float
        Largest accepted relative inconsistency of the checks (see
        :attr:`SecondOrderForm.checks`).

    Returns
    -------
    SecondOrderForm
        In the order ``positions`` / ``velocities`` of the default tangent coordinates
        (for the chain with ``pairs={"x": "v"}``: paper 003's ``[delta x; x_q]``).

    Raises
    ------
    ModelError
        No such invariant; the point is not an equilibrium at rest (the energy is not
        stationary); or the linearised field is not of second-order form with the energy's
        stiffness (the message names the failed check).
    """
    if energy not in model.invariant_names:
        raise ModelError(
            f"second_order_form needs the energy invariant {energy!r}; model "
            f"{model.name!r} has {model.invariant_names}"
        )
    lin = linearize(model, x_e, u_e)
    pos, vel = mechanical_order(model, pairs)
    fn = _energy_derivatives(model, energy)
    xe, N = lin.x_e, lin.basis
    grad, _, _, dh = (np.asarray(v, dtype=float)
                      for v in fn(xe, model.p, np.zeros(model.manifold.residual(xe).size)))
    grad = grad.ravel()
    lam = np.linalg.lstsq(dh.T, grad, rcond=None)[0] if dh.size else np.zeros(0)
    stat = float(np.max(np.abs(N.T @ grad))) / max(1.0, float(np.max(np.abs(grad))))
    _, hess, hess_lh, _ = (np.asarray(v, dtype=float) for v in fn(xe, model.p, lam))
    H = N.T @ (hess - hess_lh) @ N
    H = 0.5 * (H + H.T)
    M, G, cross = H[np.ix_(vel, vel)], H[np.ix_(pos, pos)], H[np.ix_(pos, vel)]
    A, Bl = lin.A, lin.B
    k = len(pos)
    kin = max(float(np.max(np.abs(A[np.ix_(pos, pos)]))),
              float(np.max(np.abs(A[np.ix_(pos, vel)] - np.eye(k)))),
              float(np.max(np.abs(Bl[pos]))) if Bl.size else 0.0)
    G_dyn = -M @ A[np.ix_(vel, pos)]
    D = -M @ A[np.ix_(vel, vel)]
    gscale = max(1.0, float(np.max(np.abs(G))))
    checks = {
        "kinematics": kin / max(1.0, float(np.max(np.abs(A)))),
        "stiffness_mismatch": float(np.max(np.abs(G_dyn - G))) / gscale,
        "energy_stationarity": stat,
        "cross_hessian": float(np.max(np.abs(cross))) / max(1.0, float(np.max(np.abs(H)))),
    }
    bad = {name: v for name, v in checks.items() if not v <= tol}
    if bad:
        raise ModelError(
            f"model {model.name!r} at x_e is not in second-order mechanical form with energy "
            f"{energy!r} (failed checks {', '.join(f'{n} = {v:.3g}' for n, v in bad.items())}"
            f" > tol {tol:g}): x_e must be an equilibrium at rest and pairs must match each "
            f"configuration factor with its velocity factor"
        )
    return SecondOrderForm(M=M, G=G, B=M @ Bl[vel], D=D, positions=pos, velocities=vel,
                           linear=lin, checks=checks)


def _form_or_matrix(name: str, value: Any, *, error: type = ModelError) -> Any:
    """A SecondOrderForm as it is, anything else as a real matrix (validate.array)."""
    return value if isinstance(value, SecondOrderForm) else _matrix(name, value, error=error)


def _matrix(name: str, value: Any, *, error: type = ModelError) -> Any:
    """A real matrix (or vector), never an array of more than two axes."""
    arr = validate.array(name, value, error=error)
    if arr.ndim > 2:
        raise error(f"{name} must be a matrix; got shape {arr.shape}")
    return arr


@validate.arguments(error=ModelError, tol=validate.tolerance, cluster_tol=validate.tolerance,
                    M=_form_or_matrix, G=validate.optional(_matrix),
                    B=validate.optional(_matrix))
def pbh_second_order(
    M: Any,
    G: ArrayLike | None = None,
    B: ArrayLike | None = None,
    *,
    tol: float = PBH_TOL,
    cluster_tol: float = 1e-6,
    labels: Sequence[str] = (),
) -> PBHResult:
    """Second-order PBH test ``rank [lambda^2 M + G, B] = k`` (paper 003 (18), (40)).

    Parameters
    ----------
    M : SecondOrderForm or array-like, shape=(k, k)
        The form (its ``M``, ``G``, ``B`` are used), or the mass matrix (invertible).
    G : array-like, shape=(k, k), optional
        Stiffness, when ``M`` is a matrix.
    B : array-like, shape=(k, m), optional
        Input matrix, when ``M`` is a matrix.
    tol : float
        Relative rank tolerance on ``sigma_min / sigma_max``.
    cluster_tol : float
        Values of ``lambda^2`` closer than ``cluster_tol * max(1, |M^-1 G|)`` are tested
        once.
    labels : sequence of str
        Coordinate names for messages.

    Returns
    -------
    PBHResult
        ``order = 2``; each mode's ``eigenvalue`` is ``mu = lambda^2``, a root of
        ``det(mu M + G) = 0``.
    """
    if isinstance(M, SecondOrderForm):
        form = M
        Mm, Gm, Bm = form.M, form.G, form.B
        if not labels:
            labels = [form.linear.labels[i] for i in form.positions]
    else:
        if G is None or B is None:
            raise ModelError("pbh_second_order needs M, G and B (or a SecondOrderForm)")
        Mm, Gm = np.asarray(M, dtype=float), np.asarray(G, dtype=float)
        Bm = np.asarray(B, dtype=float)
        if Bm.ndim == 1:
            Bm = Bm[:, None]
    k = Mm.shape[0]
    if Mm.shape != (k, k) or Gm.shape != (k, k) or Bm.shape[0] != k:
        raise ModelError(
            f"M and G must be (k, k) and B (k, m); got {Mm.shape}, {Gm.shape}, {Bm.shape}"
        )
    _check_tols(tol, cluster_tol)
    if np.linalg.cond(Mm) > 1e14:
        raise ModelError(f"M must be invertible; got condition number {np.linalg.cond(Mm):.3g}")
    mu = sla.eigvals(Gm, -Mm)
    scale = max(1.0, float(np.linalg.norm(np.linalg.solve(Mm, Gm), 2)))
    modes = []
    for m_, mult in _clusters(mu, cluster_tol * scale):
        ratio, deficient, W = _rank_test(np.hstack([m_ * Mm + Gm, Bm]), tol)
        modes.append(ModeTest(m_, mult, ratio, deficient, W))
    return PBHResult(all(m.controllable for m in modes), tol, modes, 2, tuple(labels))

