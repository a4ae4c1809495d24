"""Initial guesses that respect the manifold: geodesic interpolation and warm starts.

A :class:`Guess` is a sampled state trajectory on the manifold (at normalised times
``s`` in ``[0, 1]``), a control per sample interval and a final time. Between samples it
is interpolated along the one-parameter curves of the local exponential coordinates
(:mod:`workbench.control.ocp.local`): great circles on S^2, ``R exp(s log(R^T R'))`` on SO(3),
straight lines on R^n. So the guess at every collocation point lies on the manifold.

The hanging start with ``u = 0`` is a stationary point of every swing-up problem (the
gradient of the Lagrangian vanishes by symmetry), so a geodesic guess picks a great
circle for each antipodal factor (``axes``) and may add seeded noise to the control.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from workbench.control.ocp.local import ProductLocal
from workbench.control.ocp.problem import OCP
from workbench.core import validate
from workbench.core.errors import ParameterError
from workbench.core.manifolds import S2, TS2, sphere_basis
from workbench.core.types import ArrayLike, Vector

__all__ = ["Guess", "check_guess", "SAMPLES_TOL"]

SAMPLES_TOL = 1e-3
"""Default largest manifold residual of a sampled guess state (:meth:`Guess.from_samples`).

A guess needs to be near the manifold, not on it to rounding: a converged solution's nodes,
the usual warm start, carry the drift of their transcription (2e-6 for Hermite-Simpson in
ambient coordinates on 20 intervals). States in a wrong layout or of another problem are
off by O(1)."""


@dataclass
class Guess:
    """A sampled initial guess.

    Attributes
    ----------
    s : ndarray, shape=(n,)
        Normalised sample times, increasing from 0 to 1.
    x : ndarray, shape=(n, ambient_dim)
        States at ``s``.
    u : ndarray, shape=(n - 1, n_inputs) or (n, n_inputs)
        Control on each sample interval, or at each sample (first-order hold: linear in
        between).
    T : float
        Final time.
    local : ProductLocal
        The manifold's local coordinates (for interpolation).
    """

    s: np.ndarray
    x: np.ndarray
    u: np.ndarray
    T: float
    local: ProductLocal

    def state(self, s: float) -> Vector:
        """The state at normalised time ``s``, interpolated on the manifold."""
        k = int(np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.s) - 2))
        a = (s - self.s[k]) / (self.s[k + 1] - self.s[k])
        if a <= 0:
            return self.x[k]
        if a >= 1:
            return self.x[k + 1]
        return self.local.interpolate(self.x[k], self.x[k + 1], float(a))

    @property
    def first_order_hold(self) -> bool:
        """Whether the controls are sample values, linear in between."""
        return len(self.u) == len(self.s)

    def _at(self, s: np.ndarray) -> np.ndarray:
        if self.first_order_hold:
            return np.column_stack([np.interp(s, self.s, uj) for uj in self.u.T])
        idx = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.u) - 1)
        return self.u[idx]

    def controls(self, N: int) -> np.ndarray:
        """Control on each of ``N`` equal intervals (sample-and-hold at their midpoints)."""
        return self._at((np.arange(N) + 0.5) / N)

    def node_controls(self, N: int) -> np.ndarray:
        """Control at the ``N + 1`` knots of ``N`` equal intervals (first-order hold).

        A piecewise-constant guess gives the mean of the two intervals meeting at a knot.
        """
        s = np.linspace(0.0, 1.0, N + 1)
        if self.first_order_hold:
            return self._at(s)
        eps = 1e-9
        return 0.5 * (self._at(np.clip(s - eps, 0, 1)) + self._at(np.clip(s + eps, 0, 1)))

    @classmethod
    def geodesic(
        cls,
        ocp: OCP,
        *,
        T: float | None = None,
        end: ArrayLike | None = None,
        axes: dict[str, ArrayLike] | None = None,
        rng: np.random.Generator | None = None,
        noise: float = 0.0,
        samples: int = 101,
    ) -> Guess:
        """Geodesic interpolation from ``x0`` to the target, rest of the state likewise.

        Parameters
        ----------
        ocp : OCP
            The problem.
        T : float, optional
            Final time of the guess (default: the middle of the allowed range).
        end : array-like, optional
            End state (default: the target's witness point).
        axes : dict of str to array-like, shape=(3,)
            Rotation axis for an S^2 or TS^2 factor whose end point is antipodal to its
            start (a great circle is not unique there); by factor name. Each a finite,
            non-zero 3-vector (only its direction counts); other factor kinds have no axis.
        rng : numpy.random.Generator, optional
            With ``rng``, antipodal factors without an axis get a random great circle.
        noise : float
            Standard deviation of seeded control noise, relative to the bound's half-range
            (needs ``rng``); the hanging start with ``u = 0`` is a stationary point.
        samples : int
            Number of samples.

        Returns
        -------
        Guess

        Raises
        ------
        ParameterError
            ``T`` not a positive finite number, ``noise`` negative or not finite,
            ``samples`` not an integer >= 2, an ``axes`` name that is not an S^2 or TS^2
            factor, or an axis that is not a finite non-zero 3-vector.
        """
        man = ocp.model.manifold
        if T is not None:
            T = validate.positive("T", T)
        noise = validate.real("noise", noise)
        if noise < 0:
            raise ParameterError(f"noise must be >= 0; got {noise!r}")
        samples = validate.count("samples", samples, minimum=2, maximum=validate.MAX_DIM)
        unknown = sorted(set(axes or {}) - set(man.names))
        if unknown:
            raise ParameterError(f"axes names factors of the state; got {unknown}, factors "
                                 f"{list(man.names)}")
        ax = {}
        for k, v in (axes or {}).items():
            if not isinstance(man.factor(k), (S2, TS2)):
                raise ParameterError(
                    f"axes[{k!r}]: factor {k!r} is {man.factor(k).kind}; an axis picks the "
                    f"great circle of an S^2 or TS^2 factor between antipodes (factors "
                    f"with one: {[n for n, f in man.factors if isinstance(f, (S2, TS2))]})")
            ax[k] = validate.array(f"axes[{k!r}]", v, shape=(3,))
            if not np.any(ax[k]):
                raise ParameterError(f"axes[{k!r}] must be a non-zero 3-vector (a rotation "
                                     f"axis); got {ax[k].tolist()}")
        local = ProductLocal(man)
        x0 = ocp.x0
        xf = ocp.target.witness if end is None else man.check(end, name="end")
        for name, f in man.factors:
            if name in ax or not isinstance(f, (S2, TS2)):
                continue
            q0, q1 = x0[man.slices[name]][:3], xf[man.slices[name]][:3]
            if q0 @ q1 < -1 + 1e-9 and rng is not None:
                ax[name] = sphere_basis(q0) @ rng.standard_normal(2)
        y = local.log(x0, xf, axes=ax)
        s = np.linspace(0.0, 1.0, int(samples))
        x = np.array([np.asarray(local.act(x0, si * y), float).ravel() for si in s])
        u = np.zeros((len(s) - 1, ocp.model.n_inputs))
        if noise:
            if rng is None:
                raise ParameterError("noise needs an rng (numpy.random.Generator) to be seeded")
            half = np.where(np.isfinite(ocp.u_upper - ocp.u_lower),
                            0.5 * (ocp.u_upper - ocp.u_lower), 1.0)
            mid = np.where(np.isfinite(ocp.u_upper + ocp.u_lower),
                           0.5 * (ocp.u_upper + ocp.u_lower), 0.0)
            u = np.clip(mid + noise * half * rng.standard_normal(u.shape), ocp.u_lower,
                        ocp.u_upper)
        T = float(np.mean(ocp.T_range)) if T is None else float(T)
        return cls(s, x, u, T, local)

    @classmethod
    def from_samples(cls, ocp: OCP, t: ArrayLike, x: ArrayLike, u: ArrayLike, *,
                     tol: float = SAMPLES_TOL) -> Guess:
        """A guess from a sampled trajectory (e.g. a previous solution, for warm starts).

        Parameters
        ----------
        ocp : OCP
            The problem (for the manifold and the number of inputs).
        t : array-like, shape=(n,)
            Times from 0 to T: finite, strictly increasing, ``t[0] = 0``, ``n >= 2``.
        x : array-like, shape=(n, ambient_dim)
            States, each on the model's manifold to ``tol`` (never projected).
        u : array-like, shape=(n - 1, n_inputs) or (n, n_inputs)
            Controls per interval, or at the samples (first-order hold); finite.
        tol : float
            Largest accepted manifold residual of a state (default :data:`SAMPLES_TOL`,
            1e-3: a guess must be near the manifold, and a converged solution's nodes carry
            the drift of their transcription).

        Returns
        -------
        Guess

        Raises
        ------
        ParameterError
            ``t``, ``x`` or ``u`` of the wrong shape, not finite, or ``t`` not increasing
            from 0.
        ManifoldError
            A state off the manifold (named by its index and time).
        """
        if not isinstance(ocp, OCP):
            raise ParameterError(f"ocp must be an OCP; got {type(ocp).__name__}")
        tol = validate.tolerance("tol", tol)
        man, m = ocp.model.manifold, ocp.model.n_inputs
        tv = validate.array("t", t, ndim=1)
        if tv.size < 2:
            raise ParameterError(f"t must have at least 2 samples; got {tv.size}")
        if not np.all(np.diff(tv) > 0):
            k = int(np.argmin(np.diff(tv) > 0))
            raise ParameterError(f"t must be strictly increasing; got t[{k}] = {tv[k]:.6g} "
                                 f">= t[{k + 1}] = {tv[k + 1]:.6g}")
        if tv[0] != 0.0:
            raise ParameterError(f"t must start at 0 (times from 0 to T); got t[0] = "
                                 f"{tv[0]:.6g} (shift the times: t - t[0])")
        n = tv.size
        xv = validate.array("x", x, shape=(n, man.ambient_dim))
        uv = np.asarray(u, dtype=float) if m == 0 and np.size(u) == 0 else None
        if uv is not None:
            uv = np.zeros((n - 1, 0))
        else:
            uv = validate.array("u", u, ndim=2)
            if uv.shape not in ((n - 1, m), (n, m)):
                raise ParameterError(f"u must have shape ({n - 1}, {m}) (one control per "
                                     f"interval) or ({n}, {m}) (one per sample, first-order "
                                     f"hold) for {n} samples and {m} inputs; got shape "
                                     f"{uv.shape}")
        for k, row in enumerate(xv):
            man.check(row, name=f"x[{k}] (the state at t = {tv[k]:.6g})", tol=tol)
        return cls(tv / tv[-1], xv, uv, float(tv[-1]), ProductLocal(man))

    @classmethod
    def from_solution(cls, solution: Any) -> Guess:
        """A warm start from a solution's nodes, as they are (see :meth:`from_samples`).

        A solution of a transcription that does not keep the manifold (Hermite-Simpson or
        Radau in ambient coordinates) has nodes off it by the transcription's drift; they
        are taken with that drift (``tol`` is the largest scaled residual of the nodes, at
        least :data:`SAMPLES_TOL`), never projected. Shapes, times and finiteness are
        checked as in :meth:`from_samples`.

        Parameters
        ----------
        solution : OCPSolution
            With ``ocp``, ``t``, ``x`` and ``u``.

        Returns
        -------
        Guess
        """
        man = solution.ocp.model.manifold
        x = validate.array("x (the solution's nodes)", solution.x, ndim=2)
        drift = max((max(f.scaled_residual_norm(row[man.slices[n]]) for n, f in man.factors)
                     for row in x), default=0.0) if man.factors else 0.0
        tol = max(SAMPLES_TOL, 2.0 * drift) if np.isfinite(drift) else SAMPLES_TOL
        return cls.from_samples(solution.ocp, solution.t, x, solution.u, tol=tol)


def check_guess(guess: object, ocp: OCP, *also: type) -> None:
    """Refuse a ``guess=`` that is not a :class:`Guess` (or one of ``also``) for ``ocp``.

    Parameters
    ----------
    guess : object
        What ``solve`` was given; None passes.
    ocp : OCP
        The problem (a Guess must have its state and input sizes).
    *also : type
        Other accepted classes (an OCP solution, for warm starts).

    Raises
    ------
    ParameterError
        Naming what was given and how to make a guess; a guess or a solution whose states
        or controls have another problem's sizes.
    """
    if guess is None:
        return
    if not isinstance(guess, (Guess, *also)):
        shape = f" of shape {np.shape(guess)}" if isinstance(guess, np.ndarray) else ""
        raise ParameterError(
            f"guess must be a Guess or an OCPSolution; got {type(guess).__name__}{shape}. "
            "Make one with Guess.from_samples(ocp, t, x, u) (sampled states and controls) "
            "or Guess.geodesic(ocp, ...)")
    if not isinstance(ocp, OCP):  # the caller's own check names a bad problem
        return
    man, m = ocp.model.manifold, ocp.model.n_inputs
    x, u = np.asarray(guess.x), np.asarray(guess.u)
    if x.ndim != 2 or x.shape[1] != man.ambient_dim or u.ndim != 2 or u.shape[1] != m:
        other = getattr(guess, "ocp", None)
        what = "guess" if not isinstance(other, OCP) else (
            f"guess (a solution of problem {other.name!r}, model {other.model.name!r})")
        raise ParameterError(
            f"{what} is for another problem: its states have shape {x.shape} and its "
            f"controls {u.shape}; problem {ocp.name!r} (model {ocp.model.name!r}) has "
            f"{man.ambient_dim} state entries and {m} inputs")
