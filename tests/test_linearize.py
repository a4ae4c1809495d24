"""Linearisation from the graph: closed forms of the papers, finite differences, errors."""

from __future__ import annotations

import importlib
import itertools

import numpy as np
import pytest
import scipy.linalg as sla
from conftest import assert_close
from hypothesis import given, settings
from hypothesis import strategies as st

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from models.controllers import s2_pd
from models.spherical import spherical_pendulum
from workbench.core.errors import ManifoldError, ModelError
from workbench.core.manifolds import SO3, hat, so3_exp
from workbench.linear._linearize import (
    linearize,
    linearize_ambient,
    mechanical_order,
    tangent_labels,
)

E3 = np.array([0.0, 0.0, 1.0])


def rotation_taking(a, b):
    """A rotation R with R a = b (unit vectors), by Rodrigues' formula."""
    a, b = np.asarray(a, float) / np.linalg.norm(a), np.asarray(b, float) / np.linalg.norm(b)
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), a @ b
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        perp = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
        return so3_exp(np.pi * perp / np.linalg.norm(perp))
    return so3_exp(axis / s * np.arctan2(s, c))


def random_body(rng):
    L = rng.standard_normal((3, 3))
    J = L @ L.T + 0.5 * np.eye(3)
    rho = rng.standard_normal(3)
    return {"J": J, "rho": rho, "m": float(rng.uniform(0.5, 3.0)), "g": 9.81}


def pendulum_equilibrium(body, *, inverted, spin=0.0):
    """(R_e, Gamma_e): the body's centre of mass below (hanging) or above the pivot."""
    rho_hat = body["rho"] / np.linalg.norm(body["rho"])
    target = -E3 if inverted else E3
    R = so3_exp(spin * E3) @ rotation_taking(rho_hat, target)
    return R, R.T @ E3


def stiffness(body, k):
    """Paper 000 (3.21) / 001 (17): stiffness -k (m g / |rho|) hat(rho)^2."""
    rho = body["rho"]
    return -k * body["m"] * body["g"] / np.linalg.norm(rho) * hat(rho) @ hat(rho)


def test_full_pendulum_matches_paper_000_3_21(rng):
    for _ in range(3):
        body = random_body(rng)
        model = p3.full(**body)
        for inverted, k in ((False, 1), (True, -1)):
            R, _ = pendulum_equilibrium(body, inverted=inverted, spin=rng.uniform(-3, 3))
            lin = linearize(model, model.state(R=R, omega=np.zeros(3)))
            assert lin.A.shape == (6, 6) and lin.B.shape == (6, 3)
            K = stiffness(body, k)
            A_ref = np.block([[np.zeros((3, 3)), np.eye(3)],
                              [-np.linalg.solve(body["J"], K), np.zeros((3, 3))]])
            B_ref = np.vstack([np.zeros((3, 3)), np.linalg.inv(body["J"])])
            assert_close(lin.A, A_ref, atol=1e-11, rtol=1e-11, what="A vs (3.21)")
            assert_close(lin.B, B_ref, atol=1e-12, what="B = [0; J^-1]")
            assert lin.residual_norm < 1e-12


def test_reduced_and_routh_models_have_the_same_nonzero_spectrum(rng):
    body = random_body(rng)
    mgl = sla.eigh(stiffness(body, 1), body["J"], eigvals_only=True)[1:]  # drop the zero
    full, red = p3.full(**body), p3.reduced(**body)
    routh = p3.routh(**body, mu=0.0)
    for inverted, sign in ((False, 1), (True, -1)):
        R, gam = pendulum_equilibrium(body, inverted=inverted)
        lf = linearize(full, full.state(R=R, omega=np.zeros(3)))
        lr = linearize(red, red.state(Gamma=gam, omega=np.zeros(3)))
        lt = linearize(routh, routh.state(Gamma=np.r_[gam, np.zeros(3)]))
        assert (lf.dim, lr.dim, lt.dim) == (6, 5, 4)
        nonzero = np.sort_complex(np.concatenate([np.sqrt(-sign * mgl + 0j),
                                                  -np.sqrt(-sign * mgl + 0j)]))
        for lin, n_zero in ((lf, 2), (lr, 1), (lt, 0)):
            ev = np.linalg.eigvals(lin.A)
            ev = ev[np.argsort(np.abs(ev))]
            assert_close(np.abs(ev[:n_zero]), np.zeros(n_zero), atol=1e-6, what="zeros")
            got = np.sort_complex(ev[n_zero:])
            # sort_complex is unstable for +-0 real parts: compare as sets via distance
            for z in nonzero:
                assert np.min(np.abs(got - z)) < 1e-9 * max(1, abs(z)), (z, got)


