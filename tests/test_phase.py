"""Geometric phase: (5.15) against reconstruction, closed forms, orientation, 4 pi."""

from __future__ import annotations

import numpy as np
import pytest

from models import pendulum3d as p3
from models.pendulum3d import phase_density
from workbench.core.errors import ParameterError
from workbench.core.manifolds import SO3, so3_exp
from workbench.global_dynamics._phase import (
    cone_integral,
    first_self_intersection,
    geometric_phase_check,
    holonomy_angle,
    wrap_angle,
)

J = np.diag([0.13, 0.28, 0.17])
RHO = np.array([0.0, 0.0, 0.3])
E3 = np.array([0.0, 0.0, 1.0])


def circle(axis, alpha, n_panels=32, nodes=8, turns=1.0):
    """Circle at angular radius alpha about axis, counterclockwise about the outward normal."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    e1 = np.cross(axis, [1.0, 0, 0] if abs(axis[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    x, w = np.polynomial.legendre.leggauss(nodes)
    edges = np.linspace(0, 2 * np.pi * turns, n_panels + 1)
    h = 0.5 * np.diff(edges)
    t = (edges[:-1, None] + h[:, None] * (x + 1)).ravel()
    wt = (h[:, None] * w).ravel()
    ca_, sa = np.cos(alpha), np.sin(alpha)
    G = ca_ * axis + sa * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2)
    Gd = sa * (-np.sin(t)[:, None] * e1 + np.cos(t)[:, None] * e2)
    return G, Gd, wt


def test_isotropic_density_is_minus_one_and_cap_area_closed_form():
    F = phase_density(2.0 * np.eye(3))
    rng = np.random.default_rng(0)
    g = rng.standard_normal((20, 3))
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    np.testing.assert_allclose(F(g), -1.0, atol=1e-14)
    axis = np.array([0.2, -0.5, 0.8]) / np.linalg.norm([0.2, -0.5, 0.8])
    for alpha in (0.3, 1.2, 2.5):
        G, Gd, w = circle(axis, alpha)
        area = cone_integral(G, Gd, w, apex=axis)
        np.testing.assert_allclose(area, 2 * np.pi * (1 - np.cos(alpha)), rtol=1e-12)
        # reversed direction of travel: opposite sign (orientation is the curve's)
        area_r = cone_integral(G[::-1], -Gd[::-1], w[::-1], apex=axis)
        np.testing.assert_allclose(area_r, -2 * np.pi * (1 - np.cos(alpha)), rtol=1e-12)


def test_whole_sphere_integral_is_minus_4pi_for_any_inertia():
    # the two caps of a circle differ by int_S2 F dA = -4 pi (Euler number 2)
    rng = np.random.default_rng(3)
    for _ in range(3):
        A = rng.standard_normal((3, 3))
        Jr = A @ A.T + 0.5 * np.eye(3)
        F = phase_density(Jr)
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        G, Gd, w = circle(axis, 1.0, n_panels=64)
        inside = cone_integral(G, Gd, w, apex=axis, density=F, radial_nodes=128)
        outside = cone_integral(G, Gd, w, apex=-axis, density=F, radial_nodes=128)
        np.testing.assert_allclose(inside - outside, -4 * np.pi, rtol=1e-9)


def test_apex_choice_changes_the_integral_by_multiples_of_4pi_only():
    F = phase_density(J)
    G, Gd, w = circle([0.3, 0.4, 0.866], 0.7, turns=2.0)  # a doubly traversed circle
    vals = [cone_integral(G, Gd, w, apex=a / np.linalg.norm(a), density=F, radial_nodes=64)
            for a in ([0.3, 0.4, 0.866], [0.5, 0.1, 0.8], [-0.3, -0.4, -0.866])]
    k = (np.array(vals) - vals[0]) / (4 * np.pi)
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)
    assert round(k[2]) == 2                                  # wound twice: twice the sphere


def test_wrap_and_holonomy_angle():
    assert wrap_angle(np.pi) == np.pi and wrap_angle(-np.pi) == np.pi
    np.testing.assert_allclose(wrap_angle(7.0), 7.0 - 2 * np.pi)
    R = so3_exp([0.3, -0.2, 0.5])
    th, res = holonomy_angle(R, so3_exp(0.9 * E3) @ R)
    np.testing.assert_allclose([th, res], [0.9, 0.0], atol=1e-14)
    _, res = holonomy_angle(R, so3_exp([0.1, 0, 0]) @ R)
    assert res > 0.05                                         # not in the same fibre


def test_first_self_intersection_of_a_figure_eight():
    t = np.linspace(0, 2 * np.pi, 401)
    x, y = 0.3 * np.sin(t), 0.3 * np.sin(t) * np.cos(t)      # crosses itself at t = pi
    G = np.column_stack([x, y, np.ones_like(t)])
    G /= np.linalg.norm(G, axis=1, keepdims=True)
    i, j, s, u = first_self_intersection(G)
    np.testing.assert_allclose([(i + s) * t[1], (j + u) * t[1]], [0.0, np.pi], atol=0.02)
    assert first_self_intersection(G[:150]) is None


def _start(gamma0, gamma_dot0):
    g0 = np.asarray(gamma0, float) / np.linalg.norm(gamma0)
    gd0 = np.asarray(gamma_dot0, float) - (np.asarray(gamma_dot0, float) @ g0) * g0
    ax = np.cross(g0, E3)
    R0 = so3_exp(ax / np.linalg.norm(ax) * np.arctan2(np.linalg.norm(ax), g0 @ E3))
    return np.r_[g0, gd0, SO3.flat(R0), 0.0]


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_formula_matches_reconstruction_on_a_loop(mu):
    model = p3.routh_reconstruction(J=J, rho=RHO, mu=mu)
    pc = geometric_phase_check(model, _start([0.8, 0.2, 0.3], [0.0, 3.0, 1.0]),
                               density=phase_density(J),
                               t_max=10.0)
    assert pc.closure < 1e-10 and pc.fibre_residual < 1e-9
    assert abs(pc.difference) < 1e-9
    assert abs(pc.caps_differ_by - round(pc.caps_differ_by)) < 1e-8
    assert round(abs(pc.caps_differ_by)) == 1                 # apex inside: the two caps
    assert abs(pc.theta_formula) > 0.1                        # a non-trivial phase
    assert (pc.dynamic_phase == 0.0) == (mu == 0.0)


def test_lift_must_lie_over_gamma():
    model = p3.routh_reconstruction(J=J, rho=RHO, mu=0.0)
    x0 = _start([0.8, 0.2, 0.3], [0.0, 3.0, 1.0])
    x0[6:15] = SO3.flat(np.eye(3))
    with pytest.raises(ParameterError, match="R0"):
        geometric_phase_check(model, x0, density=phase_density(J), t_max=5.0)


def test_bad_inputs():
    with pytest.raises(ParameterError, match="positive-definite"):
        phase_density(-np.eye(3))
    G, Gd, w = circle(E3, 0.5)
    with pytest.raises(ParameterError, match="apex"):
        cone_integral(G, Gd, w, apex=G[0])
    with pytest.raises(ParameterError, match="shapes"):
        cone_integral(G, Gd[:-1], w, apex=E3)
