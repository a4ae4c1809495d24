"""Geometric integrators: orders, conserved quantities, manifold, symmetry, failures."""

from __future__ import annotations

import shutil

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models import controllers as C
from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from models.spherical import spherical_pendulum
from workbench.core.errors import ModelError, ParameterError, SolverError
from workbench.core.manifolds import SO3, so3_exp
from workbench.simulation._simulate import Method, simulate
from workbench.simulation.integrators import integrate, lgvi, rkmk4, s2_variational

BODY = {"J": np.diag([0.13, 0.28, 0.17]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
        "g": 9.81}
E3 = np.array([0.0, 0.0, 1.0])


def fitted_order(steps, errors) -> float:
    return float(np.polyfit(np.log(steps), np.log(errors), 1)[0])


@pytest.fixture(scope="module")
def body():
    return p3.full(**BODY)


@pytest.fixture(scope="module")
def skew_body():
    """A body with a non-diagonal inertia and an off-axis centre of mass."""
    Q = so3_exp([0.3, -0.7, 0.5])
    return p3.full(J=Q @ np.diag([0.13, 0.28, 0.17]) @ Q.T, rho=[0.05, -0.1, 0.3], m=1.3)


@pytest.fixture(scope="module")
def sphere():
    return spherical_pendulum(m=1.0, l=1.0)


def sphere_state(model):
    q = np.array([np.sin(1.0), 0.0, np.cos(1.0)])
    w = np.cross(q, [0.3, 0.8, -0.2])  # normal to q
    return model.state(q=np.concatenate([q, w]))


def body_state(model, c=1.0):
    return model.state(R=np.eye(3), omega=c * np.ones(3))


def errors_against_cvodes(model, x0, T, method, steps, **kw):
    t = np.linspace(0.0, T, 5)
    ref = simulate(model, x0, t, rtol=1e-13, atol=1e-13, **kw).final
    return [float(np.max(np.abs(simulate(model, x0, t, method=method, step=h, **kw).final
                                - ref))) for h in steps]


# ----------------------------------------------------------------------------------------
# Lie group variational integrator


@pytest.mark.parametrize("which", ["body", "skew_body"])
def test_lgvi_is_second_order(which, request):
    model = request.getfixturevalue(which)
    steps = np.array([0.04, 0.02, 0.01])
    errs = errors_against_cvodes(model, body_state(model), 2.0, Method.LGVI, steps)
    assert abs(fitted_order(steps, errs) - 2.0) < 0.1, errs


def test_lgvi_energy_bounded_momentum_exact_manifold_kept(body):
    x0 = body_state(body, 2.0)  # an energy level with irregular motion
    tr = simulate(body, x0, np.linspace(0.0, 120.0, 601), method="lgvi", step=0.02)
    E = tr.invariant_series("energy")
    dE = np.abs(E - E[0])
    third = len(dE) // 3
    assert dE.max() < 2e-3 * abs(E[0])
    # no drift: the error of the last third is of the size of the first third
    assert dE[-third:].max() < 2.0 * dE[:third].max()
    d = tr.diagnostics
    assert d["invariant_drift"]["h"]["max_abs"] < 1e-12  # discrete Noether: exact
    assert d["constraint_residual"]["R"] < 1e-13
    assert d["newton"]["max_residual"] <= 1e-13
    assert d["structure"]["symplectic"] is True


def test_lgvi_is_symmetric_backward_undoes_forward(skew_body):
    x0 = body_state(skew_body, 1.5)
    t = np.linspace(0.0, 3.0, 7)
    fwd = simulate(skew_body, x0, t, method="lgvi", step=0.01)
    back = simulate(skew_body, fwd.final, t[::-1], method="lgvi", step=0.01)
    assert_close(back.final, x0, atol=1e-11, what="LGVI backward after forward")


def test_lgvi_with_dissipative_feedback_is_second_order(body):
    k = C.angular_velocity_feedback(body, D=np.diag([0.4, 0.3, 0.5]))
    steps = np.array([0.04, 0.02, 0.01])
    errs = errors_against_cvodes(body, body_state(body, 2.0), 2.0, Method.LGVI, steps,
                                 controller=k)
    assert abs(fitted_order(steps, errs) - 2.0) < 0.1, errs
    tr = simulate(body, body_state(body, 2.0), np.linspace(0, 10, 11), controller=k,
                  method="lgvi", step=0.01)
    E = tr.invariant_series("energy")
    assert np.all(np.diff(E) < 0)  # dissipation, sampled every second
    assert tr.diagnostics["structure"]["symplectic"] is False
    assert tr.diagnostics["constraint_residual"]["R"] < 1e-13


def test_lgvi_with_attitude_feedback_is_second_order(body):
    k = C.so3_pd(body, np.eye(3), k_R=2.0, k_Omega=1.0, G=np.diag([1.0, 2.0, 3.0]))
    steps = np.array([0.04, 0.02, 0.01])
    x0 = body.state(R=so3_exp([0.5, -0.4, 0.3]), omega=[0.5, -0.2, 0.1])
    errs = errors_against_cvodes(body, x0, 2.0, Method.LGVI, steps, controller=k)
    assert abs(fitted_order(steps, errs) - 2.0) < 0.15, errs


def test_lgvi_newton_failure_reports_step_and_residual(body):
    with pytest.raises(SolverError) as info:
        simulate(body, body_state(body, 3.0), np.linspace(0, 2, 3), method="lgvi",
                 step=1.0, newton_max_iter=1)
    msg = str(info.value)
    assert info.value.status == "newton_not_converged"
    assert "step 1 of 2" in msg and "relative residual" in msg and "newton_max_iter" in msg


def test_lgvi_rejects_models_that_are_not_rigid_bodies(sphere, body):
    with pytest.raises(ModelError, match="rigid body on TSO"):
        lgvi(sphere)
    with pytest.raises(ModelError, match="rigid body on TSO"):
        lgvi(p3.reduced(**BODY))


@pytest.mark.parametrize(("kw", "match"), [
    ({"newton_tol": 0.0}, "newton_tol"),
    ({"newton_tol": 2.0}, "newton_tol"),
    ({"newton_max_iter": 0}, "newton_max_iter"),
    ({"newton_max_iter": 2.5}, "newton_max_iter"),
    ({"newton_max_iter": 10**6}, "<= 50"),
])
def test_newton_options_are_validated(body, kw, match):
    with pytest.raises(ParameterError, match=match):
        lgvi(body, **kw)


def test_newton_max_iter_is_bounded_before_anything_is_built(body):
    """The iterations are unrolled into the graph: a huge cap is refused, with the bound,
    by simulate before the step function is built (the build log stays as it was)."""
    before = len(body.build_log)
    with pytest.raises(ParameterError, match=r"newton_max_iter .*<= 50.*unrolled"):
        simulate(body, body_state(body), np.linspace(0, 1, 3), method="lgvi", step=0.1,
                 newton_max_iter=100_000)
    assert len(body.build_log) == before


def test_random_states_stay_on_tso3(skew_body):
    rng = np.random.default_rng(7)
    scheme = lgvi(skew_body)
    for _ in range(5):
        x0 = skew_body.manifold.random_point(rng, scale=2.0)
        run = integrate(skew_body, scheme, x0, [0.0, 1.0], step=0.01)
        R = SO3.matrix(run.x[-1, :9])
        assert np.max(np.abs(R.T @ R - np.eye(3))) < 1e-13
        assert np.linalg.det(R) > 0


# ----------------------------------------------------------------------------------------
# variational integrator on S^2


def test_s2_variational_is_second_order(sphere):
    steps = np.array([0.04, 0.02, 0.01])
    errs = errors_against_cvodes(sphere, sphere_state(sphere), 2.0, Method.S2_VARIATIONAL,
                                 steps)
    assert abs(fitted_order(steps, errs) - 2.0) < 0.1, errs


def test_s2_variational_with_pd_feedback_is_second_order(sphere):
    k = C.s2_pd(sphere, E3, k_q=1.0, k_w=1.0)
    steps = np.array([0.04, 0.02, 0.01])
    errs = errors_against_cvodes(sphere, sphere_state(sphere), 2.0, Method.S2_VARIATIONAL,
                                 steps, controller=k)
    assert abs(fitted_order(steps, errs) - 2.0) < 0.1, errs


def test_s2_variational_conserves_what_it_should(sphere):
    tr = simulate(sphere, sphere_state(sphere), np.linspace(0, 200, 401),
                  method="s2_variational", step=0.02)
    E = tr.invariant_series("energy")
    dE = np.abs(E - E[0])
    assert dE.max() < 3e-3 * abs(E[0])  # O(h^2) oscillation, h = 0.02
    assert dE[-100:].max() < 2.0 * dE[:100].max()
    vertical = tr.x[:, 3:] @ E3  # momentum of the rotation about e3
    assert np.max(np.abs(vertical - vertical[0])) < 1e-12
    assert tr.diagnostics["constraint_residual"]["q"] < 1e-13


def test_s2_variational_is_symmetric(sphere):
    x0 = sphere_state(sphere)
    t = np.linspace(0.0, 4.0, 5)
    fwd = simulate(sphere, x0, t, method="s2_variational", step=0.01)
    back = simulate(sphere, fwd.final, t[::-1], method="s2_variational", step=0.01)
    assert_close(back.final, x0, atol=1e-12, what="S2 VI backward after forward")


def test_s2_variational_step_without_solution_is_reported(sphere):
    with pytest.raises(SolverError) as info:
        simulate(sphere, sphere_state(sphere), [0.0, 2.0], method="s2_variational", step=2.0)
    assert info.value.status == "no_solution"
    assert "step 1 of 1" in str(info.value) and ">= 1" in str(info.value)


def test_s2_variational_rejects_other_models(body):
    with pytest.raises(ModelError, match="TS\\^2"):
        s2_variational(body)
    routh = p3.routh(**BODY, mu=0.1)  # TS2 storing (Gamma, Gamma-dot): not (q, omega)
    with pytest.raises(ModelError, match="deviates"):
        s2_variational(routh)


# ----------------------------------------------------------------------------------------
# RKMK4


@pytest.mark.parametrize(("which", "T", "steps"), [
    ("body", 2.0, [0.08, 0.04, 0.02]),
    ("sphere", 2.0, [0.04, 0.02, 0.01]),
    ("reduced", 2.0, [0.04, 0.02, 0.01]),
    ("planar", 2.0, [0.16, 0.08, 0.04]),
])
def test_rkmk4_is_fourth_order(which, T, steps, request):
    if which == "reduced":
        model = p3.reduced(**BODY)
        x0 = model.state(Gamma=so3_exp([0.4, 0.2, 0.0]).T @ E3, omega=[1.0, 0.5, -0.3])
    elif which == "planar":
        model = p3.planar(Jt=0.2, rho_s=0.3)
        x0 = model.state(p=[-np.sin(2.0), np.cos(2.0)], omega_y=[0.0])
    else:
        model = request.getfixturevalue(which)
        x0 = body_state(model) if which == "body" else sphere_state(model)
    steps = np.array(steps)
    errs = errors_against_cvodes(model, x0, T, Method.RKMK4, steps)
    assert abs(fitted_order(steps, errs) - 4.0) < 0.25, errs
    tr = simulate(model, x0, np.linspace(0, T, 3), method="rkmk4", step=steps[0])
    assert max(tr.diagnostics["constraint_residual"].values()) < 1e-13


def test_rkmk4_on_the_chain_keeps_every_link_on_ts2():
    model = chain_cart(2)
    x0 = model.state(x=[0.0, 0.0], v=[0.1, 0.0], link1=link_state([0.3, 0, 0.9539392014169456]),
                     link2=link_state(E3, [0.0, 1.0, 0.0]))
    steps = np.array([0.004, 0.002])
    errs = errors_against_cvodes(model, x0, 0.4, Method.RKMK4, steps)
    assert 3.5 < np.log2(errs[0] / errs[1]) < 4.5, errs
    tr = simulate(model, x0, np.linspace(0, 0.4, 3), method="rkmk4", step=0.004)
    assert max(tr.diagnostics["constraint_residual"].values()) < 1e-13
    assert tr.cost["rhs_evaluations"] == 4 * tr.cost["steps"]


def test_rkmk4_backward_and_closed_loop(sphere):
    k = C.s2_pd(sphere, E3, k_q=1.0, k_w=1.0)
    x0 = sphere_state(sphere)
    t = np.linspace(0.0, 2.0, 3)
    fwd = simulate(sphere, x0, t, controller=k, method="rkmk4", step=0.005)
    back = simulate(sphere, fwd.final, t[::-1], controller=k, method="rkmk4", step=0.005)
    assert_close(back.final, x0, atol=1e-7, what="RKMK4 (not symmetric) back to x0")


# ----------------------------------------------------------------------------------------
# shared driver and bad input


@pytest.mark.parametrize(("kw", "match"), [
    ({"step": 0.0}, "step must be a positive"),
    ({"step": -0.01}, "step must be a positive"),
    ({"step": 3.0}, "must not exceed the horizon"),
    ({"step": None}, "step must be a positive"),
])
def test_bad_steps_are_rejected(body, kw, match):
    for method in ("lgvi", "rkmk4"):
        with pytest.raises(ModelError, match=match):
            simulate(body, body_state(body), [0.0, 1.0, 2.0], method=method, **kw)


def test_integrate_validates_its_input(body):
    scheme = rkmk4(body)
    x0 = body_state(body)
    with pytest.raises(ParameterError, match="step must be a positive"):
        integrate(body, scheme, x0, [0.0, 1.0], step=-1.0)
    with pytest.raises(ParameterError, match="must not exceed the horizon"):
        integrate(body, scheme, x0, [0.0, 1.0], step=1.5)
    with pytest.raises(ParameterError, match="equally spaced"):
        integrate(body, scheme, x0, [0.0, 0.1, 1.0], step=0.01)
    with pytest.raises(ParameterError, match="chunk"):
        integrate(body, scheme, x0, [0.0, 1.0], step=0.01, chunk=0)


def test_outputs_and_chunks_do_not_change_the_steps(body):
    """Many output times, or small chunks, give the same steps as one interval."""
    x0 = body_state(body)
    for method in ("lgvi", "rkmk4", "rk"):
        one = simulate(body, x0, [0.0, 1.0], method=method, step=0.01)
        many = simulate(body, x0, np.linspace(0.0, 1.0, 11), method=method, step=0.01)
        assert one.cost["steps"] == many.cost["steps"] == 100
        assert_close(many.final, one.final, atol=1e-14, what=f"{method}: outputs")
    scheme = lgvi(body)
    a = integrate(body, scheme, x0, np.linspace(0, 1, 11), step=0.01, chunk=7)
    b = integrate(body, scheme, x0, np.linspace(0, 1, 11), step=0.01)
    assert_close(a.x, b.x, atol=0.0, what="chunking")


def test_build_log_records_the_step_functions(sphere):
    simulate(sphere, sphere_state(sphere), [0.0, 0.1], method="s2_variational", step=0.01)
    simulate(sphere, sphere_state(sphere), [0.0, 0.1], method="rkmk4", step=0.01)
    names = sphere.build_log.names()
    assert any(n.startswith("spherical_pendulum.s2vi_step") for n in names)
    assert any(n.startswith("spherical_pendulum.rkmk4_step") for n in names)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="jit needs a C compiler")
