"""Linear-quadratic regulators on a linearisation, and their geometric nonlinear form.

:func:`lqr` validates the weights (shapes, symmetry, ``Q >= 0``, ``R > 0``), runs the PBH
test first (an uncontrollable pair is refused with the uncontrollable mode named, rather
than left to fail inside the Riccati solver), then solves the continuous algebraic Riccati
equation with python-control (``control.lqr``; its scipy backend is the solver of record
when slycot is not installed) and reports the gain, the closed-loop eigenvalues and the
relative Riccati residual as the error estimate.

:func:`geometric_feedback` turns a gain ``K`` on tangent coordinates back into a smooth
feedback on the full stored state, ``u = u_e - K z(x)`` with ``z`` the linearisation's
first-order chart (:meth:`LinearModel.chart`). For the chain on a cart this is exactly
paper 003 (19): the chart of a link is ``(C^T (s_i e3 x q_i), C^T omega_i)`` and the
cart's is ``(x, x-dot)``. The result is a ``casadi.Function`` ``(x, p) -> u`` to simulate
or export, whose own linearisation is ``-K`` (checked in the tests).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.status import Record
from workbench.core.types import ArrayLike, Matrix
from workbench.core.validate import choice
from workbench.linear._controllability import PBH_TOL, PBHResult, _matrices, pbh
from workbench.linear._eigen import default_tol
from workbench.linear._linearize import LinearModel

__all__ = ["Requirement", "LQRCost", "LQRResult", "lqr", "geometric_feedback", "riccati_residual"]


class Requirement(Enum):
    """What :func:`lqr` demands of the pair ``(A, B)`` before solving.

    Attributes
    ----------
    CONTROLLABLE
        Every mode controllable (PBH); any uncontrollable mode is an error.
    STABILIZABLE
        Uncontrollable modes allowed if strictly stable (``Re(lambda) < -tol``).
    """

    CONTROLLABLE = "controllable"
    STABILIZABLE = "stabilizable"


@dataclass(frozen=True)
class LQRCost(Record):
    """What :func:`lqr` cost.

    Attributes
    ----------
    pbh_seconds, riccati_seconds : float
        The PBH test and the Riccati solve.
    """

    pbh_seconds: float
    riccati_seconds: float


@dataclass(frozen=True)
class LQRResult:
    """An LQR design.

    Attributes
    ----------
    K : ndarray, shape=(n_inputs, dim)
        Gain, ``du = -K z``.
    P : ndarray, shape=(dim, dim)
        Stabilising solution of the Riccati equation.
    Q : ndarray, shape=(dim, dim)
        State weight.
    R : ndarray, shape=(n_inputs, n_inputs)
        Input weight.
    closed_loop_eigenvalues : ndarray of complex, shape=(dim,)
        Eigenvalues of ``A - B K``, sorted by real part.
    method : str
        The Riccati solver python-control used (``"scipy"`` or ``"slycot"``).
    riccati_residual : float
        ``|A'P + PA - PBR^-1B'P + Q|_F / max(1, |Q|_F, |A'P|_F)``.
    controllability : PBHResult
        The PBH test run before solving.
    linear : LinearModel or None
        The linearisation designed on (None for bare matrices).
    cost : LQRCost
        ``pbh_seconds``, ``riccati_seconds`` (a typed record that also reads as a mapping).
    """

    K: Matrix
    P: Matrix
    Q: Matrix
    R: Matrix
    closed_loop_eigenvalues: np.ndarray
    method: str
    riccati_residual: float
    controllability: PBHResult
    linear: LinearModel | None = None
    cost: LQRCost | dict[str, float] = field(default_factory=dict)

    def feedback(self, *, name: str = "lqr_feedback") -> ca.Function:
        """Return the geometric nonlinear feedback of this gain (:func:`geometric_feedback`)."""
        if self.linear is None:
            raise ModelError("a feedback law needs the LinearModel the gain was designed on")
        return geometric_feedback(self.linear, self.K, name=name)

    def __str__(self) -> str:
        """A short account: gain size, Riccati residual, closed-loop spectrum, PBH margin."""
        re_ = self.closed_loop_eigenvalues.real
        span = f"[{float(np.min(re_)):.4g}, {float(np.max(re_)):.4g}]" if re_.size else "-"
        return (f"LQRResult: gain K {self.K.shape[0]}x{self.K.shape[1]} ({self.method}), "
                f"Riccati residual {self.riccati_residual:.1e}, closed-loop Re(eig) in {span}, "
                f"PBH margin {self.controllability.margin:.1e}")

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"

    def summary(self) -> dict[str, Any]:
        """Plain JSON-serialisable account."""
        return {
            "K": self.K.tolist(),
            "closed_loop_eigenvalues": [complex(v) for v in self.closed_loop_eigenvalues],
            "max_real_part": float(np.max(self.closed_loop_eigenvalues.real)),
            "method": self.method,
            "riccati_residual": self.riccati_residual,
            "pbh_margin": self.controllability.margin,
            "cost": self.cost,
        }


def _weight(W: ArrayLike, name: str, n: int, what: str, *, definite: bool) -> Matrix:
    try:
        Wm = np.asarray(W, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a numeric ({n}, {n}) matrix; got {W!r}") from exc
    if Wm.shape != (n, n):
        raise ParameterError(
            f"{name} must have shape ({n}, {n}) ({what}); got shape {Wm.shape}"
        )
    if not np.all(np.isfinite(Wm)):
        raise ParameterError(f"{name} must be finite")
    scale = max(float(np.max(np.abs(Wm))), 1e-300)
    asym = float(np.max(np.abs(Wm - Wm.T)))
    if asym > 1e-10 * scale:
        raise ParameterError(
            f"{name} must be symmetric; got max |{name} - {name}^T| = {asym:.3g}"
        )
    eig = np.linalg.eigvalsh(0.5 * (Wm + Wm.T))
    if definite and np.any(eig <= 0):
        raise ParameterError(
            f"{name} must be symmetric positive definite; got eigenvalues "
            f"{np.array2string(eig, precision=6)}"
        )
    if not definite and np.any(eig < -1e-12 * scale):
        raise ParameterError(
            f"{name} must be symmetric positive semi-definite; got eigenvalues "
            f"{np.array2string(eig, precision=6)} (smallest {eig.min():.6g})"
        )
    return 0.5 * (Wm + Wm.T)


def riccati_residual(A: Matrix, B: Matrix, Q: Matrix, R: Matrix, P: Matrix) -> float:
    """Relative residual of ``A'P + PA - P B R^-1 B' P + Q = 0`` (Frobenius norms)."""
    AP = A.T @ P
    res = AP + AP.T - P @ B @ np.linalg.solve(R, B.T @ P) + Q
    return float(np.linalg.norm(res) / max(1.0, np.linalg.norm(Q), np.linalg.norm(AP)))


@validate.arguments(pbh_tol=validate.tolerance, Q=validate.array, R=validate.array)
def lqr(
    system: Any,
    Q: ArrayLike,
    R: ArrayLike,
    *,
    B: ArrayLike | None = None,
    require: Requirement = Requirement.CONTROLLABLE,
    pbh_tol: float = PBH_TOL,
) -> LQRResult:
    """LQR gain for ``z-dot = A z + B du`` minimising ``int z'Qz + du'R du``.

    Parameters
    ----------
    system : LinearModel or array-like, shape=(dim, dim)
        The linearisation, or ``A`` (then pass ``B``).
    Q : array-like, shape=(dim, dim)
        State weight, symmetric positive semi-definite, in the system's coordinates
        (reorder the system first, e.g. with :meth:`LinearModel.permuted`, to use a
        paper's ordering).
    R : array-like, shape=(n_inputs, n_inputs)
        Input weight, symmetric positive definite.
    B : array-like, shape=(dim, n_inputs), optional
        Input matrix when ``system`` is a matrix.
    require : Requirement
        Controllability demanded before solving.
    pbh_tol : float
        Relative rank tolerance of the PBH test.

    Returns
    -------
    LQRResult

    Raises
    ------
    ParameterError
        Bad ``Q`` or ``R`` (shape, symmetry, definiteness), or an uncontrollable
        (unstabilisable) pair: the message names each offending mode and its left
        eigenvector.
    ModelError
        ``B`` given with a LinearModel or missing with a matrix, or ``A``, ``B`` not
        finite numeric matrices of conforming shapes (the checks of :func:`pbh`).
    SolverError
        The Riccati solver failed (with its exception as status) or did not stabilise.
    """
    import control

    lin = system if isinstance(system, LinearModel) else None
    A, Bm, _ = _matrices(system, B)
    n, m = A.shape[0], Bm.shape[1]
    if m == 0:
        raise ParameterError("the system has no inputs; LQR needs at least one")
    Qm = _weight(Q, "Q", n, "the tangent dimension of the linearisation", definite=False)
    Rm = _weight(R, "R", m, "the number of inputs", definite=True)
    require = choice(Requirement, require, "require")

    t0 = time.perf_counter()
    test = pbh(lin, tol=pbh_tol) if lin is not None else pbh(A, Bm, tol=pbh_tol)
    t_pbh = time.perf_counter() - t0
    etol = default_tol(A)
    offending = [md for md in test.uncontrollable
                 if require is Requirement.CONTROLLABLE or md.eigenvalue.real >= -etol]
    if offending:
        need = "controllable" if require is Requirement.CONTROLLABLE else "stabilizable"
        modes = "; ".join(test.describe_mode(md) for md in offending)
        raise ParameterError(
            f"LQR needs a {need} pair (A, B); the PBH test finds {len(offending)} "
            f"uncontrollable mode(s): {modes}. Change the actuation or the equilibrium"
            + (", or pass require=Requirement.STABILIZABLE if these modes are stable"
               if require is Requirement.CONTROLLABLE else "")
        )

    method = "slycot" if _has_slycot() else "scipy"
    t1 = time.perf_counter()
    try:
        K, P, _ = control.lqr(A, Bm, Qm, Rm, method=method)
    except Exception as exc:  # noqa: BLE001 - any solver failure is reported with its type
        raise SolverError(
            f"the Riccati solver ({method}) failed for a {n}-state system: {exc}",
            status=type(exc).__name__,
        ) from exc
    t_ric = time.perf_counter() - t1
    K, P = np.asarray(K, dtype=float), np.asarray(P, dtype=float)
    ev = np.linalg.eigvals(A - Bm @ K)
    ev = ev[np.lexsort((ev.imag, ev.real))]
    if np.max(ev.real) >= 0:
        raise SolverError(
            f"the Riccati solution does not stabilise (max Re of A - BK = "
            f"{np.max(ev.real):.3g}); (Q, A) may have unobservable modes on the imaginary axis",
            status="not stabilising",
        )
    return LQRResult(
        K=K, P=P, Q=Qm, R=Rm, closed_loop_eigenvalues=ev, method=method,
        riccati_residual=riccati_residual(A, Bm, Qm, Rm, P), controllability=test,
        linear=lin, cost=LQRCost(pbh_seconds=t_pbh, riccati_seconds=t_ric),
    )


def _has_slycot() -> bool:
    try:
        import slycot  # noqa: F401
    except ImportError:
        return False
    return True


@validate.arguments(lin=validate.instance(LinearModel, "a LinearModel (from linearize)"),
                    K=validate.array, name=validate.identifier)
def geometric_feedback(
    lin: LinearModel, K: ArrayLike, *, name: str = "geometric_feedback"
) -> ca.Function:
    """Smooth nonlinear feedback ``u = k0(x) + u_e - K z(x)`` from a gain on a linearisation.

    ``z(x)`` is the linearisation's first-order chart (zero at ``x_e``, derivative the left
    inverse of its basis), so the law's linearisation at ``x_e`` is exactly ``-K``; ``k0`` is
    the controller the linearisation was taken with (none for an open-loop linearisation).

    Parameters
    ----------
    lin : LinearModel
        The linearisation the gain acts on (its coordinates and ordering).
    K : array-like, shape=(n_inputs, dim)
        Gain.
    name : str
        Name of the returned function.

    Returns
    -------
    casadi.Function
        ``(x, p) -> u`` with ``x`` the stored state (ambient_dim,) and ``p`` the model's
        parameters; on SX symbols, or on MX if the linearisation's controller cannot be
        called on SX symbols.

    Raises
    ------
    ParameterError
        ``K`` of the wrong shape or not finite.
    ModelError
        The linearisation's controller cannot be called on SX nor on MX symbols (both
        failures in the message, the last one chained).
    """
    Km = np.asarray(K, dtype=float)
    if Km.shape != (lin.n_inputs, lin.dim) or not np.all(np.isfinite(Km)):
        raise ParameterError(
            f"K must be a finite ({lin.n_inputs}, {lin.dim}) matrix (inputs x tangent "
            f"dimension); got shape {Km.shape}"
        )
    model = lin.model
    failures: list[tuple[str, Exception]] = []
    for S in (ca.SX, ca.MX):
        x, p = S.sym("x", model.manifold.ambient_dim), S.sym("p", model.n_params)
        u = ca.DM(lin.u_e) - ca.DM(Km) @ lin.chart(x)
        if lin.controller is not None:
            try:
                k0 = lin.controller(x) if lin.controller.n_in() == 1 else lin.controller(x, p)
            except (NotImplementedError, TypeError, RuntimeError) as exc:
                failures.append((S.__name__, exc))
                continue  # a controller that takes MX symbols only: compose on MX
            u = u + (k0[0] if isinstance(k0, (list, tuple)) else k0)
        return ca.Function(name, [x, p], [u], ["x", "p"], ["u"])
    raise ModelError(
        f"could not compose the controller {lin.controller.name()!r} of the linearisation "
        f"into the feedback law for model {model.name!r}: calling it failed "
        + "; ".join(f"on {s_} symbols with {type(e).__name__}: {e}" for s_, e in failures)
    ) from failures[-1][1]
