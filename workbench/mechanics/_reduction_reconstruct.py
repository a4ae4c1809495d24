"""Reconstruction of a full trajectory from a reduced one, with its phase.

Paper 000 Prop. 17 for the 3D pendulum, for any reduction of :mod:`._reduction`: along a
reduced trajectory ``r(t)`` a *horizontal* configuration ``c_hor(t)`` (one with zero
momentum) is integrated with the shape velocities of ``r``,

    c_hor-dot = K(c_hor) nu_hor,   nu_hor = nu - (J / I) eta(c_hor),

where ``nu`` is the full velocity over ``r`` at ``c_hor`` (Routh: with momentum ``mu``),
``J = J(c_hor, nu)`` its momentum and ``I`` the locked inertia, together with the
*dynamic phase*

    theta-dot = J / I   (Routh: mu / I(shape), paper 000 (5.12)),

and the full state is the group element ``theta`` applied to ``(c_hor, nu)``: ``R = exp(
theta hat(e3)) R_hor``, ``omega = omega_hor + (mu / I) Gamma`` for the 3D pendulum (5.13)-
(5.14). The reconstruction is an ordinary model (the reduced state, the horizontal
configuration and the phase), simulated like any other; :meth:`reconstruct` maps its
trajectory to full states.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.core.manifolds import S2
from workbench.mechanics._engine import Context, Model, ModelError, ProductManifold, Rn
from workbench.mechanics._reduction_geometry import (
    Kind,
    join_state,
    split_reduced,
    split_state,
    split_velocity,
)

__all__ = ["Reconstructed", "ReconstructionMixin", "PHASE"]

PHASE = "phase"
"""Name of the reconstruction model's phase factor."""

_MAPS_KEPT = 8
"""Reconstruction maps kept per reduction (one per trajectory length; the oldest goes)."""


@dataclass
class Reconstructed:
    """A full trajectory reconstructed from a reduced one.

    Attributes
    ----------
    t : ndarray, shape=(n_times,)
        Times.
    x : ndarray, shape=(n_times, n_full)
        Full states (the full model's storage).
    phase : ndarray, shape=(n_times,)
        The dynamic phase ``theta`` (the group variable integrated from ``J / I``).
    horizontal : ndarray, shape=(n_times, n_config)
        The horizontal configuration ``c_hor`` (zero momentum, same shape).
    """

    t: np.ndarray
    x: np.ndarray
    phase: np.ndarray
    horizontal: np.ndarray


def _config_manifold(f: Any) -> Any:
    st = f.storage()
    return st[0][1] if len(st) == 2 else S2()  # one TS2 factor stores (q, omega)


