"""The 3D pendulum family (paper 000): invariants, agreement between the models, special cases."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models import pendulum3d as p3
from problems.pendulum3d_invariants import planar_period
from workbench.core.errors import ManifoldError, ModelError
from workbench.core.manifolds import SO3, TS2
from workbench.simulation._simulate import simulate

J_DIAG = np.diag([0.13, 0.28, 0.17])
J_FULL = np.array([[0.30, 0.02, -0.01], [0.02, 0.22, 0.03], [-0.01, 0.03, 0.18]])
RHO = np.array([0.01, -0.02, 0.3])
E3 = np.array([0.0, 0.0, 1.0])


def _invariant_rates(model, x):
    """d/dt of each invariant along the uncontrolled field, from the graph (exact)."""
    xs = ca.SX.sym("x", model.manifold.ambient_dim) if model.symbolic == "SX" else \
        ca.MX.sym("x", model.manifold.ambient_dim)
    f = model.function("f")(xs, np.zeros(model.n_inputs), model.p)
    rates = {}
    for name in model.invariant_names:
        inv = model.function(name)(xs, model.p)
        rate = ca.Function("r", [xs], [ca.jtimes(inv, xs, f)])
        rates[name] = float(rate(x))
    return rates


@pytest.mark.parametrize(
    "make",
    [
        lambda: p3.full(J=J_FULL, rho=RHO),
        lambda: p3.reduced(J=J_FULL, rho=RHO),
        lambda: p3.routh(J=J_FULL, rho=RHO, mu=0.37),
        lambda: p3.spinning_top(Jt=0.2, Ja=0.05, rho_s=0.3, spin=4.0),
        lambda: p3.planar(Jt=0.2, rho_s=0.3),
    ],
    ids=["full", "reduced", "routh", "top", "planar"],
)
def test_invariants_are_first_integrals_of_the_graph(make, rng):
    model = make()
    for _ in range(5):
        x = model.manifold.random_point(rng, scale=2.0)
        for name, rate in _invariant_rates(model, x).items():
            assert abs(rate) < 1e-12, f"d{name}/dt = {rate:.3e} at a random state"


def test_full_model_conserves_E_and_h_over_100s():
    model = p3.full(J=J_DIAG, rho=[0, 0, 0.3])
    x0 = model.state(R=np.eye(3), omega=np.ones(3))
    tr = simulate(model, x0, np.linspace(0, 100, 501), rtol=1e-12, atol=1e-12)
    d = tr.diagnostics["invariant_drift"]
    assert d["energy"]["max_rel"] < 1e-9 and d["h"]["max_rel"] < 1e-9
    assert tr.diagnostics["constraint_residual"]["R"] < 1e-8


def test_reduced_model_is_the_projection_of_the_full_model():
    full, red = p3.full(J=J_FULL, rho=RHO), p3.reduced(J=J_FULL, rho=RHO)
    R0 = p3.so3_exp([0.3, -0.5, 0.2])
    w0 = np.array([1.0, -0.4, 0.7])
    t = np.linspace(0, 30, 301)
    a = simulate(full, full.state(R=R0, omega=w0), t, rtol=1e-12, atol=1e-12)
    b = simulate(red, red.state(Gamma=R0.T @ E3, omega=w0), t, rtol=1e-12, atol=1e-12)
    gamma = np.einsum("nji,j->ni", a.part("R"), E3)
    assert_close(gamma, b.x[:, :3], atol=1e-9, what="Gamma = R^T e3")
    assert_close(a.x[:, 9:], b.x[:, 3:], atol=1e-8, what="omega")


def test_routh_field_equals_lagrange_poincare_field_written_in_gamma_dot(rng):
    """(5.7)-(5.9) against an independent form: Gamma'' from (4.3)-(4.4) with
    omega = Gamma' x Gamma + (nu - b) Gamma (5.11), (5.14)."""
    for _ in range(10):
        mu = rng.uniform(-1, 1)
        model = p3.routh(J=J_FULL, rho=RHO, mu=mu)
        x = TS2().random_point(rng, scale=1.5)
        gam, gdot = x[:3], x[3:]
        JG = J_FULL @ gam
        gJg = gam @ JG
        b = JG @ np.cross(gdot, gam) / gJg
        w = np.cross(gdot, gam) + (mu / gJg - b) * gam
        assert_close(np.cross(gam, w), gdot, atol=1e-14, what="Gamma' = Gamma x omega")
        wdot = np.linalg.solve(J_FULL, np.cross(J_FULL @ w, w) + 9.81 * np.cross(RHO, gam))
        gddot = np.cross(gdot, w) + np.cross(gam, wdot)
        assert_close(model.rhs(x)[3:], gddot, atol=1e-12, what="Gamma'' (5.7)")


