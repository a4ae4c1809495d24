"""Forces at rest outside the potential: find_all_equilibria refuses or takes them in.

A mechanics model's equilibria at rest are the critical points of its potential only when
every other force at rest (loads with velocities and inputs 0, dissipation, kinetic terms of
degree 0) vanishes or derives from a potential. A hostile review found the search answering
CONSISTENT for a pendulum with a joint torque ``-K sin 2 theta`` (not an input): it gave two
of its four equilibria (``sin theta = 0`` and ``cos theta = -m g l / (2 K)``) and an index 1
to a centre. The model is now refused, naming the torque; the same energy declared as a
potential gives the four in closed form; loads that vanish at rest (an input, damping) leave
the usual answer; a load of configuration-independent weight (a constant force at a point) is
exactly the gradient of its work and is taken into the potential, with the closed form of the
tilted pendulum. Wherever an index is returned it is checked against the unstable count of
the model's own linearisation (a natural system: the counts agree).
"""

from __future__ import annotations

import re

import casadi as ca
import numpy as np
import pytest

from models.chain_cart import chain_cart
from workbench import (
    ModelError,
    eigenstructure,
    enumerate_equilibria,
    find_all_equilibria,
    linearize,
    mechanics,
)
from workbench.equilibria import (
    ConfigurationFunction,
    CriticalStatus,
    critical_points,
    potential_function,
)
from workbench.equilibria._critical import _search
from workbench.equilibria._critical_loads import RestForces

M, L, G, K = 1.0, 1.0, 9.81, 10.0
THC = float(np.arccos(-M * G * L / (2 * K)))  # the reviewer's tilted equilibria, 119.37 deg


def _pendulum(name: str) -> tuple[mechanics.System, object]:
    s = mechanics.System(name)
    th = s.s1("th", velocity="w")
    s.point_mass(M, L * ca.vertcat(th.sin, 0, th.cos))
    s.gravity(G)  # pulls along +e3: V = -m g l cos th, hanging at th = 0
    return s, th


def _angle(model, state) -> float:
    p = model.manifold.split(state)["th"]
    return float(np.arctan2(p[1], p[0]))


def _unstable(model, x) -> int:
    es = eigenstructure(linearize(model, x))
    return int(np.sum(es.eigenvalues.real > es.tol))


def _field(model, th: float) -> float:
    f = model.function("f")
    x = model.state(th=th, w=[0.0])
    return float(np.max(np.abs(np.asarray(f(x, np.zeros(model.n_inputs), model.p)))))


def _reviewers_pendulum():
    s, th = _pendulum("pend_torque")
    s.moment(th, -2 * K * th.sin * th.cos)  # a joint torque that is not an input
    return s.model()


def test_the_reviewers_pendulum_is_refused_naming_its_torque():
    model = _reviewers_pendulum()
    for flag in (True, False):
        with pytest.raises(ModelError, match=r"torque on th \(load 1 of 1\).*"
                                             r"find_equilibrium.*enumerate_equilibria"):
            find_all_equilibria(model, raise_on_failure=flag)
    # the refusal is needed: the field vanishes at the four closed-form equilibria, and the
    # two tilted ones are not critical points of the potential (dV/dth = m g l sin th there)
    for th in (0.0, np.pi, THC, -THC):
        assert _field(model, th) <= 1e-13
    fn = potential_function(model)
    for th in (THC, -THC):
        force = fn.derivatives([np.cos(th), np.sin(th)])[3]
        assert abs(force[0]) == pytest.approx(M * G * L * np.sin(THC), rel=1e-12)
    # the pointers of the message find them from guesses
    found = enumerate_equilibria(model, [model.state(th=a, w=[0.0]) for a in
                                         np.linspace(-3.0, 3.0, 13)])
    angles = sorted(_angle(model, e.x) for e in found.equilibria)
    assert len(angles) == 4
    assert np.allclose(np.sort(np.abs(angles)), [0.0, THC, THC, np.pi], atol=1e-10)


