"""Independent derivations with sympy.physics.mechanics (Kane's method, in angles).

References only: no model of the workbench is built from this module. It checks the
systems that :mod:`workbench.mechanics` derives: each function here builds the
same system the textbook way — Euler angles (body 3-2-1) for attitudes, spherical angles for
directions, generalised speeds equal to the body angular velocities — and returns a numeric
function of (parameters, angles, speeds, inputs) giving the generalised accelerations, plus
the maps from angles to the workbench's rotation matrices and unit vectors. The tests
evaluate both at states away from the angles' singularities (pitch near +-90 degrees, the
polar angle near 0 or pi).

``e3`` points down: gravity acts along ``N.z``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import sympy as sp
from sympy.physics import mechanics as me


@dataclass(frozen=True)
class Derivation:
    """Kane's equations of a system, lambdified.

    Attributes
    ----------
    params : list of sympy.Symbol
        Parameter symbols, in the order ``mass_matrix``/``forcing`` take them.
    q, u, inputs : list of sympy.Symbol
        Coordinates, generalised speeds, inputs.
    mass_matrix, forcing : callable
        ``f(params, q, u, inputs)`` -> numeric arrays of Kane's ``M u-dot = F``.
    qdot : callable
        ``f(q, u)`` -> the coordinates' rates (kinematic differential equations).
    """

    params: list
    q: list
    u: list
    inputs: list
    mass_matrix: object
    forcing: object
    qdot: object

    def udot(self, p, q, u, inp):
        """Generalised accelerations at one state."""
        M = np.asarray(self.mass_matrix(p, q, u, inp), dtype=float)
        F = np.asarray(self.forcing(p, q, u, inp), dtype=float).ravel()
        return np.linalg.solve(M, F)


def rotation(angles) -> np.ndarray:
    """Body 3-2-1 (yaw, pitch, roll) angles -> rotation body -> world, shape=(3, 3)."""
    a, b, c = angles
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rx = np.array([[1, 0, 0], [0, np.cos(c), -np.sin(c)], [0, np.sin(c), np.cos(c)]])
    return Rz @ Ry @ Rx


def direction(theta, phi) -> np.ndarray:
    """Polar angle from ``e3`` and azimuth -> unit vector, shape=(3,)."""
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def _body(N, name):
    q = me.dynamicsymbols(f"{name}_q1:4")
    u = me.dynamicsymbols(f"{name}_u1:4")
    B = N.orientnew(name, "Body", q, "321")
    B.set_ang_vel(N, u[0] * B.x + u[1] * B.y + u[2] * B.z)
    kd = me.kinematic_equations(u, q, "body", "321")
    return B, q, u, kd


def _inertia_sym(name):
    Jxx, Jyy, Jzz, Jxy, Jyz, Jxz = sp.symbols(f"{name}xx {name}yy {name}zz {name}xy {name}yz "
                                           f"{name}xz")
    return (Jxx, Jyy, Jzz, Jxy, Jyz, Jxz)


def _com_inertia(B, J, m, rho):
    """Dyadic of the inertia about the centre of mass from ``J`` about the pivot."""
    Jm = sp.Matrix([[J[0], J[3], J[5]], [J[3], J[1], J[4]], [J[5], J[4], J[2]]])
    r = sp.Matrix(rho)
    Jc = Jm - m * ((r.T * r)[0] * sp.eye(3) - r * r.T)
    return me.inertia(B, Jc[0, 0], Jc[1, 1], Jc[2, 2], Jc[0, 1], Jc[1, 2], Jc[0, 2])


def _finish(N, q, u, kd, bodies, loads, params, inputs) -> Derivation:
    km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    km.kanes_equations(bodies, loads)
    t = me.dynamicsymbols._t
    qs, us = sp.symbols(f"q0:{len(q)}"), sp.symbols(f"u0:{len(u)}")
    sub = dict(zip(q, qs)) | dict(zip(u, us))
    ins = list(inputs)

    def lam(expr):
        return sp.lambdify([params, qs, us, ins], me.msubs(expr, sub), "numpy", cse=True)

    kdd = km.kindiffdict()
    qd = sp.Matrix([kdd[sp.diff(qi, t)] for qi in q])
    qdot = sp.lambdify([qs, us], me.msubs(qd, sub), "numpy")
    return Derivation(list(params), q, u, ins, lam(km.mass_matrix), lam(km.forcing), qdot)


@cache
def pendulum3d_cart() -> Derivation:
    """Kane's equations of the 3D pendulum on a planar cart.

    Rigid body with pivot inertia ``J`` and offset ``rho``; inputs ``(F_x, F_y, M_1, M_2,
    M_3)`` (cart force, body-frame moment); parameters ``(M, m, J6, rho3, g)``.
    """
    N, O_ = me.ReferenceFrame("N"), me.Point("O")
    O_.set_vel(N, 0)
    x, y, vx, vy = me.dynamicsymbols("x y vx vy")
    B, qb, ub, kd = _body(N, "B")
    M, m, g = sp.symbols("M m g")
    J, rho = _inertia_sym("J"), sp.symbols("rho1:4")
    Fx, Fy, M1, M2, M3 = sp.symbols("F_x F_y M_1 M_2 M_3")
    P = O_.locatenew("P", x * N.x + y * N.y)
    P.set_vel(N, vx * N.x + vy * N.y)
    C = P.locatenew("C", rho[0] * B.x + rho[1] * B.y + rho[2] * B.z)
    C.v2pt_theory(P, N, B)
    cart = me.Particle("cart", P, M)
    body = me.RigidBody("body", C, B, m, (_com_inertia(B, J, m, rho), C))
    loads = [(P, M * g * N.z + Fx * N.x + Fy * N.y), (C, m * g * N.z),
             (B, M1 * B.x + M2 * B.y + M3 * B.z)]
    kd_all = [sp.diff(x, me.dynamicsymbols._t) - vx, sp.diff(y, me.dynamicsymbols._t) - vy,
              *kd]
    return _finish(N, [x, y, *qb], [vx, vy, *ub], kd_all, [cart, body], loads,
                   [M, m, *J, *rho, g], [Fx, Fy, M1, M2, M3])


@cache
def quadrotor_slung_load() -> Derivation:
    """Kane's equations of the quadrotor with a slung load.

    Quadrotor on R^3 x SO(3), point load on a cable at polar angles ``(theta, phi)``; inputs
    ``(f, M1, M2, M3)``; parameters ``(mQ, J6, mL, L, g)``.
    """
    t = me.dynamicsymbols._t
    N, O_ = me.ReferenceFrame("N"), me.Point("O")
    O_.set_vel(N, 0)
    xs, vs = me.dynamicsymbols("x1:4"), me.dynamicsymbols("v1:4")
    th, ph, wth, wph = me.dynamicsymbols("theta phi w_theta w_phi")
    B, qb, ub, kd = _body(N, "B")
    mQ, mL, L, g = sp.symbols("m_Q m_L L g")
    J = _inertia_sym("J")
    f, M1, M2, M3 = sp.symbols("f M_1 M_2 M_3")
    Q = O_.locatenew("Q", xs[0] * N.x + xs[1] * N.y + xs[2] * N.z)
    Q.set_vel(N, vs[0] * N.x + vs[1] * N.y + vs[2] * N.z)
    qv = sp.sin(th) * sp.cos(ph) * N.x + sp.sin(th) * sp.sin(ph) * N.y + sp.cos(th) * N.z
    Ld = Q.locatenew("Ld", L * qv)
    Ld.set_vel(N, Q.vel(N) + L * qv.diff(t, N).subs({sp.diff(th, t): wth,
                                                     sp.diff(ph, t): wph}))
    quad = me.RigidBody("quad", Q, B, mQ, (me.inertia(B, J[0], J[1], J[2], J[3], J[4], J[5]),
                                           Q))
    load = me.Particle("load", Ld, mL)
    loads = [(Q, mQ * g * N.z - f * B.z), (Ld, mL * g * N.z), (B, M1 * B.x + M2 * B.y + M3 * B.z)]
    kd_all = [sp.diff(xs[i], t) - vs[i] for i in range(3)] + kd + [
        sp.diff(th, t) - wth, sp.diff(ph, t) - wph]
    return _finish(N, [*xs, *qb, th, ph], [*vs, *ub, wth, wph], kd_all, [quad, load], loads,
                   [mQ, *J, mL, L, g], [f, M1, M2, M3])


@cache
def double_pendulum3d() -> Derivation:
    """Kane's equations of the double 3D pendulum.

    Two rigid bodies on spherical joints (pivot inertias ``J1``, ``J2``, offsets ``rho1``,
    ``rho2``, joint ``d1``); no inputs; parameters ``(m1, J1_6, rho1_3, d1_3, m2, J2_6,
    rho2_3, g)``.
    """
    N, O_ = me.ReferenceFrame("N"), me.Point("O")
    O_.set_vel(N, 0)
    B1, q1, u1, kd1 = _body(N, "B1")
    B2, q2, u2, kd2 = _body(N, "B2")
    m1, m2, g = sp.symbols("m1 m2 g")
    J1, J2 = _inertia_sym("J1_"), _inertia_sym("J2_")
    rho1, d1, rho2 = sp.symbols("rho1_1:4"), sp.symbols("d1_1:4"), sp.symbols("rho2_1:4")
    C1 = O_.locatenew("C1", rho1[0] * B1.x + rho1[1] * B1.y + rho1[2] * B1.z)
    C1.v2pt_theory(O_, N, B1)
    P2 = O_.locatenew("P2", d1[0] * B1.x + d1[1] * B1.y + d1[2] * B1.z)
    P2.v2pt_theory(O_, N, B1)
    C2 = P2.locatenew("C2", rho2[0] * B2.x + rho2[1] * B2.y + rho2[2] * B2.z)
    C2.v2pt_theory(P2, N, B2)
    b1 = me.RigidBody("b1", C1, B1, m1, (_com_inertia(B1, J1, m1, rho1), C1))
    b2 = me.RigidBody("b2", C2, B2, m2, (_com_inertia(B2, J2, m2, rho2), C2))
    loads = [(C1, m1 * g * N.z), (C2, m2 * g * N.z)]
    return _finish(N, [*q1, *q2], [*u1, *u2], kd1 + kd2, [b1, b2], loads,
                   [m1, *J1, *rho1, *d1, m2, *J2, *rho2, g], [])


def _sym6(J) -> list[float]:
    J = np.asarray(J, dtype=float).reshape(3, 3)
    return [J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[1, 2], J[0, 2]]


def _angles(rng) -> np.ndarray:
    """Body 3-2-1 angles with the pitch away from +-90 degrees."""
    return np.array([rng.uniform(-3, 3), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3)])


def _rel(a, b) -> float:
    b = np.asarray(b, dtype=float)
    return float(np.max(np.abs(np.asarray(a) - b)) / max(1.0, float(np.max(np.abs(b)))))


def deviation(model, rng: np.random.Generator, n: int = 5) -> float:
    """Largest deviation of ``model``'s accelerations from Kane's equations at ``n`` states.

    Parameters
    ----------
    model : Model
        One of ``pendulum3d_cart`` (with ``body_moment=True``), ``quadrotor_slung_load`` or
        ``double_pendulum3d``, with any parameter values.
    rng : numpy.random.Generator
        Draws the states (angles away from their singularities), speeds and inputs.
    n : int
        Number of states.

    Returns
    -------
    float
        ``max |a_model - a_Kane| / max(1, |a_Kane|)`` over the states and the velocity
        coordinates (for the cable, ``omega-dot = q x q-ddot``).
    """
    v = model.values
    worst = 0.0
    for _ in range(n):
        if model.name == "pendulum3d_cart":
            d = pendulum3d_cart()
            ang, w = _angles(rng), rng.normal(size=3)
            xy, vv = rng.normal(size=2), rng.normal(size=2)
            u = rng.normal(size=model.n_inputs)
            p = [v["M"], v["m"], *_sym6(v["J"]), *np.ravel(v["rho"]), v["g"]]
            a = d.udot(p, [*xy, *ang], [*vv, *w], np.r_[u, np.zeros(5 - len(u))])
            x = model.state(x=xy, v=vv, R=rotation(ang), Omega=w)
            f = model.manifold.split(model.rhs(x, u))
            worst = max(worst, _rel(f["v"], a[0:2]), _rel(f["Omega"], a[2:5]))
        elif model.name == "quadrotor_slung_load":
            worst = max(worst, _quadrotor_once(model, rng))
        elif model.name == "double_pendulum3d":
            d = double_pendulum3d()
            a1, a2, w1, w2 = _angles(rng), _angles(rng), rng.normal(size=3), rng.normal(size=3)
            p = [v["m1"], *_sym6(v["J1"]), *np.ravel(v["rho1"]), *np.ravel(v["d1"]), v["m2"],
                 *_sym6(v["J2"]), *np.ravel(v["rho2"]), v["g"]]
            a = d.udot(p, [*a1, *a2], [*w1, *w2], [])
            x = model.state(R1=rotation(a1), Omega1=w1, R2=rotation(a2), Omega2=w2)
            f = model.manifold.split(model.rhs(x))
            worst = max(worst, _rel(f["Omega1"], a[0:3]), _rel(f["Omega2"], a[3:6]))
        else:
            raise ValueError(f"no Kane reference for model {model.name!r}")
    return worst


def _quadrotor_once(model, rng) -> float:
    v = model.values
    d = quadrotor_slung_load()
    ang, th, ph = _angles(rng), rng.uniform(0.3, 2.8), rng.uniform(-3, 3)
    wth, wph = rng.normal(size=2)
    xq, vq, w, u = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), rng.normal(size=4)
    q = direction(th, ph)
    d_th = np.array([np.cos(th) * np.cos(ph), np.cos(th) * np.sin(ph), -np.sin(th)])
    d_ph = np.array([-np.sin(th) * np.sin(ph), np.sin(th) * np.cos(ph), 0.0])
    qdot = d_th * wth + d_ph * wph
    x = model.state(xQ=xq, vQ=vq, R=rotation(ang), Omega=w, q=np.r_[q, np.cross(q, qdot)])
    f = model.manifold.split(model.rhs(x, u))
    p = [v["mQ"], *_sym6(v["JQ"]), v["mL"], v["L"], v["g"]]
    a = d.udot(p, [*xq, *ang, th, ph], [*vq, *w, wth, wph], u)
    ath, aph = a[6:8]
    d_phph = np.array([-np.sin(th) * np.cos(ph), -np.sin(th) * np.sin(ph), 0.0])
    d_thph = np.array([-np.cos(th) * np.sin(ph), np.cos(th) * np.cos(ph), 0.0])
    qddot = d_th * ath + d_ph * aph - q * wth**2 + 2 * d_thph * wth * wph + d_phph * wph**2
    return max(_rel(f["vQ"], a[0:3]), _rel(f["Omega"], a[3:6]),
               _rel(f["q"][3:6], np.cross(q, qddot)))