def test_jit_gives_the_same_steps(sphere):
    x0 = sphere_state(sphere)
    t = np.linspace(0, 1, 3)
    vm = simulate(sphere, x0, t, method="s2_variational", step=0.01)
    jit = simulate(sphere, x0, t, method="s2_variational", step=0.01, jit=True)
    assert_close(jit.x, vm.x, atol=1e-14, what="jit against the virtual machine")
    assert jit.options["jit"] is True


@pytest.mark.skipif(shutil.which("gcc") is None, reason="jit needs a C compiler")
def test_jit_compiles_one_graph_once_per_process():
    from workbench.simulation.integrators.common import compile_step

    x = ca.SX.sym("x", 2)
    a = ca.Function("jit_memo_a", [x], [ca.sin(x) * 3.0])
    b = ca.Function("jit_memo_b", [x], [ca.cos(x) * 3.0])  # another graph: its own build
    first = compile_step(a)
    assert compile_step(ca.Function("jit_memo_a", [x], [ca.sin(x) * 3.0])) is first
    other = compile_step(b)
    assert other is not first
    assert_close(np.asarray(first([0.3, -1.0])).ravel(), 3.0 * np.sin([0.3, -1.0]),
                 atol=1e-15, what="compiled a")
    assert_close(np.asarray(other([0.3, -1.0])).ravel(), 3.0 * np.cos([0.3, -1.0]),
                 atol=1e-15, what="compiled b")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="jit needs a C compiler")
