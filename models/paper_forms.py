"""The papers' printed equations of motion: independent references for the derived models.

The models of :mod:`models.pendulum3d` (``full``), :mod:`models.spherical` and
:mod:`models.chain_cart` are defined by their Lagrangians through
:mod:`workbench.mechanics`; the equations here are the ones the papers print, typed in by
hand (paper 000 (3.1)-(3.2); paper 002 Section II; paper 003 (12)-(13) with the erratum of
docs/science.md). They are what the derived vector fields are checked against
(``problems/mechanics_paper_models.py`` and the mechanics tests) and are never used by the
models themselves. Same state layout, parameters and invariants as the derived models.
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np

from workbench.core import Context, Model, Parameter, finite, positive, spd3
from workbench.core.errors import ParameterError
from workbench.core.manifolds import SO3, TS2, ProductManifold, Rn, hat
from workbench.core.types import ArrayLike

__all__ = ["chain_cart_printed", "spherical_pendulum_printed", "pendulum3d_full_printed"]

E3 = np.array([0.0, 0.0, 1.0])
C = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])  # R^2 -> horizontal plane of R^3

LINEAR_SOLVER = "lapacklu"
"""casadi linear solver plugin for the (dense) acceleration solve of (12)."""

PARAMETERS = (
    Parameter("J", (3, 3), "inertia about the pivot, body frame [kg m^2]", spd3),
    Parameter("rho", (3,), "pivot to centre of mass, body frame [m]", finite),
    Parameter("m", (), "mass [kg]", positive),
    Parameter("g", (), "gravitational acceleration [m/s^2]", positive),
)


def _per_link(name: str, value: float | Sequence[float], n: int) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"parameter {name!r} must be a number or one number per link "
                             f"({n}); got {value!r}") from exc
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ParameterError(
            f"parameter {name!r} must be a scalar or have one entry per link ({n}); "
            f"got shape {arr.shape}"
        )
    return arr


def chain_cart_printed(
    n: int,
    *,
    m: float = 0.5,
    masses: float | Sequence[float] = 0.1,
    lengths: float | Sequence[float] = 0.1,
    g: float = 9.81,
) -> Model:
    """The chain pendulum on a cart as printed: paper 003 (12)-(13), the matrix typed in.

    Parameters
    ----------
    n : int
        Number of links, at least 1.
    m : float
        Cart mass [kg], positive.
    masses : float or sequence of float
        Link point masses ``m_i`` [kg], one per link or one for all; positive.
    lengths : float or sequence of float
        Link lengths ``l_i`` [m], one per link or one for all; positive.
    g : float
        Gravitational acceleration [m/s^2]; paper 003's examples use 9.81.

    Returns
    -------
    Model
        Input ``u`` (horizontal force on the cart, R^2); invariants ``energy``,
        ``px``, ``py`` (horizontal linear momentum) and ``Lz`` (vertical angular momentum
        about the origin), all conserved when ``u = 0``.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ParameterError(f"n (number of links) must be an integer >= 1; got {n!r}")
    n = int(n)
    params = (
        Parameter("m", (), "cart mass [kg]", positive),
        Parameter("masses", (n,), "link point masses m_i [kg]", positive),
        Parameter("lengths", (n,), "link lengths l_i [m]", positive),
        Parameter("g", (), "gravitational acceleration [m/s^2]", positive),
    )
    values = {
        "m": m,
        "masses": _per_link("masses", masses, n),
        "lengths": _per_link("lengths", lengths, n),
        "g": g,
    }
    links = [f"link{i + 1}" for i in range(n)]

    def unpack(ctx: Context) -> tuple:
        mi, li = ctx["masses"], ctx["lengths"]
        qs = [ctx[k][0:3] for k in links]
        ws = [ctx[k][3:6] for k in links]
        # tail sums S_i = sum_{a >= i} m_a ; M_0i = S_i l_i ; M_ij = S_max(i,j) l_i l_j
        tail = [sum(mi[a] for a in range(i, n)) for i in range(n)]
        return mi, li, qs, ws, tail

    def assemble(ctx: Context) -> tuple[ca.SX, ca.SX]:
        """The matrix and right-hand side of (12), as scalar (SX) expressions."""
        mi, li, qs, ws, tail = unpack(ctx)
        Cd = ca.DM(C)
        e3 = ca.DM(E3)
        M00 = ctx["m"] + sum(mi[a] for a in range(n))
        M0 = [tail[i] * li[i] for i in range(n)]

        def Mij(i: int, j: int) -> ca.SX:
            return tail[max(i, j)] * li[i] * li[j]

        rows = []
        # cart row: M00 xdd - sum_j M0j C^T hat(q_j) wdot_j = sum_j M0j |w_j|^2 C^T q_j + u
        blocks = [M00 * ca.DM.eye(2)] + [-M0[j] * (Cd.T @ ca.skew(qs[j])) for j in range(n)]
        rows.append(ca.horzcat(*blocks))
        rhs = [sum((M0[j] * ca.dot(ws[j], ws[j])) * (Cd.T @ qs[j]) for j in range(n)) + ctx.u]
        for i in range(n):
            qi = ca.skew(qs[i])
            blocks = [M0[i] * (qi @ Cd)]
            for j in range(n):
                if j == i:
                    blocks.append(Mij(i, i) * ca.DM.eye(3))
                else:
                    blocks.append(-Mij(i, j) * (qi @ ca.skew(qs[j])))
            rows.append(ca.horzcat(*blocks))
            r = tail[i] * ctx["g"] * li[i] * (qi @ e3)
            for j in range(n):
                if j != i:
                    r = r + (Mij(i, j) * ca.dot(ws[j], ws[j])) * (qi @ qs[j])
            rhs.append(r)
        return ca.vertcat(*rows), ca.vertcat(*rhs)

    def field(ctx: Context) -> ca.MX:
        # Scalar-heavy assembly as an SX function (compact, fast); only the linear solve
        # is an MX node, so the graph stays small and its derivatives cheap.
        sx = Context(ctx.model, ca.SX.sym("x", ctx.x.shape[0]), ca.SX.sym("u", 2),
                     ca.SX.sym("p", ctx.p.shape[0]))
        A_sx, b_sx = assemble(sx)
        kin = ca.vertcat(*[ca.cross(sx[k][3:6], sx[k][0:3]) for k in links])
        asm = ca.Function(f"chain{n}_assemble", [sx.x, sx.u, sx.p], [A_sx, b_sx, kin],
                          {"cse": True})
        A, b, qdot = asm(ctx.x, ctx.u, ctx.p)
        acc = ca.solve(A, b, LINEAR_SOLVER)
        out = [ctx["v"], acc[0:2]]
        for i in range(n):
            out += [qdot[3 * i : 3 * i + 3], acc[2 + 3 * i : 5 + 3 * i]]
        return ca.vertcat(*out)

    def positions_velocities(ctx: Context) -> tuple[list, list]:
        mi, li, qs, ws, _ = unpack(ctx)
        Cd = ca.DM(C)
        pos, vel = [Cd @ ctx["x"]], [Cd @ ctx["v"]]
        for i in range(n):
            pos.append(pos[-1] + li[i] * qs[i])
            vel.append(vel[-1] + li[i] * ca.cross(ws[i], qs[i]))
        return pos, vel

    def masses_all(ctx: Context) -> list:
        mi = ctx["masses"]
        return [ctx["m"]] + [mi[i] for i in range(n)]

    def energy(ctx: Context) -> ca.MX:
        pos, vel = positions_velocities(ctx)
        ms = masses_all(ctx)
        kinetic = sum(0.5 * ms[k] * ca.dot(vel[k], vel[k]) for k in range(n + 1))
        potential = -sum(ms[k] * ctx["g"] * pos[k][2] for k in range(1, n + 1))
        return kinetic + potential

    def momentum(axis: int):
        def p(ctx: Context) -> ca.MX:
            _, vel = positions_velocities(ctx)
            ms = masses_all(ctx)
            return sum(ms[k] * vel[k][axis] for k in range(n + 1))

        return p

    def angular_momentum_z(ctx: Context) -> ca.MX:
        pos, vel = positions_velocities(ctx)
        ms = masses_all(ctx)
        return sum(ms[k] * ca.cross(pos[k], vel[k])[2] for k in range(n + 1))

    return Model(
        name=f"chain_cart_n{n}",
        manifold=ProductManifold(
            [("x", Rn(2)), ("v", Rn(2))] + [(k, TS2()) for k in links]
        ),
        n_inputs=2,
        parameters=params,
        values=values,
        vector_field=field,
        invariants={
            "energy": energy,
            "px": momentum(0),
            "py": momentum(1),
            "Lz": angular_momentum_z,
        },
        symbolic="MX",
        description=f"{n}-link spherical chain pendulum on a cart on (S^2)^{n} x R^2 "
        "(paper 003 (12)-(13))",
        equations=(
            r"M_{00}\ddot x - \sum_j M_{0j}\hat q_j\dot\omega_j = \sum_j M_{0j}\|\omega_j\|^2"
            r" C^T q_j + u \quad (12)\text{, row 0, with erratum}",
            r"\hat q_i M_{i0}\ddot x + M_{ii}\dot\omega_i - \sum_{j\ne i} M_{ij}\hat q_i\hat q_j"
            r"\dot\omega_j = \sum_{j\ne i} M_{ij}\|\omega_j\|^2\hat q_i q_j + \sum_{a\ge i}"
            r" m_a g l_i \hat q_i e_3 \quad (12)",
            r"\dot q_i = \omega_i\times q_i \quad (13)",
            r"M_{00} = m + \sum_i m_i,\; M_{0i} = C^T\sum_{a\ge i} m_a l_i,\; "
            r"M_{ij} = (\sum_{a\ge\max(i,j)} m_a) l_i l_j \quad (5), (7)",
        ),
        input_description="horizontal force on the cart u [N]",
    )



