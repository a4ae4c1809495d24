"""Reduced models of the systems beyond the papers (workbench.mechanics.reduce).

The Furuta pendulum by the shift of its arm angle, the 3D pendulum on a cart by its
translations, the quadrotor with a slung load by a translation and by yaw, the double 3D
pendulum by yaw of the pair. Checks: which inputs each reduction keeps and which it names
and holds; the quotient coordinates; the relative equilibria found as equilibria of the
reduced models against closed forms derived here by hand (the conical rod of the Furuta
pendulum, the uniform motion of the cart, the quadrotor's spinning hover with the load
swung out, the tilted double pendulum's amended potential); the full model started at the
lifted state moves along the group only (``x(t) = g_{xi t} x(0)``, simulated); the
Furuta Routh model's oscillation frequency about its tilted relative equilibrium against
the hand-derived Routhian.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import sympy as sp

from models.double_pendulum3d import double_pendulum3d
from models.furuta import furuta
from models.pendulum3d_cart import pendulum3d_cart
from models.quadrotor_slung_load import hover_input, quadrotor_slung_load
from problems._mechanics_reduction_beyond import planar_amended_potential, rx, steady_motion
from workbench import ModelError, mechanics, simulate
from workbench.core.manifolds import SO3
from workbench.equilibria import enumerate_equilibria, find_equilibrium
from workbench.linear import eigenstructure, linearize

E3 = np.array([0.0, 0.0, 1.0])
FURUTA = "angular_momentum_theta"


STEADY_TOL = 1e-8
"""Bound on ``|x(t) - g_{xi t} x(0)|`` simulated at rtol 1e-12 over about two turns: the
integrator's own phase error (3e-9 for the Furuta pendulum at 11 rad/s; 1e-10 at rtol
1e-13), well above the rounding of the field's residual."""


def _moves_along_the_group(red, x0, xi, u=None, t_end=1.0):
    """max over t of |x(t) - g_{xi t} x0| for the full model simulated from x0."""
    t = np.linspace(0.0, t_end, 6)
    ctrl = None
    if u is not None:
        x = ca.SX.sym("x", red.full.manifold.ambient_dim)
        ctrl = ca.Function("u", [x], [ca.DM(u)])
    traj = simulate(red.full, x0, t, controller=ctrl, rtol=1e-12, atol=1e-12)
    moved = np.array([np.asarray(red.act(x0, xi * tk), dtype=float).ravel() for tk in t])
    return float(np.max(np.abs(traj.x - moved)))


def _furuta_closed_form(values, alpha):
    """The arm rate and momentum of the link's steady angle alpha (thin rods, by hand).

    ``T = Ir th'^2 / 2 + mp |p'|^2 / 2 + Jp (a'^2 + th'^2 sin^2 a) / 2``, ``V = -mp g l cos
    a``, ``l = Lp / 2``, ``Jp = mp Lp^2 / 12``: at ``a' = 0``, ``th'' = 0`` the link's
    equation is ``sin a (mp g l - Omega^2 (mp l^2 + Jp) cos a) = 0``.
    """
    v = {k: float(x) for k, x in values.items()}
    omega = np.sqrt(3 * v["g"] / (2 * v["Lp"] * np.cos(alpha)))
    inertia = (v["mr"] / 3 + v["mp"]) * v["Lr"] ** 2 + v["mp"] * v["Lp"] ** 2 / 3 \
        * np.sin(alpha) ** 2
    return omega, inertia * omega


def test_furuta_motor_is_refused_by_name_and_held_or_kept():
    full = furuta()
    with pytest.raises(ModelError, match=r"motor torque on the arm.*u\[0\]: it changes the "
                                         r"momentum 'angular_momentum_theta'.*hold_zero"):
        mechanics.reduce(full, FURUTA, momentum=0.01)
    ro = mechanics.reduce(full, FURUTA, momentum=0.01, breaking_inputs="hold_zero")
    assert ro.held_inputs == (0,) and ro.model.n_inputs == 0
    assert ro.model.manifold.names == ["alpha", "alpha_dot"]
    lp = mechanics.reduce(full, FURUTA, kind="lagrange_poincare")
    assert lp.held_inputs == () and lp.model.n_inputs == 1  # equivariant: kept
    assert lp.model.manifold.names == ["theta_dot", "alpha", "alpha_dot"]


