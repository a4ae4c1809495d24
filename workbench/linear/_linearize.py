"""Coordinate-free linearisation of a model graph at an equilibrium.

At an equilibrium ``x_e`` of ``x-dot = f(x, u)`` on a manifold ``M`` (stored in ambient
coordinates) with tangent basis ``N`` (columns spanning ``T_{x_e} M``), the linearisation
in tangent coordinates ``z`` (``delta x = N z``) is::

    A = pinv(N) @ df/dx(x_e, u_e) @ N,      B = pinv(N) @ df/du(x_e, u_e)

with ``df/dx`` and ``df/du`` obtained by automatic differentiation of the casadi graph (no
hand-derived Jacobian anywhere). Its dimension is the manifold's: TSO(3) -> 6,
S^2 x R^3 -> 5, TS^2 -> 4, the chain with n links on a cart -> 4n + 4. Because
``f(x_e) = 0`` the image ``df/dx N`` is tangent at ``x_e`` and any left inverse of ``N``
gives the same ``A``; off an equilibrium this is false, so :func:`linearize` refuses
such points and reports the residual.

The default basis is the manifold's (:meth:`ProductManifold.tangent_basis`), whose
coordinates already read as the papers': ``eta`` and ``delta Omega`` for
``R = R_e exp(hat(eta))`` (paper 002 (15)); ``C^T xi`` and its rate for a link of the chain
(paper 003 (15), (38)); ``(v, eta)`` for a TS2 factor. Another basis (``basis=``) or a
reordering (:meth:`LinearModel.permuted`, :func:`mechanical_order`) gives the same system in
other coordinates; a :class:`LinearModel` remembers the change of coordinates ``T``
(``N = N_default @ T``) so that gains map back through the smooth chart of the manifold
(:meth:`LinearModel.chart`).

:func:`linearize_ambient` gives the ambient form ``delta x-dot = df/dx delta x + df/du du``
with its constraint matrix ``dh/dx`` (the form of paper 002 (6)-(7)), for comparison; it,
the Jacobian graphs and their cache live in :mod:`workbench.linear._ambient` and are
re-exported here.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Model
from workbench.core.errors import ManifoldError, ModelError
from workbench.core.manifolds import S1, S2, SO3, TS2, Rn
from workbench.core.status import Record
from workbench.core.types import ArrayLike, Matrix, Vector
from workbench.linear._ambient import (
    EQUILIBRIUM_TOL,
    AmbientLinearization,
    _check_point,
    _dh,
    _equilibrium_jacobians,
    closed_loop_jacobians,
    linearize_ambient,
)
from workbench.linear._nonsmooth import Kink, kinks

__all__ = [
    "LinearModel",
    "LinearizationCost",
    "AmbientLinearization",
    "linearize",
    "linearize_ambient",
    "tangent_labels",
    "mechanical_order",
    "closed_loop_jacobians",
    "EQUILIBRIUM_TOL",
    "KINK_TOL",
]

KINK_TOL = 1e-9
"""Default ``kink_tol`` of :func:`linearize`: an argument of ``fabs``, ``fmax``, a comparison
... within ``KINK_TOL * max(1, |operands|)`` of its kink is at it."""


# ----------------------------------------------------------------------------------------
# labels and orderings


def tangent_labels(model: Model) -> list[str]:
    """Names of the default tangent coordinates of a model, in storage order.

    ``R^n`` factor ``w``: ``w1 .. wn``; ``S2`` factor ``q``: ``q.v1, q.v2`` (``xi = B v``);
    ``TS2`` factor ``q``: ``q.v1, q.v2, q.eta1, q.eta2``; ``SO3`` factor ``R``:
    ``R.eta1 .. R.eta3`` (``R = R_e exp(hat(eta))``); ``S1`` factor ``p``: ``p.theta``.

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    list of str, length = model.manifold.dim
    """
    out: list[str] = []
    for name, f in model.manifold.factors:
        if isinstance(f, Rn):
            out += [f"{name}{i + 1}" for i in range(f.dim)]
        elif isinstance(f, TS2):
            out += [f"{name}.v1", f"{name}.v2", f"{name}.eta1", f"{name}.eta2"]
        elif isinstance(f, S2):
            out += [f"{name}.v1", f"{name}.v2"]
        elif isinstance(f, SO3):
            out += [f"{name}.eta{i + 1}" for i in range(3)]
        elif isinstance(f, S1):
            out += [f"{name}.theta"]
        else:
            out += [f"{name}.{i + 1}" for i in range(f.dim)]
    return out


def mechanical_order(
    model: Model, pairs: Mapping[str, str] | None = None
) -> tuple[list[int], list[int]]:
    """Split the tangent coordinates into configuration and velocity coordinates.

    For a mechanical model the state is (configuration, velocity). A TS2 factor is split by
    itself (``v`` is the configuration part, ``eta`` the velocity part); other factors are
    paired by name: ``pairs={"R": "omega"}`` for the 3D pendulum on TSO(3),
    ``{"x": "v"}`` for the cart of the chain. At an equilibrium at rest the velocity
    coordinates are the rates of the configuration coordinates (checked by
    :func:`workbench.linear._controllability.second_order_form`, not here).

    Parameters
    ----------
    model : Model
        The model.
    pairs : mapping of str to str, optional
        Configuration factor name -> velocity factor name, both of the same dimension.

    Returns
    -------
    positions, velocities : list of int
        Indices into the default tangent coordinates, of equal length. ``positions +
        velocities`` is the order ``[configuration; velocity]`` of paper 003 (16)
        (``[delta x; x_q; delta x-dot; x_q-dot]`` for the chain with ``pairs={"x": "v"}``).

    Raises
    ------
    ModelError
        Unknown or mismatched factor names, or a factor left out of every pair.
    """
    man = model.manifold
    pairs = dict(pairs or {})
    for a, b in pairs.items():
        for nm in (a, b):
            if nm not in man.slices:
                raise ModelError(
                    f"pairs names factor {nm!r}, which model {model.name!r} does not have; "
                    f"factors are {man.names}"
                )
        if man.factor(a).dim != man.factor(b).dim:
            raise ModelError(
                f"pairs[{a!r}] = {b!r}: a configuration factor and its velocity factor must "
                f"have the same dimension; got {man.factor(a).dim} and {man.factor(b).dim}"
            )
    paired = set(pairs) | set(pairs.values())
    pos: list[int] = []
    vel: list[int] = []
    for name, f in man.factors:
        sl = man.tangent_slices[name]
        if name in pairs:
            pos += list(range(sl.start, sl.stop))
            vb = man.tangent_slices[pairs[name]]
            vel += list(range(vb.start, vb.stop))
        elif isinstance(f, TS2) and name not in paired:
            pos += [sl.start, sl.start + 1]
            vel += [sl.start + 2, sl.start + 3]
        elif name not in paired:
            raise ModelError(
                f"factor {name!r} ({f.kind}) of model {model.name!r} is neither a TS2 factor "
                f"nor named in pairs (configuration -> velocity factor); got pairs={pairs}"
            )
    return pos, vel


# ----------------------------------------------------------------------------------------
# linear models


@dataclass(frozen=True)
class LinearizationCost(Record):
    """What :func:`linearize` cost.

    Attributes
    ----------
    seconds : float
        Wall time of the evaluation (graph builds excluded).
    """

    seconds: float


@dataclass(frozen=True)
class LinearModel:
    """A linearisation ``z-dot = A z + B du`` in tangent coordinates at an equilibrium.

    Attributes
    ----------
    A : ndarray, shape=(dim, dim)
        State matrix.
    B : ndarray, shape=(dim, n_inputs)
        Input matrix (for an input added to the controller's when closed loop).
    basis : ndarray, shape=(ambient_dim, dim)
        ``N``: ambient direction of each tangent coordinate, ``delta x = N z``.
    transform : ndarray, shape=(dim, dim)
        ``T`` with ``N = N_default @ T`` (identity for the manifold's own basis).
    x_e : ndarray, shape=(ambient_dim,)
        The equilibrium (stored ambient coordinates).
    u_e : ndarray, shape=(n_inputs,)
        The input at the equilibrium (on top of the controller's, when closed loop).
    residual : ndarray, shape=(ambient_dim,)
        ``f(x_e, u_e)``, the vector field at the point (zero at an exact equilibrium).
    model : Model
        The model linearised.
    controller : casadi.Function or None
        The feedback composed into the field, if any.
    labels : tuple of str
        Names of the tangent coordinates.
    cost : LinearizationCost
        ``seconds`` (wall time of the evaluation, excluding graph builds; a typed record
        that also reads as a mapping).
    kinks : tuple of Kink
        Operations of the field at their kink at ``x_e`` (``fabs``, ``fmax``, a
        comparison...), where ``A`` and ``B`` are one one-sided derivative: empty unless
        :func:`linearize` was asked to ``allow_kinks``.
    """

    A: Matrix
    B: Matrix
    basis: Matrix
    transform: Matrix
    x_e: Vector
    u_e: Vector
    residual: Vector
    model: Model
    controller: ca.Function | None = None
    labels: tuple[str, ...] = ()
    cost: LinearizationCost | dict[str, Any] = field(default_factory=dict)
    kinks: tuple[Kink, ...] = ()

    @property
    def dim(self) -> int:
        """Dimension of the tangent space."""
        return int(self.A.shape[0])

    @property
    def n_inputs(self) -> int:
        """Number of inputs."""
        return int(self.B.shape[1])

    @property
    def residual_norm(self) -> float:
        """Max-norm of :attr:`residual`: how far ``x_e`` is from an exact equilibrium."""
        return float(np.max(np.abs(self.residual))) if self.residual.size else 0.0

    def __str__(self) -> str:
        """A short account: size, coordinates, equilibrium residual, spectral abscissa."""
        eig = np.linalg.eigvals(self.A) if self.dim else np.zeros(0)
        absc = f", max Re(eig A) {float(np.max(eig.real)):.4g}" if eig.size else ""
        labels = ", ".join(self.labels[:6]) + (", ..." if len(self.labels) > 6 else "")
        loop = ", closed loop" if self.controller is not None else ""
        return (f"LinearModel of {self.model.name}{loop}: A {self.dim}x{self.dim}, "
                f"B {self.dim}x{self.n_inputs} in tangent coordinates ({labels}); "
                f"equilibrium residual {self.residual_norm:.1e}{absc}")

    def _repr_html_(self) -> str:
        from html import escape

        return f"<pre>{escape(str(self))}</pre>"

    def to_statespace(self) -> Any:
        """Return the linearisation as a ``control.StateSpace`` (outputs = all states).

        Returns
        -------
        control.StateSpace
            ``(A, B, I, 0)``; state names are the labels with ``.`` replaced by ``_``.
        """
        import control

        n, m = self.dim, self.n_inputs
        names = [lab.replace(".", "_") for lab in self.labels] or [f"z{i}" for i in range(n)]
        return control.ss(
            self.A, self.B if m else np.zeros((n, 0)), np.eye(n), np.zeros((n, m)),
            states=names, outputs=[f"y_{lab}" for lab in names],
            inputs=[f"u{i}" for i in range(m)], name=f"lin_{self.model.name}",
        )

    def chart(self, x: Any) -> Any:
        """Smooth first-order chart: tangent coordinates of a state (numeric or casadi).

        ``z = T^-1 chart_M(x_e, x)``, zero at ``x_e`` and with derivative the left inverse
        of :attr:`basis` there, so a gain ``K`` on ``z`` is a smooth feedback on the state.

        Parameters
        ----------
        x : array-like or casadi expression, shape=(ambient_dim,)
            The state.

        Returns
        -------
        array or casadi expression, shape=(dim,)
        """
        y = self.model.manifold.chart(self.x_e, x)
        Tinv = np.linalg.inv(self.transform)
        if isinstance(y, (ca.SX, ca.MX, ca.DM)):
            if np.allclose(Tinv, np.eye(self.dim), rtol=0, atol=0):
                return y
            return ca.DM(Tinv) @ y
        return Tinv @ np.ravel(y)

    def ambient(self, z: ArrayLike) -> Matrix:
        """Ambient directions ``N z`` of tangent vectors (columns of ``z``)."""
        return self.basis @ np.asarray(z)

    def permuted(self, order: Sequence[int]) -> LinearModel:
        """Return the same linearisation with the tangent coordinates reordered.

        Parameters
        ----------
        order : sequence of int
            A permutation of ``range(dim)``: new coordinate ``k`` is old ``order[k]``.

        Returns
        -------
        LinearModel
        """
        idx = np.asarray(order, dtype=int).ravel()
        if sorted(idx.tolist()) != list(range(self.dim)):
            raise ModelError(
                f"order must be a permutation of range({self.dim}); got {idx.tolist()}"
            )
        P = np.eye(self.dim)[:, idx]  # z_old = P z_new
        return replace(
            self,
            A=self.A[np.ix_(idx, idx)],
            B=self.B[idx, :],
            basis=self.basis @ P,
            transform=self.transform @ P,
            labels=tuple(self.labels[i] for i in idx) if self.labels else (),
        )

    def with_input_map(self, E: ArrayLike) -> LinearModel:
        """Return the linearisation with inputs ``u = E w`` (e.g. a subset of actuators).

        Parameters
        ----------
        E : array-like, shape=(n_inputs, k)
            Input map.

        Returns
        -------
        LinearModel
            ``B @ E`` as input matrix; ``u_e`` unchanged.
        """
        Em = np.asarray(E, dtype=float)
        if Em.ndim != 2 or Em.shape[0] != self.n_inputs:
            raise ModelError(
                f"E must have shape ({self.n_inputs}, k) for a model with {self.n_inputs} "
                f"inputs; got shape {Em.shape}"
            )
        return replace(self, B=self.B @ Em)


# ----------------------------------------------------------------------------------------
# tangent basis


def _basis(model: Model, x_e: Vector, basis: ArrayLike | None, tol: float) -> tuple[Matrix,
                                                                                   Matrix]:
    N0 = model.manifold.tangent_basis(x_e)
    if basis is None:
        return N0, np.eye(N0.shape[1])
    N = np.asarray(basis, dtype=float)
    if N.shape != N0.shape:
        raise ManifoldError(
            f"basis must have shape {N0.shape} (ambient_dim, dim) for model {model.name!r}; "
            f"got shape {N.shape}"
        )
    C = _dh(model, x_e)
    leak = float(np.max(np.abs(C @ N))) / max(1.0, float(np.max(np.abs(N)))) if C.size else 0.0
    if leak > tol:
        raise ManifoldError(
            f"basis columns must be tangent at x_e (dh/dx basis = 0); got max |dh/dx basis| "
            f"= {leak:.3g}"
        )
    T = np.linalg.pinv(N0) @ N
    cond = float(np.linalg.cond(T))
    if not np.isfinite(cond) or cond > 1e12:
        raise ManifoldError(
            f"basis must span the tangent space (dimension {N0.shape[1]}); its columns are "
            f"dependent (condition number {cond:.3g})"
        )
    return N, T


def _project_blocks(model: Model, N: Matrix, Jx: Matrix, Ju: Matrix) -> tuple[Matrix, Matrix]:
    """``pinv(N) Jx N`` and ``pinv(N) Ju`` for the block-diagonal basis of the manifold.

    The pseudo-inverse of a block-diagonal matrix is block diagonal (the blocks' own
    pseudo-inverses), so the products are taken factor by factor: the same sums without
    the zero blocks (O(n^2) instead of dense O(n^3) products for n factors).
    """
    man = model.manifold
    blocks = [(man.slices[n], man.tangent_slices[n]) for n in man.names]
    JN = np.zeros((Jx.shape[0], N.shape[1]))
    for rs, cs in blocks:
        JN[:, cs] = Jx[:, rs] @ N[rs, cs]
    A, B = np.zeros((N.shape[1], N.shape[1])), np.zeros((N.shape[1], Ju.shape[1]))
    for rs, cs in blocks:
        L = np.linalg.pinv(N[rs, cs])
        A[cs, :], B[cs, :] = L @ JN[rs, :], L @ Ju[rs, :]
    return A, B


# ----------------------------------------------------------------------------------------
# public entry points


@validate.arguments(
    error=ModelError, model=validate.instance(Model, "a workbench Model"),
    tol=validate.tolerance, manifold_tol=validate.tolerance, kink_tol=validate.tolerance
)
def linearize(
    model: Model,
    x_e: ArrayLike,
    u_e: ArrayLike | None = None,
    *,
    controller: ca.Function | None = None,
    basis: ArrayLike | None = None,
    tol: float = EQUILIBRIUM_TOL,
    manifold_tol: float = 1e-9,
    kink_tol: float = KINK_TOL,
    allow_kinks: bool = False,
) -> LinearModel:
    """Linearise a model (optionally in closed loop) at an equilibrium, in tangent coordinates.

    Parameters
    ----------
    model : Model
        The model; its current parameter values are used.
    x_e : array-like, shape=(ambient_dim,)
        The equilibrium, on the manifold to ``manifold_tol`` (never projected).
    u_e : array-like, shape=(n_inputs,), optional
        Input at the equilibrium (default zero); closed loop it is added to the
        controller's output.
    controller : casadi.Function, optional
        Feedback ``u = k(x)`` or ``k(x, p)`` composed into the field before
        differentiation (closed-loop linearisation).
    basis : array-like, shape=(ambient_dim, dim), optional
        Tangent basis to use instead of the manifold's; must span ``T_{x_e} M``.
    tol : float
        Largest accepted max-norm of ``f(x_e, u_e)``.
    manifold_tol : float
        Largest accepted constraint residual of ``x_e``.
    kink_tol : float
        The field is not differentiable at ``x_e`` where an operation of its graph
        (``fabs``, ``fmax``, ``fmin``, ``sign``, ``floor``, ``ceil``, ``fmod``,
        ``copysign``, ``atan2``, a comparison of an ``if_else``) has its argument within
        ``kink_tol * max(1, |operands|)`` of its kink (see
        :mod:`workbench.linear._nonsmooth`).
    allow_kinks : bool
        Linearise there anyway and list the operations in :attr:`LinearModel.kinks`
        (``A`` is then one one-sided derivative, and its eigenvalues classify nothing).

    Returns
    -------
    LinearModel

    Raises
    ------
    ManifoldError
        ``x_e`` off the manifold, or a ``basis`` that is not a tangent basis.
    ModelError
        ``x_e`` is not an equilibrium (the message gives the residual by factor), bad
        ``u_e`` / ``controller``, the field is not differentiable at ``x_e`` (unless
        ``allow_kinks``), or (a :mod:`workbench.mechanics` model) its kinetic energy is
        not positive definite at ``x_e``.
    """
    xe, ue = _check_point(model, x_e, u_e, tol, manifold_tol)
    if not isinstance(allow_kinks, bool):
        raise ModelError(f"allow_kinks must be True or False; got {allow_kinks!r}")
    if getattr(model, "state_check", None) is not None:  # a mechanics model: T definite
        model.state_check(model, xe, what="x_e")
    N, T = _basis(model, xe, basis, tol=1e-9)
    t0 = time.perf_counter()
    f0, Jx, Ju = _equilibrium_jacobians(model, xe, ue, controller, tol)
    if basis is None:  # the manifold's basis is block diagonal by factor
        A, B = _project_blocks(model, N, Jx, Ju)
    else:
        L = np.linalg.pinv(N)
        A, B = L @ Jx @ N, L @ Ju
    seconds = time.perf_counter() - t0
    found = tuple(kinks(model, controller, xe, ue, kink_tol))
    if found and not allow_kinks:
        loop = "closed-loop " if controller is not None else ""
        raise ModelError(
            f"the {loop}field of {model.name!r} is not differentiable at x_e = "
            f"{np.round(xe, 12).tolist()}: {len(found)} operation(s) at their kink there "
            f"(kink_tol {kink_tol:.1g}): {'; '.join(k.describe() for k in found[:4])}"
            f"{' ...' if len(found) > 4 else ''}. A linearisation there is one one-sided "
            "derivative and its eigenvalues classify nothing; pass allow_kinks=True to get "
            "it anyway (listed in LinearModel.kinks). A kink of a potential is a jump of "
            "the force: fabs in V appears as sign in f")
    labels = tangent_labels(model)
    if basis is not None:
        labels = [f"z{i + 1}" for i in range(N.shape[1])]
    return LinearModel(A=A, B=B, basis=N, transform=T, x_e=xe, u_e=ue, residual=f0,
                       model=model, controller=controller, labels=tuple(labels),
                       cost=LinearizationCost(seconds=seconds), kinks=found)
