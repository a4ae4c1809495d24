"""Closed forms of paper 000 for the 3D pendulum: independent references, never the model.

The problems and tests compare what the graph gives with these formulas, typed from the
paper; nothing here is derived from a model's graph.

* :func:`simultaneous_diagonalisation` -- ``M`` and ``Lambda`` of (3.21)-(3.24);
* :func:`modal_basis`, :func:`modal_state_matrix` -- the paper's coordinates
  ``x = M^T Delta Theta`` and the linear system ``[[0, I], [-k Lambda, -D]]`` in them
  (paper 000 (3.22)-(3.28), paper 001 (19), (25), (28));
* :func:`frequencies` -- ``sqrt(m g l_i)``, the frequencies of (3.22)-(3.23);
* :func:`rotation_taking` -- an attitude with a given reduced attitude (hanging or
  inverted members of H and I, (3.12)-(3.13));
* :func:`equilibrium_attitude` -- the hanging or inverted attitude for a given ``rho``;
* :func:`prop9`, :func:`relative_equilibrium` -- Proposition 9 (with the erratum): a
  relative equilibrium at ``alpha``, with its angular velocity and momentum (5.22);
* :func:`remark_polynomial`, :func:`velocity_feedback_lemma` -- paper 001: the closed-loop
  characteristic polynomial of Remarks 2-3 and the sign patterns of Lemmas 1-4 under
  angular-velocity feedback.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from workbench.core.manifolds import hat, so3_exp
from workbench.core.types import ArrayLike

__all__ = ["equilibrium_attitude", "frequencies", "modal_basis", "modal_state_matrix", "prop9",
           "relative_equilibrium", "remark_polynomial",
           "rotation_taking", "simultaneous_diagonalisation", "velocity_feedback_lemma"]

E3 = np.array([0.0, 0.0, 1.0])


def simultaneous_diagonalisation(J: ArrayLike, rho: ArrayLike, m: float, g: float
                                 ) -> tuple[np.ndarray, np.ndarray]:
    """``M`` and ``Lambda = diag(m g l_1, m g l_2, 0)`` of paper 000 (3.21)-(3.24).

    ``J = M M^T`` and ``-(m g / |rho|) hat(rho)^2 = M Lambda M^T``: from the generalised
    symmetric eigenproblem ``K v = mu J v`` with ``V^T J V = I`` (so ``M = V^-T``), the zero
    eigenvalue ordered last as in the paper.

    Parameters
    ----------
    J : array-like, shape=(3, 3)
        Inertia, symmetric positive definite.
    rho : array-like, shape=(3,)
        Centre of mass in the body frame, nonzero.
    m, g : float
        Mass and gravitational acceleration.

    Returns
    -------
    M : ndarray, shape=(3, 3)
    Lambda : ndarray, shape=(3,)
        The diagonal ``(m g l_1, m g l_2, 0)``.
    """
    J, rho = np.asarray(J, dtype=float), np.asarray(rho, dtype=float)
    K = -(m * g / np.linalg.norm(rho)) * hat(rho) @ hat(rho)
    mu, V = sla.eigh(K, J)
    order = [1, 2, 0]  # eigh sorts ascending: the zero eigenvalue comes first
    mu, V = mu[order], V[:, order]
    mu[2] = 0.0 if abs(mu[2]) < 1e-12 * mu[1] else mu[2]
    return np.linalg.inv(V.T), mu


def modal_basis(basis: ArrayLike, M: ArrayLike) -> np.ndarray:
    """A tangent basis whose coordinates are the paper's ``(x, x-dot)``, ``x = M^T Delta Theta``.

    With the model's coordinates ``z = (eta, delta omega)`` in ``basis`` (TSO(3), dimension
    6), ``z = T (x, x-dot)`` for ``T = diag(M^-T, M^-T)``; the returned ``basis @ T`` makes
    a linearisation read in ``(x, x-dot)``.

    Parameters
    ----------
    basis : array-like, shape=(ambient_dim, 6)
        The linearisation's tangent basis.
    M : array-like, shape=(3, 3)
        From :func:`simultaneous_diagonalisation`.

    Returns
    -------
    ndarray, shape=(ambient_dim, 6)
    """
    return np.asarray(basis) @ np.kron(np.eye(2), np.linalg.inv(np.asarray(M).T))


def modal_state_matrix(Lambda: ArrayLike, k: int, D: ArrayLike | None = None) -> np.ndarray:
    """``[[0, I], [-k Lambda, -D]]``: the linearisation in ``(x, x-dot)``.

    Paper 000 (3.22)-(3.24) (hanging, ``k = 1``) and (3.26)-(3.28) (inverted, ``k = -1``)
    without damping; paper 001 (19), (25), (28) with the damping ``D = M^-1 Psi'(0) M^-T``.

    Parameters
    ----------
    Lambda : array-like, shape=(3,)
        ``(m g l_1, m g l_2, 0)``.
    k : int
        +1 hanging, -1 inverted.
    D : array-like, shape=(3, 3), optional
        Damping in the paper's coordinates (default none).

    Returns
    -------
    ndarray, shape=(6, 6)
    """
    D = np.zeros((3, 3)) if D is None else np.asarray(D, dtype=float)
    return np.block([[np.zeros((3, 3)), np.eye(3)], [-k * np.diag(Lambda), -D]])


def frequencies(J: ArrayLike, rho: ArrayLike, m: float = 1.0, g: float = 9.81) -> np.ndarray:
    """``sqrt(m g l_i)``, i = 1, 2, of (3.22)-(3.23), ascending, shape=(2,).

    Parameters
    ----------
    J : array-like, shape=(3, 3)
        Inertia.
    rho : array-like, shape=(3,)
        Centre of mass in the body frame, nonzero.
    m, g : float
        Mass and gravitational acceleration.

    Returns
    -------
    ndarray, shape=(2,)
    """
    rho = np.asarray(rho, dtype=float)
    K = -m * g * hat(rho) @ hat(rho) / np.linalg.norm(rho)
    return np.sqrt(np.sort(sla.eigh(K, np.asarray(J, dtype=float), eigvals_only=True))[1:])


def rotation_taking(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """A rotation ``R`` with ``R a = b`` for unit vectors (``a = -b`` allowed).

    Parameters
    ----------
    a, b : array-like, shape=(3,)
        Unit vectors.

    Returns
    -------
    ndarray, shape=(3, 3)
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    v, c = np.cross(a, b), float(a @ b)
    s = float(np.linalg.norm(v))
    if s < 1e-14:
        if c > 0:
            return np.eye(3)
        axis = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        return so3_exp(np.pi * axis / np.linalg.norm(axis))
    return so3_exp(v / s * np.arctan2(s, c))


