"""Symmetry reduction of mechanics models (workbench.mechanics.reduce).

Checks: the derived Lagrange-Poincare and Routh fields of the 3D pendulum equal paper 000's
(models/pendulum3d.py) through the stated state map; the reduced field does not depend
on the lift (both Rodrigues charts, random group elements); quotient and lift are inverse;
the reconstruction of every kind of quotient (translations, a rotation with relative
SO(3), S^2 and R^3 factors) reproduces the full model's trajectory, with the momentum at
its value; the Routh model's spectrum at the hanging equilibrium is the Lagrange-Poincare
model's without its zero mode; relative equilibria found as Routh equilibria are critical
points of the amended potential and steady rotations of the full model; inputs that break
the symmetry are named; bad requests are refused, a momentum too large for double
precision with its bound (linear in the inertia and in rtol). Off the manifold: every reduced field
keeps |q|^2 and q . w of its S^1, S^2 and TS^2 parts as first integrals, the
Lagrange-Poincare field of the 3D pendulum is paper 000's at |Gamma| != 1, and a spinning
top keeps its phase over 100 s like the transcribed model.
"""

from __future__ import annotations

import re

import casadi as ca
import numpy as np
import pytest
from mechanics_systems import double_pendulum3d, pendulum_on_cart

from models import pendulum3d as p3
from workbench import ModelError, mechanics, simulate
from workbench.codegen import CompileOptions
from workbench.control.ocp import OCP, TargetPoint
from workbench.control.ocp import solve as solve_ocp
from workbench.core.manifolds import S2, ProductManifold, Rn
from workbench.equilibria import StepControl, ZeroProblem, continue_branch, find_equilibrium
from workbench.linear import eigenstructure, linearize

E3 = np.array([0.0, 0.0, 1.0])
BODY = {"J": np.diag([0.4486, 0.3943, 0.0772]), "rho": np.array([-0.014, 0.1044, 0.4989]),
        "m": 1.0, "g": 9.81}  # paper 000's elliptic cylinder


def _body(rng):
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return {"J": Q @ np.diag(rng.uniform(0.1, 2.0, 3)) @ Q.T, "rho": 0.4 * rng.standard_normal(3),
            "m": rng.uniform(0.3, 3.0), "g": rng.uniform(1.0, 12.0)}


@pytest.fixture(scope="module")
def pendulum():
    body = _body(np.random.default_rng(7))
    full = p3.full(**body)
    return body, full, mechanics.reduce(full, "h", kind="lagrange_poincare"), \
        mechanics.reduce(full, "h", momentum=0.4, breaking_inputs="hold_zero")


def test_lagrange_poincare_equals_paper_000_with_the_body_moment(pendulum):
    body, _, lp, _ = pendulum
    paper = p3.reduced(**body)
    assert lp.model.manifold.names == ["Gamma", "omega"] and lp.model.n_inputs == 3
    rng = np.random.default_rng(1)
    for _ in range(10):
        x, u = paper.manifold.random_point(rng), rng.standard_normal(3)
        b = paper.rhs(x, u)
        np.testing.assert_allclose(lp.model.rhs(x, u), b, rtol=0, atol=1e-12 * np.abs(b).max())
        inv, ref = lp.model.invariants(x), paper.invariants(x)
        assert abs(inv["energy"] - ref["energy"]) <= 1e-12 * (1 + abs(ref["energy"]))
        assert abs(inv["h"] - ref["h"]) <= 1e-12 * (1 + abs(ref["h"]))


def test_routh_equals_paper_000_through_the_state_map(pendulum):
    body, _, _, ro = pendulum
    paper = p3.routh(**body, mu=0.4)
    assert ro.model.manifold.names == ["Gamma"] and ro.held_inputs == (0, 1, 2)
    rng = np.random.default_rng(2)
    for _ in range(10):
        g, w = ro.model.manifold.random_point(rng).reshape(2, 3)
        gd = np.cross(w, g)  # Gamma-dot = w x Gamma
        a, b = ro.model.rhs(np.r_[g, w]), paper.rhs(np.r_[g, gd])
        mapped = np.r_[a[:3], np.cross(a[3:], g) + np.cross(w, gd)]
        np.testing.assert_allclose(mapped, b, rtol=0, atol=1e-12 * np.abs(b).max())
        e_a, e_b = ro.model.invariants(np.r_[g, w])["energy"], paper.invariants(
            np.r_[g, gd])["energy"]
        assert abs(e_a - e_b) <= 1e-12 * (1 + abs(e_b))


