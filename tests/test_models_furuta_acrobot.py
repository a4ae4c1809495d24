"""The Furuta pendulum and the acrobot, written with S^1 factors, against independent physics.

Checked: the acrobot's field equals Spong's closed-form equations ``M(q) q-ddot +
C(q, q-dot) q-dot = tau_g(q) + B u`` in angles (Tedrake's form) at random states, inputs and
parameters; the Furuta pendulum's field equals Lagrange's equations derived independently in
sympy from rotation matrices (``omega = vee(R^T R-dot)``, the rods' inertia tensors); both
conserve their energy unforced and the Furuta pendulum its arm-angle momentum (named as an
angular momentum, found again by ``detect_momenta``, kept by the variational integrator to
the Newton tolerance); the linearisations at hanging and upright have the closed-form
spectra and are PBH controllable upright; ``find_equilibrium`` lands on the equilibria; a
swing-up OCP of the Furuta pendulum solves; an LQR feedback of the acrobot upright exported
to C agrees with casadi and its header says S^1.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import sympy as sp

import workbench as wb
from models import acrobot as acro
from models import furuta as fur
from workbench import ModelError, codegen
from workbench.control.ocp import Collocation, solve
from workbench.control.ocp.study import effort_time_ocp


def _random_parameters(rng, base):
    return {k: v * rng.uniform(0.5, 2.0) for k, v in base.items()}


def _random_state(model, rng, names):
    a, b = names
    return model.state(**{a: rng.uniform(-np.pi, np.pi), f"{a}_dot": [rng.normal(0, 3)],
                          b: rng.uniform(-np.pi, np.pi), f"{b}_dot": [rng.normal(0, 3)]})


def _angles(x):
    """Angles and rates from the stored state ``(p1, rate1, p2, rate2)`` (test only)."""
    return (np.arctan2(x[1], x[0]), x[2], np.arctan2(x[4], x[3]), x[5])


# ---------------------------------------------------------------------------------------
# the acrobot against Spong's equations


def spong_acceleration(q1, q2, w1, w2, u, P):
    """``q-ddot`` of Spong's acrobot in Tedrake's form (inertias about the joints)."""
    m1, m2, l1, lc1, lc2, g = (P[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    J1, J2 = P["I1"] + m1 * lc1**2, P["I2"] + m2 * lc2**2
    c2, s1, s2, s12 = np.cos(q2), np.sin(q1), np.sin(q2), np.sin(q1 + q2)
    M = np.array([[J1 + J2 + m2 * l1**2 + 2 * m2 * l1 * lc2 * c2, J2 + m2 * l1 * lc2 * c2],
                  [J2 + m2 * l1 * lc2 * c2, J2]])
    C = np.array([[-2 * m2 * l1 * lc2 * s2 * w2, -m2 * l1 * lc2 * s2 * w2],
                  [m2 * l1 * lc2 * s2 * w1, 0.0]])
    tau_g = np.array([-m1 * g * lc1 * s1 - m2 * g * (l1 * s1 + lc2 * s12),
                      -m2 * g * lc2 * s12])
    return np.linalg.solve(M, tau_g + np.array([0.0, u]) - C @ np.array([w1, w2]))


@pytest.fixture(scope="module")
def acrobot():
    return acro.acrobot()


def test_acrobot_field_is_spongs_equations(acrobot):
    rng = np.random.default_rng(11)
    for trial in range(8):
        P = acro.SPONG_1995 if trial == 0 else _random_parameters(rng, acro.SPONG_1995)
        model = acrobot.with_parameters(**P)
        x = _random_state(model, rng, ("theta1", "theta2"))
        u = rng.normal(0, 2)
        f = model.rhs(x, [u])
        q1, w1, q2, w2 = _angles(x)
        acc = spong_acceleration(q1, q2, w1, w2, u, P)
        expected = np.r_[w1 * np.array([-x[1], x[0]]), acc[0], w2 * np.array([-x[4], x[3]]),
                         acc[1]]
        assert np.max(np.abs(f - expected)) <= 1e-11 * np.max(np.abs(expected)), (f, expected)


# ---------------------------------------------------------------------------------------
# the Furuta pendulum against a sympy derivation from rotation matrices


def _rz(a):
    return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])


def _rx(a):
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


def _vee(W):
    return sp.Matrix([W[2, 1], W[0, 2], W[1, 0]])


@pytest.fixture(scope="module")
def furuta_reference():
    """``(theta, alpha, rates, u, parameters) -> (theta-ddot, alpha-ddot)`` by sympy.

    Independent of the model: attitudes ``R_arm = Rz(theta)``, ``R_link = Rz(theta)
    Rx(alpha)``, body angular velocities ``vee(R^T R-dot)``, the rods' inertia tensors
    (arm about its end, link about its centre of mass, both with no inertia about their own
    axis), gravity along +e3, and Lagrange's equations with the torque on theta.
    """
    t = sp.symbols("t")
    th, al = sp.Function("theta")(t), sp.Function("alpha")(t)
    mr, Lr, mp, Lp, g, u = sp.symbols("mr Lr mp Lp g u", positive=True)
    R_arm, R_link = _rz(th), _rz(th) * _rx(al)
    w_arm = _vee(R_arm.T * R_arm.diff(t))
    w_link = _vee(R_link.T * R_link.diff(t))
    J_arm = sp.diag(0, mr * Lr**2 / 3, mr * Lr**2 / 3)  # rod along its body x, about its end
    J_link = sp.diag(mp * Lp**2 / 12, mp * Lp**2 / 12, 0)  # rod along its body z, about com
    com = Lr * R_arm * sp.Matrix([1, 0, 0]) + Lp / 2 * R_link * sp.Matrix([0, 0, 1])
    v = com.diff(t)
    T = (w_arm.T * J_arm * w_arm / 2 + w_link.T * J_link * w_link / 2)[0] + mp * v.dot(v) / 2
    L = T - (-mp * g * com[2])
    q, Q = [th, al], [u, 0]
    eqs = [sp.diff(L.diff(qi.diff(t)), t) - L.diff(qi) - Qi for qi, Qi in zip(q, Q)]
    dd = [qi.diff(t, 2) for qi in q]
    A, b = sp.linear_eq_to_matrix([sp.expand(e) for e in eqs], dd)
    syms = sp.symbols("th al wth wal")
    subs = {th.diff(t): syms[2], al.diff(t): syms[3]}
    subs2 = {th: syms[0], al: syms[1]}
    A = A.subs(subs).subs(subs2)
    b = b.subs(subs).subs(subs2)
    args = [*syms, u, mr, Lr, mp, Lp, g]
    fA, fb = sp.lambdify(args, A, "numpy"), sp.lambdify(args, b, "numpy")

    def acc(th_, al_, wth, wal, u_, P):
        a = [th_, al_, wth, wal, u_, P["mr"], P["Lr"], P["mp"], P["Lp"], P["g"]]
        return np.linalg.solve(np.asarray(fA(*a), float), np.asarray(fb(*a), float).ravel())

    return acc


@pytest.fixture(scope="module")
def furuta():
    return fur.furuta()


def test_furuta_field_is_the_sympy_derivation(furuta, furuta_reference):
    rng = np.random.default_rng(12)
    for trial in range(8):
        P = fur.QUBE_SERVO_2 if trial == 0 else _random_parameters(rng, fur.QUBE_SERVO_2)
        model = furuta.with_parameters(**P)
        x = _random_state(model, rng, ("theta", "alpha"))
        u = rng.normal(0, 0.05)
        f = model.rhs(x, [u])
        th, wth, al, wal = _angles(x)
        acc = furuta_reference(th, al, wth, wal, u, P)
        expected = np.r_[wth * np.array([-x[1], x[0]]), acc[0], wal * np.array([-x[4], x[3]]),
                         acc[1]]
        assert np.max(np.abs(f - expected)) <= 1e-11 * np.max(np.abs(expected)), (f, expected)


# ---------------------------------------------------------------------------------------
# invariants


@pytest.mark.parametrize("which", ["acrobot", "furuta"])
def test_energy_is_conserved_unforced(which, acrobot, furuta):
    model, names = ((acrobot, ("theta1", "theta2")) if which == "acrobot"
                    else (furuta, ("theta", "alpha")))
    x0 = _random_state(model, np.random.default_rng(3), names)
    tr = wb.simulate(model, x0, np.linspace(0.0, 5.0, 51), rtol=1e-12, atol=1e-12)
    drift = tr.diagnostics["invariant_drift"]
    assert "energy" in drift
    for name, d in drift.items():
        assert d["max_abs"] <= 1e-8 * max(1.0, abs(d["initial"])), (name, d)


def test_furuta_arm_momentum_is_angular_and_conserved(furuta):
    assert furuta.invariant_names == ["energy", "angular_momentum_theta"]
    s = fur.furuta_system()
    s.momenta.clear()  # found again from the Lagrangian alone
    assert list(s.detect_momenta()) == ["angular_momentum_theta"]
    x0 = furuta.state(theta=0.4, theta_dot=[2.0], alpha=2.5, alpha_dot=[-3.0])
    tr = wb.simulate(furuta, x0, np.linspace(0.0, 5.0, 51), rtol=1e-12, atol=1e-12)
    J = np.array([furuta.invariants(x)["angular_momentum_theta"] for x in tr.x])
    assert np.ptp(J) <= 1e-9 * np.max(np.abs(J))
    # the motor breaks it: dJ/dt = u (the torque is the momentum's rate)
    J_fn = furuta.function("angular_momentum_theta")
    x = ca.SX.sym("x", x0.size)
    grad = np.asarray(ca.Function("g", [x], [ca.gradient(J_fn(x, furuta.p), x)])(x0)).ravel()
    for u in (0.0, 0.01):
        assert grad @ furuta.rhs(x0, [u]) == pytest.approx(u, abs=1e-15)


def test_variational_integrator_keeps_the_arm_momentum(furuta):
    x0 = furuta.state(theta=0.4, theta_dot=[2.0], alpha=2.5, alpha_dot=[-3.0])
    tr = wb.simulate(furuta, x0, np.linspace(0.0, 5.0, 51), method="mechanics_variational",
                     step=1e-3)
    J = np.array([furuta.invariants(x)["angular_momentum_theta"] for x in tr.x])
    assert np.ptp(J) <= 1e-11 * np.max(np.abs(J))  # discrete Noether, Newton tolerance
    E = np.array([furuta.invariants(x)["energy"] for x in tr.x])
    assert np.ptp(E) <= 1e-3 * abs(E[0])


# ---------------------------------------------------------------------------------------
# linearisations and equilibria


def test_furuta_spectra_hanging_and_upright(furuta):
    """``omega^2 = (mp g Lp/2) M11 / det M`` with the angle-coordinate mass matrix at rest."""
    P = fur.QUBE_SERVO_2
    mp, Lp, Lr, mr, g = P["mp"], P["Lp"], P["Lr"], P["mr"], P["g"]
    M11 = mr * Lr**2 / 3 + mp * Lr**2
    M22 = mp * Lp**2 / 12 + mp * Lp**2 / 4
    M12 = mp * Lr * Lp / 2
    w = np.sqrt(mp * g * Lp / 2 * M11 / (M11 * M22 - M12**2))
    for x, roots in ((fur.hanging(furuta, 1.0), [-1j * w, 1j * w]),
                     (fur.upright(furuta, -2.0), [-w, w])):
        lin = wb.linearize(furuta, x, [0.0])
        lam = np.sort_complex(np.linalg.eigvals(lin.A))
        zero, rest = lam[np.abs(lam) < 1e-9], lam[np.abs(lam) >= 1e-9]
        assert zero.size == 2  # the arm's orbit and its momentum (a Jordan pair)
        assert np.allclose(np.sort_complex(rest), roots, rtol=1e-12, atol=0)
        sym = wb.symmetry_directions(lin)
        assert set(sym.orbits) == {"angular_momentum_theta"}
        assert set(sym.conserved) == {"angular_momentum_theta"} and sym.unexplained == 0
    assert wb.pbh(wb.linearize(furuta, fur.upright(furuta), [0.0])).controllable


def test_acrobot_spectra_hanging_and_upright(acrobot):
    """``lambda^2`` are the eigenvalues of ``-M^{-1} K`` with Spong's ``M`` and ``K``."""
    P = acro.SPONG_1995
    m1, m2, l1, lc1, lc2, g = (P[k] for k in ("m1", "m2", "l1", "lc1", "lc2", "g"))
    J1, J2 = P["I1"] + m1 * lc1**2, P["I2"] + m2 * lc2**2
    M = np.array([[J1 + J2 + m2 * l1**2 + 2 * m2 * l1 * lc2, J2 + m2 * l1 * lc2],
                  [J2 + m2 * l1 * lc2, J2]])
    K = g * np.array([[m1 * lc1 + m2 * (l1 + lc2), m2 * lc2], [m2 * lc2, m2 * lc2]])
    mu = np.linalg.eigvals(np.linalg.solve(M, K))  # hanging: lambda^2 = -mu, upright +mu
    assert np.all(mu > 0)
    for x, sign in ((acro.hanging(acrobot), -1.0), (acro.upright(acrobot), 1.0)):
        lin = wb.linearize(acrobot, x, [0.0])
        lam2 = np.linalg.eigvals(lin.A) ** 2  # pairs +-lambda: lambda^2 = sign * mu, twice
        assert np.max(np.abs(lam2.imag)) <= 1e-12 * np.max(mu)
        assert np.allclose(np.sort(lam2.real), np.sort(np.repeat(sign * mu, 2)), rtol=1e-12)
    assert wb.pbh(wb.linearize(acrobot, acro.upright(acrobot), [0.0])).controllable


