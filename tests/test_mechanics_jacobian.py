"""The Jacobians of derived MX models: the chain rule written out with the supplied Jacobian.

An MX model's ``f_x`` and ``f_u`` are ``d rates/dx + d rates/d acc * d acc/dx`` with the
accelerations' implicit-function Jacobian called once (issue 15: 85 ms -> < 50 ms to
linearise the chain at n = 50). They must equal the SX model's Jacobians (a symbolic solve
differentiated by AD), AD of the MX graph of ``f`` itself and central differences, at a
random state and at an equilibrium (where the at-rest branch solves only the nonzero
columns).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from tests.mechanics_systems import chain, pendulum_on_cart
from workbench import linearize, so3_exp

E3 = np.array([0.0, 0.0, 1.0])
RHO = np.array([0.01, -0.02, 0.3])


def _rel(a, b):
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(b))


def _ad_of_graph(model):
    """``df/dx``, ``df/du`` by AD of the model's own ``f`` graph (the previous path)."""
    f = model.function("f")
    x, u, p = (ca.MX.sym(k, f.size1_in(i)) for i, k in enumerate("xup"))
    xdot = f(x, u, p)
    return ca.Function("ad", [x, u, p], [ca.jacobian(xdot, x), ca.jacobian(xdot, u)])


def _central(model, x, u, h=1e-6):
    """Central differences of ``f`` in every ambient direction of ``x``, Richardson-extrapolated."""
    def d(k):
        cols = []
        for j in range(x.size):
            e = np.zeros(x.size)
            e[j] = k
            cols.append((model.rhs(x + e, u) - model.rhs(x - e, u)) / (2 * k))
        return np.column_stack(cols)
    return (4 * d(h) - d(2 * h)) / 3


def _hanging_body() -> np.ndarray:
    """The attitude with the centre of mass straight below the pivot (R rho along e3)."""
    r = RHO / np.linalg.norm(RHO)
    axis = np.cross(r, E3)
    return so3_exp(axis / np.linalg.norm(axis) * np.arccos(r @ E3))


CASES = {
    "pendulum on cart (8 velocities)": (
        lambda sym: pendulum_on_cart(symbolic=sym),
        lambda m: m.state(x=[0.3, -0.2], v=[0.0, 0.0], R=_hanging_body(), omega=np.zeros(3))),
    "chain n = 4 (14 velocities)": (
        lambda sym: chain(4, symbolic=sym),
        lambda m: m.manifold.join({"x": [0.3, -0.2], "v": np.zeros(2),
                                   **{f"link{i + 1}": [0, 0, 1.0, 0, 0, 0] for i in range(4)}})),
}


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("where", ["random state", "equilibrium"])
def test_mx_jacobian_equals_sx_ad_and_differences(name, where):
    make, equilibrium = CASES[name]
    mx, sx = make("MX"), make("SX")
    assert (mx.symbolic, sx.symbolic) == ("MX", "SX")
    rng = np.random.default_rng(7)
    if where == "random state":
        x, u = mx.manifold.random_point(rng), rng.normal(size=mx.n_inputs)
    else:
        x, u = equilibrium(mx), np.zeros(mx.n_inputs)
        assert np.max(np.abs(mx.rhs(x, u))) < 1e-12  # it is one
    fx, fu = (np.asarray(mx.function(k)(x, u, mx.p)) for k in ("f_x", "f_u"))
    sx_fx, sx_fu = (np.asarray(sx.function(k)(x, u, sx.p)) for k in ("f_x", "f_u"))
    ad_fx, ad_fu = (np.asarray(v) for v in _ad_of_graph(mx)(x, u, mx.p))
    assert _rel(fx, sx_fx) < 1e-9 and _rel(fu, sx_fu) < 1e-9
    assert _rel(fx, ad_fx) < 1e-9 and _rel(fu, ad_fu) < 1e-9
    assert _rel(fx, _central(mx, x, u)) < 1e-6
    if where == "equilibrium":
        a_mx, a_sx = linearize(mx, x).A, linearize(sx, x).A
        assert _rel(a_mx, a_sx) < 1e-9


def test_mx_jacobian_calls_the_supplied_jacobian_once():
    # the Jacobian graph holds one call of the accelerations' custom Jacobian (AD of f held
    # one per batch of directions)
    model = chain(12)
    assert model.symbolic == "MX" and model.manifold.ambient_dim > 64
    fx = model.function("f_x")
    names = [fx.instruction_MX(k).which_function().name()
             for k in range(fx.n_instructions()) if fx.instruction_id(k) == ca.OP_CALL]
    assert sum(n.startswith("jac_") for n in names) == 1, names
