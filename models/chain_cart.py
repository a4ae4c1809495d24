"""The n-link spherical chain pendulum on a cart, paper 003 (11)-(13), for any n >= 1.

The cart (mass ``m``) moves in the horizontal plane, position ``x`` in R^2, driven by a
horizontal force ``u`` in R^2. Link ``i`` has direction ``q_i`` in S^2 (``e3`` points
down, along gravity), angular velocity ``omega_i`` with ``q_i . omega_i = 0`` and
``q_i-dot = omega_i x q_i`` (13), length ``l_i`` and a point mass ``m_i`` at its outer end.

The accelerations solve the linear system (12) (with the erratum of papers/README.md: the
cart row carries ``sum_j M_0j |omega_j|^2 C^T q_j``) *numerically inside the graph*: the
model is an MX graph whose ``casadi.solve`` node is a linear solve, so its size grows like
n^2 (the matrix entries), not like the n^3 of a symbolic inverse.

State factors, in storage order: ``x`` (R^2), ``v`` (R^2, cart velocity), then
``link1 .. linkn`` (each TS2, storing ``(q_i, omega_i)``).
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np

from workbench.core import Context, Model, Parameter, positive
from workbench.core.errors import ParameterError
from workbench.core.manifolds import TS2, ProductManifold, Rn
from workbench.core.types import ArrayLike
from workbench.core.validate import count as _count

__all__ = ["chain_cart", "link_state", "E3", "C"]

E3 = np.array([0.0, 0.0, 1.0])
C = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])  # R^2 -> horizontal plane of R^3

LINEAR_SOLVER = "lapacklu"
"""casadi linear solver plugin for the (dense) acceleration solve; derivatives work."""


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


MAX_LINKS = 50
"""Default ``max_links`` of :func:`chain_cart`: the largest chain built without asking."""


def _memory_gb(n: int) -> float:
    """Estimated peak memory [GB] of building an ``n``-link chain (fit to 20, 50, 100)."""
    return 0.64e-3 * n**2 + 0.1


def chain_cart(
    n: int,
    *,
    m: float = 0.5,
    masses: float | Sequence[float] = 0.1,
    lengths: float | Sequence[float] = 0.1,
    g: float = 9.81,
    max_links: int = MAX_LINKS,
) -> Model:
    """Build the chain pendulum on a cart with ``n`` links.

    Parameters
    ----------
    n : int
        Number of links, at least 1 and at most ``max_links``.
    max_links : int
        Size guard (default :data:`MAX_LINKS` = 50): a larger ``n`` is refused with the
        estimated memory unless this is raised (measured peak memory of building the
        graphs and Jacobians: n = 20 about 0.5 GB, n = 50 about 2.1 GB, n = 100 about
        6.4 GB).
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
    if n > _count("max_links", max_links):
        raise ParameterError(
            f"n = {n} links > max_links = {max_links}: building the chain's graphs and "
            f"Jacobians takes about {_memory_gb(n):.1f} GB (0.5 GB at n = 20, 2.1 GB at 50, "
            f"6.4 GB at 100, measured); pass max_links={n} if you mean it")
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


def link_state(q: ArrayLike, omega: ArrayLike | None = None) -> np.ndarray:
    """Stack one link's ``(q, omega)`` (omega defaults to zero); no normalisation."""
    w = np.zeros(3) if omega is None else np.asarray(omega, dtype=float).reshape(3)
    return np.concatenate([np.asarray(q, dtype=float).reshape(3), w])
