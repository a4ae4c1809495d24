"""The variational integrator of models made by workbench.mechanics (R^k, S^1, SO(3), S^2).

Checked: every step solves the discrete Euler-Lagrange equations of the discrete Lagrangian
written independently (AD through the inverse Cayley map; on S^2 the reference shares the
integrator's w = 2/h (q_k x q_{k+1}) / (1 + q_k . q_{k+1}), so there the independent
evidence is the order-2 convergence to CVODES); second-order convergence to
CVODES (free, and with a velocity feedback: the discrete Lagrange-d'Alembert forcing and its
implicit end); symmetry (a step of -h undoes a step of h); bounded energy error without
secular drift over 10^4 steps where RKMK4 drifts; the momenta of the symmetries conserved to
the Newton tolerance's scale (3D pendulum, the pendulum on a cart with an R^2 factor, the
double 3D pendulum); bad input refused.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import workbench as wb
from models import pendulum3d
from models.acrobot import acrobot
from models.chain_cart import chain_cart, link_state
from models.double_pendulum3d import double_pendulum3d
from models.furuta import furuta
from models.pendulum3d_cart import pendulum3d_cart
from models.quadrotor_slung_load import quadrotor_slung_load
from models.spherical import spherical_pendulum
from workbench import ModelError, ParameterError, SolverError
from workbench.simulation import constraint_residuals
from workbench.simulation.integrators import integrate, mechanics_variational

METHOD = "mechanics_variational"


@pytest.fixture(scope="module")
def pendulum():
    model = pendulum3d.full(J=np.diag([0.13, 0.28, 0.17]), rho=[0.05, 0.02, 0.3])
    x0 = model.state(R=wb.so3_exp([1.2, 0.4, 0.1]), omega=[0.8, -0.5, 1.5])
    return model, x0


def _errors(model, x0, t, steps, controller=None):
    ref = wb.simulate(model, x0, t, controller=controller, rtol=1e-13, atol=1e-13)
    return np.array([
        np.max(np.abs(wb.simulate(model, x0, t, controller=controller, method=METHOD,
                                  step=h).x - ref.x))
        for h in steps])


def test_second_order_convergence_to_cvodes(pendulum):
    model, x0 = pendulum
    err = _errors(model, x0, np.linspace(0.0, 2.0, 5), [0.02, 0.01, 0.005])
    ratios = err[:-1] / err[1:]
    assert np.all((ratios > 3.6) & (ratios < 4.4)), (err, ratios)


def test_second_order_with_velocity_feedback(pendulum):
    """A damping moment u = -k omega: trapezoidal forcing, implicit in omega_{k+1}."""
    model, x0 = pendulum
    x = ca.SX.sym("x", model.manifold.ambient_dim)
    ctrl = ca.Function("damp", [x], [-0.4 * x[9:12]])
    err = _errors(model, x0, np.linspace(0.0, 2.0, 5), [0.02, 0.01, 0.005], ctrl)
    ratios = err[:-1] / err[1:]
    assert np.all((ratios > 3.6) & (ratios < 4.4)), (err, ratios)
    tr = wb.simulate(model, x0, np.linspace(0.0, 2.0, 5), controller=ctrl, method=METHOD,
                     step=0.01)
    assert tr.diagnostics["structure"]["symplectic"] is False
    assert tr.diagnostics["newton"]["max_residual"] <= 1e-13


def _explicit_del(model, h):
    """``(c0, c1, p) -> (D_1 L_d, D_2 L_d)`` by AD of ``L_d`` written through inverse maps.

    ``L_d(c0, c1) = h/2 [L(c0, xi) + L(c1, xi)]`` with ``xi`` recovered from the two
    configurations (``(x1 - x0)/h``; ``hat(h Omega/2) = (F - I)(F + I)^{-1}``, ``F = R0^T
    R1``; on S^1 ``h xi/2 = tan`` of half the angle from ``p0`` to ``p1``), left-trivialised
    by the factors' own ``K(c)^T``: independent of the closed-form Cayley derivatives the
    integrator uses.
    """
    der = model.mechanics
    nc = der.c.shape[0]
    c0, c1, cov = ca.SX.sym("c0", nc), ca.SX.sym("c1", nc), ca.SX.sym("cov", nc)
    xi, kts, k = [], [], 0
    for f in der.ing.factors:
        n = f.config_sym.shape[0]
        a, b = c0[k : k + n], c1[k : k + n]
        if f.kind == "SO(3)":
            F = ca.reshape(a, 3, 3).T @ ca.reshape(b, 3, 3)
            A = (F - ca.SX.eye(3)) @ ca.inv(F + ca.SX.eye(3))
            xi.append(2.0 / h * wb.vee(0.5 * (A - A.T)))
        elif f.kind == "S^2":  # the rotation normal to both ends taking a to b
            xi.append(2.0 / h * ca.cross(a, b) / (1.0 + ca.dot(a, b)))
        elif f.kind == "S^1":  # h xi = 2 tan(angle/2) = 2 sin / (1 + cos) from a to b
            xi.append(2.0 / h * (a[0] * b[1] - a[1] * b[0]) / (1.0 + ca.dot(a, b)))
        else:
            xi.append((b - a) / h)
        kts.append(f.kt(cov[k : k + n]))
        k += n
    kt = ca.Function("kt", [der.c, cov], [ca.vertcat(*kts)])
    L = der.T - der.V
    at = [ca.substitute(L, ca.vertcat(der.c, der.nu), ca.vertcat(c, *xi)) for c in (c0, c1)]
    Ld = h / 2 * (at[0] + at[1])
    return ca.Function("DL", [c0, c1, der.ing.p], [kt(c0, ca.gradient(Ld, c0)),
                                                   kt(c1, ca.gradient(Ld, c1))])


def _unit(v):
    return np.asarray(v, dtype=float) / np.linalg.norm(v)


def _chain():
    return chain_cart(2, m=0.5, masses=[0.1, 0.2], lengths=[0.1, 0.15])


@pytest.mark.parametrize("make", [double_pendulum3d, pendulum3d_cart, _chain,
                                  quadrotor_slung_load, furuta, acrobot])
def test_steps_solve_the_discrete_euler_lagrange_equations(make):
    """D_2 L_d(c0, c1) + D_1 L_d(c1, c2) = 0 and mu = Pi(c, nu) = -D_1 L_d = D_2 L_d.

    Also on S^2 factors: the step's discrete velocity is normal to both ends (the formula
    the reference uses) and the velocity stays tangent.
    """
    model = make()
    der, h = model.mechanics, 0.05
    DL = _explicit_del(model, h)
    Pi = ca.Function("Pi", [der.x, der.ing.p], [der.Pi])
    conf = ca.Function("c", [der.x], [der.c])
    flow = mechanics_variational(model)
    rng = np.random.default_rng(5)
    for _ in range(2):
        xs = [model.manifold.random_point(rng)]
        for _ in range(2):
            xs.append(np.asarray(flow.step(xs[-1], model.p, h)[0]).ravel())
        c = [conf(x) for x in xs]
        d1_01, d2_01 = DL(c[0], c[1], model.p)
        d1_12, _ = DL(c[1], c[2], model.p)
        mu0, mu1 = Pi(xs[0], model.p), Pi(xs[1], model.p)
        scale = 1.0 + float(ca.norm_inf(mu0))
        assert float(ca.norm_inf(d2_01 + d1_12)) < 1e-12 * scale
        assert float(ca.norm_inf(mu0 + d1_01)) < 1e-12 * scale
        assert float(ca.norm_inf(mu1 - d2_01)) < 1e-12 * scale
        assert np.max(np.abs(xs[1] - xs[0])) > 1e-2  # the step moved
        on = constraint_residuals(model, np.array(xs))
        assert max(float(r.max()) for r in on.values()) < 1e-13 * (1 + np.abs(xs).max())


def test_symmetric_a_step_back_undoes_a_step(pendulum):
    model, x0 = pendulum
    flow = mechanics_variational(model)
    x1 = np.asarray(flow.step(x0, model.p, 0.05)[0]).ravel()
    back = np.asarray(flow.step(x1, model.p, -0.05)[0]).ravel()
    assert np.max(np.abs(back - x0)) < 1e-12
    assert np.max(np.abs(x1 - x0)) > 1e-2  # the step moved


def test_energy_bounded_and_momentum_conserved_where_rkmk4_drifts(pendulum):
    """10^4 steps of h = 0.05: the energy error of the first and last tenth are alike."""
    model, x0 = pendulum
    t = np.linspace(0.0, 500.0, 1001)
    tenth = len(t) // 10
    out = {}
    for method in (METHOD, "rkmk4"):
        tr = wb.simulate(model, x0, t, method=method, step=0.05)
        dE = np.abs(tr.invariant_series("energy") - tr.invariant_series("energy")[0])
        out[method] = (dE[:tenth].max(), dE[-tenth:].max(),
                       tr.diagnostics["invariant_drift"]["h"]["max_abs"])
    first, last, dh = out[METHOD]
    assert last < 1.5 * first, out  # no secular growth
    assert dh < 1e-11, out  # vertical angular momentum: discrete Noether
    rk_first, rk_last, rk_dh = out["rkmk4"]
    assert rk_last > 5 * rk_first, out  # the non-symplectic method drifts
    assert rk_dh > 1e3 * dh, out


def test_cart_pendulum_conserves_its_momenta():
    """R^2 x SO(3): p_x, p_y, L_z to the Newton tolerance's scale, energy bounded."""
    cart = pendulum3d_cart()
    x0 = cart.state(x=[0.1, -0.2], v=[0.3, 0.1], R=wb.so3_exp([0.4, 0.2, 0.1]),
                    Omega=[0.2, -0.1, 0.5])
    tr = wb.simulate(cart, x0, np.linspace(0.0, 50.0, 501), method=METHOD, step=0.01)
    drift = tr.diagnostics["invariant_drift"]
    for name in ("p_x", "p_y", "L_z"):
        assert drift[name]["max_abs"] < 1e-11, (name, drift[name])
    assert drift["energy"]["max_rel"] < 1e-3
    assert max(tr.diagnostics["constraint_residual"].values()) < 1e-13
    # the cart moves: the test is not at rest
    assert np.ptp(tr.part("x")[:, 0]) > 1.0