def test_field_does_not_depend_on_the_lift_in_either_chart(pendulum):
    _, _, lp, ro = pendulum
    rng = np.random.default_rng(3)
    gammas = [E3, -E3, np.array([1.0, 0.0, 0.0]), np.array([0.6, 0.0, 0.8]),
              np.array([0.6, 0.0, -0.8]), np.array([0.0, 1.0, 1e-14]) / 1.0]
    for g in gammas:
        g = g / np.linalg.norm(g)
        w = rng.standard_normal(3)
        for red, r in ((lp, np.r_[g, w]), (ro, np.r_[g, w - (w @ g) * g])):
            base = red.field_at_lift(r)
            assert np.all(np.isfinite(base))
            for theta in rng.uniform(0, 2 * np.pi, 3):
                np.testing.assert_allclose(red.field_at_lift(r, theta=theta), base, rtol=0,
                                           atol=1e-12 * (1 + np.abs(base).max()))


def test_quotient_and_lift_are_inverse_and_the_lift_has_the_momentum(pendulum):
    _, full, lp, ro = pendulum
    rng = np.random.default_rng(4)
    for _ in range(5):
        r = ro.model.manifold.random_point(rng)
        x = ro.full_state(r)
        full.check_state(x, tol=1e-12)
        assert abs(ro.momentum_of(x) - 0.4) <= 1e-13
        np.testing.assert_allclose(ro.state_from_full(x), r, rtol=0, atol=1e-13)
        r = lp.model.manifold.random_point(rng)
        np.testing.assert_allclose(lp.state_from_full(lp.full_state(r)), r, rtol=0, atol=1e-13)
    x = full.manifold.random_point(rng)
    with pytest.raises(ModelError, match="with_parameters"):
        ro.state_from_full(x)  # another momentum value


def _quadrotor_with_yaw():
    """The slung-load quadrotor (R^3, SO(3), S^2) with its yaw and a translation declared."""
    s = mechanics.System("quadrotor_slung_load")
    quad, att, cable = s.rn("xQ", 3, velocity="vQ"), s.so3("R", velocity="Omega"), s.s2("q")
    s.rigid_body(1.2, s.inertia("J", np.diag([0.02, 0.03, 0.04])), att, origin=quad.x,
                 name="quad")
    s.point_mass(0.3, quad.x + 0.8 * cable.q, name="load")
    s.gravity(9.81)
    f, M = s.input(1, "thrust [N]"), s.input(3, "body moment [N m]")
    s.force_at(quad.x, ca.vertcat(0, 0, -f), body="quad")
    s.moment(att, M)
    s.momentum("L", rotate=E3, generators={quad: ca.cross(ca.DM(E3), quad.x)})
    s.momentum("px", translate={quad: [1.0, 0.0, 0.0]})
    return s.model()


def _reconstruction_error(full, red, x0, t):
    ref = simulate(full, x0, t, rtol=1e-12, atol=1e-12)
    traj = simulate(red.reconstruction, red.reconstruction_state(x0), t, rtol=1e-12,
                    atol=1e-12)
    rec = red.reconstruct(traj)
    return float(np.max(np.abs(rec.x - ref.x))), rec, ref


@pytest.mark.parametrize("make, symmetry, kind", [
    (double_pendulum3d, "h", "routh"),
    (double_pendulum3d, "h", "lagrange_poincare"),
    (_quadrotor_with_yaw, "L", "routh"),
    (_quadrotor_with_yaw, "L", "lagrange_poincare"),
    (_quadrotor_with_yaw, "px", "routh"),
    (pendulum_on_cart, "px", "routh"),
    (pendulum_on_cart, "py", "lagrange_poincare"),
])
def test_reconstruction_reproduces_the_full_trajectory(make, symmetry, kind):
    full = make()
    rng = np.random.default_rng(5)
    x0 = full.manifold.random_point(rng, scale=0.5)
    first = mechanics.reduce(full, symmetry, kind="lagrange_poincare",
                             breaking_inputs="hold_zero")
    mom = {"momentum": first.momentum_of(x0)} if kind == "routh" else {}
    red = mechanics.reduce(full, symmetry, kind=kind, breaking_inputs="hold_zero", **mom)
    err, rec, _ = _reconstruction_error(full, red, x0, np.linspace(0.0, 1.0, 21))
    assert err <= 1e-8
    J = [first.momentum_of(x) for x in rec.x]
    assert np.ptp(J) <= 1e-9 * (1 + abs(J[0]))
    assert rec.x.shape == (21, full.manifold.ambient_dim) and rec.phase[0] == 0.0


