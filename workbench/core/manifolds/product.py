"""Ordered products of named factors, stored as one concatenated ambient vector."""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core.errors import ManifoldError
from workbench.core.manifolds.base import DEFAULT_TOL, Factor
from workbench.core.manifolds.lie import _is_casadi  # noqa: F401
from workbench.core.types import ArrayLike, Expr, Matrix, Vector

__all__ = ["ProductManifold"]


# ----------------------------------------------------------------------------------------
# products


class ProductManifold:
    """An ordered product of named factors, stored as one concatenated ambient vector.

    Parameters
    ----------
    factors : sequence of (str, Factor)
        Names and factors, in storage order. Names must be unique identifiers.
    """

    def __init__(self, factors: Sequence[tuple[str, Factor]]) -> None:
        if not factors:
            raise ManifoldError("a product manifold needs at least one factor; got none")
        try:
            names = [n for n, _ in factors]
        except (TypeError, ValueError) as exc:
            raise ManifoldError(f"factors must be a sequence of (name, Factor) pairs; got "
                                f"{factors!r}") from exc
        for n in names:
            validate.identifier("factor name", n, error=ManifoldError)
        if len(set(names)) != len(names):
            raise ManifoldError(f"factor names must be unique; got {names}")
        for n, f in factors:
            if not isinstance(f, Factor):
                raise ManifoldError(f"factor {n!r} must be a Factor; got {type(f).__name__}")
        self.factors: tuple[tuple[str, Factor], ...] = tuple(factors)
        self.slices: dict[str, slice] = {}
        self.tangent_slices: dict[str, slice] = {}
        a = t = 0
        for n, f in self.factors:
            self.slices[n] = slice(a, a + f.ambient_dim)
            self.tangent_slices[n] = slice(t, t + f.dim)
            a += f.ambient_dim
            t += f.dim
        self.ambient_dim = a
        self.dim = t

    @property
    def names(self) -> list[str]:
        """Factor names in storage order."""
        return [n for n, _ in self.factors]

    def factor(self, name: str) -> Factor:
        """The factor called ``name``."""
        for n, f in self.factors:
            if n == name:
                return f
        raise ManifoldError(f"unknown factor {name!r}; this manifold has {self.names}")

    def split(self, x: Expr) -> dict[str, Expr]:
        """Named parts of a stored point (numeric or symbolic)."""
        return {n: x[self.slices[n]] for n, _ in self.factors}

    def join(self, parts: dict[str, ArrayLike]) -> Vector:
        """Concatenate named numeric parts in storage order (each flattened column-major)."""
        missing = [n for n in self.names if n not in parts]
        extra = [n for n in parts if n not in self.slices]
        if missing or extra:
            raise ManifoldError(
                f"parts must name exactly the factors {self.names}; "
                f"missing {missing}, unknown {extra}"
            )
        out = []
        for n, f in self.factors:
            a = validate.array(f"part {n!r}", parts[n], finite=False,
                               error=ManifoldError).reshape(-1, order="F")
            if a.size != f.ambient_dim:
                raise ManifoldError(
                    f"part {n!r} must have {f.ambient_dim} entries for {f.kind}; got shape "
                    f"{np.shape(parts[n])}"
                )
            out.append(a)
        return np.concatenate(out)

    def residual(self, x: Expr) -> Expr:
        """Concatenated constraint residuals of all factors."""
        parts = [f.residual(x[self.slices[n]]) for n, f in self.factors]
        if _is_casadi(x):
            return ca.vertcat(*parts)
        return np.concatenate([np.ravel(np.asarray(p, dtype=float)) for p in parts])

    def residual_norms(self, x: ArrayLike) -> dict[str, float]:
        """Max-norm constraint residual of each factor at a numeric point."""
        xv = np.asarray(x, dtype=float).ravel()
        return {n: f.residual_norm(xv[self.slices[n]]) for n, f in self.factors}

    def tangent_basis(self, x: ArrayLike) -> Matrix:
        """Block-diagonal tangent basis, shape ``(ambient_dim, dim)``."""
        xv = np.asarray(x, dtype=float).ravel()
        N = np.zeros((self.ambient_dim, self.dim))
        for n, f in self.factors:
            N[self.slices[n], self.tangent_slices[n]] = f.tangent_basis(xv[self.slices[n]])
        return N

    def retract(self, x: ArrayLike, v: ArrayLike) -> Vector:
        """Factor-wise retraction of tangent coordinates ``v`` (shape ``(dim,)``)."""
        xv = validate.array("x", x, finite=False, error=ManifoldError).ravel()
        vv = validate.array("v", v, error=ManifoldError).ravel()
        if vv.size != self.dim:
            raise ManifoldError(f"v must have {self.dim} tangent coordinates ({self.describe()});"
                                f" got shape {np.shape(v)}")
        return np.concatenate(
            [f.retract(xv[self.slices[n]], vv[self.tangent_slices[n]]) for n, f in self.factors]
        )

    def chart(self, x_e: ArrayLike, x: Expr) -> Expr:
        """Factor-wise chart around ``x_e`` (numeric centre, numeric or symbolic point)."""
        xe = np.asarray(x_e, dtype=float).ravel()
        parts = [f.chart(xe[self.slices[n]], x[self.slices[n]]) for n, f in self.factors]
        if _is_casadi(x):
            return ca.vertcat(*parts)
        return np.concatenate([np.ravel(p) for p in parts])

    def project(self, x: ArrayLike) -> Vector:
        """Factor-wise explicit projection."""
        xv = np.asarray(x, dtype=float).ravel()
        return np.concatenate([f.project(xv[self.slices[n]]) for n, f in self.factors])

    def random_point(self, rng: np.random.Generator, *, scale: float = 1.0) -> Vector:
        """A random point, factor by factor."""
        return np.concatenate([f.random_point(rng, scale=scale) for _, f in self.factors])

    def check(self, x: ArrayLike, *, name: str = "x", tol: float = DEFAULT_TOL) -> Vector:
        """Validate a numeric point factor by factor; return it flat and unchanged.

        Raises
        ------
        ManifoldError
            Naming the factor that is violated, its residual and the projection to use.
        """
        tol = validate.tolerance("tol", tol, error=ManifoldError)
        xv = validate.array(name, x, finite=False, error=ManifoldError).ravel()
        if xv.size != self.ambient_dim:
            raise ManifoldError(
                f"{name} must have {self.ambient_dim} entries ({self.describe()}); "
                f"got shape {np.shape(x)}"
            )
        for n, f in self.factors:
            f.check(xv[self.slices[n]], name=f"{name}[{n!r}]", tol=tol)
        return xv

    def describe(self) -> str:
        """E.g. ``"R: SO3 (9), omega: R^3 (3)"``."""
        return ", ".join(f"{n}: {f.kind} ({f.ambient_dim})" for n, f in self.factors)

    def __repr__(self) -> str:
        return f"ProductManifold([{self.describe()}], dim={self.dim})"
