"""Property: Ipopt's derivatives of a transcribed OCP equal casadi's flat ones, for any shape.

:mod:`workbench.control.ocp.derivatives` assembles the constraint Jacobian and the Hessian of
the Lagrangian from one interval's derivatives and the offsets of each interval's
arguments in the decision vector. An offset that is right for one OCP shape can be wrong
for another (no inputs, no collocation variables, a first-order hold, a phase condition),
so the check here draws the shape: the model (R^n, S^2 as TS2, SO(3) with its angular
velocity, and products: a spherical pendulum on a planar cart), the number of inputs (0,
1, several) and of parameters (0, several), the path constraints (none, on all nodes,
first, last), every transcription (Legendre and Radau collocation of several degrees, RK4
shooting, Hermite-Simpson) and both manifold handlings, a fixed or free horizon, the
running and terminal costs present or absent, and the gauge of a rotation symmetry.

The reference is independent of the per-interval assembly: the same NLP dict, expanded into
one flat scalar graph (``casadi.Function.expand``) and differentiated whole by casadi
(``jacobian``, ``gradient``, ``hessian``). The functions compared are those the Ipopt
solver of the transcription actually calls (``nlp_jac_g``, ``nlp_hess_l``,
``nlp_grad_f``), at a random primal-dual point (node states near the manifold, controls,
collocation variables, ``T`` in its range, multipliers) and random values of every NLP
parameter (the model's and the phase condition's coefficients). Both sides evaluate the
same expressions by different derivative graphs, so they agree to rounding: the tolerance
is ``RTOL`` times the largest entry of the reference matrix (the scale of its entries).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import casadi as ca
import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from workbench import mechanics
from workbench.control.ocp import (
    OCP,
    Collocation,
    HermiteSimpson,
    ManifoldHandling,
    MultipleShooting,
    PathConstraint,
    Scheme,
    TargetPoint,
)
from workbench.control.ocp.solve import transcribe
from workbench.core._model import Model, Parameter
from workbench.core.manifolds import ProductManifold, Rn

T_FIXED, T_FREE = 0.4, (0.2, 0.6)
"""Short horizons: with ``N = 1`` an RK4 step ``h = T`` stays within its stability range
(``h sqrt(g/l) < 2.8``) at the random states below; a longer step overflows both sides."""

RTOL = 1e-10
"""Largest difference, relative to the largest reference entry (rounding: ~1e-15)."""

E1, E3 = np.eye(3)[0], np.eye(3)[2]
FAMILIES = ("rn", "s2", "so3", "cart")
SYMMETRIC = {("s2", 0), ("s2", 1), ("s2", 3), ("cart", 0), ("cart", 2)}
"""(family, n_inputs) whose OCPs below are invariant under rotations about e3 (gauged)."""
INPUTS = {"rn": (0, 1, 2), "s2": (0, 1, 3), "so3": (0, 1, 3), "cart": (0, 1, 2)}


# models ---------------------------------------------------------------------------------


def _value(s: mechanics.System, params: bool, name: str, value: float):
    """A named parameter of the system, or the bare number when the model has none."""
    return s.parameter(name, value, name) if params else value


@cache
def model(family: str, nu: int, params: bool, symbolic: str) -> Model:
    """A small model of ``family`` with ``nu`` inputs, with or without parameters.

    ``symbolic="MX"`` builds the model's graph in MX: the SX transcription then replays it
    on SX (:func:`workbench.control.ocp.expand.sx_function`), another path to the interval.
    """
    if family == "rn":  # by hand: a damped nonlinear oscillator with a third state, R^3
        def field(ctx):
            x, u = ctx["x"], ctx.u
            a, c = (ctx["a"], ctx["c"]) if params else (2.0, 0.3)
            xdot = ca.vertcat(x[1], -a * ca.sin(x[0]) - c * x[1] * x[2], -x[2] ** 2 * ca.cos(x[0]))
            for i in range(nu):
                xdot = xdot + ca.vertcat(0, 1 + 0.2 * x[i], 0.5 * (i + 1)) * u[i]
            return xdot + 0.1 * ca.dot(u, u) * x if nu else xdot

        pars = [Parameter("a", (), "stiffness"), Parameter("c", (), "coupling")] if params else []
        return Model(name=f"rn_u{nu}", manifold=ProductManifold([("x", Rn(3))]), n_inputs=nu,
                     parameters=pars, values={"a": 2.0, "c": 0.3} if params else {},
                     vector_field=field, symbolic=symbolic)
    s = mechanics.System(f"{family}_u{nu}_p{int(params)}")
    g = _value(s, params, "g", 9.81)
    if family == "s2":  # a spherical pendulum, moment at the pivot: e3 only, or any
        link = s.s2("q")
        s.point_mass(_value(s, params, "m", 0.9), _value(s, params, "l", 0.7) * link.q)
        if nu:
            u = s.input(nu, "moment")
            s.moment(link, ca.vertcat(0, 0, u) if nu == 1 else u)
    elif family == "so3":  # a 3D pendulum on a fixed pivot, body moment
        body = s.so3("R", velocity="omega")
        rho = s.parameter("rho", np.r_[0.02, -0.01, 0.3]) if params else np.r_[0.02, -0.01, 0.3]
        s.rigid_body(_value(s, params, "m", 1.1), np.diag([0.13, 0.28, 0.17]), body, com=rho)
        if nu:
            u = s.input(nu, "moment")
            s.moment(body, ca.vertcat(u, 0, 0) if nu == 1 else u)
    else:  # a spherical pendulum on a planar cart, force on the cart: along x, or planar
        cart = s.rn("x", 2, velocity="v")
        link = s.s2("q")
        pivot = ca.vertcat(cart.x, 0)
        s.point_mass(_value(s, params, "M", 1.5), pivot)
        s.point_mass(_value(s, params, "m", 0.4), pivot + _value(s, params, "l", 0.6) * link.q)
        if nu:
            u = s.input(nu, "force")
            s.force(cart, ca.vertcat(u, 0) if nu == 1 else u)
    s.gravity(g)
    return s.model(symbolic=symbolic)


def states(family: str) -> tuple[np.ndarray, np.ndarray]:
    """``(x0, x_f)``: hanging to inverted, both fixed by rotations about e3 (except SO(3))."""
    hang, up = np.r_[E3, 0.0, 0.0, 0.0], np.r_[-E3, 0.0, 0.0, 0.0]
    if family == "rn":
        return np.r_[0.1, 0.0, 0.2], np.r_[np.pi, 0.0, 0.5]
    if family == "s2":
        return hang, up
    if family == "so3":
        tilt = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # 90 deg about e1
        return np.r_[np.eye(3).ravel(order="F"), 0, 0, 0], np.r_[tilt.ravel(order="F"), 0, 0, 0]
    return np.r_[0, 0, 0, 0, hang], np.r_[0, 0, 0, 0, up]


# shapes ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Shape:
    """One drawn OCP shape (printed by Hypothesis when a property fails)."""

    family: str
    nu: int
    params: bool
    symbolic: str
    method: Collocation | MultipleShooting | HermiteSimpson
    handling: ManifoldHandling
    free_time: bool
    running: bool
    terminal: bool
    path: tuple[str, ...]
    gauge: bool
    seed: int


@st.composite
def shapes(draw: st.DrawFn) -> Shape:
    """A random OCP shape; small sizes keep each example near 0.1-0.5 s."""
    family = draw(st.sampled_from(FAMILIES))
    N = draw(st.integers(1, 3))
    method = draw(st.one_of(
        st.builds(Collocation, N=st.just(N), degree=st.integers(1, 3),
                  scheme=st.sampled_from(Scheme)),
        st.builds(MultipleShooting, N=st.just(N), steps=st.integers(1, 2)),
        st.builds(HermiteSimpson, N=st.just(N)),
    ))
    return Shape(
        family=family, nu=draw(st.sampled_from(INPUTS[family])), params=draw(st.booleans()),
        symbolic=draw(st.sampled_from(("SX", "MX"))), method=method,
        handling=draw(st.sampled_from(ManifoldHandling)),
        free_time=draw(st.booleans()), running=draw(st.booleans()),
        terminal=draw(st.booleans()),
        path=tuple(draw(st.lists(st.sampled_from(("all", "first", "last")), max_size=2))),
        gauge=draw(st.booleans()), seed=draw(st.integers(0, 2**31 - 1)),
    )


def build(shape: Shape) -> OCP:
    """The OCP of ``shape``; every cost and constraint is invariant under rotations."""
    m = model(shape.family, shape.nu, shape.params, shape.symbolic)
    x0, xf = states(shape.family)
    return OCP(
        m, x0=x0, target=TargetPoint(m.manifold, xf), u_lower=-5.0, u_upper=5.0,
        T=T_FREE if shape.free_time else T_FIXED,
        running_cost=(lambda x, u: ca.dot(u, u) * (1 + ca.dot(x, x)) + ca.cos(ca.dot(x, x)))
        if shape.running else None,
        terminal_cost=(lambda x, T: T ** 2 * (1 + ca.dot(x, x)) + ca.sin(T))
        if shape.terminal else None,
        path_constraints=[PathConstraint(lambda x, u: ca.dot(x, x) * (1 + ca.dot(u, u)),
                                         upper=10.0, nodes=n, name=f"path {n}")
                          for n in shape.path],
        gauge=shape.gauge, name="property",
    )


# the comparison -------------------------------------------------------------------------


def random_point(tr, rng: np.random.Generator) -> np.ndarray:
    """A decision vector: node (and ambient collocation) states near the manifold, the rest
    standard normal (controls, local coordinates), ``T`` in its range."""
    man = tr.ocp.model.manifold
    w = 0.5 * rng.standard_normal(tr.nw)
    near = lambda: man.random_point(rng) + 1e-2 * rng.standard_normal(tr.nx)  # noqa: E731
    for i in tr.ix:
        w[i: i + tr.nx] = near()
    if tr.handling is ManifoldHandling.AMBIENT:
        for i in tr.ic:
            for j in range(tr.d):
                w[i + j * tr.ncol: i + (j + 1) * tr.ncol] = near()
    w[tr.iT] = rng.uniform(*tr.ocp.T_range) if tr.ocp.free_time else tr.ocp.T_range[0]
    return w


def flat_reference(nlp: dict) -> ca.Function:
    """``(x, p, lam_f, lam_g) -> (f, grad_f, g, jac_g, triu hess_lag)`` of the flat graph."""
    fn = ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]]).expand()
    x, p = ca.SX.sym("x", fn.size1_in(0)), ca.SX.sym("p", fn.size1_in(1))
    f, g = fn(x, p)
    lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", g.numel())
    H = ca.triu(ca.hessian(lam_f * f + ca.dot(lam_g, g), x)[0])
    return ca.Function("flat", [x, p, lam_f, lam_g],
                       [f, ca.gradient(f, x), g, ca.jacobian(g, x), H])


def assert_equal_to_scale(ours: ca.DM, ref: ca.DM, what: str, shape: Shape) -> None:
    """``max |ours - ref| <= RTOL max |ref|`` (exact agreement when ``ref`` is zero)."""
    A, B = np.asarray(ca.densify(ca.DM(ours))), np.asarray(ca.densify(ca.DM(ref)))
    assert A.shape == B.shape, f"{what}: shape {A.shape} != {B.shape} for {shape}"
    err, scale = float(np.max(np.abs(A - B), initial=0.0)), float(np.max(np.abs(B), initial=0.0))
    assert err <= RTOL * scale, (
        f"{what} differs from casadi's flat one by {err:.3g} (scale {scale:.3g}) at entries "
        f"{np.argwhere(np.abs(A - B) > RTOL * scale)[:6].tolist()} for {shape}")


def check(shape: Shape) -> None:
    """The property for one shape (also called directly by the regression tests)."""
    ocp = build(shape)
    tr, _ = transcribe(ocp, shape.method, handling=shape.handling)
    assert tr._structure is not None, "an SX transcription takes the structured path"
    assert (tr.i_gauge is not None) == (shape.gauge and (shape.family, shape.nu) in SYMMETRIC)
    solver = tr.solver({"print_level": 0, "sb": "yes"})
    rng = np.random.default_rng(shape.seed)
    w = random_point(tr, rng)
    P = rng.standard_normal(int(tr.nlp["p"].numel()))
    P[: ocp.model.n_params] = ocp.model.p * (1 + 0.2 * rng.uniform(-1, 1, ocp.model.n_params))
    lam_f, lam_g = rng.uniform(0.1, 2.0), rng.standard_normal(tr.ng)
    f, grad_f, g, jac_g, hess = flat_reference(tr.nlp)(w, P, lam_f, lam_g)
    for name, value in (("f", f), ("g", g), ("jac_g", jac_g), ("hess_lag", hess)):
        assert np.all(np.isfinite(np.asarray(ca.DM(value)))), (
            f"the flat {name} is not finite at the drawn point of {shape} (the test's point "
            "is outside the transcription's range, not a derivative mismatch)")
    g_ours, J = solver.get_function("nlp_jac_g")(w, P)
    assert_equal_to_scale(g_ours, g, "g", shape)
    assert_equal_to_scale(J, jac_g, "jac_g", shape)
    H = solver.get_function("nlp_hess_l")(w, P, lam_f, lam_g)
    assert_equal_to_scale(H, hess, "hess_lag", shape)
    f_ours, grad_ours = solver.get_function("nlp_grad_f")(w, P)
    assert_equal_to_scale(f_ours, f, "f", shape)
    assert_equal_to_scale(grad_ours, grad_f, "grad_f", shape)


def _shape(family: str, nu: int, method, handling=ManifoldHandling.AMBIENT, **kw) -> Shape:
    base = dict(params=True, symbolic="SX", free_time=True, running=True, terminal=True,
                path=("all",), gauge=True, seed=1)
    return Shape(family=family, nu=nu, method=method, handling=handling, **{**base, **kw})


LIE = ManifoldHandling.LIE_GROUP
EXAMPLES = [  # always run: no inputs under every transcription, gauges, the node choices
    _shape("rn", 0, MultipleShooting(N=1, steps=1), params=False, running=False,
           terminal=False, path=()),  # the minimal shape that was wrong
    _shape("rn", 0, Collocation(N=2, degree=2), LIE, free_time=False),
    _shape("s2", 0, Collocation(N=2, degree=3, scheme=Scheme.RADAU), LIE, path=("last",)),
    _shape("s2", 0, HermiteSimpson(N=2), LIE, path=("first",)),
    _shape("cart", 0, MultipleShooting(N=2, steps=2), LIE),
    _shape("cart", 2, Collocation(N=2, degree=1), symbolic="MX", path=("first", "last")),
    _shape("so3", 3, HermiteSimpson(N=3), LIE, params=False, running=False),
    _shape("so3", 1, Collocation(N=2, degree=3), LIE, terminal=False, free_time=False),
]


def _with_examples(test):
    for shape in reversed(EXAMPLES):
        test = example(shape=shape)(test)
    return test


@_with_examples
@settings(max_examples=100, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(shape=shapes())
def test_structured_derivatives_equal_casadis_flat_ones_for_any_ocp_shape(shape):
    check(shape)


@pytest.mark.parametrize(("family", "nu"), sorted(SYMMETRIC))
def test_the_drawn_symmetric_shapes_are_gauged(family, nu):
    """The property covers the phase condition: these shapes have a verified symmetry."""
    shape = Shape(family=family, nu=nu, params=True, symbolic="SX", method=HermiteSimpson(N=2),
                  handling=ManifoldHandling.AMBIENT, free_time=True, running=True,
                  terminal=True, path=("all",), gauge=True, seed=0)
    sym = build(shape).symmetry
    assert sym is not None and sym.axis == "e3" and sym.residual < 1e-12