def spherical_pendulum_printed(*, m: float = 1.0, l: float = 1.0, g: float = 9.81) -> Model:  # noqa: E741
    """The spherical pendulum as printed: paper 002, Section II.

    Parameters
    ----------
    m : float
        Point mass [kg], positive.
    l : float
        Link length [m], positive.
    g : float
        Gravitational acceleration [m/s^2], positive.

    Returns
    -------
    Model
        One TS2 factor ``q`` storing ``(q, omega)``; input ``u`` (moment, R^3); invariant
        ``energy = m l^2 |omega|^2 / 2 - m g l e3 . q`` (conserved when ``u = 0``).
    """

    def field(ctx: Context) -> ca.SX:
        x = ctx["q"]
        q, w = x[0:3], x[3:6]
        m_, l_, g_ = ctx["m"], ctx["l"], ctx["g"]
        u_normal = ctx.u - ca.dot(q, ctx.u) * q
        wdot = (g_ / l_) * ca.cross(q, ca.DM(E3)) + u_normal / (m_ * l_**2)
        return ca.vertcat(ca.cross(w, q), wdot)

    def energy(ctx: Context) -> ca.SX:
        x = ctx["q"]
        m_, l_, g_ = ctx["m"], ctx["l"], ctx["g"]
        return 0.5 * m_ * l_**2 * ca.dot(x[3:6], x[3:6]) - m_ * g_ * l_ * x[2]

    return Model(
        name="spherical_pendulum",
        manifold=ProductManifold([("q", TS2())]),
        n_inputs=3,
        parameters=(
            Parameter("m", (), "point mass [kg]", positive),
            Parameter("l", (), "link length [m]", positive),
            Parameter("g", (), "gravitational acceleration [m/s^2]", positive),
        ),
        values={"m": m, "l": l, "g": g},
        vector_field=field,
        invariants={"energy": energy},
        description="spherical pendulum on TS^2 with a control moment (paper 002, Section II)",
        equations=(
            r"\dot q = \omega\times q,\; \dot\omega = \tfrac{g}{l} q\times e_3 + "
            r"\tfrac{1}{ml^2}(I - qq^T)u \quad \text{(paper 002, Sec. II)}",
        ),
        input_description="control moment at the pivot u [N m]",
    )