def test_find_equilibrium_lands_on_upright_with_the_angle_wrapped(acrobot):
    """A guess at theta1 = pi + 0.2 - 2 pi: Newton on S^1 x S^1, no angle to wrap."""
    guess = acrobot.state(theta1=np.pi + 0.2 - 2 * np.pi, theta1_dot=[0.0], theta2=-0.15,
                          theta2_dot=[0.0])
    eq = wb.find_equilibrium(acrobot, guess)
    assert np.allclose(eq.x, acro.upright(acrobot), atol=1e-12)
    eig = wb.eigenstructure(wb.linearize(acrobot, eq.x, [0.0]))
    assert int(np.sum(eig.eigenvalues.real > 1e-8)) == 2


def test_helpers_refuse_another_model(furuta, acrobot):
    with pytest.raises(ModelError, match="acrobot"):
        acro.upright(furuta)
    with pytest.raises(ModelError, match="Furuta"):
        fur.hanging(acrobot)


# ---------------------------------------------------------------------------------------
# optimal control and C export


def test_furuta_swing_up_ocp_solves(furuta):
    ocp = effort_time_ocp(furuta, fur.hanging(furuta), fur.upright(furuta), u_max=0.05,
                          T=(0.5, 4.0), free=("theta",), name="furuta_swingup")
    sol = solve(ocp, Collocation(N=60))
    assert sol.status.ok, sol
    xf = sol.x[-1]
    assert np.allclose(xf[3:5], [-1.0, 0.0], atol=1e-8)  # the link upright, the arm anywhere
    assert abs(xf[2]) <= 1e-8 and abs(xf[5]) <= 1e-8
    # Ipopt relaxes bounds by bound_relax_factor = 1e-8 * max(1, |bound|): 1e-8 absolute here
    assert np.all(np.abs(sol.u) <= 0.05 + 2e-8)
    # the transcription follows the dynamics: each interval integrated by CVODES from its
    # node lands on the next node
    assert sol.error["local_defect"] <= 2e-3  # 8e-4 measured at N = 60 (order 6 in h)
    re = sol.resimulate()  # open loop over the whole swing-up: amplified by the upright's
    assert re["end_error"] <= 1e-2, re  # instability (4e-4 measured, 5e-7 on another minimum)


