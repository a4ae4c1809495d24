"""The chain pendulum on a cart (paper 003): conservation laws, planar invariance, bad input."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import assert_close

from models.chain_cart import chain_cart, link_state
from workbench.core.errors import ParameterError
from workbench.core.manifolds import sphere_basis
from workbench.simulation._simulate import simulate


def _random_state(model, rng, n, speed=1.0):
    parts = {"x": rng.standard_normal(2) * 0.1, "v": rng.standard_normal(2) * 0.2}
    for i in range(n):
        q = rng.standard_normal(3)
        q /= np.linalg.norm(q)
        parts[f"link{i + 1}"] = link_state(q, speed * sphere_basis(q) @ rng.standard_normal(2))
    return model.state(**parts)


@pytest.mark.parametrize("n", [1, 2, 5])
def test_invariants_are_conserved_by_the_graph_and_the_flow(n, rng):
    model = chain_cart(n, m=0.5, masses=rng.uniform(0.05, 0.3, n),
                       lengths=rng.uniform(0.05, 0.3, n))
    # exact first integrals: d/dt I = dI/dx . f = 0 at random states (from the graph)
    xs = ca.MX.sym("x", model.manifold.ambient_dim)
    f = model.function("f")(xs, np.zeros(2), model.p)
    for name in model.invariant_names:
        rate = ca.Function("r", [xs], [ca.jtimes(model.function(name)(xs, model.p), xs, f)])
        for _ in range(3):
            x = _random_state(model, rng, n)
            assert abs(float(rate(x))) < 1e-11, f"d{name}/dt at a random state"
    # and along a simulated motion
    x0 = _random_state(model, rng, n)
    tr = simulate(model, x0, np.linspace(0, 2.0, 41), rtol=1e-11, atol=1e-11)
    drift = tr.diagnostics["invariant_drift"]
    E0 = abs(drift["energy"]["initial"])
    assert drift["energy"]["max_abs"] < 1e-8 * max(E0, 1.0)
    for name in ("px", "py", "Lz"):  # momenta of order 0.1-1; integration error at rtol 1e-11
        assert drift[name]["max_abs"] < 1e-8, f"{name} drift {drift[name]['max_abs']:.2e}"
    # the constraints are kept by the exact flow; what remains is integration error of
    # fast short links at rtol = 1e-11 over 2 s
    assert max(tr.diagnostics["constraint_residual"].values()) < 1e-7


def test_links_started_in_a_vertical_plane_stay_in_it(rng):
    n = 3
    model = chain_cart(n, masses=[0.1, 0.2, 0.15], lengths=[0.1, 0.2, 0.1])
    v = np.array([np.cos(0.4), np.sin(0.4), 0.0])  # horizontal normal of the plane
    in_plane = np.cross(v, [0, 0, 1.0])
    parts = {"x": [0.1, -0.2], "v": [0.3 * in_plane[0], 0.3 * in_plane[1]]}
    for i, a in enumerate((0.5, 2.0, -1.0)):
        q = np.cos(a) * np.array([0, 0, 1.0]) + np.sin(a) * in_plane
        parts[f"link{i + 1}"] = link_state(q, (0.7 - i) * v)  # omega parallel to v
    x0 = model.state(**parts)
    # exactly: the field keeps q_i in the plane and omega_i along its normal (to the rounding
    # of the dense acceleration solve, relative to the largest acceleration: cond(A) ~ 1.5e3)
    xdot = model.rhs(x0)
    scale = max(1.0, float(np.max(np.abs(xdot))))
    for i in range(n):
        s = slice(4 + 6 * i, 10 + 6 * i)
        assert abs(xdot[s][:3] @ v) < 1e-14
        assert np.linalg.norm(np.cross(xdot[s][3:], v)) < 1e-13 * scale
    # and along the flow. The planar motion is unstable out of the plane, so rounding grows
    # by ~1e5 over 3 s; a fixed-step RK4 keeps it at 1e-11 (q) and 2e-10 (omega). (CVODES'
    # Newton corrections at rtol = 1e-11 inject more: 2e-7 and 2e-6 for the derived field.)
    tr = simulate(model, x0, np.linspace(0, 3, 61), method="rk", step=2e-3)
    for i in range(n):
        q = tr.part(f"link{i + 1}")[:, :3]
        w = tr.part(f"link{i + 1}")[:, 3:]
        assert np.max(np.abs(q @ v)) < 1e-9
        assert np.max(np.linalg.norm(np.cross(w, v), axis=1)) < 1e-8


def test_hanging_equilibrium_is_an_equilibrium_and_gravity_pulls_back():
    model = chain_cart(2)
    x = model.state(x=[0, 0], v=[0, 0], link1=link_state([0, 0, 1]), link2=link_state([0, 0, 1]))
    assert_close(model.rhs(x), np.zeros(16), atol=1e-15, what="hanging is at rest")
    tilt = np.array([np.sin(0.1), 0, np.cos(0.1)])
    x = model.state(x=[0, 0], v=[0, 0], link1=link_state(tilt), link2=link_state(tilt))
    # angular acceleration of link 1 about e2 restores it towards e3 (q-ddot = wdot x q)
    qddot = np.cross(model.rhs(x)[7:10], tilt)
    assert qddot[0] < 0


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"n": 0}, "n \\(number of links\\) must be an integer >= 1; got 0"),
        ({"n": 2.5}, "integer >= 1; got 2.5"),
        ({"n": 2, "masses": [0.1, -0.1]}, "'masses'.*must be positive"),
        ({"n": 2, "lengths": [0.1, 0.2, 0.3]},
         "'lengths' must be a scalar or have one entry per link \\(2\\)"),
        ({"n": 1, "m": 0.0}, "'m'.*must be positive"),
    ],
)
def test_bad_input(kwargs, pattern):
    n = kwargs.pop("n")
    with pytest.raises(ParameterError, match=pattern):
        chain_cart(n, **kwargs)