def test_the_same_energy_declared_as_a_potential_gives_its_four_equilibria():
    # -K sin 2 th = -d/dth (K sin^2 th): declared as a potential the search applies
    s, th = _pendulum("pend_spring_potential")
    s.potential(K * th.sin**2)
    model = s.model()
    res = find_all_equilibria(model)
    assert res.status is CriticalStatus.CONSISTENT and len(res) == 4
    assert not res.check.perfect and res.check.betti_sum_critical == 4  # 2 + 2t >= 1 + t
    expected = {0.0: 0, np.pi: 0, THC: 1, -THC: 1}  # angle: index (V'' = 20 - 9.81 at pi)
    seen = []
    for st in res.sets:
        a = _angle(model, st.state)
        key = min(expected, key=lambda e: abs(np.angle(np.exp(1j * (a - e)))))
        assert abs(np.angle(np.exp(1j * (a - key)))) <= 1e-10
        seen.append(key)
        V = -M * G * L * np.cos(key) + K * np.sin(key) ** 2
        assert st.value == pytest.approx(V, abs=1e-12)
        assert st.index == expected[key] == _unstable(model, st.state)
        assert st.field_residual <= 1e-12
    assert sorted(seen) == sorted(expected)


def test_damping_and_inputs_at_rest_leave_the_usual_answer():
    plain = find_all_equilibria(_pendulum("pend_plain")[0].model())
    s, th = _pendulum("pend_damped")
    u = s.input(1, "joint torque (N m)")
    s.moment(th, u - 0.2 * th.rate)  # an input and a velocity-proportional torque
    s.dissipation(0.5 * 0.3 * th.rate**2)
    model = s.model()
    rest = RestForces(model)
    assert rest.offending == [] and rest.folded == []  # structurally zero at rest
    res = find_all_equilibria(model)
    assert res.status is CriticalStatus.CONSISTENT and res.indices == [0, 1]
    assert res.check.perfect
    for st, ref, th0 in zip(res.sets, plain.sets, (0.0, np.pi)):
        assert abs(np.angle(np.exp(1j * (_angle(model, st.state) - th0)))) <= 1e-12
        assert st.value == pytest.approx(ref.value, abs=1e-15)
        assert st.value == pytest.approx(-M * G * L * np.cos(th0), abs=1e-12)
        assert st.field_residual <= 1e-12
        # damped: the hanging state is a stable focus, the inverted one a saddle
        assert _unstable(model, st.state) == st.index


@pytest.mark.parametrize("F", [2.0, -7.5])
def test_a_constant_force_at_a_point_is_taken_in_as_its_work(F):
    # V_eff = -m g l cos th - F l sin th = -l sqrt((m g)^2 + F^2) cos(th - phi)
    s, th = _pendulum("pend_wind")
    wind = s.parameter("F", 1.0, "horizontal force at the bob (N)")
    s.force_at(L * ca.vertcat(th.sin, 0, th.cos), ca.vertcat(wind, 0, 0))
    model = s.model()
    assert RestForces(model).folded == ["force (load 1 of 1)"]
    res = find_all_equilibria(model, params={"F": F})
    assert res.status is CriticalStatus.CONSISTENT and res.indices == [0, 1]
    assert "work potential of force (load 1 of 1)" in res.function
    phi = np.arctan2(F, M * G)
    amp = L * np.hypot(M * G, F)
    shifted = model.with_parameters(F=F)
    for st, th0, value in zip(res.sets, (phi, phi + np.pi), (-amp, amp)):
        assert abs(np.angle(np.exp(1j * (_angle(model, st.state) - th0)))) <= 1e-12
        assert st.value == pytest.approx(value, rel=1e-12)
        assert st.field_residual <= 1e-12  # the model's own field, the force included
        assert _unstable(shifted, st.state) == st.index


def _sphere_link_moment():
    s = mechanics.System("link_moment")
    q = s.s2("q")
    s.point_mass(1.0, q.q)
    s.gravity(G)
    s.moment(q, ca.DM([0.3, 0.0, 0.0]))
    return s.model(), "moment on q (load 1 of 1)"


def _body_moment():
    s = mechanics.System("body_moment")
    R = s.so3("R")
    s.rigid_body(1.0, np.diag([1.0, 2.0, 3.0]), R, com=[0.0, 0.0, 0.5])
    s.gravity(G)
    s.moment(R, ca.DM([0.0, 0.2, 0.0]))
    return s.model(), "moment on R (load 1 of 1)"