def test_jit_leaves_no_file_behind_even_in_a_child_that_skips_its_destructors(
        tmp_path, monkeypatch):
    import os
    import tempfile

    from workbench.simulation.integrators.common import compile_step

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    x = ca.SX.sym("x", 3)
    pid = os.fork()
    if pid == 0:  # like a report's problem: compile, use, leave through os._exit
        code = 1
        try:
            f = compile_step(ca.Function("jit_litter_probe", [x], [ca.exp(x) - x]))
            ok = abs(float(f([1.0, 0.0, 2.0])[2]) - (np.exp(2.0) - 2.0)) < 1e-12
            code = 0 if ok else 2
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------------------
# stability: a step beyond the method's range is refused with the estimated stable step


def linear_oscillator(w: float):
    """``x'' = -w^2 x`` written directly as a Model on R^2 (no invariants declared)."""
    from workbench.core import Model, ProductManifold, Rn

    def field(ctx):
        z = ctx["z"]
        return ca.vertcat(z[1], -w**2 * z[0])

    return Model(name="linear_oscillator", manifold=ProductManifold([("z", Rn(2))]),
                 n_inputs=0, parameters=(), values={}, vector_field=field)


@pytest.mark.parametrize("method", ["rk", "rkmk4"])
def test_rk4_stable_range_on_a_linear_oscillator_is_the_closed_form(method):
    """RK4 on x'' = -w^2 x is stable for h w <= 2 sqrt 2: |R(iy)|^2 = 1 - y^6/72 + y^8/576."""
    w = 3.0
    model = linear_oscillator(w)
    x0 = np.array([1.0, 0.0])
    edge = 2.0 * np.sqrt(2.0) / w
    for hw in (2.80, 2.82):  # inside: 5000 steps, the amplitude does not grow
        h = hw / w
        tr = simulate(model, x0, h * np.arange(5001), method=method, step=h)
        assert np.max(np.hypot(tr.x[:, 0], tr.x[:, 1] / w)) <= 1.0 + 1e-12
    for hw in (2.85, 2.9, 6.0):  # outside: refused, with the closed-form estimate
        h = hw / w
        with pytest.raises(SolverError) as info:
            simulate(model, x0, h * np.arange(201), method=method, step=h)
        msg = str(info.value)
        assert info.value.status == "unstable_step" and f"step h = {h:.4g}" in msg
        est = float(msg.split("estimated stable step h < ")[1].split(" ")[0])
        assert est == pytest.approx(edge, rel=2e-3)  # the margin: |R| <= 1.01