def test_double_pendulum_agrees_with_cvodes_and_keeps_lz():
    model = double_pendulum3d()
    x0 = model.state(R1=wb.so3_exp([0.5, 0.2, 0.0]), Omega1=[0.3, 0.1, 0.5],
                     R2=wb.so3_exp([-0.4, 0.3, 0.1]), Omega2=[0.0, 0.4, -0.2])
    t = np.linspace(0.0, 1.0, 3)
    err = _errors(model, x0, t, [0.01, 0.005])
    assert 3.6 < err[0] / err[1] < 4.4, err
    tr = wb.simulate(model, x0, np.linspace(0.0, 20.0, 201), method=METHOD, step=0.01)
    assert tr.diagnostics["invariant_drift"]["L_z"]["max_abs"] < 1e-11


def test_s2_second_order_convergence_to_cvodes():
    """The spherical pendulum from its Lagrangian (one S^2 factor): order 2 to CVODES."""
    model = spherical_pendulum()
    q = _unit([0.6, 0.0, 0.8])
    x0 = model.state(q=link_state(q, np.cross(q, [0.0, 1.5, 0.0])))
    err = _errors(model, x0, np.linspace(0.0, 2.0, 5), [0.02, 0.01, 0.005])
    ratios = err[:-1] / err[1:]
    assert np.all((ratios > 3.6) & (ratios < 4.4)), (err, ratios)