def test_labels_and_dimensions_of_the_papers_manifolds():
    body = {"J": np.diag([1.0, 2.0, 3.0]), "rho": [0, 0, 0.5]}
    assert tangent_labels(p3.full(**body)) == ["R.eta1", "R.eta2", "R.eta3", "omega1",
                                               "omega2", "omega3"]
    chain = chain_cart(3)
    assert len(tangent_labels(chain)) == chain.manifold.dim == 4 * 3 + 4
    pos, vel = mechanical_order(chain, {"x": "v"})
    labels = tangent_labels(chain)
    assert [labels[i] for i in pos][:4] == ["x1", "x2", "link1.v1", "link1.v2"]
    assert [labels[i] for i in vel][:4] == ["v1", "v2", "link1.eta1", "link1.eta2"]
    with pytest.raises(ModelError, match="neither a TS2 factor nor named in pairs"):
        mechanical_order(chain)
    with pytest.raises(ModelError, match="same dimension"):
        mechanical_order(p3.reduced(**body), {"Gamma": "omega"})


def test_s2_pd_closed_loop_matches_paper_002_6_and_7():
    model = spherical_pendulum(m=1.3, l=0.7)
    kq, kw = 1.0, 1.0
    k = s2_pd(model, E3, k_q=kq, k_w=kw)
    for q_e, ref_spec in (
        (E3, [(-1 + np.sqrt(3) * 1j) / 2, (-1 - np.sqrt(3) * 1j) / 2] * 2),
        (-E3, [-(np.sqrt(5) + 1) / 2] * 2 + [(np.sqrt(5) - 1) / 2] * 2),
    ):
        x_e = model.state(q=np.r_[q_e, np.zeros(3)])
        lin = linearize(model, x_e, controller=k)
        s = float(q_e[2])
        # (6) restricted to (v, eta) = (C^T xi, C^T delta omega) at omega = 0, q = s e3:
        # v' = eta, eta' = kq C^T hat(e3) hat(s e3) C v - kw eta = -s kq v - kw eta
        A_ref = np.block([[np.zeros((2, 2)), np.eye(2)], [-s * kq * np.eye(2), -kw * np.eye(2)]])
        assert_close(lin.A, A_ref, atol=1e-12, what=f"A at q = {s:+.0f} e3")
        ev = np.linalg.eigvals(lin.A)
        for z in ref_spec:
            assert np.min(np.abs(ev - z)) < 1e-7
        amb = linearize_ambient(model, x_e, controller=k)
        assert amb.A.shape == (6, 6) and amb.C.shape == (2, 6)
        admissible, spurious = amb.constrained_eigenvalues()
        assert_close(np.sort(admissible.real), np.sort(ev.real), atol=1e-7, what="restriction")
        # the spurious pair depends on how the field is extended off TS^2: paper 002's (1)
        # gives 0 and -k_omega; the model keeps only the moment normal to q, so the normal
        # component of delta omega is neutral and both are 0
        assert_close(np.sort(spurious.real), [0.0, 0.0], atol=1e-12, what="spurious")


def test_custom_basis_and_permutation_are_similarity_transforms(rng):
    body = random_body(rng)
    model = p3.full(**body)
    R, _ = pendulum_equilibrium(body, inverted=True)
    x_e = model.state(R=R, omega=np.zeros(3))
    lin = linearize(model, x_e)
    T = rng.standard_normal((6, 6)) + 3 * np.eye(6)
    lin_t = linearize(model, x_e, basis=lin.basis @ T)
    assert_close(lin_t.A, np.linalg.solve(T, lin.A @ T), atol=1e-9, rtol=1e-9, what="T^-1 A T")
    assert_close(lin_t.B, np.linalg.solve(T, lin.B), atol=1e-10, what="T^-1 B")
    # the chart is consistent with the basis: d chart(x_e + N dz) / d dz = I
    dz = 1e-6 * rng.standard_normal(6)
    x = model.manifold.retract(x_e, np.linalg.solve(np.eye(6), T @ dz))
    assert_close(lin_t.chart(x), dz, atol=1e-10, what="chart in the new basis")
    order = rng.permutation(6)
    lp = lin.permuted(order)
    assert_close(lp.A, lin.A[np.ix_(order, order)], atol=0, what="permuted A")
    assert_close(lp.chart(x), lin.chart(x)[order], atol=1e-15, what="permuted chart")


def test_to_statespace_round_trip():
    model = p3.full(J=np.diag([1.0, 2.0, 3.0]), rho=[0, 0, 0.5])
    lin = linearize(model, model.state(R=np.eye(3), omega=np.zeros(3)))
    ss = lin.to_statespace()
    assert_close(ss.A, lin.A, atol=0, what="A")
    assert_close(ss.B, lin.B, atol=0, what="B")
    assert ss.state_labels[0] == "R_eta1"
    assert_close(np.sort(ss.poles().imag), np.sort(np.linalg.eigvals(lin.A).imag), atol=1e-9,
                 what="poles")