def test_the_stability_checks_are_reported_in_the_diagnostics(body):
    tr = simulate(body, body_state(body), np.linspace(0, 2, 21), method="rkmk4", step=0.01)
    st = tr.diagnostics["stability"]
    assert st["status"] == "stable" and st["checked_states"] >= 2
    assert st["step_linearised_at"] == 0  # h |lambda| far inside the range: not needed
    assert st["conserved_invariants"] == ["energy", "h"]  # unforced: both are checked
    k = C.angular_velocity_feedback(body, D=np.diag([0.4, 0.3, 0.5]))
    damped = simulate(body, body_state(body), np.linspace(0, 2, 21), controller=k,
                      method="lgvi", step=0.01)
    assert "energy" not in damped.diagnostics["stability"]["conserved_invariants"]


def test_rkmk4_on_the_sphere_beyond_stability_raises(sphere):
    """The spherical pendulum near the bottom oscillates at sqrt(g/l)."""
    q = np.array([np.sin(0.1), 0.0, np.cos(0.1)])
    x0 = sphere.state(q=np.concatenate([q, np.zeros(3)]))
    w = np.sqrt(9.81)
    simulate(sphere, x0, np.linspace(0, 40, 41), method="rkmk4", step=2.5 / w)  # inside
    with pytest.raises(SolverError, match="beyond the stable range") as info:
        simulate(sphere, x0, np.linspace(0, 40, 11), method="rkmk4", step=3.2 / w)
    est = float(str(info.value).split("estimated stable step h < ")[1].split(" ")[0])
    assert est == pytest.approx(2.0 * np.sqrt(2.0) / w, rel=0.02)