def equilibrium_attitude(rho: ArrayLike, *, inverted: bool) -> np.ndarray:
    """A rotation ``R_e`` with ``R_e^T e3 = +-rho/|rho|`` (a member of H or I, (3.12)-(3.13)).

    Parameters
    ----------
    rho : array-like, shape=(3,)
        Centre of mass in the body frame, nonzero.
    inverted : bool
        The inverted attitude (``-rho/|rho|``) instead of the hanging one.

    Returns
    -------
    ndarray, shape=(3, 3)
    """
    rho = np.asarray(rho, dtype=float)
    a = rho / np.linalg.norm(rho) * (-1.0 if inverted else 1.0)
    axis = np.cross(a, E3)
    s, c = np.linalg.norm(axis), float(a @ E3)
    if s < 1e-14:  # rho along e3: the identity, or the half turn about e1
        return np.eye(3) if c > 0 else so3_exp([np.pi, 0.0, 0.0])
    return so3_exp(axis / s * np.arctan2(s, c))


def prop9(J: ArrayLike, rho: ArrayLike, a: float, m: float = 1.0, g: float = 9.81
          ) -> tuple[np.ndarray, float]:
    """Prop. 9 with the erratum: ``Gamma = -n/|n|``, ``k = omega . Gamma``, n = (J - I/a)^-1 rho.

    Parameters
    ----------
    J : array-like, shape=(3, 3)
        Inertia.
    rho : array-like, shape=(3,)
        Centre of mass in the body frame.
    a : float
        The family parameter ``alpha`` (not 0, not ``1/J_i``).
    m, g : float
        Mass and gravitational acceleration.

    Returns
    -------
    Gamma : ndarray, shape=(3,)
    k : float
    """
    n = np.linalg.solve(np.asarray(J, dtype=float) - np.eye(3) / a, np.asarray(rho, float))
    gamma = -n / np.linalg.norm(n)
    return gamma, float(np.sqrt(m * g / np.linalg.norm(n)) * n @ gamma)