def test_acrobot_lqr_exported_to_c_agrees_and_says_s1(acrobot, tmp_path):
    x_up = acro.upright(acrobot)
    lin = wb.linearize(acrobot, x_up, [0.0])
    k = wb.lqr(lin, Q=np.eye(4), R=np.eye(1)).feedback(name="acrobot_lqr")
    out = codegen.export_feedback(acrobot, k, tmp_path / "c", name="acrobot_lqr",
                                  title="LQR of the acrobot upright", example_state=x_up)
    states = out.controller.sample_states(200, seed=5)
    gap = codegen.agreement(out.controller, out.compiled, states,
                            binding=codegen.Binding.FROZEN)
    assert gap.max() < 1e-13
    header = (tmp_path / "c" / "acrobot_lqr.h").read_text()
    flat = " ".join(header.replace("*", " ").split())
    assert "S^1 theta1 (cos, sin) x S^1 theta2 (cos, sin)" in flat
    assert "theta1: S^1 factor 'theta1': an angle on S^1 stored as (cos, sin)" in flat
    assert "R^k" not in header
    # the law at the upright state is zero, and it drives a tilted state back
    assert np.allclose(np.asarray(k(x_up, acrobot.p)).ravel(), 0.0, atol=1e-14)
    x_tilt = acrobot.state(theta1=np.pi + 0.05, theta1_dot=[0.0], theta2=-0.05,
                           theta2_dot=[0.0])
    tr = wb.simulate(acrobot, x_tilt, np.linspace(0.0, 10.0, 11), controller=k, rtol=1e-10,
                     atol=1e-10)
    assert np.allclose(tr.x[-1], x_up, atol=1e-6)
