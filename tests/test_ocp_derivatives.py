"""The per-interval NLP derivatives equal casadi's derivatives of the whole flat NLP.

:mod:`workbench.control.ocp.derivatives` builds Ipopt's constraint Jacobian and the Hessian
of the Lagrangian from one interval's exact derivatives, scattered into the NLP's sparsity.
An independent reference is casadi's own AD of the flat scalar NLP (``nlpsol``'s default
``nlp_jac_g`` / ``nlp_hess_l``): the two must agree entry by entry (same sparsity, values to
rounding) at random points, random multipliers and random parameters, for every
transcription and handling, with path constraints, a terminal cost and the phase condition
of a symmetry gauge.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from workbench.control.ocp import (
    OCP,
    Collocation,
    Guess,
    HermiteSimpson,
    ManifoldHandling,
    MultipleShooting,
    PathConstraint,
    TargetPoint,
    solve,
)
from workbench.control.ocp.solve import transcribe
from workbench.control.ocp.study import effort_time_ocp

E3 = np.eye(3)[2]
METHODS = [HermiteSimpson(N=5), Collocation(N=4, degree=3), Collocation(N=3, degree=2),
           MultipleShooting(N=4)]


def _cart():
    x0 = np.r_[0.0, 0.0, 0.0, 0.0, link_state(E3)]
    xf = np.r_[0.0, 0.0, 0.0, 0.0, link_state(-E3)]
    return effort_time_ocp(chain_cart(1), x0, xf, u_max=10.0, T=(0.5, 3.0), name="d_cart")


def _body():
    red = p3.reduced(J=np.diag([0.13, 0.28, 0.17]), rho=[0, 0, 0.3], m=1.0, g=9.81)
    return OCP(red, x0=np.r_[E3, 0.0, 0.0, 0.0],
               target=TargetPoint(red.manifold, np.r_[-E3, 0.0, 0.0, 0.0]), u_lower=-1,
               u_upper=1, T=(1.0, 4.0), running_cost=lambda x, u: ca.dot(u, u) * x[2] ** 2,
               terminal_cost=lambda x, T: T ** 2 + ca.sin(x[0]),
               path_constraints=[PathConstraint(lambda x, u: ca.dot(x[3:6], x[3:6]) * u[0],
                                                upper=5.0, name="speed"),
                                 PathConstraint(lambda x, u: u[1] * x[1], lower=0.0,
                                                nodes="first", name="first")])


def _relative_difference(A: ca.DM, B: ca.DM) -> float:
    scale = max(1.0, float(np.max(np.abs(np.asarray(ca.densify(A))))))
    return float(np.max(np.abs(np.asarray(ca.densify(A - B))))) / scale


@pytest.mark.parametrize("which", ["cart", "body"])
@pytest.mark.parametrize("handling", list(ManifoldHandling))
@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.describe())
def test_structured_derivatives_equal_casadis_flat_ones(which, handling, method):
    ocp = _cart() if which == "cart" else _body()
    tr, _ = transcribe(ocp, method, handling=handling)
    assert tr._structure is not None  # the structured path was taken
    ours = tr._derivatives
    ref = ca.nlpsol("ref", "ipopt", tr.nlp, {"print_time": False})
    rng = np.random.default_rng(7)
    w = rng.normal(size=tr.nw)
    w[tr.iT] = 1.7
    P = rng.normal(size=int(tr.nlp["p"].numel()))
    lam_f, lam_g = 0.6, rng.normal(size=tr.ng)
    g_ref, J_ref = ref.get_function("nlp_jac_g")(w, P)
    g, J = ours["jac_g"](w, P)
    assert J.sparsity() == J_ref.sparsity()
    assert _relative_difference(J_ref, J) < 1e-12
    assert np.array_equal(np.asarray(g), np.asarray(g_ref))
    H_ref = ref.get_function("nlp_hess_l")(w, P, lam_f, lam_g)
    H = ours["hess_lag"](w, P, lam_f, lam_g)
    assert H.sparsity() == H_ref.sparsity()
    assert _relative_difference(H_ref, H) < 1e-12


def test_gauged_swing_up_has_its_phase_condition_and_converges():
    """The cart swing-up is gauged (rest rows: continuity, terminal, phase condition)."""
    ocp = _cart()
    assert ocp.symmetry is not None
    sol = solve(ocp, HermiteSimpson(N=20), defect_tol=None,
                guess=Guess.geodesic(ocp, T=1.5, axes={"link1": np.eye(3)[0]}))
    tr, _ = transcribe(ocp, HermiteSimpson(N=20))
    assert tr.i_gauge is not None and tr._structure is not None
    assert sol.status.ok and sol.error["constraint_violation"] < 1e-8
