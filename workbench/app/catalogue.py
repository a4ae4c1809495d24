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
from workbench.app._sampling import (
    _flat_rotations,
    _log_uniform,
    _near,
    _rotations,
    _split,
    _tangent,
    _unit,
)
from workbench.app.swingup_export import (
    TimeVaryingExport,
    swingup_tvlqr_export,
    tvlqr_table_law,
)
from workbench.codegen.spec import Entry, ExportableController, Law
from workbench.core._model import Context
from workbench.core.errors import ModelError
from workbench.core.manifolds import S2, SO3, so3_exp
from workbench.linear._linearize import linearize, mechanical_order
from workbench.linear._lqr import lqr

__all__ = ["MAX_LINKS", "TimeVaryingExport", "build", "describe", "names", "tvlqr_table_law"]

E3 = np.array([0.0, 0.0, 1.0])

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
        "(problems/swingup_spherical_cart.py), frozen trajectory table", swingup_tvlqr_export),
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
