"""The three systems defined only by their Lagrangians, against independent derivations.

``models.pendulum3d_cart``, ``models.quadrotor_slung_load`` and ``models.double_pendulum3d``
are written with :mod:`workbench.mechanics` (no hand-derived equation). Here their vector
fields are compared with Kane's equations from sympy.physics.mechanics in Euler angles and
spherical angles (``models/kane_references.py``) at random states away from the angles'
singularities and random physical parameters, and their invariants are checked along
simulations.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from sympy.physics import mechanics as me

from models import kane_references as K
from models.double_pendulum3d import double_pendulum3d
from models.pendulum3d_cart import pendulum3d_cart
from models.quadrotor_slung_load import hover_input, quadrotor_slung_load
from workbench import ParameterError, simulate, so3_exp

SEED = 20261123
TOL = 1e-10


def physical_inertia(rng, m, rho):
    """Random inertia about a pivot at ``-rho`` from the centre of mass (triangle-safe)."""
    a, b = rng.uniform(0.05, 0.3, size=2)
    moments = np.array([a, b, rng.uniform(abs(a - b) + 0.01, a + b - 0.01)])
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rho = np.asarray(rho)
    return Q @ np.diag(moments) @ Q.T + m * (rho @ rho * np.eye(3) - np.outer(rho, rho))


def test_euler_angle_map_is_sympys_direction_cosine_matrix():
    N = me.ReferenceFrame("N")
    a, b, c = sp.symbols("a b c")
    B = N.orientnew("B", "Body", [a, b, c], "321")
    dcm = np.array(sp.lambdify([a, b, c], N.dcm(B))(0.3, -0.4, 0.7), dtype=float)
    assert np.max(np.abs(dcm - K.rotation([0.3, -0.4, 0.7]))) < 1e-15


@pytest.mark.parametrize("trial", range(3))
def test_pendulum3d_cart_matches_kanes_method(trial):
    rng = np.random.default_rng([SEED, trial])
    m, rho = rng.uniform(0.2, 1.5), rng.normal(size=3) * 0.3
    model = pendulum3d_cart(M=rng.uniform(0.5, 2.0), m=m, J=physical_inertia(rng, m, rho),
                            rho=rho, g=rng.uniform(1.0, 20.0), body_moment=True)
    assert K.deviation(model, rng, n=3) < TOL


@pytest.mark.parametrize("trial", range(3))
def test_quadrotor_slung_load_matches_kanes_method(trial):
    rng = np.random.default_rng([SEED, 10 + trial])
    mQ = rng.uniform(0.3, 1.5)
    model = quadrotor_slung_load(mQ=mQ, JQ=physical_inertia(rng, mQ, np.zeros(3)),
                                 mL=rng.uniform(0.05, 0.5), L=rng.uniform(0.3, 2.0),
                                 g=rng.uniform(1.0, 20.0))
    assert K.deviation(model, rng, n=3) < TOL


@pytest.mark.parametrize("trial", range(3))
def test_double_pendulum3d_matches_kanes_method(trial):
    rng = np.random.default_rng([SEED, 20 + trial])
    m1, m2 = rng.uniform(0.5, 2.0), rng.uniform(0.3, 1.5)
    rho1, rho2 = rng.normal(size=3) * 0.3, rng.normal(size=3) * 0.3
    model = double_pendulum3d(m1=m1, J1=physical_inertia(rng, m1, rho1), rho1=rho1,
                              d1=rng.normal(size=3) * 0.5, m2=m2,
                              J2=physical_inertia(rng, m2, rho2), rho2=rho2,
                              g=rng.uniform(1.0, 20.0))
    assert K.deviation(model, rng, n=3) < TOL


class _Perturbed:
    """A model whose accelerations are off by ``eps`` (everything else delegated)."""

    def __init__(self, model, eps):
        self._model, self._eps = model, eps

    def __getattr__(self, name):
        return getattr(self._model, name)

    def rhs(self, x, u=None):
        return self._model.rhs(x, u) + self._eps


@pytest.mark.parametrize("make", [lambda: pendulum3d_cart(body_moment=True),
                                  quadrotor_slung_load, double_pendulum3d])
def test_the_reference_can_fail(make):
    """A deviation of 1e-6 in the accelerations is seen by the Kane comparison."""
    rng = np.random.default_rng(SEED)
    assert K.deviation(_Perturbed(make(), 1e-6), rng, n=1) > 1e-7


def test_invariants_are_conserved_along_simulations():
    """Energy and the declared momenta, unforced, at rtol 1e-11 over a few seconds."""
    cart = pendulum3d_cart()
    x0 = cart.state(x=[0.1, -0.2], v=[0.3, 0.1], R=so3_exp([0.4, 0.2, 0.1]),
                    Omega=[0.2, -0.1, 0.5])
    quad = quadrotor_slung_load()
    q = K.direction(0.4, 0.3)
    xq = quad.state(xQ=[0, 0, 0], vQ=[0.2, 0, 0], R=so3_exp([0.1, 0, 0.2]), Omega=[0, 0.1, 0.3],
                    q=np.r_[q, np.cross(q, [0.1, 0.5, 0.0])])
    dbl = double_pendulum3d()
    xd = dbl.state(R1=so3_exp([0.5, 0.2, 0]), Omega1=[0.3, 0.1, 0.5],
                   R2=so3_exp([-0.4, 0.3, 0.1]), Omega2=[0, 0.4, -0.2])
    for model, x, names in [(cart, x0, {"energy", "p_x", "p_y", "L_z"}),
                            (quad, xq, {"energy", "p_x", "p_y", "L_z"}),
                            (dbl, xd, {"energy", "L_z"})]:
        tr = simulate(model, x, np.linspace(0, 3, 31), rtol=1e-11, atol=1e-11)
        drift = tr.diagnostics["invariant_drift"]
        assert set(drift) == names
        for name in names:
            assert drift[name]["max_abs"] < 1e-8 * max(1.0, abs(drift[name]["initial"])), name


def test_hover_is_an_equilibrium_and_the_cart_pendulum_rests_hanging():
    quad = quadrotor_slung_load(mQ=0.7, mL=0.2)
    x = quad.state(xQ=[1, 2, -3], vQ=[0, 0, 0], R=np.eye(3), Omega=[0, 0, 0],
                   q=[0, 0, 1, 0, 0, 0])
    assert np.max(np.abs(quad.rhs(x, hover_input(quad)))) < 1e-14
    assert hover_input(quad)[0] == pytest.approx((0.7 + 0.2) * 9.81, rel=1e-15)
    cart = pendulum3d_cart()
    x = cart.state(x=[0, 0], v=[0, 0], R=np.eye(3), Omega=[0, 0, 0])
    assert np.max(np.abs(cart.rhs(x, [0, 0]))) < 1e-14


def test_non_physical_inertias_are_refused_with_the_argument_named():
    with pytest.raises(ParameterError, match="'J'.*triangle"):
        pendulum3d_cart(J=np.diag([1.0, 1.0, 3.0]))
    with pytest.raises(ParameterError, match="'JQ'"):
        quadrotor_slung_load(JQ=np.diag([1.0, -1.0, 1.0]))
    with pytest.raises(ParameterError, match="'m2'"):
        double_pendulum3d(m2=0.0)