def test_reconstruct_reads_the_momentum_the_trajectory_was_simulated_with():
    full = p3.full(**BODY)
    red = mechanics.reduce(full, "h", momentum=0.0, breaking_inputs="hold_zero")
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")
    hang = BODY["rho"] / np.linalg.norm(BODY["rho"])
    x0 = lp.full_state(np.r_[hang, 0.3, 0.2, 0.4])
    mu = red.momentum_of(x0)
    assert abs(mu) > 0.01  # another value than the model's 0
    z0 = np.r_[np.asarray(red.project(x0)).ravel(), x0[:9], 0.0]
    t = np.linspace(0.0, 2.0, 11)
    traj = simulate(red.reconstruction.with_parameters(mu=mu), z0, t, rtol=1e-12, atol=1e-12)
    ref = simulate(full, x0, t, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(red.reconstruct(traj).x - ref.x)) <= 1e-8


def test_lagrange_poincare_carries_the_inputs_that_keep_the_symmetry():
    full = _quadrotor_with_yaw()
    lp = mechanics.reduce(full, "L", kind="lagrange_poincare")
    assert lp.model.n_inputs == 4 and lp.held_inputs == ()
    with pytest.raises(ModelError, match=r"u\[0\].*u\[1\].*u\[2\].*u\[3\].*hold_zero"):
        mechanics.reduce(full, "L", momentum=0.0)
    rng = np.random.default_rng(6)
    x0 = full.manifold.random_point(rng, scale=0.3)
    u = np.array([14.0, 0.01, -0.02, 0.005])
    t = np.linspace(0.0, 1.0, 11)

    def const(model):
        x = ca.SX.sym("x", model.manifold.ambient_dim)
        return ca.Function("k", [x], [ca.DM(u)])

    ref = simulate(full, x0, t, controller=const(full), rtol=1e-12, atol=1e-12)
    traj = simulate(lp.reconstruction, lp.reconstruction_state(x0), t,
                    controller=const(lp.reconstruction), rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(lp.reconstruct(traj).x - ref.x)) <= 1e-8


def test_translation_keeps_the_other_direction_and_names_the_broken_one():
    full = pendulum_on_cart()
    with pytest.raises(ModelError, match=r"u\[0\]: it changes the momentum 'px'"):
        mechanics.reduce(full, "px", momentum=0.1)
    ro = mechanics.reduce(full, "px", momentum=0.1, breaking_inputs="hold_zero")
    assert ro.held_inputs == (0,) and ro.model.n_inputs == 4
    assert ro.model.manifold.names == ["x", "v", "R", "omega"]
    assert ro.model.manifold.factor("x").dim == 1  # the cart's y; x is the group


def test_routh_spectrum_is_the_reduced_one_without_its_zero_mode(pendulum):
    body, _, lp, _ = pendulum
    hang = body["rho"] / np.linalg.norm(body["rho"])
    ro = mechanics.reduce(p3.full(**body), "h", momentum=0.0, breaking_inputs="hold_zero")
    lam_r = eigenstructure(linearize(ro.model, np.r_[hang, 0, 0, 0])).eigenvalues
    lam_lp = eigenstructure(linearize(lp.model, np.r_[hang, 0, 0, 0])).eigenvalues
    nonzero = lam_lp[np.abs(lam_lp) > 1e-8]
    assert len(lam_r) == 4 and len(nonzero) == 4
    np.testing.assert_allclose(np.sort_complex(lam_r), np.sort_complex(nonzero), rtol=1e-9)
    assert np.max(np.abs(lam_r.real)) <= 1e-9  # hanging: oscillations only


