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
from scipy.special import ellipk

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from workbench import mechanics
from workbench.control.ocp import (
    OCP,
    Collocation,
    Direct,
    Guess,
    HermiteSimpson,
    ManifoldHandling,
    MultipleShooting,
    PathConstraint,
    Scheme,
    TargetPoint,
    TargetSet,
    solve,
)
from workbench.control.ocp.derivatives import IntervalLayout
from workbench.control.ocp.solve import transcribe
from workbench.control.ocp.study import effort_time_ocp
from workbench.core import Symbolic
from workbench.core._model import Model, Parameter
from workbench.core.manifolds import ProductManifold, Rn

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


# ----------------------------------------------------------------------------------------
# a model without inputs: the empty control block sits at the next node's offset


def test_layout_keeps_the_next_node_when_an_empty_block_shares_its_offset():
    """With no inputs, interval k's control block ``(iu_k, 0)`` starts at ``X_(k+1)``.

    The layout must still read ``X_(k+1)``: an empty argument is not the next node.
    """
    x, u, h, p = ca.SX.sym("x", 2), ca.SX.sym("u", 0), ca.SX.sym("h"), ca.SX.sym("p", 0)
    F = ca.Function("interval", [x, ca.SX.sym("Z", 0, 1), u, h, p],
                    [ca.SX.zeros(0, 1), x + h * ca.vertcat(x[1], -x[0]), 0])
    N, nx = 3, 2
    blocks = [[(k * nx, nx), ((k + 1) * nx, 0), ((k + 1) * nx, 0)] for k in range(N)]
    layout = IntervalLayout(F, blocks, [((k + 1) * nx, nx) for k in range(N)], N * nx + nx)
    assert layout.next_pos is None
    assert layout.idx.tolist() == [[0, 1, 2, 3, 8], [2, 3, 4, 5, 8], [4, 5, 6, 7, 8]]
    fJ, _, nrow = layout.local_functions(0)
    z = np.array([0.3, -0.2, 1.1, 0.7, 1.5])  # X_k, X_(k+1), T
    J = ca.DM(layout.J_sparsity, fJ(z, []))
    hh = z[4] / N  # continuity X_(k+1) - X_k - h A X_k, A = [[0, 1], [-1, 0]]
    expected = np.array([[-1.0, -hh, 1.0, 0.0, -z[1] / N],
                         [hh, -1.0, 0.0, 1.0, z[0] / N]])
    assert nrow == nx
    assert np.max(np.abs(np.asarray(ca.densify(J)) - expected)) <= 1e-15


def _oscillator() -> Model:
    """``x'' = -a x`` on R^2, no inputs, one parameter."""
    return Model(name="oscillator", manifold=ProductManifold([("x", Rn(2))]), n_inputs=0,
                 parameters=[Parameter("a", (), "stiffness [1/s^2]")], values={"a": 2.0},
                 vector_field=lambda ctx: ca.vertcat(ctx["x"][1], -ctx["a"] * ctx["x"][0]))


@pytest.mark.parametrize("handling", list(ManifoldHandling))
@pytest.mark.parametrize("method", [Collocation(N=3, degree=2), MultipleShooting(N=3),
                                    HermiteSimpson(N=3)], ids=lambda m: m.describe())
