"""The papers' controllers: closed loops against the papers' closed-loop equations.

Every check compares the graph u = k(x, p), put through the model, with an independent
numpy evaluation of the closed loop the paper writes down, or with the paper's closed-form
linearisation; bad gains must raise with the paper's condition in the message.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import controllers as ctl
from models import pendulum3d as p3
from models.chain_cart import chain_cart
from models.spherical import spherical_pendulum
from tests.conftest import assert_close
from workbench.core.errors import ManifoldError, ModelError, ParameterError
from workbench.core.manifolds import SO3, hat, so3_exp
from workbench.linear._eigen import eigenstructure
from workbench.linear._linearize import linearize

J7 = np.array([[30.0, 20, 7], [20, 40, 0], [7, 0, 50]])
E3 = np.array([0.0, 0.0, 1.0])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


@pytest.fixture(scope="module")
def full():
    return p3.full(J=J7, rho=[0.0, 0.0, 0.2], m=100.0, g=10.0)


@pytest.fixture(scope="module")
def reduced():
    return p3.reduced(J=J7, rho=[0.0, 0.0, 0.2], m=100.0, g=10.0)


def _u(k: ca.Function, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.asarray(k(x, p)).ravel()


# ----------------------------------------------------------------------------------------
# paper 001


def test_linear_velocity_feedback_on_both_models(full, reduced, rng):
    D = np.array([[3.0, 1.0, 0.0], [1.0, 2.0, 0.5], [0.0, 0.5, 1.0]])
    for model in (full, reduced):
        k = ctl.angular_velocity_feedback(model, D=D)
        for _ in range(5):
            x = model.manifold.random_point(rng)
            w = x[-3:]
            assert_close(_u(k, x, model.p), -D @ w, atol=1e-13, what="u = -D omega")


def test_saturated_feedback_bound_and_exact_jacobian_at_rest(reduced, rng):
    P, kk = np.diag([5.0, 10.0, 15.0]), 10.0
    k = ctl.saturated_velocity_feedback(reduced, P=P, k=kk)
    for scale in (1e-3, 1.0, 1e3, 1e8):
        x = np.r_[E3, scale * rng.standard_normal(3)]
        u = _u(k, x, reduced.p)
        Pw = P @ x[3:]
        assert_close(u, -kk * Pw / (1 + np.linalg.norm(Pw)), atol=1e-12 * kk, what="(34)")
        assert np.linalg.norm(u) < kk
    # d u / d omega at omega = 0 is -k P: finite, exact (paper 001 (13), Psi'(0) = k P)
    xs = ca.SX.sym("x", 6)
    jac = ca.Function("j", [xs], [ca.jacobian(k(xs, reduced.p), xs)])
    assert_close(np.asarray(jac(np.r_[E3, 0, 0, 0]))[:, 3:], -kk * P, atol=1e-13,
                 what="Psi'(0)")


def test_general_psi_and_its_checks(reduced):
    k = ctl.psi_feedback(reduced, lambda w: ca.tanh(w) + 0.1 * w**3)
    w = np.array([0.3, -2.0, 5.0])
    assert_close(_u(k, np.r_[E3, w], reduced.p), -(np.tanh(w) + 0.1 * w**3), atol=1e-13,
                 what="u = -Psi(omega)")
    with pytest.raises(ParameterError, match=r"Psi\(0\) must be 0"):
        ctl.psi_feedback(reduced, lambda w: w + 1)
    with pytest.raises(ParameterError, match=r"\(13\).*non-symmetric"):
        ctl.psi_feedback(reduced, lambda w: ca.DM([[1, 1, 0], [0, 1, 0], [0, 0, 1]]) @ w)
    with pytest.raises(ParameterError, match=r"\(13\).*eigenvalues"):
        ctl.psi_feedback(reduced, lambda w: ca.DM(np.diag([1.0, -1.0, 1.0])) @ w)
    # Psi'(0) = I but x^T Psi(x) < 0 for large x: refuted by the sampled check of (13)
    with pytest.raises(ParameterError, match=r"violates paper 001 \(13\)"):
        ctl.psi_feedback(reduced, lambda w: w - 0.01 * w**3)
    with pytest.raises(ModelError, match="casadi"):
        ctl.psi_feedback(reduced, lambda w: np.tanh(np.asarray(w, dtype=float)))


@pytest.mark.parametrize("D", [np.diag([1.0, -1.0, 2.0]), np.diag([1.0, 0.0, 2.0]),
                               np.array([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]])])
def test_bad_damping_gain_names_condition_13(full, D):
    with pytest.raises(ParameterError, match=r"D must be symmetric positive definite.*\(13\)"):
        ctl.angular_velocity_feedback(full, D=D)


def test_bad_saturation_gains_name_condition_34(full):
    with pytest.raises(ParameterError, match=r"P must be symmetric positive definite.*\(34\)"):
        ctl.saturated_velocity_feedback(full, P=np.diag([5.0, -10.0, 15.0]), k=10.0)
    with pytest.raises(ParameterError, match=r"k must be positive.*\(34\)"):
        ctl.saturated_velocity_feedback(full, P=np.eye(3), k=0.0)
    with pytest.raises(ParameterError, match="3x3"):
        ctl.saturated_velocity_feedback(full, P=np.eye(2), k=1.0)


def test_velocity_feedback_needs_omega_factor():
    with pytest.raises(ModelError, match="omega"):
        ctl.angular_velocity_feedback(spherical_pendulum(), D=np.eye(3))


def test_remark_2_spectrum_of_the_hanging_equilibrium(reduced):
    """Paper 001 Remark 2: with diagonal D, (s^2 + d1 s + m g l1)(s^2 + d2 s + m g l2)(s + d3).

    With J diagonal and rho = |rho| e3, M = sqrt(J) and l_i = |rho| / J_i.
    """
    J = np.diag([3.0, 2.0, 1.5])
    m, g, r = 2.0, 9.81, 0.4
    model = p3.reduced(J=J, rho=[0, 0, r], m=m, g=g)
    D = np.diag([0.7, 1.1, 0.9])
    k = ctl.angular_velocity_feedback(model, D=D)
    ev = eigenstructure(linearize(model, np.r_[E3, 0, 0, 0], controller=k)).eigenvalues
    d = np.diag(D) / np.diag(J)  # D of (19) is M^-1 Psi'(0) M^-T
    lam = [m * g * r / J[0, 0], m * g * r / J[1, 1]]
    ref = np.concatenate([np.roots([1, d[0], lam[0]]), np.roots([1, d[1], lam[1]]), [-d[2]]])
    assert_close(np.sort_complex(ev), np.sort_complex(ref), atol=1e-12, what="Remark 2")


# ----------------------------------------------------------------------------------------
# paper 002


def test_s2_pd_closed_loop_is_paper_002_equations_1_2(rng):
    model = spherical_pendulum(m=1.3, l=0.7, g=9.81)
    for _ in range(5):
        qd = _unit(rng.standard_normal(3))
        kq, kw = rng.uniform(0.5, 3.0, 2)
        k = ctl.s2_pd(model, qd, k_q=kq, k_w=kw)
        x = model.manifold.random_point(rng)
        q, w = x[:3], x[3:]
        xdot = model.rhs(x, _u(k, x, model.p))
        assert_close(xdot[3:], -kw * w - kq * np.cross(qd, q), atol=1e-12, what="(1)")
        assert_close(xdot[:3], np.cross(w, q), atol=1e-14, what="(2)")


def test_s2_pd_spectra_at_hanging_and_inverted():
    """Paper 002 Sec. II-C with k_q = k_w = 1: (-1 +- sqrt(3) i)/2 twice; saddle."""
    model = spherical_pendulum()
    k = ctl.s2_pd(model, E3, k_q=1.0, k_w=1.0)
    ev = eigenstructure(linearize(model, np.r_[E3, 0, 0, 0], controller=k)).eigenvalues
    ref = np.array([-0.5 + 0.5j * np.sqrt(3), -0.5 - 0.5j * np.sqrt(3)] * 2)
    assert_close(np.sort_complex(ev), np.sort_complex(ref), atol=1e-7, what="hanging")
    es = eigenstructure(linearize(model, np.r_[-E3, 0, 0, 0], controller=k))
    ref = np.array([-(np.sqrt(5) + 1) / 2] * 2 + [(np.sqrt(5) - 1) / 2] * 2)
    assert_close(np.sort(es.eigenvalues.real), np.sort(ref), atol=1e-7, what="inverted")
    assert es.n_unstable == 2


def test_s2_pd_bad_input():
    model = spherical_pendulum()
    with pytest.raises(ManifoldError, match="q_d"):
        ctl.s2_pd(model, [0.0, 0.0, 1.01], k_q=1.0, k_w=1.0)
    with pytest.raises(ParameterError, match="k_q"):
        ctl.s2_pd(model, E3, k_q=-1.0, k_w=1.0)
    with pytest.raises(ParameterError, match="k_w"):
        ctl.s2_pd(model, E3, k_q=1.0, k_w=0.0)


def _e_R(R: np.ndarray, Rd: np.ndarray, G: np.ndarray) -> np.ndarray:
    M = np.diag(G) @ Rd.T @ R - R.T @ Rd @ np.diag(G)
    return 0.5 * np.array([M[2, 1], M[0, 2], M[1, 0]])


def test_so3_pd_closed_loop_is_paper_002_equation_13(rng):
    J = np.array([[3.0, 0.2, 0.1], [0.2, 2.0, 0.0], [0.1, 0.0, 1.0]])
    G = np.array([0.9, 1.0, 1.1])
    kR, kW = 1.7, 0.8
    model = p3.full(J=J, rho=[0.05, -0.1, 0.3], m=1.5)
    for _ in range(4):
        Rd = SO3.matrix(SO3().random_point(rng))
        k = ctl.so3_pd(model, Rd, k_R=kR, k_Omega=kW, G=G)
        x = model.manifold.random_point(rng)
        R, w = SO3.matrix(x[:9]), x[9:]
        xdot = model.rhs(x, _u(k, x, model.p))
        ref = np.linalg.solve(J, np.cross(J @ w, w) - kR * _e_R(R, Rd, G) - kW * w)
        assert_close(xdot[9:], ref, atol=1e-12, what="(13)")
        # gravity is cancelled: another mass and centre of mass give the same closed loop
        other = model.with_parameters(m=7.0, rho=[0.3, 0.2, -0.1])
        assert_close(other.rhs(x, _u(k, x, other.p))[9:], ref, atol=1e-12, what="cancel")


def test_so3_pd_equilibria_and_spectrum_at_the_goal():
    """e_R = 0 at R_d exp(pi e_i^); at R_d the linearisation (16) with H = tr(G) I - G."""
    J, G = np.diag([3.0, 2.0, 1.0]), np.array([0.9, 1.0, 1.1])
    model = p3.full(J=J, rho=[0.0, 0.0, 0.3])
    Rd = so3_exp(np.array([0.3, -1.0, 0.5]))
    k = ctl.so3_pd(model, Rd, k_R=1.0, k_Omega=1.0, G=np.diag(G))
    for i in range(3):
        Re = Rd @ so3_exp(np.pi * np.eye(3)[i])
        x = np.r_[SO3.flat(Re), 0, 0, 0]
        assert np.max(np.abs(model.rhs(x, _u(k, x, model.p)))) < 1e-12
    ev = eigenstructure(linearize(model, np.r_[SO3.flat(Rd), 0, 0, 0], controller=k))
    H = np.sum(G) - G
    ref = np.concatenate([np.roots([1, 1 / J[i, i], H[i] / (2 * J[i, i])]) for i in range(3)])
    assert_close(np.sort_complex(ev.eigenvalues), np.sort_complex(ref), atol=1e-12,
                 what="(16) at R_d")


def test_so3_pd_bad_input():
    model = p3.full(J=np.eye(3), rho=[0, 0, 1.0])
    with pytest.raises(ManifoldError, match="R_d"):
        ctl.so3_pd(model, np.eye(3) + 1e-3 * hat([1.0, 0, 0]) @ hat([1.0, 0, 0]), k_R=1,
                   k_Omega=1, G=[1, 1, 1])
    with pytest.raises(ParameterError, match=r"G must be diagonal"):
        ctl.so3_pd(model, np.eye(3), k_R=1, k_Omega=1, G=np.ones((3, 3)))
    with pytest.raises(ParameterError, match=r"G must have positive"):
        ctl.so3_pd(model, np.eye(3), k_R=1, k_Omega=1, G=[1.0, -1.0, 1.0])
    with pytest.raises(ParameterError, match="k_Omega"):
        ctl.so3_pd(model, np.eye(3), k_R=1, k_Omega=0, G=[1, 1, 1])
    with pytest.raises(ModelError, match="SO3 state factor 'R'"):
        ctl.so3_pd(p3.reduced(J=np.eye(3), rho=[0, 0, 1.0]), np.eye(3), k_R=1, k_Omega=1,
                   G=[1, 1, 1])


# ----------------------------------------------------------------------------------------
# paper 003


GAINS = {"k_y": 4.0, "k_ydot": 2.8, "k_w": 1.0, "k_q": 14.0}


@pytest.fixture(scope="module")
def cart():
    return chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)


def _cart_state(rng: np.random.Generator, s: float) -> np.ndarray:
    while True:
        q = _unit(rng.standard_normal(3))
        if q[2] < -s - 0.05:
            break
    w = rng.standard_normal(3)
    w -= (w @ q) * q
    return np.r_[rng.standard_normal(2), rng.standard_normal(2), q, w]


def test_cart_feedback_makes_the_cart_a_double_integrator(cart, rng):
    """(21) with the erratum gives x-ddot = mu (22), mu from (26) evaluated in numpy."""
    k = ctl.cart_inverted_feedback(cart, **GAINS)
    C = np.eye(3)[:, :2]
    ky, kyd, kw, kq = GAINS.values()
    l1, g = 0.1, 9.81
    s = ctl.CartGains(**GAINS).s
    for _ in range(6):
        x = _cart_state(rng, s)
        pos, vel, q, w = x[0:2], x[2:4], x[4:7], x[7:10]
        qh2 = hat(q) @ hat(q)
        y = pos + kq * l1 * C.T @ q
        yd = vel - kq * l1 * C.T @ np.cross(q, w)
        A = (1 + kw) * np.eye(2) + kq * C.T @ qh2 @ C
        mu = np.linalg.solve(A, -ky * y - kyd * yd + kq * g * C.T @ qh2 @ E3
                             + kq * l1 * (w @ w) * C.T @ q)
        xdot = cart.rhs(x, _u(k, x, cart.p))
        assert_close(xdot[2:4], mu, atol=1e-10, rtol=1e-10, what="(22) x-ddot = mu")
        # (23): omega-dot = (g/l) q^ e3 - (1/l) q^ C mu
        assert_close(xdot[7:10], (g / l1) * np.cross(q, E3) - np.cross(q, C @ mu) / l1,
                     atol=1e-9, rtol=1e-10, what="(23)")


@pytest.mark.parametrize("k_q", [2.0, 1.5, 0.5])
def test_cart_gain_condition_of_proposition_5(cart, k_q):
    with pytest.raises(ParameterError, match=r"k_q must exceed 1 \+ k_w"):
        ctl.cart_inverted_feedback(cart, k_y=4.0, k_ydot=2.8, k_w=1.0, k_q=k_q)


def test_cart_controller_bad_model_and_gain():
    with pytest.raises(ModelError, match="n = 1"):
        ctl.cart_inverted_feedback(chain_cart(2), **GAINS)
    with pytest.raises(ParameterError, match="k_ydot"):
        ctl.cart_inverted_feedback(chain_cart(1), **{**GAINS, "k_ydot": -1.0})


def test_controllers_are_exportable_casadi_functions(full, cart, tmp_path):
    """Every controller is a plain (x, p) -> u casadi.Function that generates C code."""
    fns = [ctl.saturated_velocity_feedback(full, P=np.eye(3), k=1.0),
           ctl.so3_pd(full, np.eye(3), k_R=1.0, k_Omega=1.0, G=[1.0, 2.0, 3.0]),
           ctl.cart_inverted_feedback(cart, **GAINS)]
    for fn in fns:
        assert fn.name_in() == ["x", "p"] and fn.name_out() == ["u"]
        assert not fn.has_free()
        gen = ca.CodeGenerator(f"{fn.name()}.c")
        gen.add(fn)
        gen.generate(str(tmp_path) + "/")
        text = (tmp_path / f"{fn.name()}.c").read_text()
        assert f"int {fn.name()}(" in text


def test_gains_are_keyword_only():
    full = p3.full(J=np.eye(3), rho=[0, 0, 1.0])
    sphere = spherical_pendulum()
    calls = [lambda: ctl.angular_velocity_feedback(full, np.eye(3)),
             lambda: ctl.saturated_velocity_feedback(full, np.eye(3), 1.0),
             lambda: ctl.s2_pd(sphere, E3, 1.0, 1.0),
             lambda: ctl.so3_pd(full, np.eye(3), 1.0, 1.0, [1.0, 1.0, 1.0])]
    for call in calls:
        with pytest.raises(TypeError, match="positional argument"):
            call()