def test_relative_equilibrium_from_the_routh_model_is_a_steady_rotation():
    body = BODY
    full = p3.full(**body)
    mu = 0.3
    ro = mechanics.reduce(full, "h", momentum=mu, breaking_inputs="hold_zero")
    hang = body["rho"] / np.linalg.norm(body["rho"])
    eq = find_equilibrium(ro.model, np.r_[hang, 0, 0, 0])
    g = eq.x[:3]
    assert np.linalg.norm(g - hang) > 1e-3  # the spin tilts it
    grad = ro.amended_potential.factory("g", ["x", "p"], ["grad:V_mu:x"])
    dv = np.asarray(grad(eq.x, ro.model.p), dtype=float).ravel()[:3]
    assert np.max(np.abs(dv - (dv @ g) * g)) <= 1e-10
    vmu = float(ro.amended_potential(eq.x, ro.model.p))
    Jg = g @ body["J"] @ g
    assert abs(vmu - (-body["m"] * body["g"] * body["rho"] @ g + mu**2 / (2 * Jg))) <= 1e-12
    # in the full model: Gamma stays put and the attitude turns about e3 at mu / I
    x0 = ro.full_state(eq.x)
    traj = simulate(full, x0, np.linspace(0.0, 2.0, 5), rtol=1e-12, atol=1e-12)
    gammas = traj.x[:, [2, 5, 8]]  # R^T e3: the third row of R, vec(R) column-major
    assert np.max(np.abs(gammas - g)) <= 1e-9
    np.testing.assert_allclose(traj.x[:, 9:], np.tile(x0[9:], (5, 1)), atol=1e-9)
    np.testing.assert_allclose(x0[9:], mu / Jg * g, atol=1e-12)


def test_continuation_in_the_momentum_traces_relative_equilibria():
    """Zeros of the Routh field at rest over (Gamma, mu): each one, lifted with omega =
    (mu / Gamma.J Gamma) Gamma, is an equilibrium of the Lagrange-Poincare model."""
    full = p3.full(**BODY)
    ro = mechanics.reduce(full, "h", momentum=0.0, breaking_inputs="hold_zero")
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")
    m = ro.model
    y, u, p = ca.MX.sym("y", 4), ca.MX.sym("u", 0), ca.MX.sym("p", m.n_params)
    k = m.parameter_slices["mu"].start
    F = m.function("f")(ca.vertcat(y[:3], 0, 0, 0), ca.MX(0, 1),
                        ca.vertcat(p[:k], y[3], p[k + 1 :]))
    fn = ca.Function("re", [y, u, p], [F, ca.jacobian(F, y)], ["y", "u", "p"], ["F", "D"])
    prob = ZeroProblem(name="relative equilibria in mu", function=fn, u=np.zeros(0), p=m.p,
                       manifold=ProductManifold([("Gamma", S2()), ("mu", Rn(1))]))
    hang = BODY["rho"] / np.linalg.norm(BODY["rho"])
    b = continue_branch(prob, np.r_[hang, 0.0], direction=np.r_[0.0, 0.0, 0.0, 1.0],
                        max_points=25, control=StepControl(max_step=0.1))
    assert len(b.points) == 25 and np.ptp(b.points[:, 3]) > 0.5
    for yv in b.points:
        g, mu = yv[:3], yv[3]
        x = np.r_[g, mu / (g @ BODY["J"] @ g) * g]
        assert np.max(np.abs(lp.model.rhs(x))) <= 1e-9


def test_an_ocp_solves_on_the_reduced_model():
    lp = mechanics.reduce(p3.full(**BODY), "h", kind="lagrange_poincare")
    m = lp.model
    hang = BODY["rho"] / np.linalg.norm(BODY["rho"])
    tilted = hang + np.array([0.5, 0.0, 0.0])
    goal = np.r_[tilted / np.linalg.norm(tilted), 0.0, 0.0, 0.0]
    ocp = OCP(m, x0=np.r_[hang, 0.0, 0.0, 0.0], target=TargetPoint(m.manifold, goal),
              u_lower=-5.0, u_upper=5.0, T=2.0, running_cost=lambda x, u: ca.dot(u, u),
              name="reduced_tilt")
    sol = solve_ocp(ocp)
    assert sol.ok
    np.testing.assert_allclose(sol.x[-1], goal, atol=1e-6)