@pytest.mark.parametrize("alpha", [0.4, 1.2])
def test_furuta_relative_equilibria_are_the_conical_rod(alpha):
    full = furuta()
    omega, mu = _furuta_closed_form(full.values, alpha)
    ro = mechanics.reduce(full, FURUTA, momentum=mu, breaking_inputs="hold_zero")
    starts = [ro.model.state(alpha=a, alpha_dot=[0.0])
              for a in np.linspace(0.0, 2 * np.pi, 8, endpoint=False)]
    found = enumerate_equilibria(ro.model, starts).equilibria
    angles = np.sort([np.arctan2(e.x[1], e.x[0]) for e in found])
    np.testing.assert_allclose(angles, [-alpha, 0.0, alpha, np.pi], rtol=0, atol=1e-12)
    tilted = next(e for e in found if abs(np.arctan2(e.x[1], e.x[0]) - alpha) < 1e-6)
    s = steady_motion(ro, tilted.x)
    assert abs(s["xi"] - omega) <= 1e-12 * omega and abs(s["momentum"] - mu) <= 1e-15
    assert s["residual"] <= 1e-12
    assert _moves_along_the_group(ro, s["x"], s["xi"]) <= STEADY_TOL


def test_furuta_routh_frequency_is_the_hand_routhians():
    """About the tilted relative equilibrium: omega_n^2 = V_mu''(a) / m_eff(a) with the
    shape mass ``m_eff = mp Lp^2 / 3 - (mp Lr l cos a)^2 / I(a)`` (the arm eliminated)."""
    full = furuta()
    v = {k: float(x) for k, x in full.values.items()}
    alpha = 0.9
    _, mu = _furuta_closed_form(full.values, alpha)
    a = sp.Symbol("a")
    half, mp = v["Lp"] / 2, v["mp"]
    inertia = (v["mr"] / 3 + mp) * v["Lr"] ** 2 + mp * v["Lp"] ** 2 / 3 * sp.sin(a) ** 2
    vmu = -mp * v["g"] * half * sp.cos(a) + mu**2 / (2 * inertia)
    m_eff = mp * v["Lp"] ** 2 / 3 - (mp * v["Lr"] * half * sp.cos(a)) ** 2 / inertia
    assert abs(float(sp.diff(vmu, a).subs(a, alpha))) <= 1e-15
    w2 = float((sp.diff(vmu, a, 2) / m_eff).subs(a, alpha))
    ro = mechanics.reduce(full, FURUTA, momentum=mu, breaking_inputs="hold_zero")
    eig = eigenstructure(linearize(ro.model, ro.model.state(alpha=alpha, alpha_dot=[0.0])))
    lam = np.sort(eig.eigenvalues.imag)
    assert np.max(np.abs(eig.eigenvalues.real)) <= 1e-9
    np.testing.assert_allclose(lam, [-np.sqrt(w2), np.sqrt(w2)], rtol=1e-11)


@pytest.mark.parametrize("symmetry, held, direction", [("p_x", 0, 0), ("p_y", 1, 1)])
def test_cart_translation_routh_moves_the_hanging_pendulum_uniformly(symmetry, held,
                                                                     direction):
    full = pendulum3d_cart()
    total = float(full.values["M"] + full.values["m"])
    mu = 0.7
    ro = mechanics.reduce(full, symmetry, momentum=mu, breaking_inputs="hold_zero")
    assert ro.held_inputs == (held,) and ro.model.n_inputs == 1  # the other force stays
    assert ro.model.manifold.names == ["x", "v", "R", "Omega"]
    tilt = rx(0.4)  # released tilted: Newton finds the hanging equilibrium
    eq = find_equilibrium(ro.model, ro.model.state(x=[0.2], v=[0.0], R=tilt,
                                                   Omega=[0.0, 0.0, 0.0]))
    s = steady_motion(ro, eq.x)
    np.testing.assert_allclose(SO3.matrix(eq.parts["R"]).T @ E3, E3, atol=1e-12)
    assert abs(s["xi"] - mu / total) <= 1e-14
    assert s["x"][2 + direction] == pytest.approx(mu / total, abs=1e-14)  # the cart's v
    vmu = float(ro.amended_potential(eq.x, ro.model.p))
    V = float(ro.potential_full(s["x"], full.p))
    assert abs(vmu - V - mu**2 / (2 * total)) <= 1e-14
    assert _moves_along_the_group(ro, s["x"], s["xi"], t_end=2.0) <= STEADY_TOL