def test_bad_points_are_refused_with_the_residual():
    model = p3.full(J=np.diag([1.0, 2.0, 3.0]), rho=[0, 0, 0.5])
    with pytest.raises(ModelError, match=r"not an equilibrium.*max \|f\(x_e, u_e\)\| = 0\.2.*"
                                         r"R: 0\.2"):
        linearize(model, model.state(R=np.eye(3), omega=[0.2, 0, 0]))
    tilted = model.state(R=so3_exp([0.3, 0, 0]), omega=np.zeros(3))
    with pytest.raises(ModelError, match="not an equilibrium.*omega"):
        linearize(model, tilted)
    # ... but it is one with the input that holds it there: u_e = -m g rho x R^T e3
    moment = 1.0 * 9.81 * np.cross(model.values["rho"], so3_exp([0.3, 0, 0]).T @ E3)
    lin = linearize(model, tilted, u_e=-moment)
    assert lin.residual_norm < 1e-12
    with pytest.raises(ManifoldError, match="x_e.*not on SO3"):
        linearize(model, np.r_[1.01 * SO3.flat(np.eye(3)), np.zeros(3)])
    with pytest.raises(ModelError, match="u_e must be 3 finite numbers"):
        linearize(model, model.state(R=np.eye(3), omega=np.zeros(3)), u_e=[1.0])
    with pytest.raises(ManifoldError, match="basis must have shape"):
        linearize(model, model.state(R=np.eye(3), omega=np.zeros(3)), basis=np.eye(6))
    x_e = model.state(R=np.eye(3), omega=np.zeros(3))
    N = linearize(model, x_e).basis
    with pytest.raises(ManifoldError, match="tangent"):
        linearize(model, x_e, basis=N + 0.1)
    with pytest.raises(ManifoldError, match="dependent"):
        linearize(model, x_e, basis=np.column_stack([N[:, :5], N[:, 0]]))
    with pytest.raises(ModelError, match="controller must"):
        linearize(model, x_e, controller="pd")


# ----------------------------------------------------------------------------------------
# agreement with finite differences of the vector field in the chart, random models


def _fd_linearization(model, x_e, u_e, controller=None, h=1e-6):
    """Central differences of z -> pinv(N) f(retract(x_e, z)): A and B to O(h^2)."""
    N = model.manifold.tangent_basis(x_e)
    L = np.linalg.pinv(N)
    f = model.function("f")

    def field(x, du):
        u = u_e + du
        if controller is not None:
            u = u + np.asarray(controller(x, model.p)).ravel()
        return np.asarray(f(x, u, model.p)).ravel()

    dim, m = N.shape[1], model.n_inputs
    A = np.zeros((dim, dim))
    for j in range(dim):
        e = np.zeros(dim)
        e[j] = h
        A[:, j] = L @ (field(model.manifold.retract(x_e, e), np.zeros(m))
                       - field(model.manifold.retract(x_e, -e), np.zeros(m))) / (2 * h)
    B = np.zeros((dim, m))
    for j in range(m):
        e = np.zeros(m)
        e[j] = h
        B[:, j] = L @ (field(x_e, e) - field(x_e, -e)) / (2 * h)
    return A, B


@settings(max_examples=12, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**31 - 1), inverted=st.booleans(), spin=st.floats(-3.0, 3.0))
def test_pendulum_agrees_with_finite_differences(seed, inverted, spin):
    rng = np.random.default_rng(seed)
    body = random_body(rng)
    for model in (p3.full(**body), p3.reduced(**body)):
        R, gam = pendulum_equilibrium(body, inverted=inverted, spin=spin)
        parts = {"R": R} if "R" in model.manifold.names else {"Gamma": gam}
        x_e = model.state(**parts, omega=np.zeros(3))
        lin = linearize(model, x_e)
        A, B = _fd_linearization(model, x_e, np.zeros(3))
        scale = max(1.0, np.max(np.abs(lin.A)))
        assert_close(lin.A, A, atol=1e-6 * scale, what=f"A vs FD ({model.name})")
        assert_close(lin.B, B, atol=1e-7 * max(1, np.max(np.abs(B))), what="B vs FD")


@settings(max_examples=8, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 3))
def test_chain_agrees_with_finite_differences(seed, n):
    rng = np.random.default_rng(seed)
    model = chain_cart(n, m=rng.uniform(0.2, 2), masses=rng.uniform(0.05, 0.5, n),
                       lengths=rng.uniform(0.05, 0.5, n), g=9.81)
    s = rng.choice([-1.0, 1.0], n)
    x_e = np.concatenate([rng.standard_normal(2), np.zeros(2)]
                         + [link_state(si * E3) for si in s])
    lin = linearize(model, x_e)
    A, B = _fd_linearization(model, x_e, np.zeros(2))
    scale = max(1.0, np.max(np.abs(lin.A)))
    assert_close(lin.A, A, atol=1e-6 * scale, what="chain A vs FD")
    assert_close(lin.B, B, atol=1e-6 * max(1, np.max(np.abs(B))), what="chain B vs FD")