def test_the_routh_model_compiles_to_c_and_integrates_the_same(tmp_path):
    ro = mechanics.reduce(p3.full(**BODY), "h", momentum=0.3, breaking_inputs="hold_zero")
    x0 = ro.model.manifold.random_point(np.random.default_rng(10), scale=0.3)
    t = np.linspace(0.0, 1.0, 11)
    plain = simulate(ro.model, x0, t, rtol=1e-10, atol=1e-10)
    compiled = simulate(ro.model, x0, t, rtol=1e-10, atol=1e-10, compilation="c",
                        compile_options=CompileOptions(cache_dir=tmp_path))
    assert compiled.options["compilation"] == "c"
    np.testing.assert_allclose(compiled.x, plain.x, atol=1e-9)


def test_models_accept_other_parameter_values_and_the_momentum_as_parameter(pendulum):
    body, _, _, ro = pendulum
    m2 = ro.model.with_parameters(mu=-1.0, m=2 * body["m"])
    paper = p3.routh(**{**body, "m": 2 * body["m"]}, mu=-1.0)
    g, w = m2.manifold.random_point(np.random.default_rng(8)).reshape(2, 3)
    gd = np.cross(w, g)
    a, b = m2.rhs(np.r_[g, w]), paper.rhs(np.r_[g, gd])
    np.testing.assert_allclose(np.r_[a[:3], np.cross(a[3:], g) + np.cross(w, gd)], b,
                               atol=1e-12 * np.abs(b).max())
    with pytest.raises(Exception, match="J"):
        ro.model.with_parameters(J=-np.eye(3))


def test_refusals_name_what_is_wrong(pendulum):
    _, full, _, _ = pendulum
    with pytest.raises(ModelError, match="known: \\['h'\\]"):
        mechanics.reduce(full, "L_z", momentum=0.0)
    with pytest.raises(ModelError, match="momentum .* is required"):
        mechanics.reduce(full, "h")
    with pytest.raises(ModelError, match="Routh value"):
        mechanics.reduce(full, "h", kind="lagrange_poincare", momentum=1.0)
    with pytest.raises(ModelError, match="kind must be one of"):
        mechanics.reduce(full, "h", kind="poincare", momentum=1.0)
    with pytest.raises(ModelError, match="mechanics System"):
        mechanics.reduce(p3.reduced(J=np.eye(3), rho=[0, 0, 1.0]), "h", momentum=0.0)
    with pytest.raises(ModelError, match="R\\^2"):
        mechanics.reduce(pendulum_on_cart(), "Lz", kind="lagrange_poincare")
    s = mechanics.System("spherical")
    link = s.s2("q")
    s.point_mass(1.0, link.q)
    s.gravity(9.81)
    s.momentum("h", rotate=E3)
    with pytest.raises(ModelError, match="SO\\(3\\) factor that turns"):
        mechanics.reduce(s, "h", momentum=0.0)
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")
    with pytest.raises(ModelError, match="kind='routh'"):
        lp.amended_potential  # noqa: B018
    s = mechanics.System("axis_as_parameter")
    body = s.so3("R")
    s.rigid_body(1.0, np.eye(3), body, com=[0.0, 0.0, 0.5])
    s.gravity(9.81)
    s.momentum("h", rotate=s.parameter("axis", [0.0, 0.0, 1.0]))
    with pytest.raises(ModelError, match="depends on parameters"):
        mechanics.reduce(s, "h", kind="lagrange_poincare")


def _momentum_bound(full, momentum, **kw):
    """The bound quoted by the refusal of ``momentum`` (which must be refused)."""
    with pytest.raises(ModelError, match=r"momentum = \S+ is too large for the Routh lift in "
                                         r"double precision") as err:
        mechanics.reduce(full, "h", momentum=momentum, **kw)
    return float(re.search(r"must be at most \(rtol / eps\) min\(I / \|eta\|\) = (\S+) here",
                           str(err.value)).group(1))