def test_routh_reconstruction_gives_back_the_full_motion():
    full = p3.full(J=J_FULL, rho=RHO)
    x0 = full.state(R=p3.so3_exp([0.2, 0.1, -0.3]), omega=[0.8, -0.6, 1.1])
    t = np.linspace(0, 100, 1001)
    a = simulate(full, x0, t, rtol=1e-12, atol=1e-12)
    ts, mu = p3.routh_state_from_full(full, x0)
    recon = p3.routh_reconstruction(J=J_FULL, rho=RHO, mu=mu)
    b = simulate(recon, np.r_[ts, x0[:9], 0.0], t,
                 rtol=1e-12, atol=1e-12)
    R, w = p3.reconstruct(recon, b.x)
    assert_close(R, a.part("R"), atol=1e-7, what="R (5.13)")
    assert_close(w, a.x[:, 9:], atol=1e-7, what="omega (5.14)")
    with pytest.raises(ModelError, match="routh_reconstruction"):
        p3.reconstruct(full, a.x)
    with pytest.raises(ModelError, match=r"shape \(n, 16\)"):
        p3.reconstruct(recon, b.x[:, :15])


def test_planar_period_matches_the_elliptic_integral():
    for theta0 in (0.3, 2.0, 3.0):
        per = planar_period(Jt=0.2, rho_s=0.3, theta0=theta0)
        assert abs(per["measured"] - per["closed_form"]) < 1e-8 * per["closed_form"]


def test_spinning_top_is_the_axisymmetric_3d_pendulum_at_constant_spin():
    top = p3.spinning_top(Jt=0.2, Ja=0.05, rho_s=0.3, spin=3.0)
    axi = p3.reduced(J=np.diag([0.2, 0.2, 0.05]), rho=[0, 0, 0.3])
    g0 = np.array([np.sin(0.7), 0.0, np.cos(0.7)])
    t = np.linspace(0, 10, 101)
    a = simulate(top, top.state(Gamma=g0, omega_xy=[0.2, 0.1]), t, rtol=1e-12, atol=1e-12)
    b = simulate(axi, axi.state(Gamma=g0, omega=[0.2, 0.1, 3.0]), t, rtol=1e-12, atol=1e-12)
    assert_close(a.x[:, :3], b.x[:, :3], atol=1e-9, what="Gamma")
    assert_close(b.x[:, 5], np.full(101, 3.0), atol=1e-9, what="omega_z stays at the spin")


def test_off_manifold_initial_states_are_rejected_not_normalised():
    model = p3.full(J=J_DIAG, rho=[0, 0, 0.3])
    R0 = np.array([[0, -0.9999, -0.0141], [-1, 0, 0], [0, 0.0141, -0.9999]])  # paper 001
    x0 = np.r_[SO3.flat(R0), 0, 0, 0]
    with pytest.raises(ManifoldError, match=r"x0\['R'\] is not on SO3.*SO3\(\)\.project"):
        simulate(model, x0, [0, 1])
    with pytest.raises(ManifoldError, match="must have 12 entries"):
        simulate(model, np.zeros(11), [0, 1])