def test_structured_jacobian_without_inputs_equals_casadis(method, handling):
    """The minimal shape that was wrong: ``n_inputs = 0`` (continuity rows read ``T``)."""
    model = _oscillator()
    ocp = OCP(model, x0=[1.0, 0.0], target=TargetPoint(model.manifold, np.r_[0.0, -1.0]),
              u_lower=[], u_upper=[], T=(0.5, 2.0), terminal_cost=lambda x, T: T)
    tr, _ = transcribe(ocp, method, handling=handling)
    assert tr._structure is not None
    ref = ca.nlpsol("ref", "ipopt", tr.nlp, {"print_time": False})
    rng = np.random.default_rng(11)
    w, P = rng.normal(size=tr.nw), rng.normal(size=int(tr.nlp["p"].numel()))
    w[tr.iT] = 1.3
    _, J_ref = ref.get_function("nlp_jac_g")(w, P)
    _, J = tr._derivatives["jac_g"](w, P)
    assert J.sparsity() == J_ref.sparsity()
    assert _relative_difference(J_ref, J) < 1e-12
    lam_g = rng.normal(size=tr.ng)
    H_ref = ref.get_function("nlp_hess_l")(w, P, 0.4, lam_g)
    H = tr._derivatives["hess_lag"](w, P, 0.4, lam_g)
    assert H.sparsity() == H_ref.sparsity()
    assert _relative_difference(H_ref, H) < 1e-12


L_FALL, G_FALL = 0.8, 9.81


def _falling_pendulum() -> OCP:
    """An unforced spherical pendulum released from the horizontal: reach the bottom first.

    Minimum time to ``q . e1 = 0`` from ``q = e1`` at rest (gravity along ``e3``): the
    quarter period of a planar swing of amplitude 90 deg, ``sqrt(l/g) K(1/2)``.
    """
    s = mechanics.System("falling_pendulum")
    link = s.s2("q")
    ll, gg = s.parameter("l", L_FALL, "length [m]"), s.parameter("g", G_FALL, "gravity")
    s.point_mass(1.0, ll * link.q)
    s.gravity(gg)
    model = s.model()
    assert model.n_inputs == 0
    speed = np.sqrt(2 * G_FALL / L_FALL)  # energy: l^2 w^2 / 2 = g l at the bottom
    bottom = TargetSet(lambda x: x[0], ProductManifold([("y", Rn(1))]), [0.0],
                       witness=np.r_[0.0, 0.0, 1.0, 0.0, -speed, 0.0], description="q.e1 = 0")
    return OCP(model, x0=np.r_[1.0, 0.0, 0.0, 0.0, 0.0, 0.0], target=bottom, u_lower=[],
               u_upper=[], T=(0.4, 0.9), terminal_cost=lambda x, T: T, name="falling")


@pytest.mark.parametrize("handling", list(ManifoldHandling))
@pytest.mark.parametrize("method", [Collocation(N=8, degree=3),
                                    Collocation(N=8, degree=2, scheme=Scheme.RADAU),
                                    MultipleShooting(N=8), HermiteSimpson(N=8)],
                         ids=lambda m: m.describe())
def test_feasible_problem_without_inputs_solves_as_with_the_flat_graph(method, handling):
    """Structured derivatives (SX graph) and casadi's flat ones (MX graph) solve alike.

    With the next node dropped from the layout, collocation and shooting ended at
    MAX_ITERATIONS or FAILED (feasible point found) after hundreds of iterations; the flat
    graph converges in a few. Both must report SUCCESS with the same objective, and ``T``
    must be the closed-form quarter period to the transcription's accuracy.
    """
    ocp = _falling_pendulum()
    # one solve each (Direct); ambient nodes of Radau, shooting and Hermite-Simpson drift by
    # the scheme's local error, so no manifold_tol there
    tol = None if handling is ManifoldHandling.AMBIENT else 1e-10
    sols = [solve(ocp, method, handling=handling, graph=graph, defect_tol=None,
                  manifold_tol=tol, strategy=Direct(), raise_on_failure=False)
            for graph in (Symbolic.SX, Symbolic.MX)]
    structured, flat = sols
    assert structured.status is flat.status and flat.status.ok, (structured.ipopt_status,
                                                                 flat.ipopt_status)
    assert structured.ipopt_status == flat.ipopt_status == "Solve_Succeeded"
    assert abs(structured.objective - flat.objective) <= 1e-9 * abs(flat.objective)
    T_exact = np.sqrt(L_FALL / G_FALL) * ellipk(0.5)
    assert abs(structured.T - T_exact) <= 1e-3 * T_exact  # N = 8: transcription error