def test_a_momentum_beyond_double_precision_is_refused_with_its_scale():
    """Beyond (rtol / eps) min(I / |eta|) the lift's group velocity drowns the reduced
    velocities: refused up front (was an 'internal' quotient error), with the bound. For the
    3D pendulum turning about the vertical, I(Gamma) = Gamma^T J Gamma and eta = Gamma (the
    body rates of the rotation), so I / |eta|_inf lies in [lambda_min(J), sqrt(3) lambda_max(J)];
    the bound is linear in the inertia and in rtol; below it the lift and quotient are
    inverse to rtol."""
    eps = np.finfo(float).eps
    full = p3.full(**BODY)
    bound = _momentum_bound(full, 1e300)
    lam = np.linalg.eigvalsh(BODY["J"])
    assert 1e-8 / eps * lam[0] <= bound <= 1e-8 / eps * np.sqrt(3) * lam[-1]
    assert _momentum_bound(full, -2 * bound) == bound  # the sign does not matter
    heavy = p3.full(**{**BODY, "J": 1e3 * BODY["J"]})
    assert _momentum_bound(heavy, 1e300) == pytest.approx(1e3 * bound, rel=1e-12)
    assert _momentum_bound(full, 1e300, rtol=1e-6) == pytest.approx(100 * bound, rel=1e-12)
    ro = mechanics.reduce(full, "h", momentum=0.9 * bound, breaking_inputs="hold_zero")
    rng = np.random.default_rng(9)
    for _ in range(3):
        r = ro.model.manifold.random_point(rng)
        x = ro.full_state(r)
        assert abs(ro.momentum_of(x) / (0.9 * bound) - 1) <= 1e-8
        assert np.max(np.abs(ro.state_from_full(x) - r)) <= 1e-8 * np.max(np.abs(r))
    with pytest.raises(ModelError, match=r"mu = 1e\+300 is too large.* must be at most"):
        ro.model.with_parameters(mu=1e300)
    assert ro.model.with_parameters(mu=-0.5 * bound).values["mu"] == -0.5 * bound


def test_the_problem_runs_quick():
    from problems import mechanics_reduction

    res = mechanics_reduction.solve(quick=True)
    assert res.ok, [c for c in res.comparisons if not c.ok]
    assert max(res.values["max_deviation"].values()) <= mechanics_reduction.FIELD_TOL
    assert res.values["relative_equilibria"]["points"] > 100


@pytest.mark.skipif(not hasattr(mechanics.System, "s1"), reason="no S^1 factor in this build")
@pytest.mark.parametrize("kind", ["routh", "lagrange_poincare"])
def test_shift_of_angles_reduces_and_reconstructs(kind):
    s = mechanics.System("two_rotors")
    a, b = s.s1("a", velocity="a_dot"), s.s1("b", velocity="b_dot")
    s.kinetic(0.5 * a.rate**2 + 0.3 * b.rate**2 + 0.1 * a.rate * b.rate)
    s.potential(2.0 * (1 - (a.cos * b.cos + a.sin * b.sin)))  # depends on a - b only
    s.moment(a, s.input(1, "motor on a [N m]"))
    s.momentum("L", shift=[a, b])
    full = s.model()
    with pytest.raises(ModelError, match=r"u\[0\]: it changes the momentum 'L'"):
        mechanics.reduce(full, "L", momentum=0.0)
    lp = mechanics.reduce(full, "L", kind="lagrange_poincare")
    assert lp.model.n_inputs == 1  # equivariant: kept by Lagrange-Poincare
    rng = np.random.default_rng(9)
    x0 = full.manifold.random_point(rng)
    mom = {"momentum": lp.momentum_of(x0)} if kind == "routh" else {}
    red = mechanics.reduce(full, "L", kind=kind, breaking_inputs="hold_zero", **mom)
    assert red.model.manifold.names[:1] == (["b_rel"] if kind == "routh" else ["a_dot"])
    err, _, _ = _reconstruction_error(full, red, x0, np.linspace(0.0, 2.0, 21))
    assert err <= 1e-8
    r = red.model.manifold.random_point(rng)
    np.testing.assert_allclose(red.field_at_lift(r, theta=2.1), red.field_at_lift(r),
                               atol=1e-13)