def test_closed_loop_agrees_with_finite_differences(rng):
    model = spherical_pendulum(m=0.8, l=1.4)
    q_d = rng.standard_normal(3)
    q_d /= np.linalg.norm(q_d)
    k = s2_pd(model, q_d, k_q=2.0, k_w=0.7)
    for q_e in (q_d, -q_d):
        x_e = model.state(q=np.r_[q_e, np.zeros(3)])
        lin = linearize(model, x_e, controller=k)
        A, B = _fd_linearization(model, x_e, np.zeros(3), controller=k)
        assert_close(lin.A, A, atol=1e-7, what="closed-loop A vs FD")
        assert_close(lin.B, B, atol=1e-7, what="closed-loop B vs FD")


def test_all_chain_equilibria_are_equilibria():
    model = chain_cart(2)
    for s in itertools.product([1.0, -1.0], repeat=2):
        lin = linearize(model, np.concatenate([np.zeros(4)] + [link_state(si * E3)
                                                                 for si in s]))
        assert lin.dim == 12 and lin.residual_norm == 0.0


# ----------------------------------------------------------------------------------------
# moved from test_review_engine.py


def test_linearize_reexports_the_ambient_form_and_stays_small():
    amb = importlib.import_module("workbench.linear._ambient")
    # through importlib: the package binds the name linearize to the function
    lin_mod = importlib.import_module("workbench.linear._linearize")

    for name in ("AmbientLinearization", "linearize_ambient", "closed_loop_jacobians",
                 "EQUILIBRIUM_TOL"):
        assert getattr(lin_mod, name) is getattr(amb, name) and name in lin_mod.__all__
    for module in (lin_mod, amb):
        with open(module.__file__, encoding="utf-8") as fh:
            assert sum(1 for _ in fh) <= 600, f"{module.__name__} is past ~600 lines"


def test_a_kink_is_found_only_at_its_switching_point():
    """``V = k max(|x| - 1, 0)^2 / 2``, the dead zone of a spring: C^1, its force ``k (|x| -
    1) sign(x)`` outside the zone and zero inside, so the field has kinks at ``x = +-1`` and
    nowhere else. Linearised inside the zone it is the free particle; at ``x = 1`` it is
    refused (naming the comparison), and ``allow_kinks`` returns one one-sided derivative
    with the operations listed. The tolerance scales with the operands."""
    import casadi as ca

    from workbench import mechanics

    s = mechanics.System("dead_zone")
    x = s.rn("x", 1)
    s.point_mass(1.0, x.x)
    s.potential(0.5 * 4.0 * ca.fmax(ca.fabs(x.x[0]) - 1.0, 0.0) ** 2)
    model = s.model()
    lin = linearize(model, model.state(x=0.5, x_dot=0.0))
    assert np.array_equal(lin.A, [[0.0, 1.0], [0.0, 0.0]]) and lin.kinks == ()
    for edge in (1.0, -1.0, 1.0 + 1e-12):
        with pytest.raises(ModelError, match=r"not differentiable at x_e .*fmax\([-0-9.e]+, 0\)"):
            linearize(model, model.state(x=edge, x_dot=0.0))
    lin = linearize(model, model.state(x=1.0, x_dot=0.0), allow_kinks=True)
    assert lin.kinks and all(k.gap == 0.0 for k in lin.kinks)
    assert lin.kinks[0].function == "f"
    # off the edge by more than kink_tol * max(1, |x|): smooth there (inside the zone)
    linearize(model, model.state(x=1.0 - 1e-6, x_dot=0.0))
    with pytest.raises(ModelError, match="not differentiable"):
        linearize(model, model.state(x=1.0 - 1e-6, x_dot=0.0), kink_tol=1e-5)
    with pytest.raises(ModelError, match="allow_kinks must be True or False"):
        linearize(model, model.state(x=0.5, x_dot=0.0), allow_kinks="yes")


def test_the_papers_models_have_no_kink_at_their_equilibria():
    full = p3.full(J=np.diag([3.0, 2.0, 1.0]), rho=[0.0, 0.0, 0.5])
    for R in (np.diag([1.0, -1.0, -1.0]), np.eye(3)):
        assert linearize(full, full.state(R=R, omega=np.zeros(3))).kinks == ()
    sp = spherical_pendulum()
    assert linearize(sp, sp.state(q=np.r_[E3, np.zeros(3)])).kinks == ()
    chain = chain_cart(2)
    x_e = np.r_[np.zeros(4), link_state(-E3), link_state(-E3)]
    assert linearize(chain, x_e).kinks == ()
