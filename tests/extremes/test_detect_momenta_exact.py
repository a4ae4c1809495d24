"""A momentum is declared, and a system reduced, only on exact evidence (or on request).

Samples cannot prove a symmetry: a narrow bump of the potential between them breaks it
unseen (a mass on R^1 x R^1 with ``V = 5 exp(-((x - 0.5) / 0.05)^2) + y^2 / 2``: the
translation of ``x`` passed the sampled test and the confirming simulations, and
``reduce`` then dropped the wall). The evidence is now exact where it can be:

- ``dJ/dt`` written without the solve (Noether's identity) equals ``grad J . f`` of the
  model's own field (an independent computation) at random states;
- the modular evaluation decides identities exactly: ``sin^2 + cos^2 = 1``, square roots
  on every branch, a nonzero of size 1e-20; ``exp(x) exp(-x) = 1`` is left undecided
  (never wrongly "zero");
- without unfolding the declaration's constants, the derivation's rounded products of
  constants break a true identity (why :func:`unfolded` exists);
- the cart's translations are zero in the graph; the Furuta arm's angle (written with
  literal floats or with parameters), the 3D pendulum's rotation about gravity and the
  joint translation of coupled masses are identities; the bump (``exp``) and a wall
  (``fmax``) are undecided, a rational spike narrower than the samples is proved broken:
  none of these three is declared by default;
- ``reduce`` refuses a symmetry not established exactly (the bump; a transverse kick
  that conserves the momentum but breaks the field's invariance), and reduces it on
  request with a warning and its evidence;
- the moduli alias no floats: modulo ``2^61 - 1`` a spike scaled by ``1 - 2^-61`` was
  "zero" and reduced; the seeded primes have 2 of order above the double exponent range,
  ``x - 2^-k x`` and ``2^(+-61) x - x`` are nonzero, and a coefficient summed to one
  prime is caught by the other.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import sympy

from workbench import ModelError, mechanics
from workbench.mechanics._exact import (
    ORDER_BOUND,
    PRIMES,
    Verdict,
    _residue,
    identically_zero,
    primes,
    unfolded,
)
from workbench.mechanics._symmetry import (
    Candidate,
    conservation_evidence,
    invariance_evidence,
    momentum_rate,
)


def bump(c: float = 0.5, w: float = 0.05, *, lorentz: bool = False,
         scale: float | None = None) -> mechanics.System:
    """The reviewer's mass on R^1 x R^1 with a narrow bump at ``x = c`` (or a Lorentzian
    ``L``; with ``scale``, ``L - scale * L``)."""
    s = mechanics.System("bump")
    x, y = s.rn("x", 1, velocity="v"), s.rn("y", 1, velocity="vy")
    s.point_mass(1.0, ca.vertcat(x.x, y.x, 0))
    d = (x.x[0] - c) / w
    v = 5.0 / (1 + d**2) if lorentz or scale is not None else 5.0 * ca.exp(-d**2)
    if scale is not None:
        v = v - scale * v
    s.potential(v + 0.5 * y.x[0] ** 2)
    return s


def furuta(parameters: bool) -> mechanics.System:
    """The Furuta pendulum of docs/own-model.md (a point bob), with literal floats or not."""
    s = mechanics.System("furuta")
    arm, link = s.s1("theta", velocity="theta_dot"), s.s1("alpha", velocity="alpha_dot")
    values = {"Jr": 4.0e-4, "Lr": 0.085, "lp": 0.0645, "mp": 0.024, "g": 9.81}
    Jr, Lr, lp, mp, g = (s.parameter(k, v) for k, v in values.items()) if parameters \
        else values.values()
    s.kinetic(0.5 * Jr * arm.rate**2)
    s.point_mass(mp, Lr * ca.vertcat(arm.cos, arm.sin, 0)
                 + lp * (link.cos * ca.DM([0, 0, 1])
                         + link.sin * ca.vertcat(arm.sin, -arm.cos, 0)))
    s.gravity(g)
    s.moment(arm, s.input(1, "motor torque [N m]"))
    return s


def pendulum3d() -> mechanics.System:
    s = mechanics.System("pendulum3d")
    body = s.so3("R", velocity="omega")
    J = s.parameter("J", np.diag([0.4486, 0.3943, 0.0772]), check=mechanics.inertia)
    rho, m = s.parameter("rho", [-0.014, 0.1044, 0.4989]), s.parameter("m", 1.0)
    s.rigid_body(m, J, body, com=rho, inertia_about="origin")
    s.gravity(9.81)
    return s


def cart() -> mechanics.System:
    s = mechanics.System("cart")
    x, link = s.rn("x", 2, velocity="v"), s.s2("q")
    s.point_mass(0.5, ca.vertcat(x.x, 0))
    s.point_mass(0.1, ca.vertcat(x.x, 0) + 0.3 * link.q)
    s.gravity(9.81)
    return s


def coupled() -> mechanics.System:
    s = mechanics.System("coupled")
    a, b = s.rn("a", 1), s.rn("b", 1)
    s.point_mass(1.0, a.x)
    s.point_mass(2.0, b.x)
    s.potential(0.7 * (a.x[0] - b.x[0]) ** 2 + 0.1 * (a.x[0] - b.x[0]) ** 4)
    return s


def evidence(s: mechanics.System, gens) -> tuple[bool, str]:
    """The conservation evidence of the momentum ``gens(s)`` declares on ``s``."""
    s.momentum("J", **gens(s))
    model = s.model()
    der = model.mechanics
    return conservation_evidence(der, [Candidate("J", "", der.ing.momenta["J"])],
                                 model.p)[0]


# ----------------------------------------------------------------------------------------
# dJ/dt without the solve is the model's own


@pytest.mark.parametrize("make, gens", [
    (cart, lambda s: {"translate": {s.factor("x"): [1.0, 0.0]}}),
    (lambda: furuta(False), lambda s: {"shift": [s.factor("theta")]}),
    (pendulum3d, lambda s: {"rotate": [0.0, 0.0, 1.0]}),
    (lambda: bump(), lambda s: {"translate": {s.factor("y"): [1.0]}}),
], ids=["cart", "furuta", "pendulum3d", "bump_y"])
def test_momentum_rate_is_grad_j_times_the_field(make, gens):
    s = make()
    s.momentum("J", **gens(s))
    model = s.model(check=False)  # the bump's y-translation is no symmetry: not checked
    der = model.mechanics
    rate = ca.Function("E", [der.x, der.ing.p], [momentum_rate(der, der.ing.momenta["J"])])
    grad = ca.Function("g", [der.x, der.ing.p], [ca.gradient(
        der.momentum(der.ing.momenta["J"])(der.x, der.ing.p), der.x)])
    rng = np.random.default_rng(4)
    for _ in range(4):
        x = model.manifold.random_point(rng)
        g = np.asarray(grad(x, model.p), dtype=float).ravel()
        f = np.asarray(model.function("f")(x, np.zeros(model.n_inputs), model.p),
                       dtype=float).ravel()
        e = float(rate(x, model.p))
        assert e == pytest.approx(g @ f, abs=1e-12 * np.linalg.norm(g) * np.linalg.norm(f))
        if s.name == "bump":  # translating y: dJ/dt = -dV/dy = -y, not small
            assert e == pytest.approx(-x[2], rel=1e-12)


# ----------------------------------------------------------------------------------------
# the modular evaluation


def _verdict(expr_of, n: int = 2) -> Verdict:
    """The verdict on ``expr_of(x)`` over an R^n factor (state ``(x, v)``)."""
    r = mechanics.System("plain").rn("r", n)
    fn = ca.Function("e", [ca.vertcat(r.x, r.v), ca.SX.sym("p", 0)], [expr_of(r.x)])
    return identically_zero(fn, [r], np.zeros(0))[0][0]


@pytest.mark.parametrize("expr, verdict", [
    (lambda x: ca.sin(x[0]) ** 2 + ca.cos(x[0]) ** 2 - 1, Verdict.ZERO),
    (lambda x: ca.sqrt(x[0] ** 2 + x[1] ** 2) ** 2 - x[0] ** 2 - x[1] ** 2, Verdict.ZERO),
    (lambda x: (x[0] + x[1]) ** 3 - x[0] ** 3 - 3 * x[0] ** 2 * x[1] - 3 * x[0] * x[1] ** 2
     - x[1] ** 3, Verdict.ZERO),
    (lambda x: x[0] / (x[0] + x[1]) + x[1] / (x[0] + x[1]) - 1, Verdict.ZERO),
    (lambda x: x[0] * x[1] - x[1] * x[0] + 1e-20 * x[0], Verdict.NONZERO),
    (lambda x: ca.exp(x[0]) * ca.exp(-x[0]) - 1, Verdict.UNDECIDED),
    (lambda x: ca.exp(-(x[0] / 0.05) ** 2), Verdict.UNDECIDED),
    (lambda x: ca.fmax(x[0], 0.0) - ca.fmax(x[0], 0.0), Verdict.ZERO),
], ids=["circle", "sqrt_branches", "binomial", "rational", "tiny", "exp_pair", "bump",
        "same_fmax"])
def test_the_modular_evaluation_decides_identities_exactly(expr, verdict):
    assert _verdict(expr) is verdict


def test_a_sign_only_one_branch_satisfies_is_not_an_identity():
    # sqrt(x^2) - x is zero for x > 0 only: not every branch vanishes, never "zero"
    assert _verdict(lambda x: ca.sqrt(x[0] ** 2) - x[0]) is not Verdict.ZERO


def test_folded_constants_would_break_an_identity_unfolded_ones_do_not():
    """The free double pendulum's shift: an identity of the mechanics, but the derivation
    folds products of 0.9, 0.8, 0.7 in different orders, each rounded."""
    s = mechanics.System("free_double")
    a, b = s.s1("a"), s.s1("b")
    c_ab, s_ab = a.cos * b.cos - a.sin * b.sin, a.sin * b.cos + a.cos * b.sin
    s.point_mass(1.0, 0.9 * ca.vertcat(a.sin, a.cos))
    s.point_mass(0.7, 0.9 * ca.vertcat(a.sin, a.cos) + 0.8 * ca.vertcat(s_ab, c_ab))
    s.momentum("La", shift=[a])
    model = s.model()
    der = model.mechanics
    folded = ca.Function("E", [der.x, der.ing.p], [momentum_rate(der, der.ing.momenta["La"])])
    assert identically_zero(folded, der.ing.factors, model.p)[0] == [Verdict.NONZERO]
    exact, k = unfolded(der)
    assert k.size > 0 and 0.9 in k.tolist()
    fn = ca.Function("E", [exact.x, exact.ing.p], [momentum_rate(exact, der.ing.momenta["La"])])
    assert identically_zero(fn, der.ing.factors, np.r_[model.p, k])[0] == [Verdict.ZERO]
    rng = np.random.default_rng(0)  # the unfolded equations are the same system
    for _ in range(3):
        x = model.manifold.random_point(rng)
        f = exact.rates()(x, np.linalg.solve(*(np.asarray(m, dtype=float) for m in
                                               exact.assembly()(x, [], np.r_[model.p, k]))))
        ref = model.function("f")(x, [], model.p)
        assert np.asarray(f).ravel() == pytest.approx(np.asarray(ref).ravel(), abs=1e-13)


# ----------------------------------------------------------------------------------------
# what detect_momenta establishes


@pytest.mark.parametrize("make, gens, how", [
    (cart, lambda s: {"translate": {s.factor("x"): [1.0, 0.0]}}, "zero in the derived graph"),
    (lambda: furuta(False), lambda s: {"shift": [s.factor("theta")]}, "vanishes identically"),
    (lambda: furuta(True), lambda s: {"shift": [s.factor("theta")]}, "vanishes identically"),
    (pendulum3d, lambda s: {"rotate": [0.0, 0.0, 1.0]}, "vanishes identically"),
    (coupled, lambda s: {"translate": {s.factor("a"): [1.0], s.factor("b"): [1.0]}},
     ""),  # casadi may cancel (a - b) terms in the graph itself, or leave them
], ids=["cart_translation", "furuta_literal", "furuta_parameters", "pendulum3d_rotation",
        "coupled_joint_translation"])
def test_the_known_symmetries_are_proved(make, gens, how):
    exact, words = evidence(make(), gens)
    assert exact and how in words


@pytest.mark.parametrize("make, found", [
    (cart, {"linear_momentum_x_1", "linear_momentum_x_2", "angular_momentum_e3"}),
    (lambda: furuta(False), {"angular_momentum_theta"}),
    (pendulum3d, {"angular_momentum_e3"}),
    (coupled, {"linear_momentum_1"}),
], ids=["cart", "furuta", "pendulum3d", "coupled"])
def test_detect_momenta_declares_the_proved_ones_without_a_warning(make, found, recwarn):
    got = make().detect_momenta()
    assert set(got) == found
    assert not any("sampled" in d for d in got.values())
    assert not [w for w in recwarn if issubclass(w.category, UserWarning)]


@pytest.mark.parametrize("c, w", [(2.0, 0.1), (2.0, 0.3), (0.5, 0.05), (30.0, 1.0)])
def test_the_reviewers_bump_is_not_declared(c, w):
    assert bump(c, w).detect_momenta() == {}
    exact, words = evidence(bump(c, w), lambda s: {"translate": {s.factor("x"): [1.0]}})
    assert not exact and "its graph holds exp" in words


def test_a_rational_spike_the_samples_miss_is_proved_broken():
    """A Lorentzian of width 1e-7: ``|dV/dx| <~ 1e-13 / |x - 0.5|^3`` at the samples, ``~3e7``
    beside its top."""
    s = bump(0.5, 1e-7, lorentz=True)
    with pytest.warns(UserWarning, match="not identically zero"):
        found = s.detect_momenta(accept_sampled=True, confirm=False)
    assert list(found) == ["linear_momentum_x_1"]  # the samples alone would declare it
    assert bump(0.5, 1e-7, lorentz=True).detect_momenta() == {}
    exact, words = evidence(bump(0.5, 1e-7, lorentz=True),
                            lambda s: {"translate": {s.factor("x"): [1.0]}})
    assert not exact and "not identically zero (nonzero at a point" in words


def test_sampled_evidence_is_declared_on_request_and_said():
    s = bump()
    with pytest.warns(UserWarning, match="declared on sampled evidence only"):
        found = s.detect_momenta(accept_sampled=True)
    assert list(found) == ["linear_momentum_x_1"]
    assert found["linear_momentum_x_1"].startswith(
        "translation of x along its axis 1 [sampled evidence only: whether dJ/dt vanishes "
        "everywhere is not decided exactly (its graph holds exp)")
    with pytest.raises(ModelError, match="accept_sampled must be True or False"):
        bump().detect_momenta(accept_sampled=1)


# ----------------------------------------------------------------------------------------
# the consequence for reduce


def test_reduce_refuses_the_bump_and_says_why_then_reduces_on_request():
    s = bump()
    s.momentum("px", translate={s.factor("x"): [1.0]})
    with pytest.raises(ModelError, match=r"the symmetry 'px' of 'bump' is not established "
                                         r"exactly: .*exp.*accept_sampled=True"):
        mechanics.reduce(s, "px", momentum=2.0)
    with pytest.warns(UserWarning, match="reduced on the evidence of 3 random states"):
        red = mechanics.reduce(s, "px", momentum=2.0, accept_sampled=True)
    assert "the bracket [X, f]" in red.evidence and "exp" in red.evidence
    with pytest.raises(ModelError, match="accept_sampled must be True or False"):
        mechanics.reduce(s, "px", momentum=2.0, accept_sampled="yes")


def kicked(force) -> mechanics.System:
    s = mechanics.System("kicked")
    x = s.rn("x", 2, velocity="v")
    s.point_mass(1.0, x.x)
    s.force(x, ca.vertcat(0, force(x.x[0])))
    s.momentum("p1", translate={x: [1.0, 0.0]})
    return s


def test_a_transverse_kick_conserves_the_momentum_but_breaks_the_invariance():
    """``F = (0, 3 exp(-((x1 - 0.5) / 0.05)^2))`` does no work along x1 (``p1`` conserved,
    exactly) but depends on x1: the reduced field would depend on the lift."""
    s = kicked(lambda x1: 3.0 * ca.exp(-((x1 - 0.5) / 0.05) ** 2))
    model = s.model()
    der = model.mechanics
    (conserved, _), = conservation_evidence(der, [Candidate("p1", "", der.ing.momenta["p1"])],
                                            model.p)
    assert conserved
    with pytest.raises(ModelError, match=r"whether the bracket \[X, f\] .* not decided "
                                         r"exactly \(its graph holds exp\)"):
        mechanics.reduce(s, "p1", kind="lagrange_poincare")
    # a kick growing linearly in x1: the invariance is proved broken
    red_free = mechanics.reduce(kicked(lambda x1: 0.0 * x1), "p1", kind="lagrange_poincare")
    lin = kicked(lambda x1: 0.3 * x1).model()
    ok, words = invariance_evidence(lin.mechanics, red_free.act, lin.p)
    assert not ok and "not identically zero" in words
    assert red_free.evidence.startswith("exact: dJ/dt is zero in the derived graph")


# ----------------------------------------------------------------------------------------
# the moduli alias no floats


def test_the_primes_are_seeded_primes_modulo_which_2_has_a_large_order():
    """Checked independently (sympy's primality and multiplicative order); the Mersenne
    prime the evaluation used before fails: 2 has order 61 there, so 2^-61 = 1."""
    for seed in (0, 1, 7):
        qs = primes(seed)
        assert len(qs) == len(set(qs)) == PRIMES >= 2
        assert qs == primes(seed)  # deterministic
        for q in qs:
            assert sympy.isprime(q) and q % 4 == 3 and q.bit_length() == 61
            assert sympy.n_order(2, q) > ORDER_BOUND >= 1074 + 1023 + 53
    assert set(primes(0)).isdisjoint(primes(1))
    mersenne = (1 << 61) - 1
    assert sympy.n_order(2, mersenne) == 61 and _residue(2.0**-61, mersenne) == 1


def test_the_reviewers_scaled_spike_is_not_a_symmetry():
    """``V = L - 2^-61 L``, ``L`` a Lorentzian of width 1e-7: modulo ``2^61 - 1`` it was zero
    (declared ``linear_momentum_x_1`` and reduced as exact); ``dV/dx ~ -3.2e7`` beside the
    top."""
    s = bump(0.5, 1e-7, scale=2.0**-61)
    s.momentum("px", translate={s.factor("x"): [1.0]})
    model = s.model(check=False)
    der = model.mechanics
    dv = ca.Function("dV", [der.x], [ca.gradient(der.ing.potential, der.x)[0]])
    x0 = np.zeros(der.x.numel())
    x0[0] = 0.5 + 5e-8
    assert float(dv(x0)) == pytest.approx(-3.2e7, rel=1e-6)
    assert bump(0.5, 1e-7, scale=2.0**-61).detect_momenta() == {}
    for seed in range(4):  # whichever primes and points
        (exact, words), = conservation_evidence(
            der, [Candidate("px", "", der.ing.momenta["px"])], model.p, seed=seed)
        assert not exact and "not identically zero (nonzero at a point" in words
    s = bump(0.5, 1e-7, scale=2.0**-61)
    s.momentum("px", translate={s.factor("x"): [1.0]})
    with pytest.raises(ModelError, match=r"'px' of 'bump' is not established exactly: "
                                         r"dJ/dt is not identically zero"):
        mechanics.reduce(s, "px", momentum=0.0)


@pytest.mark.parametrize("k", [1, 30, 52, 53, 61, 122, 183, 600, 1074])
def test_one_minus_a_power_of_two_is_not_zero(k):
    """``x - 2^-k x`` has the coefficient ``1 - 2^-k != 0`` (exact in the graph: the two
    terms are not folded); modulo ``2^61 - 1`` every ``k`` divisible by 61 was zero."""
    assert _verdict(lambda x: x[0] - 2.0**-k * x[0]) is Verdict.NONZERO
    if k <= 53:  # 1 - 2^-k one float
        assert _verdict(lambda x: x[0] - (1 - 2.0**-k) * x[0]) is Verdict.NONZERO


@pytest.mark.parametrize("e", [61, -61, 122, -122, 1023, -1074])
def test_scalings_by_powers_of_two_are_not_the_identity(e):
    assert _verdict(lambda x: 2.0**e * x[0] - x[0]) is Verdict.NONZERO
    assert _verdict(lambda x: 2.0**e * x[0] - 2.0**e * x[0]) is Verdict.ZERO


@pytest.mark.parametrize("which", range(PRIMES))
def test_a_coefficient_divisible_by_one_prime_is_caught_by_another(which):
    """``h x + l x`` with ``h + l = q`` (``h`` the 53 leading bits of the prime, ``l`` the
    rest, both exact floats): zero modulo ``q``, the real coefficient ``q`` is not."""
    q = primes(0)[which]
    h = float(q)  # rounded to 53 bits: q - h is small and exact
    low = float(q - int(h))
    assert int(h) + int(low) == q and low != 0
    assert (_residue(h, q) + _residue(low, q)) % q == 0  # one prime alone says "zero"
    assert _verdict(lambda x: h * x[0] + low * x[0]) is Verdict.NONZERO