def _constraint_rates(model, x):
    """``d/dt`` of ``|q|^2`` (S^2, TS^2, S^1) and ``q . w`` (TS^2) along the ambient field
    at ``x``, each relative to the size of its terms."""
    f = model.rhs(x)
    man, out = model.manifold, {}
    for name, fac in man.factors:
        sl = man.slices[name]
        if fac.kind not in ("S2", "TS2", "S1"):
            continue
        k = 2 if fac.kind == "S1" else 3
        q, dq = x[sl][:k], f[sl][:k]
        out[f"|{name}|"] = abs(q @ dq) / (np.linalg.norm(q) * np.linalg.norm(dq) + 1e-300)
        if fac.kind == "TS2":
            w, dw = x[sl][3:], f[sl][3:]
            rate = dq @ w + q @ dw
            out[f"{name}.w"] = abs(rate) / (np.linalg.norm(dq) * np.linalg.norm(w)
                                            + np.linalg.norm(q) * np.linalg.norm(dw) + 1e-300)
    return out


def _off_manifold(model, rng, stretch):
    """A random point of the model's manifold with every S^2, TS^2 and S^1 direction
    stretched by ``stretch`` (TS^2 velocities kept normal to it)."""
    x = model.manifold.random_point(rng)
    for name, fac in model.manifold.factors:
        sl = model.manifold.slices[name]
        if fac.kind in ("S2", "S1"):
            x[sl] *= stretch
        elif fac.kind == "TS2":
            x[sl][:3] *= stretch
    return x


def _cart_with_link():
    """A spherical pendulum on a cart moving in the plane (R^2 and S^2), translations."""
    s = mechanics.System("cart_with_link")
    cart, link = s.rn("x", 2, velocity="v"), s.s2("q")
    s.point_mass(1.5, ca.vertcat(cart.x, 0))
    s.point_mass(0.4, ca.vertcat(cart.x, 0) + 0.7 * link.q)
    s.gravity(9.81)
    s.momentum("px", translate={cart: [1.0, 0.0]})
    return s.model()


def _two_rotors():
    s = mechanics.System("two_rotors")
    a, b = s.s1("a", velocity="a_dot"), s.s1("b", velocity="b_dot")
    s.kinetic(0.5 * a.rate**2 + 0.3 * b.rate**2 + 0.1 * a.rate * b.rate)
    s.potential(2.0 * (1 - (a.cos * b.cos + a.sin * b.sin)))
    s.momentum("L", shift=[a, b])
    return s.model()


@pytest.mark.parametrize("make, symmetry", [
    (lambda: p3.full(**BODY), "h"),
    (double_pendulum3d, "h"),
    (_quadrotor_with_yaw, "L"),
    (_cart_with_link, "px"),
    pytest.param(_two_rotors, "L", marks=pytest.mark.skipif(
        not hasattr(mechanics.System, "s1"), reason="no S^1 factor in this build")),
])
@pytest.mark.parametrize("kind", ["routh", "lagrange_poincare"])
def test_the_ambient_field_keeps_every_constraint_off_the_manifold(make, symmetry, kind):
    """Off the sphere (|q| = 0.9, 1.2) the reduced field moves each direction with the
    kinematics of the ambient point: |q|^2 and (TS^2) q . w are first integrals."""
    full = make()
    rng = np.random.default_rng(11)
    mom = {"momentum": 0.37} if kind == "routh" else {}
    red = mechanics.reduce(full, symmetry, kind=kind, breaking_inputs="hold_zero", **mom)
    for stretch in (0.9, 1.2):
        for _ in range(3):
            rates = _constraint_rates(red.model, _off_manifold(red.model, rng, stretch))
            assert rates and max(rates.values()) <= 1e-14, rates