def relative_equilibrium(J: ArrayLike, rho: ArrayLike, a: float, *, m: float, g: float,
                         omega_hint: ArrayLike) -> tuple[np.ndarray, np.ndarray, float]:
    """Prop. 9 cases 4/5 with the erratum, and (5.22): ``Gamma``, ``omega``, ``mu`` at alpha.

    ``Gamma = -n/|n|``, ``omega = +-sqrt(m g/|n|) n`` with ``n = (J - I/a)^-1 rho``, and
    ``mu = (omega . Gamma)(Gamma^T J Gamma)``; the sign of omega (case 4 or 5) is the one
    closer to ``omega_hint``.

    Parameters
    ----------
    J : array-like, shape=(3, 3)
        Inertia.
    rho : array-like, shape=(3,)
        Centre of mass in the body frame.
    a : float
        The family parameter alpha.
    m, g : float
        Mass and gravitational acceleration.
    omega_hint : array-like, shape=(3,)
        Picks the sign of omega.

    Returns
    -------
    Gamma, omega : ndarray, shape=(3,)
    mu : float
    """
    J = np.asarray(J, dtype=float)
    n = np.linalg.solve(J - np.eye(3) / a, np.asarray(rho, dtype=float))
    nn = np.linalg.norm(n)
    gam = -n / nn
    om = np.sqrt(m * g / nn) * n
    if om @ np.asarray(omega_hint, dtype=float) < 0:
        om = -om
    return gam, om, float(om @ gam * (gam @ J @ gam))


def remark_polynomial(d: ArrayLike, mgl: ArrayLike, k: int) -> np.ndarray:
    """Paper 001 Remarks 2-3: ``(s^2 + d1 s + k mgl1)(s^2 + d2 s + k mgl2)(s + d3)``.

    Parameters
    ----------
    d : array-like, shape=(3,)
        The diagonal damping ``D = M^-1 Psi'(0) M^-T`` (assumed diagonal by the Remarks).
    mgl : array-like, shape=(2,) or (3,)
        ``m g l_1``, ``m g l_2`` (:func:`simultaneous_diagonalisation`).
    k : int
        +1 at hanging (Remark 2), -1 at inverted (Remark 3).

    Returns
    -------
    ndarray, shape=(6,)
        Polynomial coefficients, highest power first.
    """
    d, mgl = np.asarray(d, dtype=float), np.asarray(mgl, dtype=float)
    return np.polymul(np.polymul([1.0, d[0], k * mgl[0]], [1.0, d[1], k * mgl[1]]),
                      [1.0, d[2]])


def velocity_feedback_lemma(pattern: dict[str, int], n_stable: int, dim: int, *, full: bool,
                            hanging: bool) -> tuple[str, dict[str, tuple[int, int]]]:
    """Paper 001 Lemmas 1-4 against a closed-loop spectrum's sign pattern.

    Under ``u = -Psi(omega)``: at hanging (Lemma 1 on TSO(3), Lemma 2 on S^2 x R^3) one
    zero eigenvalue on TSO(3) (none on S^2 x R^3), the rest in the open left half plane,
    at least one of them real; at inverted (Lemmas 3, 4) the same zeros, three negative
    and two positive real eigenvalues and a three-dimensional stable subspace.

    Parameters
    ----------
    pattern : dict of str to int
        From :func:`workbench.study.sign_pattern`.
    n_stable : int
        Dimension of the stable subspace found.
    dim : int
        Dimension of the linearisation (6 on TSO(3), 5 on S^2 x R^3).
    full, hanging : bool
        Which model and which equilibrium.

    Returns
    -------
    lemma : str
    checks : dict of str to (int, int)
        Statement -> (what the Lemma says, what the spectrum has).
    """
    n_zero = 1 if full else 0
    checks = {"zero eigenvalues": (n_zero, pattern["zero"])}
    if hanging:
        checks["eigenvalues in the open left half plane"] = (dim - n_zero,
                                                             pattern["left_half_plane"])
        checks["negative real eigenvalues >= 1"] = (1, min(1, pattern["negative_real"]))
        return ("Lemma 1" if full else "Lemma 2"), checks
    checks.update({"negative real eigenvalues": (3, pattern["negative_real"]),
                   "positive real eigenvalues": (2, pattern["positive_real"]),
                   "stable subspace dimension": (3, n_stable)})
    return ("Lemma 3" if full else "Lemma 4"), checks
