"""The papers' controllers exportable to C: registry, default gains, test states.

:func:`build` turns an export name into a
:class:`~workbench.codegen.spec.ExportableController` for :mod:`workbench.codegen` (which
knows no concrete model): the workbench's controller from :mod:`models.controllers` (or
the chain's geometric LQR feedback), the model with the paper's parameters, the default
gains and the example state of the paper, and a sampler that crowds the law's singular or
saturated region. For run-time gains (:attr:`~workbench.codegen.spec.Binding.
PARAMETERS_AND_GAINS`) each entry's ``law`` is the same law of :mod:`models.controllers`
(``*_law``) called with the gains as casadi symbols, so every law has one definition.
:func:`names` and :func:`describe` list the entries (``workbench export-c --list``).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from models import controllers, pendulum3d, spherical
from models.chain_cart import chain_cart, link_state
from workbench.codegen.spec import Binding, Entry, ExportableController, Law
from workbench.core._model import Context
from workbench.core.errors import ModelError
from workbench.core.manifolds import S2, SO3, so3_exp
from workbench.core.types import ArrayLike
from workbench.linear._linearize import linearize, mechanical_order
from workbench.linear._lqr import lqr

__all__ = ["MAX_LINKS", "build", "describe", "names"]

E3 = np.array([0.0, 0.0, 1.0])

# ----------------------------------------------------------------------------------------
# sampling helpers


def _log_uniform(rng: np.random.Generator, lo: float, hi: float, n: int) -> np.ndarray:
    return np.exp(rng.uniform(np.log(lo), np.log(hi), n))


def _unit(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _near(q: np.ndarray, angles: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Unit vectors at the given angles from the unit vector ``q`` (random directions)."""
    a = np.asarray(angles, dtype=float)
    u = _tangent(np.tile(q, (a.size, 1)), np.ones(a.size), rng)
    out = np.cos(a)[:, None] * q + np.sin(a)[:, None] * np.cross(u, q)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _tangent(q: np.ndarray, scale: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Random vectors normal to each row of ``q`` with the given norms."""
    w = rng.standard_normal(q.shape)
    w -= np.sum(w * q, axis=1, keepdims=True) * q
    return w / np.linalg.norm(w, axis=1, keepdims=True) * scale[:, None]


def _split(n: int, weights: tuple[float, ...]) -> list[int]:
    counts = [int(n * w) for w in weights]
    counts[0] += n - sum(counts)
    return counts


def _rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.array([SO3.matrix(SO3().random_point(rng)) for _ in range(n)])


def _flat_rotations(R: np.ndarray) -> np.ndarray:
    return np.array([SO3.flat(r) for r in R])


# ----------------------------------------------------------------------------------------
# paper 001 (34): saturated angular-velocity feedback


def _saturated_export(options: dict[str, Any]) -> ExportableController:
    """Paper 001 Section 7: the full 3D pendulum and the saturated feedback (34)."""
    J = np.array([[30.0, 20.0, 7.0], [20.0, 40.0, 0.0], [7.0, 0.0, 50.0]])
    model = pendulum3d.full(J=J, rho=[0.0, 0.0, 0.2], m=100.0, g=10.0)
    P, k = np.diag([5.0, 10.0, 15.0]), 10.0
    R0 = np.array([[0.0, -0.9999, -0.0141], [-1.0, 0.0, 0.0], [0.0, 0.0141, -0.9999]])
    x0 = model.state(R=SO3.matrix(SO3().project(R0)), omega=np.zeros(3))
    Pinv = np.linalg.inv(P)

    def sampler(rng: np.random.Generator, n: int) -> np.ndarray:
        c = _split(n, (0.3, 0.3, 0.2, 0.1, 0.1))
        R = _rotations(rng, n)
        w = [_unit(rng, c[0]) * _log_uniform(rng, 1e-3, 1e1, c[0])[:, None],
             # saturated: |P w| from 1e2 to 1e9
             (Pinv @ (_unit(rng, c[1]) * _log_uniform(rng, 1e2, 1e9, c[1])[:, None]).T).T,
             # near the origin, where |P w| -> 0 switches branch in the C^1 norm
             _unit(rng, c[2]) * _log_uniform(rng, 1e-300, 1e-6, c[2])[:, None],
             np.eye(3)[rng.integers(0, 3, c[3])] * rng.normal(0, 1e4, (c[3], 1)),
             np.zeros((c[4], 3))]
        return np.hstack([_flat_rotations(R), np.vstack(w)])

    return ExportableController(
        name="saturated_velocity_feedback",
        title="saturated angular-velocity feedback u = -k P omega / (1 + |P omega|), "
              "paper 001 (34)",
        model=model,
        function=controllers.saturated_velocity_feedback(model, P=P, k=k),
        gains={"P": P, "k": np.array(k)},
        gain_entries=(Entry("P", 9, "P, symmetric positive definite, row-major [-]"),
                      Entry("k", 1, "saturation level |u| <= k [N m]")),
        law=lambda ctx, g: controllers.saturated_velocity_law(ctx, **g),
        state_entries=(
            Entry("R", 9, "attitude R (body to inertial), column-major [-]"),
            Entry("omega", 3, "angular velocity, body frame [rad/s]")),
        output=Entry("u", 3, "control moment, body frame [N m]; |u| <= k"),
        example_state=x0,
        example_note="paper 001 Section 7: R(0) (printed matrix, projected onto SO(3)), "
                     "omega(0) = 0",
        singular="no singularity; |u| saturates at k as |P omega| grows; at omega = 0 "
                 "the norm takes its branch |P omega| = 0",
        sampler=sampler,
    )


# ----------------------------------------------------------------------------------------
# paper 002: geometric PD on S^2 and SO(3)


def _s2_pd_export(options: dict[str, Any]) -> ExportableController:
    """Paper 002 Section II: the spherical pendulum and the geometric PD on S^2."""
    model = spherical.spherical_pendulum(m=1.0, l=1.0, g=9.81)
    qd, kq, kw = E3.copy(), 1.0, 1.0
    a = np.deg2rad(150.0)
    q0 = np.array([np.sin(a), 0.0, np.cos(a)])

    def sampler(rng: np.random.Generator, n: int) -> np.ndarray:
        c = _split(n, (0.3, 0.35, 0.2, 0.15))
        q = np.vstack([_unit(rng, c[0]),
                       # the antipode -q_d (the saddle of the closed loop)
                       _near(-qd, _log_uniform(rng, 1e-14, 1e-2, c[1]), rng),
                       _near(qd, _log_uniform(rng, 1e-14, 1e-2, c[2]), rng),
                       np.tile(-qd, (c[3], 1))])
        w = _tangent(q, np.concatenate([_log_uniform(rng, 1e-12, 1e2, n - c[3]),
                                        np.full(c[3], 1e-300)]), rng)
        return np.hstack([q, w])

    return ExportableController(
        name="s2_pd",
        title="geometric PD on S^2 with gravity cancellation, paper 002 Section II-A",
        model=model,
        function=controllers.s2_pd(model, qd, k_q=kq, k_w=kw),
        gains={"q_d": qd, "k_q": np.array(kq), "k_w": np.array(kw)},
        gain_entries=(Entry("q_d", 3, "desired direction, unit vector [-]"),
                      Entry("k_q", 1, "attitude gain [1/s^2]"),
                      Entry("k_w", 1, "angular-velocity gain [1/s]")),
        law=lambda ctx, g: controllers.s2_pd_law(ctx, **g),
        state_entries=(Entry("q", 3, "link direction, unit vector (e3 points down) [-]"),
                       Entry("omega", 3, "angular velocity, q . omega = 0 [rad/s]")),
        output=Entry("u", 3, "control moment at the pivot [N m]"),
        example_state=np.concatenate([q0, [0.0, 0.5, 0.0]]),
        example_note="150 degrees from q_d = e3 (near the inverted saddle), "
                     "omega = (0, 0.5, 0)",
        singular="no singularity; the closed loop has a saddle at q = -q_d (there "
                 "q_d x q = 0 and the attitude term vanishes)",
        sampler=sampler,
    )


def _so3_pd_export(options: dict[str, Any]) -> ExportableController:
    """Paper 002 Section III: the full 3D pendulum and the geometric PD on SO(3)."""
    model = pendulum3d.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.3], m=1.0, g=9.81)
    Rd, G, kR, kW = np.eye(3), np.array([0.9, 1.0, 1.1]), 1.0, 1.0

    def sampler(rng: np.random.Generator, n: int) -> np.ndarray:
        c = _split(n, (0.3, 0.4, 0.15, 0.15))
        R = [_rotations(rng, c[0])]
        # the saddles R_d exp(pi hat(e_i)), approached to 1e-14
        axes = rng.integers(0, 3, c[1])
        small = _unit(rng, c[1]) * _log_uniform(rng, 1e-14, 1e-2, c[1])[:, None]
        R.append(np.array([Rd @ so3_exp(np.pi * np.eye(3)[a]) @ so3_exp(s)
                           for a, s in zip(axes, small)]))
        small = _unit(rng, c[2]) * _log_uniform(rng, 1e-14, 1e-2, c[2])[:, None]
        R.append(np.array([Rd @ so3_exp(s) for s in small]))
        # rotations by nearly pi about arbitrary axes
        ang = np.pi - _log_uniform(rng, 1e-12, 1e-2, c[3])
        R.append(np.array([Rd @ so3_exp(a * u) for a, u in zip(ang, _unit(rng, c[3]))]))
        w = _unit(rng, n) * _log_uniform(rng, 1e-12, 1e2, n)[:, None]
        return np.hstack([_flat_rotations(np.vstack(R)), w])

    return ExportableController(
        name="so3_pd",
        title="geometric PD on SO(3) with gravity cancellation, paper 002 Section III-A",
        model=model,
        function=controllers.so3_pd(model, Rd, k_R=kR, k_Omega=kW, G=G),
        gains={"R_d": Rd, "k_R": np.array(kR), "k_Omega": np.array(kW), "G": G},
        gain_entries=(Entry("R_d", 9, "desired attitude, rotation, row-major [-]"),
                      Entry("k_R", 1, "attitude gain [N m]"),
                      Entry("k_Omega", 1, "angular-velocity gain [N m s]"),
                      Entry("G", 3, "diagonal (g1, g2, g3) of G, positive [-]")),
        law=lambda ctx, g: controllers.so3_pd_law(ctx, **g),
        state_entries=(
            Entry("R", 9, "attitude R (body to inertial), column-major [-]"),
            Entry("omega", 3, "angular velocity Omega, body frame [rad/s]")),
        output=Entry("u", 3, "control moment, body frame [N m]"),
        example_state=np.concatenate([SO3.flat(so3_exp(np.array([0.0, 2.5, 0.5]))),
                                      [0.1, -0.2, 0.3]]),
        example_note="R(0) = exp(hat((0, 2.5, 0.5))), Omega(0) = (0.1, -0.2, 0.3); the "
                     "body (m = 1, rho = (0, 0, 0.3)) is not given by paper 002 and does "
                     "not enter its closed loop",
        singular="no singularity; the closed loop has saddles at R_d exp(pi hat(e_i)) "
                 "(there e_R = 0)",
        sampler=sampler,
    )


# ----------------------------------------------------------------------------------------
# paper 003 (21), (26): nonlinear controller for the inverted pendulum on a cart (n = 1)


def _cart_nonlinear_export(options: dict[str, Any]) -> ExportableController:
    """Paper 003 Section 5 (Fig. 5): the inverted pendulum on a cart, (21) and (26)."""
    model = chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    gains = {"k_y": 4.0, "k_ydot": 2.8, "k_w": 1.0, "k_q": 14.0}
    s = float(np.sqrt((1 + gains["k_w"]) / gains["k_q"]))
    q0 = S2().project([0.64, -0.64, -0.42])

    def sampler(rng: np.random.Generator, n: int) -> np.ndarray:
        c = _split(n, (0.25, 0.3, 0.15, 0.15, 0.15))
        z = [-rng.uniform(s, 1.0, c[0]),                  # inside D = {q . e3 < -s}
             # both rings where the matrix of (26) is singular, q . e3 = -s and +s
             -s + rng.choice([-1, 1], c[1]) * _log_uniform(rng, 1e-10, 1e-3, c[1]),
             s + rng.choice([-1, 1], c[2]) * _log_uniform(rng, 1e-10, 1e-3, c[2]),
             -1 + _log_uniform(rng, 1e-16, 1e-3, c[3]),   # near the inverted equilibrium
             rng.uniform(-1.0, 1.0, c[4])]
        z = np.clip(np.concatenate(z), -1.0, 1.0)
        phi = rng.uniform(0, 2 * np.pi, n)
        r = np.sqrt(np.maximum(0.0, 1 - z**2))
        q = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        w = _tangent(q, _log_uniform(rng, 1e-9, 1e2, n), rng)
        xv = rng.normal(0, 1, (n, 4)) * _log_uniform(rng, 1e-6, 1e1, n)[:, None]
        return np.hstack([xv, q, w])

    return ExportableController(
        name="cart_nonlinear",
        title="nonlinear stabilisation of the inverted spherical pendulum on a cart, paper "
              "003 (21) (with erratum) and (26)",
        model=model,
        function=controllers.cart_inverted_feedback(model, **gains),
        gains={k: np.array(v) for k, v in gains.items()},
        gain_entries=(Entry("k_y", 1, "output gain [1/s^2]"),
                      Entry("k_ydot", 1, "output-rate gain [1/s]"),
                      Entry("k_w", 1, "energy-shaping gain [-]"),
                      Entry("k_q", 1, "output gain on the link, k_q > 1 + k_w [-]")),
        law=lambda ctx, g: controllers.cart_inverted_law(ctx, **g),
        state_entries=(Entry("x", 2, "cart position [m]"),
                       Entry("v", 2, "cart velocity [m/s]"),
                       Entry("link1", 6, "link direction q1 (unit, e3 down) [-], then its "
                                         "angular velocity omega1 [rad/s]")),
        output=Entry("u", 2, "horizontal force on the cart [N]"),
        example_state=model.state(x=[0.2, 0.1], v=[0.0, 0.1],
                                  link1=np.concatenate([q0, np.zeros(3)])),
        example_note="paper 003 Section 5 (Fig. 5): x(0) = (0.2, 0.1), xdot(0) = (0, 0.1), "
                     "q1(0) = (0.64, -0.64, -0.42) normalised, omega1(0) = 0",
        singular=f"singular where q1 . e3 = -s or +s with s = sqrt((1 + k_w)/k_q) "
                 f"(s = {s:.6g} at the default gains): the boundary of the domain D of (43) "
                 f"and its mirror image; the law is meant for D = {{q1 . e3 < -s}}",
        sampler=sampler,
    )


# ----------------------------------------------------------------------------------------
# paper 003 (19): the chain's geometric LQR feedback at the hanging equilibrium


def _law_chain(lin: Any) -> Law:
    def law(ctx: Context, k: dict[str, Any]) -> Any:
        return ca.DM(lin.u_e) - k["K"] @ lin.chart(ctx.x)

    return law


def _chain_lqr_export(options: dict[str, Any]) -> ExportableController:
    """Paper 003 Section 5 (Fig. 3): LQR feedback (19) of the chain, ``options["n"]`` links."""
    n = int(options["n"])
    model = chain_cart(n, m=0.5, masses=0.1, lengths=0.1, g=9.81)
    x_e = model.state(x=np.zeros(2), v=np.zeros(2),
                      **{f"link{i + 1}": link_state(E3) for i in range(n)})
    # paper 003 Section 5: Q = diag[8 I2, I_2n, 8 I2, I_2n] in the order of (16),
    # [x; x_q; x-dot; x_q-dot], and R = I2
    pos, vel = mechanical_order(model, {"x": "v"})
    lin = linearize(model, x_e).permuted(pos + vel)
    Q = np.diag([8.0, 8.0] + [1.0] * (2 * n) + [8.0, 8.0] + [1.0] * (2 * n))
    design = lqr(lin, Q, np.eye(2))
    K = design.K
    law = _law_chain(lin)
    fn = design.feedback(name=f"chain_lqr_n{n}")
    links = {f"link{i + 1}": link_state(
        so3_exp(np.deg2rad(5.0 + i) * np.array([0.0, 1.0, 0.0])) @ E3) for i in range(n)}

    def sampler(rng: np.random.Generator, n_s: int) -> np.ndarray:
        kind = rng.integers(0, 4, n_s * n)
        ang = _log_uniform(rng, 1e-14, 1e-2, n_s * n)
        ang[kind == 3] = 0.0             # exactly at the antipode, where the chart is 0
        q = np.where((kind == 1)[:, None], _near(E3, ang, rng), _near(-E3, ang, rng))
        q = np.where((kind == 0)[:, None], _unit(rng, n_s * n), q).reshape(n_s, n, 3)
        w = _tangent(q.reshape(-1, 3), _log_uniform(rng, 1e-12, 1e2, n_s * n), rng)
        w = w.reshape(n_s, n, 3)
        links_ = np.concatenate([q, w], axis=2).reshape(n_s, 6 * n)
        xv = rng.normal(0, 1, (n_s, 4)) * _log_uniform(rng, 1e-9, 1e1, n_s)[:, None]
        return np.hstack([xv, links_])

    return ExportableController(
        name=f"chain_lqr_n{n}",
        title=f"geometric LQR feedback of the {n}-link chain on a cart at the hanging "
              f"equilibrium, paper 003 (19), Q and R of Section 5",
        model=model,
        function=fn,
        gains={"K": K},
        gain_entries=(Entry("K", 2 * (4 * n + 4),
                            f"LQR gain, 2 x {4 * n + 4}, row-major, on the chart of (16) "
                            f"[x; C^T(e3 x q_i), i = 1..{n}; x-dot; C^T omega_i, "
                            f"i = 1..{n}] (SI units)"),),
        law=law,
        state_entries=(Entry("x", 2, "cart position [m]"),
                       Entry("v", 2, "cart velocity [m/s]"))
        + tuple(Entry(f"link{i + 1}", 6, f"link {i + 1}: direction q{i + 1} (unit, e3 "
                                         f"down) [-], angular velocity omega{i + 1} [rad/s]")
                for i in range(n)),
        output=Entry("u", 2, "horizontal force on the cart [N]"),
        example_state=model.state(x=[0.2, 0.1], v=[0.0, -0.1], **links),
        example_note="x(0), xdot(0) of paper 003 (27); link i tilted (5 + i - 1) degrees "
                     "from the hanging direction about e2",
        singular="no singularity; the chart C^T (e3 x q_i) vanishes at the antipode "
                 "q_i = -e3, so a link exactly inverted is seen as hanging",
        sampler=sampler,
    )


# ----------------------------------------------------------------------------------------
# the TVLQR tracker of the spherical cart swing-up (problems/swingup_spherical_cart.py)


def tvlqr_table_law(t_grid: ArrayLike, x_ref: ArrayLike, u_ref: ArrayLike, gains: ArrayLike,
                    charts: ArrayLike, *, u_lower: ArrayLike | None = None,
                    u_upper: ArrayLike | None = None, name: str = "tvlqr_table"
                    ) -> ca.Function:
    """The sampled-data TVLQR law of :mod:`workbench.control._tvlqr` as a table lookup ``(x, t) -> u``.

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


def _swingup_tvlqr_export(options: dict[str, Any]) -> ExportableController:
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


# ----------------------------------------------------------------------------------------
# the registry

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class _Family:
    pattern: str
    summary: str
    make: Callable[[dict[str, Any]], ExportableController]


_REGISTRY: dict[str, _Family] = {
    "saturated_velocity_feedback": _Family(
        "saturated_velocity_feedback",
        "paper 001 (34): u = -k P omega/(1 + |P omega|) on the full 3D pendulum",
        _saturated_export),
    "s2_pd": _Family("s2_pd", "paper 002 Sec. II-A: geometric PD on S^2 (spherical "
                     "pendulum)", _s2_pd_export),
    "so3_pd": _Family("so3_pd", "paper 002 Sec. III-A: geometric PD on SO(3) (full 3D "
                      "pendulum)", _so3_pd_export),
    "chain_lqr": _Family("chain_lqr_n<N>", "paper 003 (19): geometric LQR feedback of the "
                         "N-link chain on a cart, any N >= 1 (e.g. chain_lqr_n5)",
                         _chain_lqr_export),
    "cart_nonlinear": _Family("cart_nonlinear", "paper 003 (21), (26): nonlinear inverted "
                              "pendulum on a cart (n = 1)", _cart_nonlinear_export),
    "swingup_tvlqr_cart": _Family(
        "swingup_tvlqr_cart", "TVLQR tracker (x, t) -> u of the spherical cart swing-up "
        "(problems/swingup_spherical_cart.py), frozen trajectory table", _swingup_tvlqr_export),
}

_CHAIN = re.compile(r"^chain_lqr_n([0-9]+)$")
MAX_LINKS = 50
"""Largest chain exported (the graph and the gain grow like n^2)."""


def names() -> list[str]:
    """Export names; a family with an option appears as its pattern (``chain_lqr_n<N>``)."""
    return [f.pattern for f in _REGISTRY.values()]


def describe() -> list[tuple[str, str]]:
    """``(name or pattern, one-line summary)`` of every exportable controller."""
    return [(f.pattern, f.summary) for f in _REGISTRY.values()]


def build(name: str) -> ExportableController:
    """Build the exportable controller called ``name``.

    Parameters
    ----------
    name : str
        A name of :func:`names`; the chain family is ``chain_lqr_n<N>`` with the number of
        links ``N`` (1 to :data:`MAX_LINKS`), e.g. ``"chain_lqr_n5"``.

    Returns
    -------
    ExportableController

    Raises
    ------
    ModelError
        If ``name`` is not a controller of the workbench (the message lists them).
    """
    if not isinstance(name, str) or not _NAME.match(name):
        raise ModelError(f"controller name must be a C identifier naming a controller of "
                         f"the workbench ({', '.join(names())}); got {name!r}")
    m = _CHAIN.match(name)
    if m:
        n = int(m.group(1))
        if not 1 <= n <= MAX_LINKS:
            raise ModelError(f"chain_lqr_n<N> needs 1 <= N <= {MAX_LINKS} links; got "
                             f"N = {n} (from {name!r})")
        return _REGISTRY["chain_lqr"].make({"n": n})
    if name == "chain_lqr":
        raise ModelError("chain_lqr needs the number of links in its name: chain_lqr_n<N>, "
                         "e.g. chain_lqr_n5")
    if name not in _REGISTRY:
        raise ModelError(f"{name!r} is not an exportable controller of the workbench; "
                         f"known: {', '.join(names())} (see 'workbench export-c --list')")
    return _REGISTRY[name].make({})