def test_spinning_top_keeps_its_phase_like_the_transcribed_model():
    """A top at 30 rad/s over 100 s (rtol 1e-10): the derived Lagrange-Poincare model's
    error on Gamma against paper 000's model at rtol 1e-13 is the transcribed model's
    (CVODES drifts |Gamma| by ~4e-6 in both; a field scaled by 1/|Gamma| off the sphere
    turned that drift into a phase error of 3e-3)."""
    top = {"J": np.diag([0.28, 0.28, 0.13]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
           "g": 9.81}
    lp = mechanics.reduce(p3.full(**top), "h", kind="lagrange_poincare")
    paper = p3.reduced(**top)
    tilt = 0.6
    r0 = np.r_[0.0, -np.sin(tilt), np.cos(tilt), 0.0, 0.3, 30.0]
    t = np.linspace(0.0, 100.0, 1001)
    ref = simulate(paper, r0, t, rtol=1e-13, atol=1e-13).x[:, :3]
    errs = {}
    for name, model in (("derived", lp.model), ("transcribed", paper)):
        traj = simulate(model, r0, t, rtol=1e-10, atol=1e-10)
        errs[name] = float(np.max(np.abs(traj.x[:, :3] - ref)))
        drift = float(np.max(np.abs(np.linalg.norm(traj.x[:, :3], axis=1) - 1)))
        assert drift > 1e-7  # the integrator does leave the sphere: the test has teeth
    assert errs["transcribed"] <= 2e-5
    assert errs["derived"] <= 1.1 * errs["transcribed"], errs


def test_off_the_sphere_the_lagrange_poincare_field_is_paper_000s(pendulum):
    """At |Gamma| != 1 the lift's attitude is stretched along e3 (R^T e3 = Gamma): unforced,
    the derived field is paper 000's (4.3)-(4.4) at the ambient point, gravity's moment
    m g rho x Gamma included; the body moment acts through R^T R = I + (s^2 - 1) g g^T
    (g = Gamma / s), J d(omega-dot)/du = I + (s^2 - 1)/2 (I - g g^T): exact on the sphere,
    never below half off it."""
    body, _, lp, _ = pendulum
    paper = p3.reduced(**body)
    rng = np.random.default_rng(12)
    for s in (0.5, 0.9, 1.3, 2.0):
        x = paper.manifold.random_point(rng, scale=2.0)
        x[:3] *= s
        b = paper.rhs(x)
        np.testing.assert_allclose(lp.model.rhs(x), b, rtol=0, atol=1e-13 * np.abs(b).max())
        B = np.asarray(lp.model.function("f_u")(x, np.zeros(3), lp.model.p))
        g = x[:3] / s
        expect = np.eye(3) + 0.5 * (s**2 - 1) * (np.eye(3) - np.outer(g, g))
        np.testing.assert_allclose(body["J"] @ B[3:], expect, rtol=0, atol=1e-12)
        np.testing.assert_allclose(B[:3], 0.0, atol=0)


def test_reconstruct_builds_its_map_once_per_trajectory_length(pendulum):
    _, full, lp, _ = pendulum
    rng = np.random.default_rng(13)
    x0 = full.manifold.random_point(rng)
    z = lp.reconstruction_state(x0)
    first = lp.reconstruct(np.tile(z, (4, 1)))
    fn = lp._reconstruct_map(4)
    second = lp.reconstruct(np.tile(z, (4, 1)))
    assert lp._reconstruct_map(4) is fn  # cached, not rebuilt
    np.testing.assert_array_equal(first.x, second.x)
    np.testing.assert_allclose(first.x[0], x0, atol=1e-13)  # phase 0: the state itself


def _unforced(model):
    """The field at u = 0 as one SX function of (x, p) (what an unforced simulation runs)."""
    x, p = ca.SX.sym("x", model.manifold.ambient_dim), ca.SX.sym("p", model.n_params)
    return ca.Function("f0", [x, p], [model.function("f")(x, ca.DM.zeros(model.n_inputs), p)])


def test_the_unforced_fields_evaluate_no_chart_and_no_more_than_the_full_model(pendulum):
    """Gravity along the symmetry axis sees the lift only through R^T e3 = Gamma: the
    unforced reduced fields contain no chart switch (if_else) and no normalisation, and
    the Lagrange-Poincare one has fewer operations than the full model's (a graph size,
    not a time; benchmarks/bench_reduction.py times them)."""
    _, full, lp, ro = pendulum
    ops = {}
    for name, model in (("full", full), ("lp", lp.model), ("routh", ro.model)):
        fn = _unforced(model)
        ids = [fn.instruction_id(k) for k in range(fn.n_instructions())]
        assert ca.OP_IF_ELSE_ZERO not in ids and ca.OP_SQRT not in ids, name
        ops[name] = fn.n_instructions()
    assert ops["lp"] < ops["full"], ops
    assert ops["routh"] < 1.5 * ops["full"], ops
