"""C export of the swing-up TVLQR tracker: a time-varying law as a frozen table lookup.

:func:`tvlqr_table_law` writes the sampled-data TVLQR law of
:mod:`workbench.control._tvlqr` as a casadi table lookup ``(x, t) -> u`` (``casadi.low``
and MX indexing, the trajectory table frozen into the code, the handover to the
equilibrium LQR and the OCP's saturation); :class:`TimeVaryingExport` is the exportable
controller whose stored input is ``[x; t]``; :func:`swingup_tvlqr_export` builds the entry
``swingup_tvlqr_cart`` of the export catalogue (:mod:`workbench.app.catalogue`) from the
quick-mode solve of ``problems/swingup_spherical_cart.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench.app._sampling import _log_uniform, _split
from workbench.codegen.spec import Binding, Entry, ExportableController
from workbench.core._model import Context
from workbench.core.errors import ModelError
from workbench.core.types import ArrayLike

__all__ = ["tvlqr_table_law", "TimeVaryingExport", "swingup_tvlqr_export"]


def tvlqr_table_law(t_grid: ArrayLike, x_ref: ArrayLike, u_ref: ArrayLike, gains: ArrayLike,
                    charts: ArrayLike, *, u_lower: ArrayLike | None = None,
                    u_upper: ArrayLike | None = None, name: str = "tvlqr_table"
                    ) -> ca.Function:
    """The sampled-data TVLQR law of :mod:`workbench.control._tvlqr` as a lookup ``(x, t) -> u``.

    With ``t_grid = t_0 .. t_K`` (``K`` samples) and the tables extended by one row, the
    equilibrium (``x_ref[K] = x_eq``, ``u_ref[K] = u_eq``, ``gains[K] = K_eq``), the law is

        k = casadi.low(t_grid, t) + (t >= t_K)    (0 before t_0, K from t_K on)
        u = clip(u_ref[k] - gains[k] (C_k (x - x_ref[k])), u_lower, u_upper)

    i.e. sample ``k`` is held on ``[t_k, t_k+1)`` (``casadi.low`` in linear lookup: the
    last ``k`` with ``t_k <= t``), the first sample before ``t_0`` and the equilibrium LQR
    from ``t_K`` on. ``C_k`` is the matrix of the manifold's chart around ``x_ref[k]``,
    which is linear for the flat and sphere factors: ``chart(x_ref[k], x) = C_k (x -
    x_ref[k])``. The tables are constants of the function (indexed by the MX index ``k``).

    Parameters
    ----------
    t_grid : array-like, shape=(K+1,)
        Increasing sample times.
    x_ref : array-like, shape=(K+1, nx)
    u_ref : array-like, shape=(K+1, nu)
    gains : array-like, shape=(K+1, nu, dim)
    charts : array-like, shape=(K+1, dim, nx)
        Rows ``0 .. K``: the samples, then the equilibrium.
    u_lower, u_upper : array-like, optional
        Input saturation (none by default).
    name : str
        Function name.

    Returns
    -------
    casadi.Function
        ``(x, t) -> u`` (MX).
    """
    tg = np.asarray(t_grid, float).ravel()
    X, U = np.asarray(x_ref, float), np.asarray(u_ref, float)
    G, C = np.asarray(gains, float), np.asarray(charts, float)
    n_rows = tg.size
    if (tg.size < 2 or not np.all(np.diff(tg) > 0) or X.shape[0] != n_rows
            or U.shape[0] != n_rows or G.shape[0] != n_rows or C.shape[0] != n_rows
            or G.shape[1:] != (U.shape[1], C.shape[1]) or C.shape[2] != X.shape[1]):
        raise ModelError(f"inconsistent TVLQR table: t_grid {tg.shape}, x_ref {X.shape}, "
                         f"u_ref {U.shape}, gains {G.shape}, charts {C.shape} (K + 1 rows, "
                         f"the last one the equilibrium)")
    nx, nu, dim = X.shape[1], U.shape[1], C.shape[1]
    x, t = ca.MX.sym("x", nx), ca.MX.sym("t")
    k = ca.low(ca.DM(tg), t, {"lookup_mode": "linear"}) + (t >= float(tg[-1]))

    def row(table: np.ndarray, width: int) -> ca.MX:
        return ca.MX(ca.DM(table.reshape(-1))).get_nz(False, width * k + ca.DM(range(width)))

    xk, uk = row(X, nx), row(U, nu)
    # each sample's matrices stored column-major (casadi's order)
    Kk = ca.reshape(row(G.transpose(0, 2, 1), nu * dim), nu, dim)
    Ck = ca.reshape(row(C.transpose(0, 2, 1), dim * nx), dim, nx)
    u = uk - Kk @ (Ck @ (x - xk))
    if u_lower is not None:
        u = ca.fmax(u, ca.DM(np.broadcast_to(np.asarray(u_lower, float), (nu,)).copy()))
    if u_upper is not None:
        u = ca.fmin(u, ca.DM(np.broadcast_to(np.asarray(u_upper, float), (nu,)).copy()))
    return ca.Function(name, [x, t], [u], ["x", "t"], ["u"])


@dataclass
class TimeVaryingExport(ExportableController):
    """An exportable ``(x, t) -> u``: the stored input is ``[x; t]`` (``nx`` = ambient + 1).

    Only :attr:`~workbench.codegen.spec.Binding.FROZEN` is offered: the table is computed
    from the model's parameter values, so they cannot be run-time inputs. ``reference``
    is the Python controller of :mod:`workbench.control._tvlqr` at ``(x, t)`` (for the tests).
    """

    reference: Callable[[np.ndarray, float], np.ndarray] | None = None

    @property
    def nx(self) -> int:
        """Size of the stored input ``[x; t]``."""
        return int(self.model.manifold.ambient_dim) + 1

    def function_for(self, binding: Binding) -> ca.Function:
        """``[x; t] -> u`` (MX: the table lookup has no SX form), FROZEN only."""
        binding = Binding(binding)
        if binding is not Binding.FROZEN:
            raise ModelError(f"{self.name} is exported with binding frozen only (its "
                             f"trajectory table is computed from the model's parameter "
                             f"values); got {binding.value}")
        if binding not in self._cache:
            z = ca.MX.sym("x", self.nx)
            n = self.nx - 1
            self._cache[binding] = ca.Function(self.name, [z], [self.function(z[:n], z[n])],
                                               ["x"], ["u"])
        return self._cache[binding]


def _frozen_only(ctx: Context, gains: dict[str, Any]) -> Any:
    raise ModelError("swingup_tvlqr_cart has no run-time gains (binding frozen only)")


def swingup_tvlqr_export(options: dict[str, Any]) -> ExportableController:
    """The TVLQR tracker of problems/swingup_spherical_cart.py (quick-mode reference)."""
    from problems import swingup_spherical_cart as sw
    from workbench.control._tvlqr import tvlqr_along
    from workbench.control.ocp import Collocation, multistart

    ocp = sw.problem()
    ladder = [Collocation(N=n, degree=3) for n in (10, 20, 40)]
    # the problem's quick-mode path: 4 seeded coarse starts refined 20 -> 40
    best, _ = multistart(ocp, ladder[0], seeds=range(4), T_guesses=sw.T_GUESSES,
                         refine_with=ladder[1:], max_iter=150)
    ctrl = tvlqr_along(best, x_eq=ocp.target.point, substeps=1, Q=sw.Q_LQR, R=sw.R_LQR)
    model, man = ctrl.model, ctrl.model.manifold
    lo, hi = np.asarray(ocp.u_lower, float), np.asarray(ocp.u_upper, float)
    X = np.vstack([ctrl.x_ref[:-1], ctrl.x_eq])
    U = np.vstack([ctrl.u_ref, ctrl.u_eq])
    G = np.concatenate([ctrl.gains, ctrl.gain_eq[None]])
    z = ca.SX.sym("x", man.ambient_dim)
    charts = []
    for xk in X:  # chart(x_k, x) = C_k (x - x_k) on (R^2)^2 x TS^2; checked
        e = man.chart(xk, z)
        Ck = ca.jacobian(e, z)
        if ca.depends_on(Ck, z):
            raise ModelError("the chart of the swing-up model is not linear in x")
        Ck = np.asarray(ca.evalf(Ck), float)
        if np.max(np.abs(np.asarray(man.chart(xk, xk), float))) > 1e-12:
            raise ModelError("the chart does not vanish at its centre")
        charts.append(Ck)
    fn = tvlqr_table_law(ctrl.t, X, U, G, np.array(charts), u_lower=lo, u_upper=hi,
                         name="swingup_tvlqr_cart_law")

    def reference(x: np.ndarray, t: float) -> np.ndarray:
        k = int(np.clip(np.searchsorted(ctrl.t, t, side="right") - 1, 0, len(ctrl.u_ref)))
        return np.clip(ctrl.control(k, x), lo, hi)

    T, dt, K = ctrl.T, ctrl.dt, len(ctrl.u_ref)

    def sampler(rng: np.random.Generator, n: int) -> np.ndarray:
        c = _split(n, (0.3, 0.2, 0.2, 0.1, 0.1, 0.1))
        idx = rng.integers(0, K + 1, n)
        t = np.concatenate([
            rng.uniform(0.0, T, c[0]),
            ctrl.t[idx[:c[1]]],                                        # on the grid
            np.nextafter(ctrl.t[idx[c[1]:c[1] + c[2]]],
                         rng.choice([-np.inf, np.inf], c[2])),         # one ulp around it
            ctrl.t[idx[:c[3]]] + rng.choice([-1, 1], c[3])
            * _log_uniform(rng, 1e-14, 1e-6, c[3]),                    # near it
            -_log_uniform(rng, 1e-12, 1.0, c[4]),                      # before t_0
            T + _log_uniform(rng, 1e-12, 3.0, c[5])])                  # after the horizon
        # states around the reference at a random sample (or the equilibrium), some far
        centre = np.vstack([ctrl.x_ref, ctrl.x_eq])[rng.integers(0, K + 2, n)]
        scale = _log_uniform(rng, 1e-10, 1.0, n)
        x = np.array([man.retract(xc, s * rng.standard_normal(man.dim))
                      for xc, s in zip(centre, scale)])
        return np.hstack([x, t[:, None]])

    return TimeVaryingExport(
        name="swingup_tvlqr_cart",
        title="time-varying LQR tracker of the optimal swing-up of the spherical pendulum "
              "on a cart (problems/swingup_spherical_cart.py, paper 003 n = 1), with the "
              "handover to the LQR of the inverted equilibrium",
        model=model,
        function=fn,
        gains={},
        gain_entries=(),
        law=_frozen_only,
        state_entries=(Entry("x", 2, "cart position [m]"),
                       Entry("v", 2, "cart velocity [m/s]"),
                       Entry("link1", 6, "link direction q1 (unit, e3 down) [-], then its "
                                         "angular velocity omega1 [rad/s]"),
                       Entry("t", 1, f"time since the start of the swing-up [s]; sample k "
                                     f"held on [k dt, (k+1) dt), dt = {dt:.6g} s, {K} "
                                     f"samples, the first before 0, the equilibrium LQR "
                                     f"from T = {T:.6g} s on")),
        output=Entry("u", 2, f"horizontal force on the cart [N], saturated to "
                             f"[{lo.min():g}, {hi.max():g}]: u = clip(u_ref(t) - K(t) "
                             f"chart(x_ref(t), x))"),
        example_state=np.concatenate([ocp.x0, [0.0]]),
        example_note="the start of the swing-up: hanging at rest, cart at the origin, t = 0",
        singular="no singularity; the input saturates at the bounds of the OCP; the table "
                 "(t grid, x_ref, u_ref, K and the chart matrices C_k) is frozen into the "
                 "code; sample k is held on [t_k, t_k+1) (first sample before t_0), the "
                 "equilibrium LQR from T on",
        sampler=sampler,
        reference=reference,
    )
