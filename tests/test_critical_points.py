"""All critical sets of a potential without guesses: counts, indices, topology, Morse-Bott.

The examples are those whose critical sets are known in closed form: gravity's height
functions on (S^2)^n (the chain on a cart), SO(3) (the 3D pendulum: two circles),
SO(3) x SO(3) (the double 3D pendulum: four 2-tori) and the 2-torus of the Furuta pendulum
(two circles: its arm angle is a symmetry) and of the acrobot (four points). Independent
checks: the closed forms of the equilibria and of ``V`` there, the model's own field
``f(x, 0)`` at the states found, the unstable count of the model's linearisation against the
index, and finite differences of ``V`` along the retraction against the Riemannian Hessian.
Functions with many critical points (cos 5a + cos(5b) / 2 on T^2: 100; cos 40 theta on S^1:
80) are found in full and in closed form, the search ending only when new sets stop
appearing; and the Morse-Bott inequalities are shown blind to missing sets (a perfect
subset; a dropped pair of indices 0 and 1), which is why a search that did not settle is
UNSETTLED, never CONSISTENT.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import acrobot, furuta, pendulum3d
from models.chain_cart import chain_cart
from models.double_pendulum3d import double_pendulum3d
from models.relative_equilibria import rotation_problem, static_equilibria
from workbench import (
    S1,
    S2,
    SO3,
    TS2,
    ModelError,
    ParameterError,
    ProductManifold,
    Rn,
    SolverError,
    eigenstructure,
    linearize,
    mechanics,
    so3_exp,
)
from workbench.equilibria import (
    ConfigurationFunction,
    CriticalStatus,
    critical_points,
    find_all_equilibria,
    potential_function,
)
from workbench.equilibria._critical_topology import (
    FACTOR_POLYNOMIALS,
    manifold_polynomial,
    morse_bott_check,
    torus_polynomial,
)

E3 = np.array([0.0, 0.0, 1.0])


def _unstable(model, x) -> int:
    es = eigenstructure(linearize(model, x))
    return int(np.sum(es.eigenvalues.real > es.tol))


def _random_spd(rng, cond=30.0):
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return Q @ np.diag(np.geomspace(1.0, cond, 3) * 0.05) @ Q.T


def test_chain_on_a_cart_has_2_to_the_n_equilibria():
    n, g = 3, 9.81
    masses, lengths = [0.1, 0.2, 0.15], [0.1, 0.2, 0.3]
    model = chain_cart(n, masses=masses, lengths=lengths, g=g)
    res = find_all_equilibria(model)
    assert res.status is CriticalStatus.CONSISTENT and len(res) == 2**n
    _assert_settled(res)
    assert res.check.perfect and res.check.betti_sum_critical == res.check.betti_sum_manifold == 8
    below = np.cumsum(masses[::-1])[::-1]  # mass at and below each link
    patterns = set()
    for s in res.sets:
        parts = model.manifold.split(s.state)
        qz = np.array([parts[f"link{i + 1}"][2] for i in range(n)])
        assert np.max(np.abs(np.abs(qz) - 1)) <= 1e-12  # every link vertical
        patterns.add(tuple(np.sign(qz)))
        assert s.index == 2 * int(np.sum(qz < 0))  # each inverted link: index 2
        assert s.value == pytest.approx(-g * float(np.sum(below * lengths * qz)), abs=1e-12)
        # the free cart is a quotient: its translations sweep R^2, fixed at 0 by the gauge
        assert (s.topology, s.translation_dimension, s.compact_dimension) == ("R^2", 2, 0)
        assert np.all(parts["x"] == 0) and np.all(parts["v"] == 0)
        assert s.field_residual <= 1e-12
        assert _unstable(model, s.state) == s.index
    assert len(patterns) == 8


def test_pendulum3d_has_two_critical_circles():
    rng = np.random.default_rng(7)
    J, rho, m, g = _random_spd(rng), rng.standard_normal(3) * 0.3, 1.3, 9.81
    model = pendulum3d.full(J=J, rho=rho, m=m, g=g)
    res = find_all_equilibria(model)
    assert res.ok and len(res) == 2 and res.indices == [0, 2]
    assert res.check.perfect and res.check.betti_sum_critical == 4  # RP^3: 1 + 1 + 1 + 1
    fn = potential_function(model)
    for s, sign in zip(res.sets, (1.0, -1.0)):
        assert (s.topology, s.betti, s.dimension, s.nullity) == ("circle", (1, 1), 1, 1)
        assert s.value == pytest.approx(-sign * m * g * np.linalg.norm(rho), rel=1e-12)
        for c in s.points:  # hanging: R rho = |rho| e3 (e3 down); inverted: -|rho| e3
            R = SO3.matrix(c)
            assert np.allclose(R @ rho, sign * np.linalg.norm(rho) * E3, atol=1e-10)
        # the circle: turned about the vertical the point stays critical
        for theta in np.linspace(0.3, 6.0, 5):
            R = so3_exp(theta * E3) @ SO3.matrix(s.point)
            assert np.max(np.abs(fn.derivatives(SO3.flat(R))[3])) <= 1e-12
        assert s.field_residual <= 1e-12
        assert _unstable(model, s.state) == s.index


def test_double_pendulum3d_has_four_critical_2tori():
    model = double_pendulum3d()
    res = find_all_equilibria(model)
    assert res.ok and res.indices == [0, 2, 2, 4]
    assert res.check.perfect and res.check.betti_sum_critical == 16  # 4 x 4
    _assert_settled(res)
    v = model.values
    for s in res.sets:
        assert (s.topology, s.betti, s.dimension) == ("2-torus", (1, 2, 1), 2)
        parts = model.manifold.split(s.state)
        sgn = []
        for name in ("R1", "R2"):  # each body hanging (R e3 = e3) or inverted
            col = SO3.matrix(parts[name]) @ E3
            sgn.append(col[2])
            assert np.allclose(np.abs(col), E3, atol=1e-10)
        assert s.index == 2 * sum(x < 0 for x in sgn)
        V = -v["g"] * ((v["m1"] * v["rho1"][2] + v["m2"] * v["d1"][2]) * sgn[0]
                       + v["m2"] * v["rho2"][2] * sgn[1])
        assert s.value == pytest.approx(float(V), rel=1e-12)
        # each torus holds 4 critical points of the start function: a perfect Morse function
        # on T^2, so the homotopy's 16 starts are 4 x 4
        assert len(s.points) == 4
        assert s.field_residual <= 1e-12
        assert _unstable(model, s.state) == s.index


def test_double_pendulum3d_with_offsets_off_the_body_axes():
    # the centres of mass and the joint off the principal axes: the body symmetries of V are
    # rotations about m1 rho1 + m2 d1 (body 1) and rho2 (body 2), found by the detection
    rng = np.random.default_rng(5)
    J1, J2 = _random_spd(rng, cond=1.5), _random_spd(rng, cond=1.5)
    rho1, d1, rho2 = (rng.standard_normal(3) * s for s in (0.2, 0.4, 0.2))
    model = double_pendulum3d(J1=J1 * 4, J2=J2 * 4, rho1=rho1, d1=d1, rho2=rho2)
    res = find_all_equilibria(model)
    assert res.ok and res.indices == [0, 2, 2, 4] and res.check.perfect
    a1 = model.values["m1"] * rho1 + model.values["m2"] * d1
    for s in res.sets:
        assert s.topology == "2-torus"
        parts = model.manifold.split(s.state)
        for name, a in (("R1", a1), ("R2", rho2)):  # a's image vertical: up or down
            w = SO3.matrix(parts[name]) @ a
            assert np.allclose(np.cross(w, E3), 0, atol=1e-10)
        assert _unstable(model, s.state) == s.index


def test_furuta_has_two_critical_circles_and_the_acrobot_four_points():
    fur = furuta.furuta()
    res = find_all_equilibria(fur)
    assert res.ok and res.indices == [0, 1] and res.check.perfect
    assert res.check.betti_sum_critical == res.check.betti_sum_manifold == 4  # T^2
    assert [s.topology for s in res.sets] == ["circle", "circle"]
    assert res.symmetry == ["shift of the angle theta at rate 1.0"]
    for s, cos_alpha in zip(res.sets, (1.0, -1.0)):
        assert fur.manifold.split(s.state)["alpha"][0] == pytest.approx(cos_alpha, abs=1e-12)
        assert _unstable(fur, s.state) == s.index
    acro = acrobot.acrobot()
    res = find_all_equilibria(acro)
    assert res.ok and res.indices == [0, 1, 1, 2] and res.check.perfect
    v = acro.values
    for s in res.sets:
        assert s.topology == "point"
        p = acro.manifold.split(s.state)
        c1, c2 = p["theta1"][0], p["theta2"][0]
        assert abs(abs(c1) - 1) <= 1e-12 and abs(abs(c2) - 1) <= 1e-12
        V = -v["g"] * ((v["m1"] * v["lc1"] + v["m2"] * v["l1"]) * c1 + v["m2"] * v["lc2"] * c1 * c2)
        assert s.value == pytest.approx(float(V), rel=1e-12)
        assert _unstable(acro, s.state) == s.index


def test_relative_equilibria_are_critical_points_of_the_amended_potential():
    # the Routh model's energy at rest is the amended potential -m g rho.Gamma + mu^2/(2 I);
    # compared with the searches that sample sphere points (models.relative_equilibria)
    J, rho, m, g = np.diag([0.4486, 0.3943, 0.0772]), np.array([-0.014, 0.1044, 0.4989]), 1.0, 9.81
    reduced = pendulum3d.reduced(J=J, rho=rho, m=m, g=g)
    rotation = rotation_problem(reduced)
    static = static_equilibria(reduced)
    for mu, count in ((0.0, 2), (3.0, 6)):
        routh = pendulum3d.routh(J=J, rho=rho, mu=mu, m=m, g=g)
        fn = ConfigurationFunction.from_state(routh, routh.function("energy"))
        res = critical_points(fn)
        assert res.ok and len(res) == count
        f = routh.function("f")
        for s in res.sets:
            gam = s.point
            k = mu / (gam @ J @ gam)  # omega = k Gamma, from mu = omega . J Gamma
            # paper 000: a relative equilibrium balances the moments
            balance = k**2 * np.cross(J @ gam, gam) + m * g * np.cross(rho, gam)
            assert np.max(np.abs(balance)) <= 1e-9 * max(1.0, mu**2)
            assert np.max(np.abs(rotation.residual(np.append(gam, k)))) <= 1e-9 * max(1, mu**2)
            assert np.max(np.abs(np.asarray(f(s.state, [], routh.p)))) <= 1e-7 * max(1.0, mu**2)
        if mu == 0.0:  # the static equilibria of the sampling search
            assert np.allclose(res.sets[0].point, static["hanging"].parts["Gamma"], atol=1e-10)
            assert np.allclose(res.sets[1].point, static["inverted"].parts["Gamma"], atol=1e-10)


def test_riemannian_hessian_is_the_hessian_along_the_retraction():
    man = ProductManifold([("a", S1()), ("q", S2()), ("R", SO3()), ("x", Rn(2))])
    rng = np.random.default_rng(11)
    c = ca.SX.sym("c", man.ambient_dim)
    w1, w2 = rng.standard_normal(man.ambient_dim), rng.standard_normal(man.ambient_dim)
    expr = ca.dot(ca.DM(w1), c) + ca.dot(ca.DM(w2), c) ** 2 + ca.sin(c[3] * c[8])
    fn = ConfigurationFunction(man, ca.Function("V", [c], [expr]))
    y = man.random_point(rng)
    H = fn.riemannian_hessian(y)
    h, n = 1e-4, man.dim
    E = np.eye(n)
    V = fn.value
    fd = np.array([[(V(man.retract(y, h * (E[i] + E[j]))) - V(man.retract(y, h * (E[i] - E[j])))
                     - V(man.retract(y, h * (E[j] - E[i]))) + V(man.retract(y, -h * (E[i] + E[j]))))
                    / (4 * h * h) for j in range(n)] for i in range(n)])
    assert np.max(np.abs(H - fd)) <= 1e-6 * max(1.0, np.max(np.abs(H)))  # O(h^2) differences


def test_betti_tables_and_the_morse_bott_check():
    # Euler characteristics P(-1): S^1 0, S^2 2, SO(3) = RP^3 0, R^k 1; Betti sums 2, 2, 4, 1
    euler = {k: sum(b * (-1) ** i for i, b in enumerate(p)) for k, p in FACTOR_POLYNOMIALS.items()}
    assert euler == {"Rn": 1, "S1": 0, "S2": 2, "SO3": 0}
    assert {k: sum(p) for k, p in FACTOR_POLYNOMIALS.items()} == {"Rn": 1, "S1": 2, "S2": 2,
                                                                  "SO3": 4}
    assert torus_polynomial(2) == (1, 2, 1) and torus_polynomial(0) == (1,)
    so3 = ProductManifold([("R", SO3())])
    assert sum(manifold_polynomial(ProductManifold([("A", SO3()), ("B", SO3())]))) == 16
    circle = torus_polynomial(1)
    ok = morse_bott_check(manifold_polynomial(so3), [(0, circle), (2, circle)])
    assert ok.holds and ok.perfect
    missing = morse_bott_check(manifold_polynomial(so3), [(0, circle)])
    assert not missing.holds and missing.betti_sum_critical == 2 < missing.betti_sum_manifold
    wrong_index = morse_bott_check(manifold_polynomial(so3), [(0, circle), (1, circle)])
    assert not wrong_index.holds  # M - P = t - t^3 = (1 + t)(t - t^2): R has a negative entry
    # a cancelling pair (index 1 and 2) on S^2 keeps the inequalities, not perfection
    pair = morse_bott_check((1, 0, 1), [(0, (1,)), (1, (1,)), (2, (1,)), (2, (1,))])
    assert pair.holds and not pair.perfect and pair.remainder == (0, 1)


def test_deflation_finds_what_the_homotopy_misses():
    q, k = ca.SX.sym("q", 3), ca.SX.sym("k")
    V = ca.Function("V", [q, k], [-q[2] + k * q[0] ** 2])
    sphere = ProductManifold([("q", S2())])
    assert len(critical_points(V, manifold=sphere, p=[0.3])) == 2  # kappa < 1/2: the poles
    kappa = 2.0
    res = critical_points(V, manifold=sphere, p=[kappa])
    assert res.ok and res.indices == [0, 1, 2, 2] and not res.check.perfect
    z = -1 / (2 * kappa)  # the two tilted maxima, born from the upper pole
    tilted = [s for s in res.sets if abs(s.point[2] - z) <= 1e-12]
    assert len(tilted) == 2 and all("deflation" in s.found_by[0] for s in tilted)
    for s in tilted:
        assert abs(abs(s.point[0]) - np.sqrt(1 - z * z)) <= 1e-12
        assert s.value == pytest.approx(-z + kappa * (1 - z * z), rel=1e-12)


def _re_power(a, b, k):
    """``Re (a + i b)^k``: ``cos(k theta)`` on the unit circle ``(a, b) = (cos, sin) theta``."""
    re, im = 1, 0
    for _ in range(k):
        re, im = re * a - im * b, re * b + im * a
    return re


def _torus_cosines(k=5, weight=0.5):
    """``cos(k a) + weight cos(k b)`` on T^2: (2k)^2 critical points, all nondegenerate."""
    c = ca.SX.sym("c", 4)
    V = _re_power(c[0], c[1], k) + weight * _re_power(c[2], c[3], k)
    torus = ProductManifold([("a", S1()), ("b", S1())])
    return ca.Function("V", [c, ca.SX.sym("p", 0)], [V]), torus


def _assert_settled(res):
    end = res.search
    assert end.settled and end.last_new + end.fruitless == end.starts == res.deflation["starts"]
    assert end.patience == max(8, 3 * (len(res) + res.manifold.dim)) <= end.fruitless
    assert end.new_rate_bound == pytest.approx(1 - 0.05 ** (1 / end.fruitless), rel=1e-12)
    assert end.new_rate_bound <= 3 / end.fruitless  # the rule of three


def test_many_critical_points_are_all_found_until_new_ones_stop_appearing():
    """cos 5a + cos(5b) / 2 on T^2 has its critical points where 5a and 5b are multiples of
    pi: 100 points of index [cos 5a = 1] + [cos 5b = 1]; cos 40 theta on S^1 has 80. The
    deflation goes on until 3 (sets + dim) starts in a row find nothing new."""
    V, torus = _torus_cosines()
    res = critical_points(V, manifold=torus)
    assert res.status is CriticalStatus.CONSISTENT and len(res) == 100
    cells = set()
    for s in res.sets:
        a = np.arctan2(s.point[1], s.point[0])
        b = np.arctan2(s.point[3], s.point[2])
        ja, jb = np.rint(5 * a / np.pi), np.rint(5 * b / np.pi)
        assert abs(5 * a - ja * np.pi) <= 1e-9 and abs(5 * b - jb * np.pi) <= 1e-9
        ca_, cb = (-1.0) ** ja, (-1.0) ** jb
        assert s.index == int(ca_ > 0) + int(cb > 0) and s.topology == "point"
        assert s.value == pytest.approx(ca_ + 0.5 * cb, abs=1e-12)
        cells.add((int(ja) % 10, int(jb) % 10))
    assert len(cells) == 100
    assert [res.indices.count(i) for i in range(3)] == [25, 50, 25]
    _assert_settled(res)
    c = ca.SX.sym("c", 2)
    circle = critical_points(ca.Function("V", [c], [_re_power(c[0], c[1], 40)]),
                             manifold=ProductManifold([("t", S1())]))
    assert circle.ok and len(circle) == 80 and circle.indices.count(1) == 40
    angles = np.sort([np.arctan2(s.point[1], s.point[0]) % (2 * np.pi) for s in circle.sets])
    np.testing.assert_allclose(angles, np.arange(80) * np.pi / 40, atol=1e-9)
    _assert_settled(circle)


def test_the_morse_bott_inequalities_cannot_see_missing_sets():
    """Why CONSISTENT is not a proof of completeness: the homotopy alone finds 4 of the
    torus's 100 critical points and they are a perfect Morse function's (M = P_T2); and
    dropping a pair of sets of indices 0 and 1 from the 100 leaves the inequalities holding.
    So without a settled search the status is UNSETTLED, never CONSISTENT."""
    V, torus = _torus_cosines()
    alone = critical_points(V, manifold=torus, deflation_starts=0, raise_on_failure=False)
    assert len(alone) == 4 and alone.check.perfect
    assert alone.status is CriticalStatus.UNSETTLED and alone.search.starts == 0
    assert "deflation was off" in alone.message
    with pytest.raises(SolverError, match="UNSETTLED"):
        critical_points(V, manifold=torus, deflation_starts=0)
    full = critical_points(V, manifold=torus)
    pairs = [(s.index, s.betti) for s in full.sets]
    drop = [pairs.index((0, (1,))), pairs.index((1, (1,)))]
    fewer = [pq for i, pq in enumerate(pairs) if i not in drop]
    assert morse_bott_check(manifold_polynomial(torus), fewer).holds
    assert "necessary for completeness, not sufficient" in full.message
    assert "not sufficient" in CriticalStatus.CONSISTENT.value
    short = critical_points(V, manifold=torus, max_deflation_starts=40, raise_on_failure=False)
    assert short.status is CriticalStatus.UNSETTLED and short.check.holds
    assert not short.search.settled and short.search.starts == 40
    assert "raise max_deflation_starts" in short.message
    # with sets known to be missing (the inequalities fail) the patience is 4 times longer
    early = critical_points(V, manifold=torus, max_deflation_starts=10, raise_on_failure=False)
    assert early.status is CriticalStatus.MISSED and not early.check.holds
    assert early.search.patience == 4 * 3 * (len(early) + 2) and not early.search.settled


def test_a_non_abelian_symmetry_is_reported_unclassified():
    c = ca.SX.sym("c", 6)
    V = ca.Function("V", [c], [ca.dot(c[:3], c[3:])])
    man = ProductManifold([("q1", S2()), ("q2", S2())])
    with pytest.raises(SolverError, match="UNCLASSIFIED"):
        critical_points(V, manifold=man)
    res = critical_points(V, manifold=man, raise_on_failure=False)
    assert res.status is CriticalStatus.UNCLASSIFIED and res.check is None
    assert any("do not commute" in n for n in res.symmetry_notes)
    # q1 = -q2 (index 0) and q1 = q2 (index 2): two 2-spheres, orbits of the joint rotations
    assert res.indices == [0, 2] and [s.value for s in res.sets] == pytest.approx([-1, 1])
    for s in res.sets:
        assert s.morse_bott and s.dimension == 2 and s.topology == "unknown"
        assert abs(abs(s.point[:3] @ s.point[3:]) - 1) <= 1e-12


def test_a_load_at_rest_outside_the_potential_is_refused():
    # a constant torque at the joint does work around the circle: no potential has its
    # equilibria (sin a = 0.5 / 9.81) as critical points, so the search is refused up front,
    # whatever raise_on_failure, naming the load (tests/extremes/test_critical_loads.py)
    s = mechanics.System("biased_pendulum")
    a = s.s1("a")
    s.point_mass(1.0, ca.vertcat(a.sin, 0, a.cos))
    s.gravity(9.81)
    s.moment(a, ca.SX(0.5))
    for flag in (True, False):
        with pytest.raises(ModelError, match=r"torque on a \(load 1 of 1\)"):
            find_all_equilibria(s.model(), raise_on_failure=flag)


def test_bad_targets_and_options_are_refused():
    c = ca.SX.sym("c", 3)
    V = ca.Function("V", [c], [c[2]])
    sphere = ProductManifold([("q", S2())])
    with pytest.raises(ModelError, match="manifold="):
        critical_points(V)
    with pytest.raises(ModelError, match="was not made by workbench.mechanics"):
        critical_points(pendulum3d.reduced(J=np.eye(3), rho=[0, 0, 1.0]))
    with pytest.raises(ModelError, match="only configuration factors"):
        critical_points(V, manifold=ProductManifold([("x", TS2())]))
    with pytest.raises(ModelError, match="scalar"):
        critical_points(ca.Function("V", [c], [c]), manifold=sphere)
    with pytest.raises(ParameterError, match="constant"):
        critical_points(ca.Function("V", [c], [ca.DM(1.0)]), manifold=sphere)
    with pytest.raises(ParameterError, match="max_starts"):
        find_all_equilibria(chain_cart(3), max_starts=4)
    with pytest.raises(ParameterError, match="tol"):
        critical_points(V, manifold=sphere, tol=-1.0)


@pytest.mark.slow
def test_chain_with_eight_links_has_256_equilibria():
    res = find_all_equilibria(chain_cart(8))
    assert res.ok and len(res) == 256 and res.check.perfect
    assert sorted(res.indices) == sorted(2 * bin(k).count("1") for k in range(256))
    assert max(s.field_residual for s in res.sets) <= 1e-12


def test_the_mechanics_hooks_give_the_potential_on_the_configuration():
    """``model.mechanics`` exposes Q, V(c, p) and the state at rest: V at rest is the
    model's energy there (T = 0), and the state at rest is on the model's manifold."""
    rng = np.random.default_rng(21)
    model = double_pendulum3d()
    der = model.mechanics
    Q = der.configuration_manifold()
    assert [n for n, _ in Q.factors] == ["R1", "R2"] and Q.dim == 6
    V, rest = der.potential_function(), der.rest_state()
    energy = model.function("energy")
    for _ in range(3):
        c = Q.random_point(rng)
        x = np.asarray(rest(c), dtype=float).ravel()
        model.check_state(x, tol=1e-12)
        assert float(V(c, model.p)) == pytest.approx(float(energy(x, model.p)), rel=1e-13)
        assert potential_function(model).value(c) == pytest.approx(float(V(c, model.p)))


def test_the_amended_potential_of_a_derived_routh_model_gives_the_relative_equilibria():
    """The derived Routh model says which factors are configuration (Gamma): the critical
    points of its amended potential, with no configuration named, are those of paper
    000's transcribed Routh energy (2 at mu = 0, 6 at mu = 3)."""
    J, rho = np.diag([0.4486, 0.3943, 0.0772]), np.array([-0.014, 0.1044, 0.4989])
    full = pendulum3d.full(J=J, rho=rho)
    for mu, count in ((0.0, 2), (3.0, 6)):
        red = mechanics.reduce(full, "h", momentum=mu, breaking_inputs="hold_zero")
        assert red.configuration == ["Gamma"] and red.model.reduction is red
        derived = critical_points(ConfigurationFunction.from_state(red.model,
                                                                   red.amended_potential))
        paper = pendulum3d.routh(J=J, rho=rho, mu=mu)
        ref = critical_points(ConfigurationFunction.from_state(paper, paper.function("energy")))
        assert derived.ok and len(derived) == len(ref) == count
        assert derived.indices == ref.indices
        for a, b in zip(derived.sets, ref.sets):
            np.testing.assert_allclose(a.point, b.point, atol=1e-10)
            assert a.value == pytest.approx(b.value, rel=1e-12, abs=1e-12)


def test_a_reduction_names_its_configuration_factors():
    rng = np.random.default_rng(22)
    cart = mechanics.System("cart_link")
    x, link = cart.rn("x", 2, velocity="v"), cart.s2("q")
    cart.point_mass(1.5, ca.vertcat(x.x, 0))
    cart.point_mass(0.4, ca.vertcat(x.x, 0) + 0.7 * link.q)
    cart.gravity(9.81)
    cart.momentum("px", translate={x: [1.0, 0.0]})
    red = mechanics.reduce(cart, "px", momentum=0.2)
    assert red.model.manifold.names == ["x", "v", "q"] and red.configuration == ["x", "q"]
    lp = mechanics.reduce(double_pendulum3d(), "L_z", kind="lagrange_poincare")
    assert lp.configuration == ["Gamma", "R2_rel"]
    fn = ConfigurationFunction.from_state(red.model, red.amended_potential)
    assert fn.manifold.names == ["x", "q"]  # the cart's y is a position, read by default
    c = fn.manifold.random_point(rng)
    state = fn.state(c)
    assert np.all(state[red.model.manifold.slices["v"]] == 0)
