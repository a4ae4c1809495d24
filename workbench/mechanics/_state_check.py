"""The checks of a mechanics model that hold state by state, run where the model is used.

A kinetic energy can be positive definite at one state and not at another (a mass matrix
written by hand, ``m (1 - x^2)``; an attitude expression that degenerates). The build
checks of :mod:`._model` run at one seeded state; a :class:`StateCheck` runs the same
definiteness test at the states a computation actually uses: the initial state of a
simulation, an OCP or a linearisation, every output state of a simulated trajectory and
every node of an OCP solution. It is attached to the model as ``model.state_check`` and
called ``model.state_check(model, x, t=..., what=...)`` (the model is passed so that a
copy made by ``Model.with_parameters`` is checked with its own values); models not made by
:mod:`workbench.mechanics` have none.

The test: the tangent mass matrix ``K = N^T M N`` (``M`` the Hessian of ``T`` in the
velocities, ``N`` a basis of the admissible velocities), scaled to a unit diagonal
``D^-1/2 K D^-1/2`` so that it does not depend on units (kg against kg m^2, a 1e11 kg
cart against a 1 kg bob), must have its smallest eigenvalue above :data:`PD_RTOL`. Along
many states the mass matrix is one casadi Function evaluated on all of them at once and
the eigenvalues are taken in stacked batches; a state that comes near the limit is
decided by :func:`check_kinetic_energy`, whose message names the state, the eigenvalue and
the factor where the failing direction lies.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from workbench.mechanics._engine import ModelError
from workbench.mechanics._equations import Derivation
from workbench.mechanics._factors import S2Factor

__all__ = ["PD_RTOL", "StateCheck", "check_kinetic_energy"]

PD_RTOL = 1e-10
"""The tangent mass matrix, scaled to a unit diagonal (``D^-1/2 K D^-1/2``, so that the test
does not depend on units: kg against kg m^2, a 1e11 kg cart against a 1 kg bob), counts as
singular when its smallest eigenvalue is below ``PD_RTOL``."""

SCREEN = 1e-6
"""States whose scaled smallest eigenvalue (in the batch's own tangent basis) is below this
are decided one by one by :func:`check_kinetic_energy` (its basis, its exact message)."""

CHUNK = 4096
"""States evaluated per batch (bounds the memory of the stacked mass matrices)."""


def _flat(x: np.ndarray) -> str:
    """A state on one line, four significant digits."""
    return np.array2string(np.asarray(x), precision=4, max_line_width=100000)


def check_kinetic_energy(der: Derivation, factors: list, x: np.ndarray, p: np.ndarray, *,
                         mass_matrix: ca.Function | None = None) -> None:
    """Raise ModelError unless ``T`` is positive definite on the tangent velocities at ``x``.

    Parameters
    ----------
    der : Derivation
        The derived equations.
    factors : list of Factor
        The system's factors.
    x : ndarray, shape=(n_x,)
        A state (only its configuration matters).
    p : ndarray, shape=(n_p,)
        Parameter values.
    mass_matrix : casadi.Function, optional
        ``der.mass_matrix()`` when the caller holds it (it is built otherwise).
    """
    M = np.asarray((mass_matrix or der.mass_matrix())(x, p))
    bases, spans, k = [], [], 0
    xs = np.asarray(x, dtype=float).ravel()
    kx = 0
    for f in factors:
        nc = f.config_sym.shape[0]
        B = f.velocity_basis(xs[kx : kx + nc])
        kx += sum(s.shape[0] for s in f.state_symbols())
        bases.append(B)
        spans.append((f, k, k + B.shape[1]))
        k += B.shape[1]
    N = np.zeros((M.shape[0], k))
    r = c = 0
    for B in bases:
        N[r : r + B.shape[0], c : c + B.shape[1]] = B
        r, c = r + B.shape[0], c + B.shape[1]
    K = N.T @ M @ N
    if not np.all(np.isfinite(K)):
        raise ModelError(f"the kinetic energy's mass matrix is not finite at x = {xs.tolist()}")
    K = 0.5 * (K + K.T)
    d = np.diag(K).copy()
    eig_k = np.linalg.eigvalsh(K)
    if np.all(d > 0):
        w = 1.0 / np.sqrt(d)
        eig, vec = np.linalg.eigh(K * np.outer(w, w))  # unit diagonal: eigenvalues in (0, n)
        if eig[0] > PD_RTOL:
            return
        v = w * vec[:, 0]
        kind = "singular" if eig[0] >= -PD_RTOL else "not positive definite"
        scaled = f"; scaled to a unit diagonal, {eig[0]:.3g}"
    else:  # a velocity with no inertia (a zero diagonal entry), or a negative one
        v = (d <= 0).astype(float)
        small = PD_RTOL * max(float(np.max(np.abs(eig_k))), 1e-300)
        kind = "not positive definite" if eig_k[0] < -small else "singular"
        scaled = ""
    worst = max(spans, key=lambda s: float(np.linalg.norm(v[s[1] : s[2]])))
    raise ModelError(
        f"the kinetic energy is {kind} at the state x = {_flat(xs)}: "
        f"smallest eigenvalue {eig_k[0]:.3g} of the mass matrix on the tangent velocities "
        f"(largest {eig_k[-1]:.3g}{scaled}); its direction lies mostly in factor "
        f"{worst[0].name!r} ({worst[0].velocity_names})")


def _sphere_bases(q: np.ndarray) -> np.ndarray:
    """Orthonormal bases of the planes normal to the rows of ``q``, shape=(n, 3, 2).

    Any orthonormal basis gives the same eigenvalues of ``K``; this one is vectorised
    (``e_i`` minus its component along ``q``, ``i`` the axis of the smallest ``|q_i|``,
    then ``q x b1``).
    """
    n = q.shape[0]
    qn = q / np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-300)
    i = np.argmin(np.abs(qn), axis=1)
    e = np.zeros((n, 3))
    e[np.arange(n), i] = 1.0
    b1 = e - qn[np.arange(n), i][:, None] * qn
    b1 /= np.linalg.norm(b1, axis=1, keepdims=True)
    b2 = np.cross(qn, b1)
    return np.stack([b1, b2], axis=2)


class StateCheck:
    """The kinetic energy's definiteness, checked at the states where a model is used.

    Parameters
    ----------
    der : Derivation
        The derived equations (its mass matrix).
    factors : list of Factor
        The system's factors, in storage order.

    Notes
    -----
    Called as ``check(model, x, t=None, what="x0")``; see :meth:`__call__`.
    """

    def __init__(self, der: Derivation, factors: list) -> None:
        self._der, self._factors = der, list(factors)
        self._mass: ca.Function | None = None
        # the S^2 factors' configurations in the state, and their velocity columns in nu
        self._spheres: list[tuple[int, int]] = []
        kx = kv = 0
        for f in self._factors:
            nv = f.velocity_sym.shape[0]
            if isinstance(f, S2Factor):
                self._spheres.append((kx, kv))
            kx += sum(s.shape[0] for s in f.state_symbols())
            kv += nv
        self._n_nu = kv

    @property
    def mass_matrix(self) -> ca.Function:
        """``(x, p) -> M``, the ambient mass matrix (built on first use)."""
        if self._mass is None:
            self._mass = self._der.mass_matrix()
        return self._mass

    def _screen(self, X: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Indices of the rows of ``X`` whose scaled smallest eigenvalue is below SCREEN."""
        n, nv = X.shape[0], self._n_nu
        M = np.asarray(self.mass_matrix(X.T, p), dtype=float)  # one call, all states
        M = M.reshape(nv, n, nv).transpose(1, 0, 2)
        if self._spheres:  # the tangent velocities: N^T M N with N block diagonal
            k = nv - len(self._spheres)
            N = np.zeros((n, nv, k))
            r = c = 0
            starts = {kv: kx for kx, kv in self._spheres}
            while r < nv:
                if r in starts:
                    N[:, r : r + 3, c : c + 2] = _sphere_bases(X[:, starts[r] : starts[r] + 3])
                    r, c = r + 3, c + 2
                else:
                    N[:, r, c] = 1.0
                    r, c = r + 1, c + 1
            M = np.einsum("nij,njk->nik", np.einsum("nji,njk->nik", N, M), N)
        K = 0.5 * (M + M.transpose(0, 2, 1))
        bad = ~np.all(np.isfinite(K.reshape(n, -1)), axis=1)
        d = np.diagonal(K, axis1=1, axis2=2)
        bad |= np.any(~(d > 0), axis=1)
        ok = ~bad
        if np.any(ok):
            w = 1.0 / np.sqrt(d[ok])
            low = np.linalg.eigvalsh(K[ok] * w[:, :, None] * w[:, None, :])[:, 0]
            bad[np.flatnonzero(ok)[low <= SCREEN]] = True
        return np.flatnonzero(bad)

    def __call__(self, model: Any, x: Any, *, t: Any = None, what: str = "x0") -> None:
        """Raise ModelError at the first state where the kinetic energy is not definite.

        Parameters
        ----------
        model : Model
            The model being used (its current parameter values are taken).
        x : array-like, shape=(ambient_dim,) or (n, ambient_dim)
            One state, or states in order.
        t : array-like, shape=(n,), optional
            Their times, for the message.
        what : str
            What the states are, for the message (``"x0"``, ``"the trajectory"``, ...).

        Raises
        ------
        ModelError
            Naming the state (its index and time along a result) and what was found there.
        """
        X = np.atleast_2d(np.asarray(x, dtype=float))
        p = np.asarray(model.p, dtype=float)
        times = None if t is None else np.asarray(t, dtype=float).ravel()
        for start in range(0, X.shape[0], CHUNK):
            block = X[start : start + CHUNK]
            for i in self._screen(block, p):
                k = start + int(i)
                try:
                    check_kinetic_energy(self._der, self._factors, X[k], p,
                                         mass_matrix=self.mass_matrix)
                except ModelError as exc:
                    raise ModelError(f"{model.name}: {self._where(what, k, X, times)}: "
                                     f"{exc}") from exc

    @staticmethod
    def _where(what: str, k: int, X: np.ndarray, times: np.ndarray | None) -> str:
        if X.shape[0] == 1:
            return f"at {what}"
        when = f" t = {times[k]:.6g}" if times is not None and k < times.size else ""
        return f"along {what}, at{when} (state {k} of {X.shape[0]})"
