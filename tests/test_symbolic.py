"""Symbolic linearisations read from the graph: closed forms of papers 000, 001, 002."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from conftest import assert_close

from models import pendulum3d as p3
from models.chain_cart import chain_cart, link_state
from models.controllers import s2_pd
from models.spherical import spherical_pendulum
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import so3_exp
from workbench.linear._linearize import linearize
from workbench.linear.symbolic import casadi_to_sympy, exact_number, symbolic_linearization

J1, J2, J3, r, m, g, k1, k2, k3 = sp.symbols("J1 J2 J3 rho m g k1 k2 k3", positive=True)
s = sp.Symbol("s")  # the Laplace variable of SymbolicLinearization (no assumptions)
AXIAL = {"J": sp.diag(J1, J2, J3), "rho": [0, 0, r], "m": m, "g": g}
BODY = {"J": np.diag([3.0, 2.0, 1.0]), "rho": [0.0, 0.0, 0.4]}


def _zero(expr) -> bool:
    return sp.simplify(sp.together(expr)) == 0


@pytest.mark.parametrize("inverted", [False, True])
def test_remark_2_and_3_are_derived_from_the_reduced_graph(inverted):
    model = p3.reduced(**BODY)
    gam = [0.0, 0.0, -1.0 if inverted else 1.0]
    lin = symbolic_linearization(model, model.state(Gamma=gam, omega=np.zeros(3)),
                                 parameters=AXIAL)
    K = sp.zeros(3, 5)
    K[:, 2:] = sp.diag(k1, k2, k3)  # u = -diag(k) delta omega, Psi'(0) = diag(k)
    poly = lin.closed_loop(K).charpoly()
    # Remarks 2-3 with J = diag(J_i), rho = rho e3: d_i = k_i / J_i, m g l_i = m g rho / J_i
    sign = -1 if inverted else 1
    d = [k1 / J1, k2 / J2, k3 / J3]
    mgl = [m * g * r / J1, m * g * r / J2]
    remark = ((s**2 + d[0] * s + sign * mgl[0]) * (s**2 + d[1] * s + sign * mgl[1])
              * (s + d[2]))
    assert _zero(poly - remark)
    factored = lin.closed_loop(K).factored()
    assert isinstance(factored, sp.Mul) and len(sp.factor_list(sp.numer(factored))[1]) == 3


def test_open_loop_full_model_is_paper_000_3_22_to_3_24():
    model = p3.full(**BODY)
    lin = symbolic_linearization(model, model.state(R=np.eye(3), omega=np.zeros(3)),
                                 parameters=AXIAL)
    expected = s**2 * (s**2 + m * g * r / J1) * (s**2 + m * g * r / J2)
    assert _zero(lin.charpoly() - expected)
    assert lin.B == sp.Matrix([[0, 0, 0]] * 3 + [[1 / J1, 0, 0], [0, 1 / J2, 0],
                                                 [0, 0, 1 / J3]])


def test_spherical_pd_polynomials_of_paper_002():
    model = spherical_pendulum()
    k = s2_pd(model, [0.0, 0.0, 1.0], k_q=1.0, k_w=1.0)
    hang = symbolic_linearization(model, model.state(q=[0, 0, 1.0, 0, 0, 0]), controller=k)
    inv = symbolic_linearization(model, model.state(q=[0, 0, -1.0, 0, 0, 0]), controller=k)
    assert sp.expand(hang.factored() - (s**2 + s + 1) ** 2) == 0
    assert sp.expand(inv.factored() - (s**2 + s - 1) ** 2) == 0
    ml, ll, gl = sp.symbols("m l g", positive=True)
    open_ = symbolic_linearization(model, model.state(q=[0, 0, 1.0, 0, 0, 0]),
                                   parameters={"m": ml, "l": ll, "g": gl})
    assert _zero(open_.charpoly() - (s**2 + gl / ll) ** 2)


def test_symbolic_agrees_with_numeric_at_a_general_body(rng):
    L = rng.standard_normal((3, 3))
    J = L @ L.T + np.eye(3)
    rho = rng.standard_normal(3)
    model = p3.full(J=J, rho=rho, m=1.3, g=9.81)
    a = rho / np.linalg.norm(rho)
    axis = np.cross(a, [0, 0, 1.0])
    R = so3_exp(axis / np.linalg.norm(axis) * np.arccos(a[2]))
    x_e = model.state(R=R, omega=np.zeros(3))
    ms, gs = sp.symbols("m g", positive=True)
    lin = symbolic_linearization(model, x_e, parameters={"J": sp.Matrix(J), "rho": list(rho),
                                                         "m": ms, "g": gs})
    A, B = lin.evaluate({"m": 1.3, "g": 9.81})
    num = linearize(model, x_e)
    assert_close(A, num.A, atol=1e-10, rtol=1e-10, what="symbolic A at the numbers")
    assert_close(B, num.B, atol=1e-12, what="symbolic B")


def test_exact_numbers_and_the_walker():
    assert exact_number(0.5) == sp.Rational(1, 2)
    assert exact_number(-3.0) == -3
    assert isinstance(exact_number(np.sqrt(2)), sp.Float)
    import casadi as ca

    x = ca.SX.sym("x", 2)
    fn = ca.Function("f", [x], [ca.vertcat(ca.sin(x[0]) * x[1] + 0.25, ca.sqrt(x[0]))])
    a, b = sp.symbols("a b")
    (out,) = casadi_to_sympy(fn, [[a, b]])
    assert out == [sp.sin(a) * b + sp.Rational(1, 4), sp.sqrt(a)]
    with pytest.raises(ModelError, match="nonzeros"):
        casadi_to_sympy(fn, [[a]])


def test_errors():
    chain = chain_cart(1)
    x_e = np.concatenate([np.zeros(4), link_state([0, 0, 1.0])])
    with pytest.raises(ModelError, match="SX graphs only"):
        symbolic_linearization(chain, x_e)
    model = p3.reduced(**BODY)
    x_e = model.state(Gamma=[0, 0, 1.0], omega=np.zeros(3))
    with pytest.raises(ParameterError, match="unknown parameter.*'mass'"):
        symbolic_linearization(model, x_e, parameters={"mass": m})
    with pytest.raises(ParameterError, match=r"'rho' must have shape \(3,\)"):
        symbolic_linearization(model, x_e, parameters={"rho": [0, r]})
    with pytest.raises(ModelError, match="max_nodes"):
        symbolic_linearization(model, x_e, max_nodes=10)
    lin = symbolic_linearization(model, x_e, parameters=AXIAL)
    with pytest.raises(ParameterError, match=r"K must have shape \(3, 5\)"):
        lin.closed_loop(sp.zeros(3, 4))
    with pytest.raises(ParameterError, match="values needed"):
        lin.evaluate({"m": 1.0})