def test_chain_on_cart_energy_bounded_and_momenta_kept():
    """R^2 x S^2 x S^2, h = 0.01 over 10^4 steps: energy error flat, px, py, Lz kept."""
    model = _chain()
    q1, q2 = _unit([0.3, 0.1, 0.9]), _unit([-0.2, 0.4, 0.8])
    x0 = model.state(x=[0, 0], v=[0.1, -0.05],
                     link1=link_state(q1, np.cross(q1, [0.5, -1.0, 0.3])),
                     link2=link_state(q2, np.cross(q2, [1.0, 0.2, -0.4])))
    t = np.linspace(0.0, 100.0, 1001)
    tenth = len(t) // 10
    tr = wb.simulate(model, x0, t, method=METHOD, step=0.01)
    dE = np.abs(tr.invariant_series("energy") - tr.invariant_series("energy")[0])
    assert dE[-tenth:].max() < 1.5 * dE[1 : tenth + 1].max()
    assert dE.max() < 3e-4 * abs(tr.invariant_series("energy")[0])  # measured 1.1e-4
    drift = tr.diagnostics["invariant_drift"]
    for name in ("px", "py", "Lz"):
        assert drift[name]["max_abs"] < 1e-11, (name, drift[name])
    assert max(tr.diagnostics["constraint_residual"].values()) < 1e-13


def test_newton_failure_is_reported_with_status(pendulum):
    model, x0 = pendulum
    with pytest.raises(SolverError, match="Newton did not converge") as info:
        wb.simulate(model, x0, np.linspace(0.0, 1.0, 3), method=METHOD, step=0.05,
                    newton_max_iter=1)
    assert info.value.status == "newton_not_converged"


def test_bad_input_is_refused(pendulum):
    model, x0 = pendulum
    with pytest.raises(ModelError, match="made by workbench.mechanics"):
        mechanics_variational(pendulum3d.reduced(J=np.diag([1.0, 2.0, 3.0]), rho=[0, 0, 1]))
    odd = spherical_pendulum()
    odd.mechanics.ing.factors[0].kind = "SE(3)"  # a kind the integrator does not know
    with pytest.raises(ModelError, match=r"factor 'q'.*SE\(3\).*rkmk4"):
        mechanics_variational(odd)
    with pytest.raises(ModelError, match="model must be a workbench Model"):
        mechanics_variational("pendulum")
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ModelError, match="step"):
            wb.simulate(model, x0, [0.0, 1.0], method=METHOD, step=bad)
    for tol in (0.0, -1e-12, 2.0, float("nan"), "tight"):
        with pytest.raises(ParameterError, match="newton_tol"):
            mechanics_variational(model, newton_tol=tol)
    with pytest.raises(ParameterError, match="newton_max_iter"):
        mechanics_variational(model, newton_max_iter=0)
    with pytest.raises(ModelError, match="controller"):
        mechanics_variational(model, ca.Function("k", [ca.SX.sym("x", 2)], [ca.SX.zeros(3)]))
    flow = mechanics_variational(model)
    with pytest.raises(ParameterError, match="step"):
        integrate(model, flow, x0, [0.0, 1.0], step=0.0)