def test_cart_reconstruction_reproduces_the_full_model():
    full = pendulum3d_cart()
    x0 = full.manifold.random_point(np.random.default_rng(11), scale=0.5)
    lp = mechanics.reduce(full, "p_y", kind="lagrange_poincare")
    ro = mechanics.reduce(full, "p_y", momentum=lp.momentum_of(x0), breaking_inputs="hold_zero")
    t = np.linspace(0.0, 2.0, 11)
    rec = ro.reconstruct(simulate(ro.reconstruction, ro.reconstruction_state(x0), t,
                                  rtol=1e-12, atol=1e-12))
    ref = simulate(full, x0, t, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(rec.x - ref.x)) <= 1e-8


def test_quadrotor_routh_holds_what_breaks_and_falls_freely():
    full = quadrotor_slung_load()
    v = {k: float(np.asarray(x).ravel()[0]) for k, x in full.values.items() if k != "JQ"}
    with pytest.raises(ModelError, match=r"u\[0\]: it changes the momentum 'p_x'"):
        mechanics.reduce(full, "p_x", momentum=0.0)
    ro = mechanics.reduce(full, "p_x", momentum=0.3, breaking_inputs="hold_zero")
    assert ro.held_inputs == (0,) and ro.model.n_inputs == 3  # the body moment stays
    yaw = mechanics.reduce(full, "L_z", momentum=0.3, breaking_inputs="hold_zero")
    assert yaw.held_inputs == (0, 1, 2, 3)  # thrust and moment both turn L_z
    rng = np.random.default_rng(12)
    for _ in range(5):  # nothing holds it up: the centre of mass falls at g
        x, moment = ro.full_state(ro.model.manifold.random_point(rng)), rng.standard_normal(3)
        f = np.asarray(full.function("f")(x, np.r_[0.0, moment], full.p))
        acc_q, w, wd, q = f[3:6].ravel(), x[21:24], f[21:24].ravel(), x[18:21]
        acc_l = acc_q + v["L"] * (np.cross(wd, q) + np.cross(w, np.cross(w, q)))
        com = (v["mQ"] * acc_q + v["mL"] * acc_l) / (v["mQ"] + v["mL"])
        np.testing.assert_allclose(com, v["g"] * E3, rtol=0, atol=1e-12 * v["g"])
        r = ro.state_from_full(x)
        np.testing.assert_allclose(ro.model.rhs(r, moment),
                                   np.asarray(ro.project_rate(x, f)).ravel(), atol=1e-12)


def test_quadrotor_spinning_hover_with_the_load_swung_out():
    """Level, spinning at Omega about the vertical through the centre of mass, the load out
    at beta: ``cos(beta) = (mQ + mL) g / (mQ L Omega^2)`` (tension ``T q = mL (g e3 +
    Omega^2 b n)``, ``mQ Omega^2 a = T |q_h|``, ``mQ a = mL b``, ``a + b = L sin beta``)."""
    full = quadrotor_slung_load()
    mq, ml, L, g = (float(full.values[k]) for k in ("mQ", "mL", "L", "g"))
    hover = hover_input(full)
    lp = mechanics.reduce(full, "L_z", kind="lagrange_poincare")
    assert lp.held_inputs == () and lp.model.n_inputs == 4
    omega = 6.0
    beta = np.arccos((mq + ml) * g / (mq * L * omega**2))
    b = mq * L * np.sin(beta) / (mq + ml)
    a = ml * b / mq
    q = np.array([0.0, np.sin(beta), np.cos(beta)])
    x0 = full.state(xQ=[0.0, -a, 0.0], vQ=[omega * a, 0.0, 0.0], R=np.eye(3),
                    Omega=[0.0, 0.0, omega], q=np.r_[q, omega * E3 - (omega * q[2]) * q])
    r = lp.state_from_full(x0)
    assert np.max(np.abs(lp.model.rhs(r, hover))) <= 1e-12 * omega**2
    eq = find_equilibrium(lp.model, r, u=hover)
    assert eq.iterations == 0
    s = steady_motion(lp, r, hover)
    assert abs(s["xi"] - omega) <= 1e-12 * omega and s["residual"] <= 1e-12
    assert _moves_along_the_group(lp, x0, omega, u=hover) <= STEADY_TOL


