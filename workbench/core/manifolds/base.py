"""The abstract manifold factor: a level set of a submersion, with derived checks."""

from __future__ import annotations

from abc import ABC, abstractmethod
from functools import lru_cache

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core.errors import ManifoldError
from workbench.core.manifolds.lie import _is_casadi, _vec  # noqa: F401
from workbench.core.types import ArrayLike, Expr, Matrix, Vector

__all__ = ["Factor", "DEFAULT_TOL"]

DEFAULT_TOL = 1e-9
"""Default tolerance on constraint residuals when a point is checked to lie on a factor."""


# ----------------------------------------------------------------------------------------
# factors


def _build_constraint_functions(factor: Factor) -> tuple[ca.Function, ca.Function] | None:
    xs = ca.SX.sym("x", factor.ambient_dim)
    h = ca.vec(ca.SX(factor.residual(xs)))
    if h.numel() == 0:
        return None
    return (ca.Function("h", [xs], [h], ["x"], ["h"]),
            ca.Function("dh", [xs], [ca.jacobian(h, xs)], ["x"], ["dh"]))


_constraint_functions = lru_cache(maxsize=256)(_build_constraint_functions)


class Factor(ABC):
    """A manifold factor, the level set ``{x in R^N : h(x) = 0}`` of a submersion ``h``.

    Subclasses define the submersion (:meth:`residual`), its Jacobian, a tangent basis, a
    retraction and a chart that agree to first order (see the module docstring), and an
    explicit projection. :meth:`belongs`, :meth:`is_tangent` and :meth:`check` are derived
    here once.

    Attributes
    ----------
    ambient_dim : int
        ``N``, the number of stored coordinates.
    dim : int
        Dimension of the manifold (``N`` minus the number of independent constraints).
    kind : str
        Short name used in messages ("S2", "SO3", ...).
    """

    ambient_dim: int
    dim: int
    kind: str
    projection_hint: str = "Factor.project(x)"

    @abstractmethod
    def residual(self, x: Expr) -> Expr:
        """Constraint residual ``h(x)``, zero exactly on the manifold.

        Parameters
        ----------
        x : array-like or casadi expression, shape=(ambient_dim,)
            Ambient coordinates.

        Returns
        -------
        array or casadi expression
            The residual (shape depends on the factor; empty for R^n).
        """

    def residual_norm(self, x: ArrayLike) -> float:
        """Max-norm of :meth:`residual` at a numeric point."""
        r = np.asarray(self.residual(self._numeric(x)), dtype=float).ravel()
        return float(np.max(np.abs(r))) if r.size else 0.0

    def residual_scales(self, x: Vector) -> Vector:
        """Size of the quantity each residual entry is computed from (default all 1).

        A constraint on a quantity with a scale is checked relative to it: an entry
        ``h_i`` passes when ``|h_i| <= tol * max(1, scale_i)`` (e.g. tangency on TS^2,
        ``|q . w| <= tol * max(1, |w|)``: the most accurate float64 state at ``|w| = 1e8``
        has ``|q . w| ~ 1e-8``). Constraints that are already relative (``|q|^2 = 1``,
        ``R^T R = I``: the entries of a rotation are at most 1) keep scale 1.

        Parameters
        ----------
        x : ndarray, shape=(ambient_dim,)
            A numeric point.

        Returns
        -------
        ndarray
            One scale per entry of the flattened :meth:`residual`.
        """
        r = np.asarray(self.residual(x), dtype=float).ravel()
        return np.ones(r.size)

    def scaled_residual_norm(self, x: ArrayLike) -> float:
        """``max_i |h_i(x)| / max(1, scale_i)``: the residual compared with a tolerance."""
        xv = self._numeric(x)
        r = np.abs(np.asarray(self.residual(xv), dtype=float).ravel())
        if not r.size:
            return 0.0
        scales = np.maximum(1.0, np.abs(self.residual_scales(xv)))
        return float(np.max(r / scales))

    @abstractmethod
    def tangent_basis(self, x: ArrayLike) -> Matrix:
        """Basis of the tangent space at a numeric point.

        Parameters
        ----------
        x : array-like, shape=(ambient_dim,)
            A point on the factor.

        Returns
        -------
        ndarray, shape=(ambient_dim, dim)
            Columns spanning ``T_x M``; they are the derivative of :meth:`retract`.
        """

    @abstractmethod
    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:
        """Move from ``x`` along tangent coordinates ``v`` and land exactly on the factor.

        Parameters
        ----------
        x : array-like, shape=(ambient_dim,)
            A point on the factor.
        v : array-like, shape=(dim,)
            Tangent coordinates in the basis of :meth:`tangent_basis`.

        Returns
        -------
        ndarray, shape=(ambient_dim,)
            The new point.
        """

    @abstractmethod
    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:
        """Smooth local coordinates of ``x`` around ``x_e``, first-order inverse of retract.

        Parameters
        ----------
        x_e : array-like, shape=(ambient_dim,)
            The chart's centre (numeric).
        x : array-like or casadi expression, shape=(ambient_dim,)
            The point (numeric or symbolic).

        Returns
        -------
        array or casadi expression, shape=(dim,)
            Zero at ``x_e``, derivative the left inverse of the tangent basis there.
        """

    @abstractmethod
    def project(self, x: ArrayLike) -> Vector:
        """Closest point on the factor (explicit; never applied automatically).

        Parameters
        ----------
        x : array-like, shape=(ambient_dim,)
            A point near the factor.

        Returns
        -------
        ndarray, shape=(ambient_dim,)
            The projected point.
        """

    @abstractmethod
    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:
        """A random point (velocity parts scaled by ``scale``), for tests and sampling."""

    def constraint_functions(self) -> tuple[ca.Function, ca.Function] | None:
        """``x -> vec(h(x))`` and ``x -> dh/dx`` as casadi.Functions, built once per factor.

        Returns
        -------
        (casadi.Function, casadi.Function) or None
            On SX symbols, cached for the factor (the 256 most recent factors); None for a
            factor without constraints (R^n). Numeric calls take one point or a matrix of
            points as columns.
        """
        try:
            hash(self)
        except TypeError:  # an unhashable (user) factor: built on every call
            return _build_constraint_functions(self)
        return _constraint_functions(self)

    def constraint_jacobian(self, x: ArrayLike) -> Matrix:
        """Jacobian ``dh/dx`` at a numeric point, shape ``(n_constraints, ambient_dim)``."""
        fns = self.constraint_functions()
        if fns is None:
            return np.zeros((0, self.ambient_dim))
        return np.asarray(fns[1](self._numeric(x)), dtype=float)

    # derived ------------------------------------------------------------------------------

    def _numeric(self, x: ArrayLike, name: str = "x") -> Vector:
        """``x`` as a flat real array (complex, bool, str refused; never truncated)."""
        return validate.array(name, x, finite=False, error=ManifoldError).reshape(
            -1, order="F")

    def _tangent(self, v: ArrayLike) -> Vector:
        """Tangent coordinates ``v`` as ``dim`` finite real numbers, or ManifoldError."""
        return validate.array(f"v (tangent coordinates on {self.kind})", v, size=self.dim,
                              error=ManifoldError).reshape(-1)

    def belongs(self, x: ArrayLike, *, tol: float = DEFAULT_TOL) -> bool:
        """Whether ``x`` has the right size and scaled constraint residual at most ``tol``.

        ``tol`` must be a positive finite number (ManifoldError otherwise); see
        :meth:`residual_scales` for the relative thresholds.
        """
        tol = validate.tolerance("tol", tol, error=ManifoldError)
        if not validate.is_real_array_like(x):
            return False
        xv = self._numeric(x)
        return xv.size == self.ambient_dim and bool(np.all(np.isfinite(xv))) and (
            self.scaled_residual_norm(xv) <= tol
        )

    def is_tangent(self, x: ArrayLike, v: ArrayLike, *, tol: float = DEFAULT_TOL) -> bool:
        """Whether the ambient vector ``v`` is tangent at ``x``: ``dh/dx(x) v = 0``.

        Relative: ``|dh/dx v| <= tol * max(1, |dh/dx| |v|)``; ``tol`` must be a positive
        finite number.
        """
        tol = validate.tolerance("tol", tol, error=ManifoldError)
        xv, vv = self._numeric(x, "x"), self._numeric(v, "v")
        for label, arr, raw in (("x", xv, x), ("v", vv, v)):
            if arr.size != self.ambient_dim or not np.all(np.isfinite(arr)):
                raise ManifoldError(f"{label} must be {self.ambient_dim} finite numbers for "
                                    f"{self.kind}; got shape {np.shape(raw)}: {arr.tolist()}")
        H = self.constraint_jacobian(xv)
        if not H.size:
            return True
        lhs = np.abs(H @ vv)
        scale = float(np.linalg.norm(H, 2) * np.linalg.norm(vv))
        return bool(np.all(lhs <= validate.scaled_tolerance(tol, scale)))

    def check(self, x: ArrayLike, *, name: str = "x", tol: float = DEFAULT_TOL) -> Vector:
        """Validate a numeric point and return it as a flat array, unchanged.

        Parameters
        ----------
        x : array-like
            The point, either flat ``(ambient_dim,)`` or in the factor's natural shape.
        name : str
            Name of the argument, used in the error message.
        tol : float
            Largest accepted constraint residual (max-norm, each entry relative to the
            scale of its quantity, see :meth:`residual_scales`); a positive finite number.

        Returns
        -------
        ndarray, shape=(ambient_dim,)
            The same numbers, flattened.

        Raises
        ------
        ManifoldError
            With the residual and the explicit projection to use, if ``x`` is off the factor.
        """
        tol = validate.tolerance("tol", tol, error=ManifoldError)
        xv = self._numeric(x, name)
        if xv.size != self.ambient_dim:
            raise ManifoldError(
                f"{name} must have {self.ambient_dim} entries for {self.kind}; "
                f"got shape {np.shape(x)}"
            )
        if not np.all(np.isfinite(xv)):
            raise ManifoldError(f"{name} must be finite; got {xv.tolist()}")
        res = self.scaled_residual_norm(xv)
        if not res <= tol:  # also an overflowing (inf or nan) residual
            raise ManifoldError(
                f"{name} is not on {self.kind}: {self.describe_residual(xv)} "
                f"(max scaled constraint residual {res:.3g} > tol {tol:.1g}). Nothing is "
                f"normalised silently; project it explicitly with {self.projection_hint} "
                f"and report the change, or pass a larger tol."
            )
        return xv

    def describe_residual(self, x: Vector) -> str:
        """Readable account of how ``x`` violates the constraints."""
        return f"|h(x)| = {self.residual_norm(x):.3g}"

    def __repr__(self) -> str:
        return f"{self.kind}()"
