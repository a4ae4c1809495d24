"""Ambient Jacobians of a model graph at an equilibrium, and the ambient linearisation.

At an equilibrium ``(x_e, u_e)`` of ``x-dot = f(x, u)`` on a manifold ``M = {h = 0}``
stored in ambient coordinates, automatic differentiation of the casadi graph gives
``df/dx``, ``df/du`` (optionally with a feedback ``u = k(x, p)`` composed in,
:func:`closed_loop_jacobians`) and ``dh/dx``. :func:`linearize_ambient` returns them as
the ambient form ``delta x-dot = df/dx delta x + df/du du`` with the constraint
``dh/dx delta x = 0`` (paper 002 (6)-(7)); its spectrum splits into the admissible
eigenvalues (those of the tangent linearisation of :func:`workbench.linear._linearize.linearize`,
which projects the same Jacobians onto a tangent basis) and spurious ones
(:meth:`AmbientLinearization.constrained_eigenvalues`).

The Jacobian graphs are cached per (model graphs, controller); both refuse points that are
not equilibria, with the residual by factor.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._feedback import feedback_function
from workbench.core._model import BuildRecord, Model
from workbench.core.errors import ModelError
from workbench.core.types import ArrayLike, Matrix, Vector

__all__ = [
    "AmbientLinearization",
    "linearize_ambient",
    "closed_loop_jacobians",
    "EQUILIBRIUM_TOL",
]

EQUILIBRIUM_TOL = 1e-8
"""Default largest accepted max-norm of ``f(x_e, u_e)`` at a point called an equilibrium."""


# ----------------------------------------------------------------------------------------
# building the Jacobians


def closed_loop_jacobians(model: Model, controller: ca.Function | None) -> ca.Function:
    """``(x, u, p) -> (f, df/dx, df/du)`` of ``f(x, k(x, p) + u, p)`` (``k = 0`` if None).

    Open loop, the model's cached ``f``, ``f_x`` and ``f_u`` are used; closed loop, the
    controller is composed into the graph and differentiated with it.

    Parameters
    ----------
    model : Model
        The plant.
    controller : casadi.Function or None
        ``u = k(x)`` or ``k(x, p)``.

    Returns
    -------
    casadi.Function
    """
    if controller is not None:
        _check_controller(model, controller)
    S = model.sym
    x = S.sym("x", model.manifold.ambient_dim)
    u, p = S.sym("u", model.n_inputs), S.sym("p", model.n_params)
    f = model.function("f")
    if controller is None:
        outs = [f(x, u, p), model.function("f_x")(x, u, p), model.function("f_u")(x, u, p)]
    else:
        k = controller(x) if controller.n_in() == 1 else controller(x, p)
        xdot = f(x, k + u, p)
        outs = [xdot, ca.jacobian(xdot, x), ca.jacobian(xdot, u)]
    # dense outputs: converting a sparse DM to numpy costs more than the evaluation at n = 50
    outs = [ca.densify(o) for o in outs]
    return ca.Function("jacobians", [x, u, p], outs, ["x", "u", "p"], ["f", "f_x", "f_u"])


def _check_controller(model: Model, controller: Any) -> None:
    feedback_function(model, controller)  # raises ModelError for a controller that does not fit


_JAC_CACHE: dict[tuple[int, int], tuple[Any, Any, ca.Function]] = {}
_JAC_CACHE_SIZE = 64  # most recent (model graphs, controller) pairs kept


def _jacobians(model: Model, controller: ca.Function | None) -> ca.Function:
    """Return the cached :func:`closed_loop_jacobians` per (shared model graphs, controller).

    The cache holds references to both keys' objects, so their ids stay unique.
    """
    graphs = model._graphs  # noqa: SLF001 - identity of the graphs shared by with_parameters
    key = (id(graphs), id(controller))
    hit = _JAC_CACHE.get(key)
    if hit is None:
        t0 = time.perf_counter()
        fn = closed_loop_jacobians(model, controller)
        if controller is not None:  # open loop reuses the model's own (logged) f_x, f_u
            model.build_log.add(BuildRecord(
                f"{model.name}.jacobians[{controller.name()}]", int(fn.n_nodes()),
                time.perf_counter() - t0, model.symbolic))
        hit = (graphs, controller, fn)
        if len(_JAC_CACHE) >= _JAC_CACHE_SIZE:
            _JAC_CACHE.pop(next(iter(_JAC_CACHE)))
        _JAC_CACHE[key] = hit
    return hit[2]


def _input(model: Model, u_e: ArrayLike | None) -> Vector:
    if u_e is None:
        return np.zeros(model.n_inputs)
    uv = validate.array("u_e", u_e, finite=False, error=ModelError).ravel()
    if uv.size != model.n_inputs or not np.all(np.isfinite(uv)):
        raise ModelError(
            f"u_e must be {model.n_inputs} finite numbers for model {model.name!r}; got "
            f"{np.asarray(u_e).tolist()}"
        )
    return uv


def _dh(model: Model, x_e: Vector) -> Matrix:
    man = model.manifold
    blocks = []
    for name, f in man.factors:
        J = f.constraint_jacobian(x_e[man.slices[name]])
        if J.shape[0]:
            row = np.zeros((J.shape[0], man.ambient_dim))
            row[:, man.slices[name]] = J
            blocks.append(row)
    return np.vstack(blocks) if blocks else np.zeros((0, man.ambient_dim))


def _check_point(model: Model, x_e: ArrayLike, u_e: ArrayLike | None, tol: float,
                 manifold_tol: float) -> tuple[Vector, Vector]:
    """``x_e`` (on the manifold) and ``u_e`` validated, and ``tol`` checked."""
    if not isinstance(model, Model):
        raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
    xe = model.check_state(x_e, name="x_e", tol=manifold_tol)
    ue = _input(model, u_e)
    validate.tolerance("tol", tol, error=ModelError)
    return xe, ue


def _equilibrium_jacobians(model: Model, x_e: Vector, u_e: Vector,
                           controller: ca.Function | None, tol: float
                           ) -> tuple[Vector, Matrix, Matrix]:
    """``f``, ``df/dx`` and ``df/du`` at ``(x_e, u_e)`` (one evaluation), or ModelError.

    Raises ModelError if ``max |f(x_e, u_e)| > tol``: off an equilibrium ``df/dx N`` is not
    tangent and the linearisation has no meaning.
    """
    jac = _jacobians(model, controller)
    f0, Jx, Ju = (np.asarray(v, dtype=float) for v in jac(x_e, u_e, model.p))
    f0 = f0.ravel()
    if not (np.all(np.isfinite(f0)) and np.all(np.isfinite(Jx)) and np.all(np.isfinite(Ju))):
        raise ModelError(
            f"the field of {model.name!r} or its Jacobian is not finite at x_e = "
            f"{x_e.tolist()}, u_e = {np.asarray(u_e).tolist()} (f = {f0.tolist()}): an "
            "overflow, or a singular solve inside the field there (e.g. a mass matrix "
            "singular at that state)")
    res = float(np.max(np.abs(f0))) if f0.size else 0.0
    # relative to the size of the field's terms near x_e: |df/dx| |x_e| (rounding of x_e);
    # the limit is at least tol, so the spectral norm (an SVD) is needed only above tol
    if res <= tol:
        return f0, Jx, Ju.reshape(model.manifold.ambient_dim, model.n_inputs)
    scale = float(np.linalg.norm(Jx, 2) * np.linalg.norm(x_e, np.inf)) if Jx.size else 0.0
    limit = validate.scaled_tolerance(tol, scale)
    if not res <= limit:
        loop = "closed-loop " if controller is not None else ""
        raise ModelError(
            f"x_e is not an equilibrium of the {loop}field of {model.name!r}: "
            f"max |f(x_e, u_e)| = {res:.3g} > tol * max(1, |df/dx| |x_e|) = {limit:.3g} "
            f"(tol {tol:.1g}; by factor: "
            f"{_describe_residual(model, f0)}). Linearise only at equilibria (find one "
            f"first), or pass a larger tol."
        )
    return f0, Jx, Ju.reshape(model.manifold.ambient_dim, model.n_inputs)


def _describe_residual(model: Model, r: Vector) -> str:
    man = model.manifold
    parts = []
    for name in man.names:
        v = r[man.slices[name]]
        if v.size and np.max(np.abs(v)) > 0:
            parts.append(f"{name}: {np.max(np.abs(v)):.3g}")
    return ", ".join(parts) if parts else "all zero"


# ----------------------------------------------------------------------------------------
# the ambient form


@dataclass(frozen=True)
class AmbientLinearization:
    """The ambient form ``d(delta x)/dt = F delta x + G du`` with ``C delta x = 0``.

    Attributes
    ----------
    A : ndarray, shape=(ambient_dim, ambient_dim)
        ``df/dx`` at the equilibrium.
    B : ndarray, shape=(ambient_dim, n_inputs)
        ``df/du``.
    C : ndarray, shape=(n_constraints, ambient_dim)
        ``dh/dx``: admissible perturbations lie in its null space (paper 002 (7)).
    basis : ndarray, shape=(ambient_dim, dim)
        The manifold's tangent basis, spanning the null space of ``C``.
    x_e : ndarray, shape=(ambient_dim,)
        The equilibrium.
    """

    A: Matrix
    B: Matrix
    C: Matrix
    basis: Matrix
    x_e: Vector

    def constrained_eigenvalues(self, *, tol: float = 1e-8) -> tuple[Vector, Vector]:
        """Split the ambient spectrum into the admissible and the spurious eigenvalues.

        At an equilibrium ``ker C`` is invariant under ``A``; the eigenvalues of ``A`` are
        those of its restriction to ``ker C`` (the linearisation in tangent coordinates)
        and those of the induced map on the quotient (the spurious ones of paper 002,
        e.g. ``0`` and ``-k_omega`` on S^2, whose eigenvectors violate (7)).

        Parameters
        ----------
        tol : float
            Largest accepted ``|C N' A N|`` (invariance check, relative to ``|A|``).

        Returns
        -------
        admissible, spurious : ndarray of complex
        """
        N = self.basis
        scale = max(1.0, float(np.linalg.norm(self.A, 2)))
        leak = float(np.linalg.norm(self.C @ self.A @ N, 2)) / scale if self.C.size else 0.0
        if leak > tol:
            raise ModelError(
                f"the null space of C is not invariant under A (|C A N| / |A| = {leak:.3g} "
                f"> tol {tol:g}); x_e is not an equilibrium of a field tangent to the manifold"
            )
        restricted = np.linalg.pinv(N) @ self.A @ N
        # complement: orthonormal basis of range(C^T)
        if self.C.size:
            W = np.linalg.qr(self.C.T)[0]
            # the induced map on R^N / ker C in the coordinates y = W^T x
            quotient = W.T @ self.A @ W
            spurious = np.linalg.eigvals(quotient)
        else:
            spurious = np.zeros(0, dtype=complex)
        return np.linalg.eigvals(restricted), spurious


@validate.arguments(
    error=ModelError, model=validate.instance(Model, "a workbench Model"),
    tol=validate.tolerance, manifold_tol=validate.tolerance
)
def linearize_ambient(
    model: Model,
    x_e: ArrayLike,
    u_e: ArrayLike | None = None,
    *,
    controller: ca.Function | None = None,
    tol: float = EQUILIBRIUM_TOL,
    manifold_tol: float = 1e-9,
) -> AmbientLinearization:
    """Linearise in ambient coordinates, with the constraint matrix (paper 002 (6)-(7) form).

    Parameters
    ----------
    model, x_e, u_e, controller, tol, manifold_tol
        As in :func:`workbench.linear._linearize.linearize`.

    Returns
    -------
    AmbientLinearization
        ``A = df/dx``, ``B = df/du`` (by automatic differentiation) and ``C = dh/dx``.

    Raises
    ------
    ManifoldError
        ``x_e`` off the manifold.
    ModelError
        ``x_e`` is not an equilibrium (the message gives the residual by factor), or bad
        ``u_e`` / ``controller``.
    """
    xe, ue = _check_point(model, x_e, u_e, tol, manifold_tol)
    _, Jx, Ju = _equilibrium_jacobians(model, xe, ue, controller, tol)
    return AmbientLinearization(A=Jx, B=Ju, C=_dh(model, xe),
                                basis=model.manifold.tangent_basis(xe), x_e=xe)
