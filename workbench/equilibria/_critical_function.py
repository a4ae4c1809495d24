"""A smooth function on a product of S^1, S^2, SO(3) and R^k, with its critical-point maps.

:class:`ConfigurationFunction` holds ``V(c, p)`` as a casadi graph on a configuration
manifold (no velocities) and derives, by automatic differentiation:

* the generalised force ``K(c)^T dV/dc`` factor by factor (R^k: ``g``; S^1: ``J p . g``;
  S^2: ``q x g``; SO(3): ``vee(R^T G - G^T R)``), which vanishes exactly at the critical
  points and is the residual Newton drives to zero;
* the Riemannian Hessian in the tangent coordinates of
  :meth:`ProductManifold.tangent_basis`, the Hessian of ``v -> V(retract(c, v))`` at
  ``v = 0``: ``N^T (d^2V/dc^2) N`` plus the curvature of each factor's retraction,
  ``-(p . g)`` on S^1, ``-(q . g) I_2`` on S^2 and ``sym(G^T R) - tr(G^T R) I_3`` on SO(3)
  (from ``d^2/ds^2 exp(s hat(xi)) q = -|xi|^2 q`` for ``xi`` normal to ``q`` and
  ``hat(v)^2 = v v^T - |v|^2 I``).

:func:`potential_function` takes the potential of a model made by :mod:`workbench.mechanics`
from the hooks of the derivation it carries (``model.mechanics.configuration_manifold()``,
``potential_function()``, ``rest_state()``); :meth:`ConfigurationFunction.from_state`
takes any function of a model's state (an amended potential ``V + mu^2 / (2 I)`` on the
shape space of a Routh model), with its velocities set to zero.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._evaluator import DenseEvaluator
from workbench.core._model import Model
from workbench.core.errors import ModelError
from workbench.core.manifolds import S1, S2, SO3, TS2, ProductManifold, Rn, vee
from workbench.core.types import ArrayLike, Matrix, Vector

__all__ = ["ConfigurationFunction", "potential_function", "generalised_force", "home_point"]


def generalised_force(manifold: ProductManifold, c: ca.SX, g: ca.SX) -> ca.SX:
    """``K(c)^T g`` factor by factor: zero exactly where ``g`` annihilates the tangent space.

    Parameters
    ----------
    manifold : ProductManifold
        Configuration factors.
    c, g : casadi.SX, shape=(ambient_dim, 1)
        The point and an ambient covector.

    Returns
    -------
    casadi.SX
        One block per factor (R^k: k rows, S^1: 1, S^2: 3, SO(3): 3).
    """
    out = []
    for name, f in manifold.factors:
        sl = manifold.slices[name]
        x, gf = c[sl], g[sl]
        if isinstance(f, Rn):
            out.append(gf)
        elif isinstance(f, S1):
            out.append(x[0] * gf[1] - x[1] * gf[0])
        elif isinstance(f, S2):
            out.append(ca.cross(x, gf))
        else:
            R, G = ca.reshape(x, 3, 3), ca.reshape(gf, 3, 3)
            out.append(vee(R.T @ G - G.T @ R))
    return ca.vertcat(*out)


def home_point(manifold: ProductManifold) -> Vector:
    """The reference configuration: ``(1, 0)`` on S^1, ``e3`` on S^2, ``I`` on SO(3), 0."""
    parts = {}
    for name, f in manifold.factors:
        parts[name] = (np.array([1.0, 0.0]) if isinstance(f, S1) else
                       np.array([0.0, 0.0, 1.0]) if isinstance(f, S2) else
                       np.eye(3).reshape(9) if isinstance(f, SO3) else np.zeros(f.dim))
    return manifold.join(parts)


def _text(name: str, value: Any) -> str:
    if not isinstance(value, str):
        raise ModelError(f"{name} must be a str; got {type(value).__name__} {value!r:.80}")
    return value


def _check_manifold(manifold: Any) -> ProductManifold:
    if not isinstance(manifold, ProductManifold):
        raise ModelError(f"manifold must be a ProductManifold of S1, S2, SO3 and Rn factors; "
                         f"got {type(manifold).__name__}")
    bad = [n for n, f in manifold.factors if not isinstance(f, (S1, S2, SO3, Rn))]
    if bad:
        raise ModelError(f"manifold must have only configuration factors (S1, S2, SO3, Rn); "
                         f"factors {bad} of {manifold.describe()} are not")
    return manifold


class ConfigurationFunction:
    """A smooth scalar function ``V(c, p)`` on a product of S^1, S^2, SO(3) and R^k.

    Parameters
    ----------
    manifold : ProductManifold
        The configuration space: S1, S2, SO3 and Rn factors only.
    function : casadi.Function
        ``(c, p) -> V`` (or ``c -> V``), ``c`` of shape ``(ambient_dim, 1)``, ``V`` scalar.
    p : array-like, optional
        Parameter values (the second input), empty by default.
    name : str
        For messages.
    state : callable, optional
        ``state(c) -> x``: the model state at rest a configuration stands for (the
        configuration itself by default).

    Raises
    ------
    ModelError
        Naming the argument that does not fit.
    """

    def __init__(self, manifold: ProductManifold, function: ca.Function, *,
                 p: ArrayLike = (), name: str = "V",
                 state: Callable[[Vector], Vector] | None = None) -> None:
        self.manifold = _check_manifold(manifold)
        if not isinstance(function, ca.Function) or function.n_in() not in (1, 2) or \
                function.n_out() != 1:
            raise ModelError(f"function must be a casadi.Function (c, p) -> V with one "
                             f"output; got {function!r}")
        self.p = validate.array("p", p, error=ModelError).ravel()
        n_c = manifold.ambient_dim
        if function.numel_in(0) != n_c:
            raise ModelError(f"function's first input must have {n_c} entries "
                             f"({manifold.describe()}); got {function.numel_in(0)}")
        if function.n_in() == 2 and function.numel_in(1) != self.p.size:
            raise ModelError(f"p must have {function.numel_in(1)} entries (the function's "
                             f"second input); got {self.p.size}")
        if function.n_in() == 1 and self.p.size:
            raise ModelError(f"p must be empty for a function of c alone; got {self.p.size} "
                             "entries")
        if function.numel_out(0) != 1:
            raise ModelError(f"function must return a scalar; got shape "
                             f"{function.size_out(0)}")
        self.name = _text("name", name)
        self.function = function
        self._state = state
        c = ca.SX.sym("c", n_c)
        pp = ca.SX.sym("p", self.p.size)
        V = function(c, pp) if function.n_in() == 2 else function(c)
        self.c_sym, self.p_sym, self.V_sym = c, pp, V
        g = ca.gradient(V, c)
        self.g_sym = g
        F = generalised_force(manifold, c, g)
        self.F_sym = F
        self._eval = DenseEvaluator(ca.Function(
            "critical_derivatives", [c, pp],
            [ca.densify(e) for e in (V, g, ca.hessian(V, c)[0], F, ca.jacobian(F, c))]))

    @classmethod
    def from_state(cls, model: Model, function: ca.Function, *,
                   configuration: Sequence[str] | None = None, p: ArrayLike | None = None,
                   name: str | None = None) -> ConfigurationFunction:
        """A function of a model's state ``(x, p) -> V``, read on its configuration at rest.

        Parameters
        ----------
        model : Model
            Whose state the function takes.
        function : casadi.Function
            ``(x, p) -> V`` (e.g. a Routh model's amended potential).
        configuration : sequence of str, optional
            The model's factors that are configuration (S1, S2, SO3, Rn; a TS2 factor
            contributes its direction ``q``). Default: for a reduced model (it carries its
            :class:`workbench.mechanics.Reduction` as ``model.reduction``) the reduction's
            ``configuration`` (the shape coordinates, R^k ones included); otherwise every
            S1, S2, SO3 and TS2 factor, R^k factors being velocities unless named here.
        p : array-like, optional
            The function's parameter values (default ``model.p``).
        name : str, optional

        Returns
        -------
        ConfigurationFunction
            Its ``state(c)`` is the model state with ``c`` and zero velocities.
        """
        if not isinstance(model, Model):
            raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
        man = model.manifold
        if not isinstance(function, ca.Function) or function.n_in() != 2 or \
                function.numel_in(0) != man.ambient_dim:
            raise ModelError(f"function must be a casadi.Function (x, p) -> V with x of "
                             f"{man.ambient_dim} entries (the state of {model.name!r}); got "
                             f"{function!r:.120}")
        if name is not None:
            _text("name", name)
        if configuration is not None and (isinstance(configuration, (str, bytes)) or not
                                          isinstance(configuration, Sequence) or not all(
                                              isinstance(n, str) for n in configuration)):
            raise ModelError(f"configuration must be a sequence of factor names (str) of "
                             f"{model.name!r} ({man.names}) or None; got {configuration!r:.120}")
        reduction = getattr(model, "reduction", None)
        if configuration is None and reduction is not None:
            configuration = list(reduction.configuration)
        if configuration is None:
            configuration = [n for n, f in man.factors if isinstance(f, (S1, S2, SO3, TS2))]
        unknown = [n for n in configuration if n not in man.names]
        if unknown:
            raise ModelError(f"configuration names {unknown} are not factors of model "
                             f"{model.name!r} ({man.names})")
        factors = []
        for n in configuration:
            f = man.factor(n)
            if isinstance(f, TS2):
                f = S2()
            elif not isinstance(f, (S1, S2, SO3, Rn)):
                raise ModelError(f"factor {n!r} ({f.kind}) cannot be configuration")
            factors.append((n, f))
        cman = ProductManifold(factors)
        c = ca.SX.sym("c", cman.ambient_dim)
        parts = []
        for n, f in man.factors:
            k = man.slices[n].stop - man.slices[n].start
            if n in cman.slices:
                part = c[cman.slices[n]]
                parts.append(ca.vertcat(part, ca.SX.zeros(3, 1)) if isinstance(f, TS2)
                             else part)
            else:
                parts.append(ca.SX.zeros(k, 1))
        xs = ca.vertcat(*parts)
        to_state = ca.Function("state_at_rest", [c], [xs])
        pv = model.p if p is None else validate.array("p", p, error=ModelError).ravel()
        pp = ca.SX.sym("p", function.numel_in(1))
        fn = ca.Function("V_config", [c, pp], [function(xs, pp)])
        ev = DenseEvaluator(to_state)
        return cls(cman, fn, p=pv, name=name or function.name(),
                   state=lambda cv: ev(np.asarray(cv, dtype=float))[0])

    # evaluations --------------------------------------------------------------------------
    def derivatives(self, c: ArrayLike) -> tuple[float, Vector, Matrix, Vector, Matrix]:
        """``V``, ``dV/dc``, ``d^2V/dc^2``, the generalised force and its Jacobian at ``c``."""
        V, g, H, F, J = self._eval(np.asarray(c, dtype=float).ravel(), self.p)
        n = g.size  # (column outputs come back 1-D: a 1 x 1 Hessian too)
        return float(V[0]), g, H.reshape(n, n), F, J.reshape(F.size, n)

    def value(self, c: ArrayLike) -> float:
        """``V(c)``."""
        return self.derivatives(c)[0]

    def gradient(self, c: ArrayLike) -> Vector:
        """The ambient gradient ``dV/dc``."""
        return self.derivatives(c)[1]

    def state(self, c: ArrayLike) -> Vector:
        """The state a configuration stands for (the configuration itself by default)."""
        cv = np.asarray(c, dtype=float).ravel()
        return cv.copy() if self._state is None else np.asarray(self._state(cv)).ravel()

    def riemannian_hessian(self, c: ArrayLike) -> Matrix:
        """The Hessian of ``v -> V(retract(c, v))`` at 0, shape ``(dim, dim)`` (symmetric).

        Equal to the Riemannian Hessian at a critical point (module docstring).
        """
        cv = np.asarray(c, dtype=float).ravel()
        _, g, Hc, _, _ = self.derivatives(cv)
        man = self.manifold
        N = man.tangent_basis(cv)
        H = N.T @ Hc @ N
        for name, f in man.factors:
            sl, ts = man.slices[name], man.tangent_slices[name]
            x, gf = cv[sl], g[sl]
            if isinstance(f, S1):
                H[ts, ts] -= float(x @ gf)
            elif isinstance(f, S2):
                H[ts, ts] -= float(x @ gf) * np.eye(2)
            elif isinstance(f, SO3):
                R, G = x.reshape(3, 3, order="F"), gf.reshape(3, 3, order="F")
                A = G.T @ R
                H[ts, ts] += 0.5 * (A + A.T) - np.trace(A) * np.eye(3)
        return 0.5 * (H + H.T)

    def __repr__(self) -> str:
        return f"ConfigurationFunction({self.name!r} on {self.manifold.describe()})"


def potential_function(model: Model) -> ConfigurationFunction:
    """The potential energy of a model made by :mod:`workbench.mechanics`, on its configuration.

    Uses the hooks of the derivation the model carries (``model.mechanics``:
    ``configuration_manifold()``, ``potential_function()`` and ``rest_state()``), with the
    model's current parameter values.

    Parameters
    ----------
    model : Model
        Made by ``mechanics.System(...).model()``.

    Returns
    -------
    ConfigurationFunction
        On the configuration factors in storage order (S^2 factors as S2, their angular
        velocities dropped); ``state(c)`` is the model state at rest.

    Raises
    ------
    ModelError
        If the model was not made by the mechanics layer, or its potential depends on the
        velocities.
    """
    if not isinstance(model, Model):
        raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
    der = getattr(model, "mechanics", None)
    if der is None or not hasattr(der, "potential_function"):
        raise ModelError(
            f"model {model.name!r} was not made by workbench.mechanics (it carries no "
            "derivation with a potential); pass a ConfigurationFunction, or use "
            "ConfigurationFunction.from_state(model, V) with V a casadi.Function (x, p) -> V")
    rest = DenseEvaluator(der.rest_state())
    return ConfigurationFunction(der.configuration_manifold(), der.potential_function(),
                                 p=model.p, name=f"potential of {model.name}",
                                 state=lambda c: rest(np.asarray(c, dtype=float))[0])