class ReconstructionMixin:
    """The reconstruction part of :class:`workbench.mechanics.Reduction`."""

    _recon: Model | None = None
    _recon_fn: ca.Function | None = None
    _recon_point: ca.Function | None = None
    _recon_maps: dict[int, ca.Function] | None = None

    def _horizontal(self) -> ca.Function:
        """``(r, c_hor, p, mu) -> (x, c_hor-dot, theta-dot)``, SX."""
        if self._recon_fn is not None:
            return self._recon_fn
        S, der, q = ca.SX, self._der, self.quotient
        nc = int(der.c.shape[0])
        r, ch, p = S.sym("r", self.n_r), S.sym("c", nc), S.sym("p", self.n_p)
        mu, xi = S.sym("mu"), S.sym("xi")
        parts = split_reduced(self.storage, r)
        cs, k = [], 0
        for f in self.factors:
            n = f.config_sym.shape[0]
            cs.append(ch[k : k + n])
            k += n
        if self.kind is Kind.ROUTH:
            x_xi = join_state(cs, q.velocity(cs, parts, self.kind, xi))
            J = self._J_affine(x_xi, p)
            slope = ca.jacobian(J, xi)
            x = ca.substitute(x_xi, xi, (mu - ca.substitute(J, xi, 0)) / slope)
            Jv = mu
        else:
            x = join_state(cs, q.velocity(cs, parts, self.kind, None))
            Jv = self._J(x, p)
        inertia = self.locked_inertia_full(x, p)
        nu_h = split_state(self.factors, x)[1]
        nu_h = ca.vertcat(*nu_h) - (Jv / inertia) * self.eta(x, p)
        kin = ca.Function("kinematics", [der.x], [der.cdot])
        cdot = kin(join_state(cs, split_velocity(self.factors, nu_h)))
        self._recon_fn = ca.Function("horizontal", [r, ch, p, mu], [x, cdot, Jv / inertia],
                                     ["r", "c", "p", "mu"], ["x", "c_dot", "theta_dot"])
        return self._recon_fn

    @property
    def reconstruction(self) -> Model:
        """The reduced model with the horizontal configuration and the dynamic phase.

        State: the reduced state, then ``<factor>_hor`` (each factor's configuration), then
        ``phase`` (R^1); the reduced model's inputs and parameters. Its trajectory maps to
        full states by :meth:`reconstruct`; its initial state is
        :meth:`reconstruction_state`.
        """
        if self._recon is not None:
            return self._recon
        red, hor = self.model, self._horizontal()
        names = {n for n, _ in self.storage}
        storage = list(self.storage)
        for f in self.factors:
            nm = f"{f.name}_hor"
            if nm in names:
                raise ModelError(f"reconstruction factor name {nm!r} is already used")
            storage.append((nm, _config_manifold(f)))
        storage.append((PHASE, Rn(1)))
        n_r, n_c, n_p = self.n_r, int(self._der.c.shape[0]), self.n_p
        routh = self.kind is Kind.ROUTH

        def field(ctx: Context) -> Any:
            r, c = ctx.x[:n_r], ctx.x[n_r : n_r + n_c]
            mu = ctx.p[n_p] if routh else 0.0
            _, cdot, tdot = hor(r, c, ctx.p[:n_p], mu)
            rdot = red.function("f")(r, ctx.u, ctx.p)
            return ca.vertcat(rdot, cdot, tdot)

        def invariant(name: str) -> Any:
            return lambda ctx: red.function(name)(ctx.x[:n_r], ctx.p)

        self._recon = Model(
            name=f"{red.name}_reconstruction", manifold=ProductManifold(storage),
            n_inputs=red.n_inputs, parameters=red.parameters, values=red.values,
            vector_field=field,
            invariants={n: invariant(n) for n in red.invariant_names},
            symbolic=red.symbolic,
            description=f"{red.description}, with the horizontal configuration and the "
                        "dynamic phase (reconstruction)",
            equations=(r"\dot c_{hor} = K(c_{hor})\,\nu_{hor},\; \dot\theta = J/I"
                       r"\quad\text{(paper 000 (5.10)-(5.14), any abelian symmetry)}",),
            input_description=red.input_description, spd_solves=red.spd_solves)
        return self._recon

    def reconstruction_state(self, x_full: Any, *, tol: float = 1e-9) -> np.ndarray:
        """The reconstruction model's state over a full state: ``(pi(x), c(x), 0)``.

        Parameters
        ----------
        x_full : array-like, shape=(n_full,)
            A full state (Routh: with the model's momentum value, to ``tol``).
        tol : float
            As in :meth:`state_from_full`.

        Returns
        -------
        ndarray
        """
        r = self.state_from_full(x_full, tol=tol)
        x = np.asarray(x_full, dtype=float).ravel()
        cs = []
        k = 0
        for f in self.factors:
            nc, nv = f.config_sym.shape[0], f.velocity_sym.shape[0]
            cs.append(x[k : k + nc])
            k += nc + nv
        return np.concatenate([r, *cs, [0.0]])

    def reconstruct(self, trajectory: Any) -> Reconstructed:
        """Full states from a trajectory of :attr:`reconstruction`.

        Parameters
        ----------
        trajectory : Trajectory or array-like, shape=(n_times, n_reconstruction)
            A simulated trajectory of the reconstruction model (its ``t``, ``x`` and its
            model's parameter values, e.g. another momentum from ``with_parameters``, are
            used), or its states alone (then ``t`` is their index and the parameter values
            are :attr:`reconstruction`'s).

        Returns
        -------
        Reconstructed
        """
        model = self.reconstruction
        X = np.asarray(getattr(trajectory, "x", trajectory), dtype=float)
        n = model.manifold.ambient_dim
        if X.ndim != 2 or X.shape[1] != n or not np.all(np.isfinite(X)):
            raise ModelError(f"trajectory must be states of {model.name!r}: an array of shape "
                             f"(n_times, {n}) of finite numbers; got shape {X.shape}")
        t = np.asarray(getattr(trajectory, "t", np.arange(X.shape[0])), dtype=float)
        n_r, n_c, n_p = self.n_r, int(self._der.c.shape[0]), self.n_p
        # the parameter values it was simulated with (a model from with_parameters)
        used = getattr(trajectory, "model", None)
        pv = used.p if isinstance(used, Model) and used.manifold.names == \
            model.manifold.names and used.n_params == model.n_params else model.p
        mu = float(pv[n_p]) if self.kind is Kind.ROUTH else 0.0
        Xf = np.asarray(self._reconstruct_map(X.shape[0])(X.T, pv[:n_p], mu), dtype=float).T
        return Reconstructed(t, Xf, X[:, -1].copy(), X[:, n_r : n_r + n_c].copy())

    def _reconstruct_map(self, n_times: int) -> ca.Function:
        """``(states, p, mu) -> full states``, mapped over ``n_times`` columns (cached)."""
        if self._recon_maps is None:
            self._recon_maps = {}
        if n_times not in self._recon_maps:
            if self._recon_point is None:
                n_r, n_c = self.n_r, int(self._der.c.shape[0])
                xs = ca.SX.sym("s", self.reconstruction.manifold.ambient_dim)
                p, mu = ca.SX.sym("p", self.n_p), ca.SX.sym("mu")
                x_hor, _, _ = self._horizontal()(xs[:n_r], xs[n_r : n_r + n_c], p, mu)
                self._recon_point = ca.Function("reconstruct", [xs, p, mu],
                                                [self.act(x_hor, xs[-1])])
            if len(self._recon_maps) >= _MAPS_KEPT:
                self._recon_maps.pop(next(iter(self._recon_maps)))
            self._recon_maps[n_times] = self._recon_point.map(n_times, "serial")
        return self._recon_maps[n_times]