def _spring_as_force():
    # a gradient (of k |p - a|^2 / 2) written as a force: refused, the weight depends on th
    s, th = _pendulum("spring_force")
    bob = L * ca.vertcat(th.sin, 0, th.cos)
    s.force_at(bob, -3.0 * (bob - ca.DM([1.0, 0.0, 0.0])))
    return s.model(), "force (load 1 of 1)"


def _linear_dissipation():
    s, th = _pendulum("linear_drag")
    s.dissipation(0.5 * (th.rate - 0.1) ** 2)  # >= 0 but least at w = 0.1: -dD/dw = 0.1 at rest
    return s.model(), "dissipation (-dD/dnu at rest)"


@pytest.mark.parametrize("build", [_sphere_link_moment, _body_moment, _spring_as_force,
                                   _linear_dissipation])
def test_forces_at_rest_that_are_not_taken_in_are_refused(build):
    model, name = build()
    with pytest.raises(ModelError, match=re.escape(name) + r".*System.potential\(U\)"):
        find_all_equilibria(model, raise_on_failure=False)
    # each is a force at rest outside the potential somewhere: the sampled line sees it too
    rest = RestForces(model)
    rng = np.random.default_rng(3)
    big = max(float(np.max(np.abs(rest.residual(rest.manifold.random_point(rng)))))
              for _ in range(8))
    assert big > 1e-3


def test_a_rotating_frame_is_refused_and_its_amended_potential_has_the_equilibria():
    # a bead on a hoop turning at Om about the vertical: T0 = m l^2 Om^2 sin^2 th / 2 acts at
    # rest as the potential -T0; equilibria sin th = 0 and cos th = g / (l Om^2)
    Om = 5.0
    s, th = _pendulum("hoop")
    s.kinetic(0.5 * M * L**2 * Om**2 * th.sin**2)
    model = s.model()
    with pytest.raises(ModelError, match=r"kinetic energy .*degree 0.*V - T0"):
        find_all_equilibria(model)
    x = ca.SX.sym("x", model.manifold.ambient_dim)
    pv = ca.SX.sym("p", model.p.size)
    cos, sin = x[0], x[1]
    amended = ca.Function("V_minus_T0", [x, pv],
                          [-M * G * L * cos - 0.5 * M * L**2 * Om**2 * sin**2])
    res = critical_points(ConfigurationFunction.from_state(model, amended))
    thc = np.arccos(G / (L * Om**2))
    assert res.ok and len(res) == 4
    angles = sorted(abs(_angle(model, st.state)) for st in res.sets)
    assert np.allclose(angles, [0.0, thc, thc, np.pi], atol=1e-10)
    for st in res.sets:  # the model's own field vanishes there
        assert _field(model, _angle(model, st.state)) <= 1e-12


def test_the_sampled_check_measures_the_force_outside_the_potential():
    model = _reviewers_pendulum()
    rest = RestForces(model)
    assert [f.source for f in rest.offending] == ["torque on th (load 1 of 1)"]
    for th in np.linspace(-3.0, 3.0, 7):  # the closed form of the torque
        r = rest.residual([np.cos(th), np.sin(th)])
        assert r == pytest.approx([-2 * K * np.sin(th) * np.cos(th)], abs=1e-12)
    rest.check(np.array([1.0, 0.0]), "the hanging state", 1e-12)  # vanishes there
    with pytest.raises(ModelError, match=r"at th = pi/4.*differs from the potential's by 10"):
        rest.check(np.array([np.sqrt(0.5), np.sqrt(0.5)]), "th = pi/4", 1e-9)
    # a search told nothing of the structural test still stops at its first start
    rest.offending.clear()
    with pytest.raises(ModelError, match="at random sample 1"):
        _search(rest.function, model=model, field_tol=1e-9, rest=rest,
                raise_on_failure=False)
    # and a model without forces at rest passes it everywhere (chain: S^2 x S^2 x R^2)
    chain = RestForces(chain_cart(2))
    rng = np.random.default_rng(11)
    for _ in range(20):
        c = chain.manifold.random_point(rng)
        assert np.max(np.abs(chain.residual(c))) <= 1e-13 * max(
            1.0, float(np.max(np.abs(chain.function.gradient(c)))))