def _euler(ctx: Context, gamma: ca.SX, omega: ca.SX) -> ca.SX:
    """J^-1 (J w x w + m g rho x Gamma + u): (3.1) / (4.3) with the control moment."""
    J, rho, m, g = ctx["J"], ctx["rho"], ctx["m"], ctx["g"]
    moment = ca.cross(J @ omega, omega) + m * g * ca.cross(rho, gamma) + ctx.u
    return ca.solve(J, moment)


def _energy(ctx: Context, gamma: ca.SX, omega: ca.SX) -> ca.SX:
    return 0.5 * ca.dot(omega, ctx["J"] @ omega) - ctx["m"] * ctx["g"] * ca.dot(ctx["rho"], gamma)


def pendulum3d_full_printed(
    *, J: ArrayLike, rho: ArrayLike, m: float = 1.0, g: float = 9.81
) -> Model:
    """The full 3D pendulum on TSO(3) as printed: paper 000 (3.1)-(3.2), paper 001 (1)-(2).

    Parameters
    ----------
    J : array-like, shape=(3, 3)
        Inertia about the pivot in the body frame, symmetric positive definite.
    rho : array-like, shape=(3,)
        Vector from the pivot to the centre of mass in the body frame [m].
    m : float
        Mass [kg], positive.
    g : float
        Gravitational acceleration [m/s^2], positive.

    Returns
    -------
    Model
        State ``R`` (SO3, 9 stored numbers) and ``omega`` (R^3); input ``u``, the body
        control moment (R^3); invariants ``energy`` and ``h`` (vertical angular momentum,
        conserved when ``u = 0``).
    """

    def field(ctx: Context) -> ca.SX:
        R, w = SO3.matrix(ctx["R"]), ctx["omega"]
        gamma = R.T @ E3
        return ca.vertcat(ca.vec(R @ hat(w)), _euler(ctx, gamma, w))

    def energy(ctx: Context) -> ca.SX:
        return _energy(ctx, SO3.matrix(ctx["R"]).T @ E3, ctx["omega"])

    def h(ctx: Context) -> ca.SX:
        return ca.dot(ctx["omega"], ctx["J"] @ (SO3.matrix(ctx["R"]).T @ E3))

    return Model(
        name="pendulum3d_full",
        manifold=ProductManifold([("R", SO3()), ("omega", Rn(3))]),
        n_inputs=3,
        parameters=PARAMETERS,
        values={"J": J, "rho": rho, "m": m, "g": g},
        vector_field=field,
        invariants={"energy": energy, "h": h},
        description="3D pendulum on TSO(3) (paper 000 (3.1)-(3.2); paper 001 (1)-(2))",
        equations=(
            r"J\dot\omega = J\omega\times\omega + mg\,\rho\times R^T e_3 + u \quad (3.1)",
            r"\dot R = R\hat\omega \quad (3.2)",
            r"E = \tfrac12\omega^T J\omega - mg\,\rho^T R^T e_3,\; h = \omega^T J R^T e_3"
            r"\quad \text{(Prop. 1)}",
        ),
        input_description="body-fixed control moment u [N m]",
    )
