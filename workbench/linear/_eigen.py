"""Eigenstructure of a linearisation: stable, unstable and centre subspaces.

Eigenvalues are split by the sign of their real part with a stated tolerance ``tol``:
stable if ``Re(lambda) < -tol``, unstable if ``Re(lambda) > tol``, centre otherwise. The
default ``tol = 1e-7 max(1, |D^-1 A D|_2)``, where ``D^-1 A D`` is ``A`` balanced by a
diagonal scaling of powers of 2 (``scipy.linalg.matrix_balance``, the same as LAPACK's
eigenvalue drivers apply), covers the ``O(sqrt(eps))`` spread of the computed eigenvalues
of a Jordan block (the double zero eigenvalue of a rotation about the vertical, paper 000
(3.24)), and is reported with the result. The balanced norm is the scale of the computed
eigenvalues' errors: for a stiff system (a spring of stiffness ``k`` beside a pendulum)
``|A|_2`` grows like ``k`` while the eigenvalues grow like ``sqrt(k)``, so a tolerance
from ``|A|_2`` would call a saddle's ``+-3`` a centre once ``k`` is about ``1e8``.

Bases of the three invariant subspaces are computed from an ordered real Schur
decomposition (``scipy.linalg.schur`` with ``sort``) of the balanced matrix, which is
reliable with repeated and defective eigenvalues where eigenvector matrices are not; they
are mapped back by ``D``, orthonormal in tangent coordinates, and mapped to ambient
directions by the linearisation's basis ``N`` (the stable-manifold computations start
from them).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from dataclasses import field as dc_field
from enum import Enum
from typing import Any

import numpy as np
import scipy.linalg as sla

from workbench.core import validate
from workbench.core.errors import ModelError
from workbench.core.types import ArrayLike, Matrix
from workbench.core.validate import choice

__all__ = ["Stability", "Subspace", "Eigenstructure", "eigenstructure", "default_tol"]


class Stability(Enum):
    """Classification of an equilibrium by its linearisation.

    Attributes
    ----------
    STABLE_NODE
        All eigenvalues real and negative.
    STABLE_FOCUS
        All eigenvalues with negative real part, some complex (paper 002: "asymptotically
        stable focus").
    UNSTABLE_NODE, UNSTABLE_FOCUS
        All eigenvalues with positive real part (real / some complex).
    SADDLE
        Hyperbolic with both stable and unstable eigenvalues.
    CENTRE
        All eigenvalues on the imaginary axis (linearisation inconclusive).
    NONHYPERBOLIC
        Some eigenvalues on the imaginary axis and some off it.
    """

    STABLE_NODE = "stable node"
    STABLE_FOCUS = "stable focus"
    UNSTABLE_NODE = "unstable node"
    UNSTABLE_FOCUS = "unstable focus"
    SADDLE = "saddle"
    CENTRE = "centre"
    NONHYPERBOLIC = "non-hyperbolic"


class Subspace(Enum):
    """The three spectral subspaces."""

    STABLE = "stable"
    UNSTABLE = "unstable"
    CENTRE = "centre"


def default_tol(A: ArrayLike) -> float:
    """Return the default real-part tolerance ``1e-7 max(1, |D^-1 A D|_2)``.

    Parameters
    ----------
    A : array_like, shape=(n, n)
        A finite square matrix.

    Returns
    -------
    float
        The tolerance, from the norm of ``A`` balanced by :func:`_balance` (see the module
        docstring).
    """
    return _tol_of_balanced(_balance(np.asarray(A, dtype=float))[0])


def _tol_of_balanced(B: Matrix) -> float:
    """``1e-7 max(1, |B|_2)`` for a balanced ``B``."""
    return 1e-7 * max(1.0, float(np.linalg.norm(B, 2)) if B.size else 0.0)


def _balance(A: Matrix) -> tuple[Matrix, np.ndarray]:
    """``(D^-1 A D, diag(D))``: ``A`` scaled by powers of 2 (exact), no permutation."""
    if A.size == 0:
        return A, np.ones(A.shape[0])
    B, (scale, _) = sla.matrix_balance(A, permute=False, separate=True)
    return B, scale


@dataclass(frozen=True)
class Eigenstructure:
    """Spectrum, spectral subspaces and classification of ``z-dot = A z``.

    Attributes
    ----------
    eigenvalues : ndarray of complex, shape=(dim,)
        Sorted by real part, then imaginary part.
    eigenvectors : ndarray of complex, shape=(dim, dim)
        Unit right eigenvectors in tangent coordinates (columns, same order; unreliable for
        defective eigenvalues, see :attr:`eigenvector_condition`).
    tol : float
        The real-part tolerance used.
    stable_basis, unstable_basis, centre_basis : ndarray, shape=(dim, k)
        Orthonormal real bases of the invariant subspaces (tangent coordinates).
    stability : Stability
        The classification.
    basis : ndarray, shape=(ambient_dim, dim) or None
        Tangent basis ``N`` of the linearisation (for ambient directions).
    residual : float
        ``max_k |A v_k - lambda_k v_k| / max(1, |A|)`` (accuracy of the eigenpairs).
    eigenvector_condition : float
        Condition number of the eigenvector matrix (large: near-defective).
    resolved_in_tol : ndarray of complex, shape=(k,)
        Eigenvalues counted as centre (``|Re| <= tol``) whose real part is nevertheless
        resolved: above ``1e-3 tol`` and ten times its rounding error bound
        ``n eps |D^-1 A D|_2 kappa`` (``kappa`` the eigenvalue's condition number). Such a
        spectrum has time scales further apart than the tolerance's ``1e-7`` (a slow saddle
        beside a stiff mode); with the default tolerance a ``UserWarning`` says so, and a
        smaller ``tol`` classifies them by the sign of their real part.
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    tol: float
    stable_basis: Matrix
    unstable_basis: Matrix
    centre_basis: Matrix
    stability: Stability
    basis: Matrix | None
    residual: float
    eigenvector_condition: float
    resolved_in_tol: np.ndarray = dc_field(default_factory=lambda: np.zeros(0, complex))

    @property
    def n_stable(self) -> int:
        """Dimension of the stable subspace."""
        return int(self.stable_basis.shape[1])

    @property
    def n_unstable(self) -> int:
        """Dimension of the unstable subspace."""
        return int(self.unstable_basis.shape[1])

    @property
    def n_centre(self) -> int:
        """Dimension of the centre subspace."""
        return int(self.centre_basis.shape[1])

    @property
    def dims(self) -> tuple[int, int, int]:
        """``(n_stable, n_unstable, n_centre)``."""
        return self.n_stable, self.n_unstable, self.n_centre

    def subspace(self, which: Subspace) -> Matrix:
        """Orthonormal basis (tangent coordinates) of one spectral subspace."""
        return {
            Subspace.STABLE: self.stable_basis,
            Subspace.UNSTABLE: self.unstable_basis,
            Subspace.CENTRE: self.centre_basis,
        }[choice(Subspace, which, "which")]

    def ambient(self, which: Subspace) -> Matrix:
        """Ambient directions ``N V`` spanning one spectral subspace.

        Parameters
        ----------
        which : Subspace
            Which subspace.

        Returns
        -------
        ndarray, shape=(ambient_dim, k)
            Tangent vectors at the equilibrium, in stored ambient coordinates.

        Raises
        ------
        ModelError
            If the eigenstructure was computed from a bare matrix (no basis).
        """
        if self.basis is None:
            raise ModelError(
                "ambient directions need the linearisation's tangent basis; compute the "
                "eigenstructure from a LinearModel (or pass basis=)"
            )
        return self.basis @ self.subspace(which)

    def describe(self) -> str:
        """One line, e.g. ``"saddle with 3 unstable modes (3 stable)"``."""
        s, u, c = self.dims
        if self.stability is Stability.SADDLE:
            return f"saddle with {u} unstable mode{'s' if u != 1 else ''} ({s} stable)"
        if self.stability is Stability.NONHYPERBOLIC:
            return f"non-hyperbolic: {s} stable, {u} unstable, {c} centre"
        return f"{self.stability.value} ({s} stable, {u} unstable, {c} centre)"

    def summary(self) -> dict[str, Any]:
        """Plain JSON-serialisable account."""
        return {
            "eigenvalues": [complex(v) for v in self.eigenvalues],
            "n_stable": self.n_stable,
            "n_unstable": self.n_unstable,
            "n_centre": self.n_centre,
            "stability": self.stability.value,
            "description": self.describe(),
            "tol": self.tol,
            "residual": self.residual,
            "eigenvector_condition": self.eigenvector_condition,
            "resolved_in_tol": [[float(v.real), float(v.imag)] for v in self.resolved_in_tol],
        }


def _classify(ev: np.ndarray, tol: float) -> Stability:
    re = ev.real
    s, u = int(np.sum(re < -tol)), int(np.sum(re > tol))
    c = ev.size - s - u
    complex_ = bool(np.any(np.abs(ev.imag) > tol))
    if c == ev.size:
        return Stability.CENTRE
    if c:
        return Stability.NONHYPERBOLIC
    if u == 0:
        return Stability.STABLE_FOCUS if complex_ else Stability.STABLE_NODE
    if s == 0:
        return Stability.UNSTABLE_FOCUS if complex_ else Stability.UNSTABLE_NODE
    return Stability.SADDLE


def _invariant_basis(B: Matrix, scale: np.ndarray, select: Any) -> Matrix:
    """Orthonormal basis of the invariant subspace of ``A = D B D^-1`` that ``select`` picks.

    ``B`` is ``A`` balanced (:func:`_balance`) and ``scale`` the diagonal of ``D``: the
    ordered Schur form of ``B`` gives its subspace ``Z``, and ``A``'s is ``D Z``,
    orthonormalised.
    """
    if B.shape[0] == 0:
        return np.zeros((0, 0))
    _, Z, sdim = sla.schur(B, output="real", sort=select)
    if sdim == 0:
        return Z[:, :0]
    q, _ = np.linalg.qr(scale[:, None] * Z[:, :sdim])
    return q


@validate.arguments(error=ModelError, tol=validate.optional(validate.tolerance))
def eigenstructure(
    system: Any, *, tol: float | None = None, basis: ArrayLike | None = None
) -> Eigenstructure:
    """Eigenvalues, spectral subspaces and classification of a linearisation.

    Parameters
    ----------
    system : LinearModel or array-like, shape=(dim, dim)
        A :class:`~workbench.linear._linearize.LinearModel` (its ``A`` and ``basis`` are used) or
        a square matrix.
    tol : float, optional
        Real-part tolerance: ``|Re(lambda)| <= tol`` counts as centre. Default
        :func:`default_tol` ``(A)``.
    basis : array-like, shape=(ambient_dim, dim), optional
        Ambient tangent basis, for a bare matrix (ignored for a LinearModel).

    Returns
    -------
    Eigenstructure

    Raises
    ------
    ModelError
        If the matrix is not square and finite, or ``tol`` is not positive.
    """
    if hasattr(system, "A") and hasattr(system, "basis"):
        A = np.asarray(system.A, dtype=float)
        N = np.asarray(system.basis, dtype=float)
    else:
        try:
            A = np.asarray(system, dtype=float)
            N = None if basis is None else np.asarray(basis, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ModelError(f"A (and basis) must be numeric matrices; got "
                             f"{type(system).__name__} {system!r}") from exc
    if A.ndim != 2 or A.shape[0] != A.shape[1] or not np.all(np.isfinite(A)):
        raise ModelError(f"A must be a finite square matrix; got shape {A.shape}")
    if N is not None and N.shape[1] != A.shape[0]:
        raise ModelError(
            f"basis must have {A.shape[0]} columns (one per tangent coordinate); got shape "
            f"{N.shape}"
        )
    Bal, dscale = _balance(A)
    t = _tol_of_balanced(Bal) if tol is None else float(tol)
    if not (np.isfinite(t) and t > 0):
        raise ModelError(f"tol must be positive and finite; got {tol!r}")
    ev, V = np.linalg.eig(A)
    order = np.lexsort((ev.imag, ev.real))
    ev, V = ev[order], V[:, order]
    scale = max(1.0, float(np.linalg.norm(A, 2))) if A.size else 1.0
    resid = float(np.max(np.abs(A @ V - V * ev))) / scale if A.size else 0.0
    cond = float(np.linalg.cond(V)) if A.size else 1.0
    stable = _invariant_basis(Bal, dscale, lambda re, im: re < -t)
    unstable = _invariant_basis(Bal, dscale, lambda re, im: re > t)
    centre = _invariant_basis(Bal, dscale, lambda re, im: abs(re) <= t)
    counts = (int(np.sum(ev.real < -t)), int(np.sum(ev.real > t)))
    if (stable.shape[1], unstable.shape[1]) != counts:  # pragma: no cover - defensive
        raise ModelError(
            f"ordered Schur form and eigenvalues disagree on the stable/unstable split "
            f"({stable.shape[1]}, {unstable.shape[1]}) vs {counts}: eigenvalues lie within "
            f"rounding of the tolerance {t:.3g}; pass another tol"
        )
    resolved = _resolved_in_tol(Bal, ev, t)
    if resolved.size and tol is None:
        warnings.warn(
            f"eigenstructure: eigenvalue(s) {np.round(resolved, 6).tolist()} count as centre "
            f"under the default real-part tolerance {t:.3g} (1e-7 of the balanced |A|), but "
            "their real parts are resolved beyond rounding: the spectrum's time scales are "
            f"further apart than 1e7; pass tol= below {np.min(np.abs(resolved.real)):.3g} "
            "to classify them by sign", UserWarning, stacklevel=3)
    return Eigenstructure(
        eigenvalues=ev, eigenvectors=V, tol=t, stable_basis=stable, unstable_basis=unstable,
        centre_basis=centre, stability=_classify(ev, t), basis=N, residual=resid,
        eigenvector_condition=cond, resolved_in_tol=resolved,
    )


def _resolved_in_tol(B: Matrix, ev: np.ndarray, tol: float) -> np.ndarray:
    """The eigenvalues within ``tol`` of the imaginary axis whose real part is resolved.

    Resolved: ``|Re| > 1e-3 tol`` and ``> 10 n eps |B|_2 kappa``, ``kappa = |y| |x| /
    |y^H x|`` from the balanced matrix ``B``'s left and right eigenvectors (first-order
    perturbation theory; a defective eigenvalue's ``kappa`` is huge, so a Jordan block's
    split never counts).
    """
    inside = (np.abs(ev.real) <= tol) & (np.abs(ev.real) > 1e-3 * tol)
    if not np.any(inside):
        return np.zeros(0, complex)
    lam, left, right = sla.eig(B, left=True, right=True)
    with np.errstate(divide="ignore"):
        kappa = (np.linalg.norm(left, axis=0) * np.linalg.norm(right, axis=0)
                 / np.abs(np.sum(left.conj() * right, axis=0)))
    bound = 10 * B.shape[0] * np.finfo(float).eps * float(np.linalg.norm(B, 2))
    out = []
    for value in ev[inside]:
        k = int(np.argmin(np.abs(lam - value)))  # the same eigenvalue of the similar B
        if abs(value.real) > bound * kappa[k]:
            out.append(value)
    return np.asarray(out, dtype=complex)