class _Recording:
    """A model's RestForces whose check records where it was made."""

    def __init__(self, rest: RestForces) -> None:
        self.rest, self.where, self.notes = rest, [], rest.notes

    def check(self, c, where, tol) -> None:
        self.where.append(where)
        self.rest.check(c, where, tol)


def test_the_sampled_check_is_made_at_every_start_of_the_search():
    s, th = _pendulum("pend_recorded")
    model = s.model()
    rec = _Recording(RestForces(model))
    res = _search(rec.rest.function, model=model, field_tol=1e-9, rest=rec,
                  raise_on_failure=True, deflation_starts=5)
    kinds = [w.split(" (")[0].rsplit(" ", 1)[0] for w in rec.where]
    assert kinds.count("homotopy start") == len(res.paths) == 2  # (cos th, sin th) = +-e1
    starts = kinds.count("seeded deflation start")
    assert starts == res.deflation["starts"] == res.search.starts >= res.search.patience == 9
    assert kinds.count("random sample") >= 6
    assert set(kinds) == {"random sample", "homotopy start", "seeded deflation start"}


@pytest.mark.parametrize("Om", [0.0, 3.0])
def test_the_index_is_the_unstable_count_of_a_natural_system_only(Om):
    # V = cos a + cos b on T^2 and T = (a'^2 + b'^2) / 2 + Om sin(a) b': the term linear in
    # the velocities does nothing at rest (the same 4 equilibria) but its gyroscopic force
    # Om cos(a) acts on the linearisation; at the maximum (index 2) z = a + i b obeys
    # z'' + i Om z' - z = 0, lambda = (-i Om +- sqrt(4 - Om^2)) / 2: stable for Om > 2
    s = mechanics.System("gyro_torus")
    a, b = s.s1("a"), s.s1("b")
    s.kinetic(0.5 * (a.rate**2 + b.rate**2) + Om * a.sin * b.rate)
    s.potential(a.cos + b.cos)
    model = s.model()
    res = find_all_equilibria(model)
    assert res.indices == [0, 1, 1, 2] and res.check.perfect
    assert ("gyroscopically stable" in res.message) == (Om != 0)
    for st in res.sets:
        assert st.field_residual <= 1e-12
        unstable = _unstable(model, st.state)
        if Om == 0 or st.index != 2:
            assert unstable == st.index
    top = res.sets[-1]
    lam = eigenstructure(linearize(model, top.state)).eigenvalues
    root = np.sqrt(complex(4 - Om**2))
    expected = [(-1j * Om + sg * root) / 2 for sg in (1, -1)]
    expected += [np.conj(e) for e in expected]
    def order(v):
        return sorted(v, key=lambda z: (round(z.imag, 9), round(z.real, 9)))

    assert np.array(order(lam)) == pytest.approx(np.array(order(expected)), abs=1e-12)
    assert _unstable(model, top.state) == (2 if Om < 2 else 0)


def test_a_constant_force_on_a_spherical_link_tilts_its_two_equilibria():
    # V_eff = -(m g e3 + F) . l q on S^2: critical at q = +-a/|a|, a = m g e3 + F (index 0
    # and 2); the sampled check on S^2 compares the derivation's projected force with q x dV
    F = np.array([1.5, -2.0, 0.0])
    s = mechanics.System("link_wind")
    q = s.s2("q")
    s.point_mass(M, L * q.q)
    s.gravity(G)
    s.force_at(L * q.q, ca.DM(F))
    model = s.model()
    res = find_all_equilibria(model)
    assert res.status is CriticalStatus.CONSISTENT and res.indices == [0, 2]
    a = M * G * np.array([0.0, 0.0, 1.0]) + F
    for st, sign in zip(res.sets, (1.0, -1.0)):
        qv = model.manifold.split(st.state)["q"][:3]
        assert np.allclose(qv, sign * a / np.linalg.norm(a), atol=1e-12)
        assert st.value == pytest.approx(-sign * L * np.linalg.norm(a), rel=1e-12)
        assert st.field_residual <= 1e-12
        assert _unstable(model, st.state) == st.index