def test_integrate_reports_the_largest_and_fastest_step_between_outputs(body):
    """Two outputs, 200 steps: the largest state and the start of the fastest step that
    integrate reports are those of the same run with an output at every step."""
    x0 = body_state(body, c=2.0)
    h, n = 0.01, 200
    coarse = integrate(body, rkmk4(body), x0, [0.0, n * h], step=h)
    fine = integrate(body, rkmk4(body), x0, h * np.arange(n + 1), step=h)
    assert_close(coarse.x[-1], fine.x[-1], atol=1e-12, what="the same steps (round-off)")
    (t_big, x_big, what_big), (t_fast, x_fast, what_fast) = coarse.between
    assert "largest" in what_big and "fastest" in what_fast
    k = int(np.argmax(np.max(np.abs(fine.x), axis=1)))
    assert t_big == pytest.approx(fine.t[k])
    assert_close(x_big, fine.x[k], atol=1e-12, what="the largest state")
    j = int(np.argmax(np.max(np.abs(np.diff(fine.x, axis=0)), axis=1)))
    assert t_fast == pytest.approx(fine.t[j])
    assert_close(x_fast, fine.x[j], atol=1e-12, what="the start of the fastest step")
    # simulate linearises the step there too
    tr = simulate(body, x0, [0.0, n * h], method="rkmk4", step=h)
    assert tr.diagnostics["stability"]["checked_states"] == 2 + 2