def test_double_pendulum_quotient_coordinates_are_gamma1_and_r1t_r2():
    full = double_pendulum3d()
    ro = mechanics.reduce(full, "L_z", momentum=0.8)
    lp = mechanics.reduce(full, "L_z", kind="lagrange_poincare")
    assert ro.model.manifold.names == ["Gamma", "R2_rel", "Omega2_rel"]
    assert lp.model.manifold.names == ["Gamma", "Omega1", "R2_rel", "Omega2"]
    rng = np.random.default_rng(13)
    x = full.manifold.random_point(rng)
    R1, W1, R2, W2 = SO3.matrix(x[0:9]), x[9:12], SO3.matrix(x[12:21]), x[21:24]
    Q = R1.T @ R2
    gam = R1.T @ E3
    np.testing.assert_allclose(lp.state_from_full(x), np.r_[gam, W1, Q.T.ravel(), W2],
                               atol=1e-15)
    x = ro.full_state(ro.model.manifold.random_point(rng))  # at the momentum 0.8
    R1, W1, R2, W2 = SO3.matrix(x[0:9]), x[9:12], SO3.matrix(x[12:21]), x[21:24]
    Q, gam = R1.T @ R2, R1.T @ E3
    w = -(W1 - (W1 @ gam) * gam)  # Gamma-dot = w x Gamma
    np.testing.assert_allclose(ro.state_from_full(x), np.r_[gam, w, Q.T.ravel(), W2 - Q.T @ W1],
                               atol=1e-14)


def test_double_pendulum_relative_equilibria_are_the_hand_amended_potentials():
    full = double_pendulum3d()
    mu = 0.8
    ro = mechanics.reduce(full, "L_z", momentum=mu)
    grad, hess, inertia = planar_amended_potential(full.values, mu)
    from scipy import optimize

    ranks = {}
    for phi in [(0.0, 0.0), (0.0, np.pi), (0.4, 0.7), (0.3, -0.8), (0.6, -2.9), (3.0, -1.0)]:
        start = ro.model.state(Gamma=np.r_[rx(phi[0]).T @ E3, 0.0, 0.0, 0.0],
                               R2_rel=rx(phi[1] - phi[0]), Omega2_rel=[0.0, 0.0, 0.0])
        eq = find_equilibrium(ro.model, start)
        g1, Q = eq.parts["Gamma"][:3], SO3.matrix(eq.parts["R2_rel"])
        found = np.array([np.arctan2(g1[1], g1[2]), 0.0])
        found[1] = found[0] + np.arctan2(Q[2, 1], Q[1, 1])
        hand = optimize.root(lambda y: grad(*y), found, jac=lambda y: hess(*y), tol=1e-15).x
        np.testing.assert_allclose(np.angle(np.exp(1j * (hand - found))), 0.0, atol=1e-10)
        s = steady_motion(ro, eq.x)
        assert abs(s["xi"] * inertia(*found) - mu) <= 1e-12 * mu
        assert s["residual"] <= 1e-12
        ranks[phi] = eq.rank
        if phi == (0.4, 0.7):
            assert _moves_along_the_group(ro, s["x"], s["xi"]) <= STEADY_TOL
    # tangent dimension 10: the tilted pair is isolated; the aligned pair keeps a circle of
    # critical points (body 2 turned about the common vertical axis, a Morse-Bott circle)
    assert ranks[(0.4, 0.7)] == 10 and ranks[(0.0, 0.0)] == 9 and ranks[(0.0, np.pi)] == 9


@pytest.mark.parametrize("kind", ["routh", "lagrange_poincare"])
def test_furuta_reconstruction_reproduces_the_full_model(kind):
    full = furuta()
    x0 = full.state(theta=0.3, theta_dot=[4.0], alpha=2.0, alpha_dot=[-1.5])
    lp = mechanics.reduce(full, FURUTA, kind="lagrange_poincare")
    mom = {"momentum": lp.momentum_of(x0)} if kind == "routh" else {}
    red = mechanics.reduce(full, FURUTA, kind=kind, breaking_inputs="hold_zero", **mom)
    t = np.linspace(0.0, 2.0, 11)
    rec = red.reconstruct(simulate(red.reconstruction, red.reconstruction_state(x0), t,
                                   rtol=1e-12, atol=1e-12))
    ref = simulate(full, x0, t, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(rec.x - ref.x)) <= 1e-8
