"""Bad input at every public entry point: a clear error of a documented type, no output.

One table, one row per (entry point, kind of bad input): wrong types, wrong shapes, NaN and
inf, non-unit directions, non-orthonormal rotations, negative or zero physical parameters,
unknown names. Each row names the exception class it must raise (a
:class:`~workbench.core.errors.WorkbenchError` subclass: ManifoldError, ParameterError,
ModelError, SolverError, ReportInputError) and words its message must contain: the
argument, what was expected and what was got. The rows marked "fixed" raised something else
(numpy's ValueError, IndexError, casadi's RuntimeError, AttributeError) or silently
returned NaN or a wrong value before issue 11; they are the tests of those fixes.

Writers (Result.write_json, build_report, export_c) are also checked to leave their output
directory as it was when they refuse their input.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

import casadi as ca
import numpy as np
import pytest

from models import controllers as C
from models import pendulum3d as p3
from models.chain_cart import chain_cart
from models.pendulum3d import phase_density
from models.relative_equilibria import rotation_problem, static_equilibria
from models.relative_families import at_alpha, trace_relative_equilibria
from models.spherical import spherical_pendulum
from workbench import (
    S1,
    S2,
    SO3,
    TS2,
    ProductManifold,
    Rn,
    eigenstructure,
    geometric_feedback,
    hat,
    kalman_rank,
    linearize,
    lqr,
    pbh,
    simulate,
    so3_exp,
    so3_log,
    vee,
)
from workbench.app.report import ReportInputError, build_report, check_out_dir
from workbench.control._attraction import clopper_pearson
from workbench.control._lyapunov import Lyapunov, as_states
from workbench.control._tvlqr import tvlqr
from workbench.control.ocp import OCP, Collocation, TargetPoint
from workbench.control.ocp import solve as ocp_solve_fn
from workbench.core.errors import (
    ManifoldError,
    ModelError,
    ParameterError,
    SolverError,
    WorkbenchError,
)
from workbench.core.manifolds import sphere_basis
from workbench.equilibria._continuation import StepControl, continue_branch
from workbench.equilibria._equilibria import find_equilibrium
from workbench.global_dynamics._ftle import lyapunov_exponent
from workbench.global_dynamics._phase import first_self_intersection, holonomy_angle
from workbench.global_dynamics._poincare import poincare_map, stabilized_field, turning_section
from workbench.linear.symbolic import exact_number, symbolic_linearization
from workbench.simulation._sweep import grid, sweep
from workbench.simulation.accuracy import AccuracySweep, work_precision
from workbench.simulation.integrators import integrate, lgvi
from workbench.study._result import Result

NAN, INF = float("nan"), float("inf")
J0 = np.diag([3.0, 2.0, 1.0])
RHO0 = np.array([0.1, 0.2, 0.3])
REFLECTION = np.diag([1.0, 1.0, -1.0])


@cache
def full():
    return p3.full(J=J0, rho=RHO0)


@cache
def red():
    return p3.reduced(J=J0, rho=RHO0)


def x_full():
    return full().state(R=np.eye(3), omega=np.zeros(3))


def x_hang():
    return red().state(Gamma=RHO0 / np.linalg.norm(RHO0), omega=np.zeros(3))


@cache
def lin():
    return linearize(red(), x_hang())


@cache
def cart():
    return chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)


def ocp(**kw: Any) -> Any:
    """The swing-up OCP of the cart with keyword overrides."""
    args = {"x0": np.r_[0, 0, 0, 0, 0, 0, 1.0, 0, 0, 0], "u_lower": -10.0, "u_upper": 10.0,
            "T": (0.5, 3.0), "target": TargetPoint(cart().manifold,
                                                   np.r_[0, 0, 0, 0, 0, 0, -1.0, 0, 0, 0])}
    args.update(kw)
    return OCP(cart(), **args)


def ocp_solve(**kw: Any) -> Any:
    return ocp_solve_fn(ocp(), Collocation(N=4), **kw)


def tv(**kw: Any) -> Any:
    """TVLQR of the cart at rest at the inverted equilibrium, with keyword overrides."""
    xe = np.r_[0, 0, 0, 0, 0, 0, -1.0, 0, 0, 0]
    args = {"t": np.linspace(0, 1, 11), "x_ref": np.tile(xe, (11, 1)),
            "u_ref": np.zeros((10, 2)), "x_eq": xe}
    args.update(kw)
    return tvlqr(cart(), args.pop("t"), args.pop("x_ref"), args.pop("u_ref"), **args)


def sim(**kw: Any) -> Any:
    """simulate the full model from rest over [0, 1] with keyword overrides."""
    args = {"model": full(), "x0": x_full(), "t": [0.0, 1.0]}
    args.update(kw)
    return simulate(args.pop("model"), args.pop("x0"), args.pop("t"), **args)


def fn(n_in: int, n_out: int) -> ca.Function:
    x = ca.SX.sym("x", n_in)
    return ca.Function("k", [x], [ca.SX.zeros(n_out)])


@dataclass(frozen=True)
class Case:
    """One bad call: what it must raise, and words its message must contain."""

    id: str
    call: Callable[[], Any]
    error: type[Exception]
    words: tuple[str, ...]


def case(id_: str, call: Callable[[], Any], error: type[Exception], *words: str) -> Case:
    return Case(id_, call, error, words)


M, P, D, S = ManifoldError, ParameterError, ModelError, SolverError

CASES = [
    # --- manifolds: hat/vee/exp/log (fixed: numpy errors, NaN results, log of non-rotations)
    case("hat-str", lambda: hat("abc"), M, "hat", "numeric", "str"),
    case("hat-shape", lambda: hat([1.0, 2.0]), M, "hat", "(3,)", "(2,)"),
    case("hat-nan", lambda: hat([NAN, 0, 0]), M, "hat", "finite", "nan"),
    case("vee-shape", lambda: vee([1.0, 2.0, 3.0]), M, "vee", "(3, 3)", "(3,)"),
    case("so3_exp-nan", lambda: so3_exp([NAN, 0, 0]), M, "so3_exp", "finite", "nan"),
    case("so3_exp-inf", lambda: so3_exp([INF, 0, 0]), M, "so3_exp", "finite", "inf"),
    case("so3_exp-shape", lambda: so3_exp([1, 2, 3, 4]), M, "so3_exp", "(3,)", "(4,)"),
    case("so3_log-not-orthogonal", lambda: so3_log(np.ones((3, 3))), M,
         "so3_log", "rotation", "R^T R - I", "project"),
    case("so3_log-reflection", lambda: so3_log(REFLECTION), M, "rotation", "det R = -1"),
    case("so3_log-nan", lambda: so3_log(np.full((3, 3), NAN)), M, "so3_log", "finite"),
    case("so3_log-shape", lambda: so3_log(np.eye(2)), M, "(3, 3)", "(2, 2)"),
    case("sphere_basis-zero", lambda: sphere_basis([0, 0, 0]), M, "unit vector", "zero"),
    # --- factors and products
    case("S2.check-non-unit", lambda: S2().check([0, 0, 2.0]), M,
         "not on S2", "|q| = 2", "expected 1", "project"),
    case("S2.check-str", lambda: S2().check("abc"), M, "numeric", "str"),
    case("S2.check-size", lambda: S2().check([0, 0, 1.0, 0]), M, "3 entries", "(4,)"),
    case("S2.check-nan", lambda: S2().check([NAN, 0, 1.0]), M, "finite", "nan"),
    case("SO3.check-not-orthonormal", lambda: SO3().check(np.ones((3, 3))), M,
         "not on SO3", "R^T R - I", "project"),
    case("SO3.check-reflection", lambda: SO3().check(REFLECTION), M, "reflection", "det = -1"),
    case("TS2.check-not-tangent", lambda: TS2().check([0, 0, 1.0, 0, 0, 1.0]), M,
         "not on TS2", "q.w = 1", "expected 0"),
    case("S1.check-non-unit", lambda: S1().check([2.0, 0]), M, "not on S1", "|p| = 2"),
    case("S2.project-zero", lambda: S2().project([0, 0, 0]), M, "zero vector", "S2"),
    case("S2.project-nan", lambda: S2().project([NAN, 0, 0]), M, "finite", "nan"),
    case("S1.project-zero", lambda: S1().project([0.0, 0.0]), M, "zero vector", "S1"),
    case("SO3.project-zero", lambda: SO3().project(np.zeros(9)), M, "rank", "not unique"),
    case("SO3.project-nan", lambda: SO3().project(np.full(9, NAN)), M, "finite"),
    case("Rn-zero", lambda: Rn(0), M, "integer n >= 1", "n=0"),
    case("Rn-float", lambda: Rn(1.5), M, "integer n >= 1", "1.5"),
    case("product-empty", lambda: ProductManifold([]), M, "at least one factor"),
    case("product-duplicate", lambda: ProductManifold([("a", Rn(1)), ("a", Rn(1))]), M,
         "unique", "'a'"),
    case("product-not-a-factor", lambda: ProductManifold([("a", 3)]), M, "Factor", "int"),
    case("product-unknown-factor", lambda: full().manifold.factor("zz"), M,
         "unknown factor", "'zz'", "['R', 'omega']"),
    case("product-join-missing", lambda: full().manifold.join({"R": np.eye(3)}), M,
         "missing ['omega']"),
    case("product-join-size", lambda: full().manifold.join({"R": np.eye(2), "omega": [0, 0, 0]}),
         M, "part 'R'", "9 entries", "(2, 2)"),
    case("product-retract-size", lambda: full().manifold.retract(x_full(), [1.0, 2.0]), M,
         "6 tangent", "(2,)"),
    # --- model parameters
    case("J-vector", lambda: p3.full(J=[1, 2, 3], rho=RHO0), P, "'J'", "3x3", "3-vector"),
    case("J-str", lambda: p3.full(J="J", rho=RHO0), P, "'J'", "numeric", "'J'"),
    case("J-none", lambda: p3.full(J=None, rho=RHO0), P, "'J'", "real numeric array", "None"),
    case("J-non-symmetric", lambda: p3.full(J=[[1, 1, 0], [0, 1, 0], [0, 0, 1]], rho=RHO0), P,
         "'J'", "symmetric positive definite", "non-symmetric"),
    case("J-indefinite", lambda: p3.full(J=np.diag([1, 1, -1]), rho=RHO0), P,
         "'J'", "symmetric positive definite", "eigenvalues [-1."),
    case("J-zero", lambda: p3.full(J=np.zeros((3, 3)), rho=RHO0), P,
         "'J'", "positive definite", "eigenvalues [0."),
    case("J-nan", lambda: p3.full(J=np.full((3, 3), NAN), rho=RHO0), P, "'J'", "finite", "nan"),
    case("rho-shape", lambda: p3.full(J=J0, rho=[1, 2]), P, "'rho'", "shape (3,)", "(2,)"),
    case("rho-inf", lambda: p3.full(J=J0, rho=[INF, 0, 0]), P, "'rho'", "finite", "inf"),
    case("m-zero", lambda: p3.full(J=J0, rho=RHO0, m=0), P, "'m'", "positive", "0"),
    case("m-negative", lambda: p3.full(J=J0, rho=RHO0, m=-1), P, "'m'", "positive", "-1"),
    case("m-str", lambda: p3.full(J=J0, rho=RHO0, m="a"), P, "'m'", "numeric", "'a'"),
    case("m-shape", lambda: p3.full(J=J0, rho=RHO0, m=[1, 2]), P, "'m'", "shape ()", "(2,)"),
    case("g-zero", lambda: p3.full(J=J0, rho=RHO0, g=0), P, "'g'", "positive", "0"),
    case("g-nan", lambda: p3.full(J=J0, rho=RHO0, g=NAN), P, "'g'", "finite", "nan"),
    case("mu-nan", lambda: p3.routh(J=J0, rho=RHO0, mu=NAN), P, "'mu'", "finite", "nan"),
    case("Jt-zero", lambda: p3.spinning_top(Jt=0, Ja=1, rho_s=1, spin=1), P, "'Jt'", "positive"),
    case("rho_s-negative", lambda: p3.spherical(Jt=1, Ja=1, rho_s=-1), P, "'rho_s'", "positive"),
    case("l-zero", lambda: spherical_pendulum(l=0), P, "'l'", "positive", "0"),
    case("n-zero", lambda: chain_cart(0), P, "n (number of links)", "integer >= 1", "got 0"),
    case("n-float", lambda: chain_cart(1.5), P, "integer >= 1", "1.5"),
    case("n-str", lambda: chain_cart("2"), P, "integer >= 1", "'2'"),
    case("masses-length", lambda: chain_cart(2, masses=[1, 2, 3]), P,
         "'masses'", "one entry per link (2)", "(3,)"),
    case("masses-str", lambda: chain_cart(2, masses="a"), P, "'masses'", "'a'"),
    case("lengths-negative", lambda: chain_cart(2, lengths=[-1, 1]), P, "'lengths'", "positive"),
    case("cart-mass-zero", lambda: chain_cart(2, m=0), P, "'m'", "positive"),
    case("with_parameters-unknown", lambda: full().with_parameters(mass=1), P,
         "unknown parameter", "'mass'", "known"),
    case("with_parameters-bad-J", lambda: full().with_parameters(J=-np.eye(3)), P,
         "'J'", "eigenvalues"),
    # --- model functions
    case("function-unknown", lambda: full().function("zz"), D, "'zz'", "known"),
    case("state-unknown-part", lambda: full().state(R=np.eye(3), omega=[0, 0, 0], zz=1), M,
         "unknown ['zz']"),
    case("state-not-rotation", lambda: full().state(R=2 * np.eye(3), omega=[0, 0, 0]), M,
         "x['R']", "not on SO3"),
    case("rhs-size", lambda: full().rhs(x_full()[:5]), D, "12 finite numbers", "(5,)"),
    case("rhs-nan", lambda: full().rhs(np.full(12, NAN)), D, "finite", "nan"),
    case("rhs-u-size", lambda: full().rhs(x_full(), [1, 2]), D, "u", "3 entries", "(2,)"),
    case("rhs-u-nan", lambda: full().rhs(x_full(), [NAN, 0, 0]), D, "u", "finite"),
    case("invariants-size", lambda: full().invariants(x_full()[:5]), D, "12", "(5,)"),
    # --- simulate
    case("simulate-model-str", lambda: simulate("m", x_full(), [0, 1]), D, "Model", "str"),
    case("simulate-x0-size", lambda: sim(x0=x_full()[:5]), M, "x0", "12 entries", "(5,)"),
    case("simulate-x0-nan", lambda: sim(x0=np.full(12, NAN)), M, "x0['R']", "finite"),
    case("simulate-x0-not-rotation", lambda: sim(x0=np.r_[2 * np.eye(3).ravel(), 0, 0, 0]), M,
         "x0['R']", "not on SO3"),
    case("simulate-t-one", lambda: sim(t=[0.0]), D, "t", "at least two times", "got 1"),
    case("simulate-t-nan", lambda: sim(t=[0.0, NAN]), D, "t must be finite"),
    case("simulate-t-not-monotone", lambda: sim(t=[0, 2, 1]), D, "strictly increasing"),
    case("simulate-t-2d", lambda: sim(t=[[0, 1], [2, 3]]), D, "t", "1-D", "(2, 2)"),
    case("simulate-t-str", lambda: sim(t="t"), D, "t", "1-D", "'t'"),
    case("simulate-method", lambda: sim(method="euler"), D, "method", "cvodes", "'euler'"),
    case("simulate-rtol-negative", lambda: sim(rtol=-1), D, "rtol", "positive", "-1"),
    case("simulate-rtol-str", lambda: sim(rtol="a"), D, "rtol", "positive", "'a'"),
    case("simulate-tol-negative", lambda: sim(tol=-1), D, "tol", "positive", "-1"),
    case("simulate-max_steps-zero", lambda: sim(max_steps=0), D, "max_steps", ">= 1", "0"),
    case("simulate-too-few-steps", lambda: sim(x0=full().state(R=np.eye(3), omega=[1, 2, 3]),
                                               t=[0, 10], max_steps=3), S,
         "cvodes failed", "CV_TOO_MUCH_WORK"),
    case("simulate-rk-no-step", lambda: sim(method="rk"), D, "step", "positive", "None"),
    case("simulate-rk-step-too-long", lambda: sim(method="rk", step=2.0), D,
         "step", "must not exceed the horizon"),
    case("simulate-rk-uneven", lambda: sim(method="rk", step=0.1, t=[0, 1, 3]), D,
         "equally spaced"),
    case("simulate-degree", lambda: sim(method="collocation", step=0.1, degree=0), D,
         "degree", ">= 1", "0"),
    case("simulate-lgvi-wrong-model", lambda: sim(model=red(), x0=x_hang(), method="lgvi",
                                                  step=0.1), D, "TSO(3)", "rkmk4"),
    case("simulate-s2var-wrong-model", lambda: sim(method="s2_variational", step=0.1), D,
         "TS^2", "rkmk4"),
    case("simulate-controller-type", lambda: sim(controller=3), D, "casadi.Function", "int"),
    case("simulate-controller-input", lambda: sim(controller=fn(3, 3)), D,
         "12 entries", "[3]"),
    case("simulate-controller-output", lambda: sim(controller=fn(12, 2)), D,
         "3 inputs", "got 2"),
    case("simulate-multistep", lambda: sim(multistep="x"), D, "multistep", "'x'"),
    case("simulate-newton_tol", lambda: sim(method="lgvi", step=0.1, newton_tol=-1), P,
         "newton_tol", "(0, 1)", "-1"),
    case("simulate-newton_max_iter", lambda: sim(method="lgvi", step=0.1, newton_max_iter=0), P,
         "newton_max_iter", ">= 1", "0"),
    case("integrate-step-zero", lambda: integrate(full(), lgvi(full(), None), x_full(),
                                                  np.array([0.0, 1.0]), step=0.0), P,
         "step", "positive", "0"),
    # --- linearisation and linear analysis
    case("linearize-not-equilibrium",
         lambda: linearize(full(), full().state(R=np.eye(3), omega=[1, 0, 0])), D,
         "not an equilibrium", "max |f(x_e, u_e)|", "tol"),
    case("linearize-model-str", lambda: linearize("m", x_hang()), D, "Model", "str"),
    case("linearize-x-nan", lambda: linearize(red(), np.full(6, NAN)), M,
         "x_e['Gamma']", "finite"),
    case("linearize-u", lambda: linearize(red(), x_hang(), [1, 2]), D, "u_e", "3 finite"),
    case("linearize-tol", lambda: linearize(red(), x_hang(), tol=NAN), D, "tol", "positive"),
    case("linearize-basis-shape", lambda: linearize(red(), x_hang(), basis=np.eye(3)), M,
         "basis", "(6, 5)", "(3, 3)"),
    case("linearize-basis-dependent", lambda: linearize(red(), x_hang(), basis=np.zeros((6, 5))),
         M, "basis", "dependent"),
    case("linearize-controller", lambda: linearize(red(), x_hang(), controller="k"), D,
         "controller", "casadi.Function", "str"),
    case("eigenstructure-str", lambda: eigenstructure("A"), D, "numeric", "'A'"),
    case("eigenstructure-non-square", lambda: eigenstructure(np.ones((2, 3))), D,
         "square", "(2, 3)"),
    case("eigenstructure-nan", lambda: eigenstructure(np.full((2, 2), NAN)), D, "finite"),
    case("eigenstructure-tol", lambda: eigenstructure(lin(), tol=-1), D, "tol", "positive"),
    case("pbh-no-B", lambda: pbh(np.eye(2)), D, "B is required"),
    case("pbh-B-rows", lambda: pbh(np.eye(2), np.ones((3, 1))), D, "square", "(3, 1)"),
    case("pbh-str", lambda: pbh("A", "B"), D, "numeric", "'A'"),
    case("pbh-nan", lambda: pbh(np.full((2, 2), NAN), np.ones((2, 1))), D, "finite"),
    case("pbh-tol", lambda: pbh(lin(), tol=2), D, "tol", "(0, 1)", "2"),
    case("kalman-tol", lambda: kalman_rank(lin(), tol=-1), D, "tol", "positive", "-1"),
    case("kalman-str", lambda: kalman_rank("A", "B"), D, "numeric"),
    case("lqr-Q-shape", lambda: lqr(lin(), np.eye(2), np.eye(3)), P, "Q", "(5, 5)", "(2, 2)"),
    case("lqr-Q-non-symmetric", lambda: lqr(lin(), np.triu(np.ones((5, 5))), np.eye(3)), P,
         "Q must be symmetric"),
    case("lqr-Q-negative", lambda: lqr(lin(), -np.eye(5), np.eye(3)), P,
         "Q", "semi-definite", "-1"),
    case("lqr-R-singular", lambda: lqr(lin(), np.eye(5), np.zeros((3, 3))), P,
         "R", "positive definite", "0."),
    case("lqr-R-nan", lambda: lqr(lin(), np.eye(5), np.full((3, 3), NAN)), P, "R", "finite"),
    case("lqr-R-str", lambda: lqr(lin(), np.eye(5), "R"), P, "R", "numeric", "'R'"),
    case("lqr-A-scalar", lambda: lqr(2.0, np.eye(1), np.eye(1), B=1.0), D, "square", "()"),
    case("lqr-A-str", lambda: lqr("A", np.eye(2), np.eye(1), B=np.ones((2, 1))), D, "numeric"),
    case("lqr-B-rows", lambda: lqr(np.eye(2), np.eye(2), np.eye(1), B=np.ones(3)), D,
         "square", "(3, 1)"),
    case("lqr-require", lambda: lqr(lin(), np.eye(5), np.eye(3), require="x"), P,
         "require", "'x'"),
    case("lqr-uncontrollable", lambda: lqr(np.eye(2), np.eye(2), np.eye(1),
                                           B=np.array([[1.0], [0.0]])), P,
         "controllable", "uncontrollable mode", "lambda = 1", "left eigenvector"),
    case("geometric_feedback-K", lambda: geometric_feedback(lin(), np.ones((2, 2))), P,
         "K", "(3, 5)", "(2, 2)"),
    case("symbolic-not-equilibrium",
         lambda: symbolic_linearization(red(), red().state(Gamma=[1, 0, 0], omega=[.1, 0, 0])),
         D, "not an equilibrium"),
    case("exact_number-nan", lambda: exact_number(NAN), P, "finite", "nan"),
    # --- equilibria and continuation
    case("find_equilibrium-off-manifold", lambda: find_equilibrium(red(), [0, 0, 2.0, 0, 0, 0]),
         M, "guess['Gamma']", "not on S2"),
    case("find_equilibrium-tol", lambda: find_equilibrium(red(), x_hang(), tol=-1), P,
         "tol", "positive", "-1"),
    case("find_equilibrium-max_iterations", lambda: find_equilibrium(red(), x_hang(),
                                                                     max_iterations=0), P,
         "max_iterations", "integer >= 1", "0"),
    case("find_equilibrium-params", lambda: find_equilibrium(red(), x_hang(),
                                                             params={"mass": 1}), P, "'mass'"),
    case("find_equilibrium-model", lambda: find_equilibrium("m", x_hang()), D, "Model", "str"),
    case("find_equilibrium-u", lambda: find_equilibrium(red(), x_hang(), u=[1]), D,
         "u", "3 entries", "(1,)"),
    case("find_equilibrium-no-convergence",
         lambda: find_equilibrium(red(), red().state(Gamma=[1, 0, 0], omega=[5, 5, 5]),
                                  max_iterations=2), S,
         "no convergence in 2 iterations", "raise_on_failure"),
    case("rotation_problem-model", lambda: rotation_problem(full()), D, "S2 x R^3", "SO3"),
    case("rotation_problem-invariant", lambda: rotation_problem(red(), energy="E"), D,
         "no invariant 'E'", "energy"),
    case("static-balanced", lambda: static_equilibria(p3.reduced(J=J0, rho=[0, 0, 0])), P,
         "'rho'", "balanced", "undefined"),
    case("trace-k_max", lambda: trace_relative_equilibria(red(), k_max=-1), P, "k_max", "-1"),
    case("at_alpha-zero", lambda: at_alpha(None, 0.0), P, "alpha", "nonzero", "static"),
    case("at_alpha-str", lambda: at_alpha(None, "a"), P, "alpha", "number", "'a'"),
    case("StepControl-step", lambda: StepControl(step=-1), P, "step", "positive", "-1"),
    case("StepControl-nan", lambda: StepControl(step=NAN), P, "step", "nan"),
    case("continue_branch-off", lambda: continue_branch(rotation_problem(red()), [0, 0, 2.0, 0]),
         M, "start['Gamma']", "not on S2"),
    case("continue_branch-size", lambda: continue_branch(rotation_problem(red()), [0, 0, 1.0]),
         M, "start", "4 entries", "(3,)"),
    case("continue_branch-max_points",
         lambda: continue_branch(rotation_problem(red()), np.r_[0, 0, 1.0, 0], max_points=1), P,
         "max_points", ">= 2", "1"),
    # --- controllers and Lyapunov functions
    case("damping-indefinite", lambda: C.angular_velocity_feedback(full(), D=-np.eye(3)), P,
         "D", "symmetric positive definite", "-1."),
    case("damping-str", lambda: C.angular_velocity_feedback(full(), D="D"), P, "D", "(3, 3)",
         "'D'"),
    case("damping-nan", lambda: C.angular_velocity_feedback(full(), D=np.full((3, 3), NAN)), P,
         "D", "finite"),
    case("damping-wrong-model",
         lambda: C.angular_velocity_feedback(spherical_pendulum(), D=np.eye(3)), D,
         "'omega'", "spherical_pendulum"),
    case("saturation-zero", lambda: C.saturated_velocity_feedback(full(), P=np.eye(3), k=0), P,
         "k", "positive", "0"),
    case("saturation-str", lambda: C.saturated_velocity_feedback(full(), P=np.eye(3), k="k"), P,
         "k", "positive number", "'k'"),
    case("psi-not-zero-at-zero", lambda: C.psi_feedback(full(), lambda w: w + 1), P,
         "Psi(0) must be 0", "1.0"),
    case("s2_pd-non-unit-goal", lambda: C.s2_pd(spherical_pendulum(), [0, 0, 2.0], k_q=1, k_w=1), M,
         "q_d", "not on S2"),
    case("s2_pd-gain", lambda: C.s2_pd(spherical_pendulum(), [0, 0, 1.0], k_q=-1, k_w=1), P,
         "k_q", "positive", "-1"),
    case("s2_pd-wrong-model", lambda: C.s2_pd(full(), [0, 0, 1.0], k_q=1, k_w=1), D, "TS2", "'q'"),
    case("lyapunov30-balanced",
         lambda: C.velocity_feedback_lyapunov(p3.full(J=J0, rho=[0, 0, 0])), P,
         "rho", "nonzero", "balanced"),
    case("hanging_set_level-eps", lambda: C.hanging_set_level(full(), eps=NAN), P,
         "eps", "[0, 2 m g |rho|)", "nan"),
    case("Lyapunov-model", lambda: Lyapunov("m", lambda c: 0, name="V"), D, "Model", "str"),
    case("Lyapunov-not-scalar", lambda: Lyapunov(full(), lambda c: c["omega"],
                                                 name="V").function(), D, "scalar", "(3, 1)"),
    case("as_states-shape", lambda: as_states(full(), np.zeros((2, 5))), D,
         "states", "(n, 12)", "(2, 5)"),
    case("as_states-nan", lambda: as_states(full(), np.full((2, 12), NAN)), D,
         "states", "finite", "[0, 1]"),
    case("clopper_pearson-k", lambda: clopper_pearson(5, 3), P, "0 <= k <= n", "k = 5"),
    case("clopper_pearson-confidence", lambda: clopper_pearson(1, 3, confidence=2), P,
         "confidence", "(0, 1)", "2"),
    # --- Poincare sections, phases, sweeps, accuracy
    case("section-axis-zero", lambda: turning_section(axis=[0, 0, 0]), P, "axis", "unit"),
    case("section-axis-non-unit", lambda: turning_section(axis=[0, 0, 2.0]), P, "axis", "unit"),
    case("section-direction", lambda: turning_section(direction="up"), P,
         "direction", "Direction", "'up'"),
    case("poincare-n_crossings", lambda: poincare_map(red(), x_hang(), turning_section(),
                                                      n_crossings=0, t_max=1), P,
         "n_crossings", ">= 1", "0"),
    case("poincare-t_max", lambda: poincare_map(red(), x_hang(), turning_section(),
                                                n_crossings=1, t_max=NAN), P, "t_max", "nan"),
    case("poincare-section", lambda: poincare_map(red(), x_hang(), "s", n_crossings=1, t_max=1),
         D, "section", "Section", "str"),
    case("stabilized_field-gain", lambda: stabilized_field(red(), gain=-1), P, "gain", ">= 0"),
    case("ftle-t_final", lambda: lyapunov_exponent(red(), x_hang(), t_final=0), P,
         "t_final", "positive", "0"),
    case("phase_density-indefinite", lambda: phase_density(-np.eye(3)), P,
         "J", "positive-definite"),
    case("phase_density-str", lambda: phase_density("J"), P, "J", "positive-definite", "'J'"),
    case("holonomy-not-rotation", lambda: holonomy_angle(np.ones((3, 3)), np.eye(3)), M,
         "R_start", "not on SO3"),
    case("holonomy-nan", lambda: holonomy_angle(np.eye(3), np.full((3, 3), NAN)), M,
         "R_end", "finite"),
    case("self_intersection-shape", lambda: first_self_intersection(np.ones((5, 2))), P,
         "gamma", "(n, 3)", "(5, 2)"),
    case("sweep-fn", lambda: sweep(3, [{}]), P, "fn", "callable", "int"),
    case("sweep-items", lambda: sweep(lambda: 1, [1, 2]), P, "items[0]", "dict", "1"),
    case("sweep-workers", lambda: sweep(lambda: 1, [{}], workers=0), P, "workers", "0"),
    case("grid-axis", lambda: grid(a=3), P, "'a'", "sequence", "3"),
    case("accuracy-sweep-values", lambda: AccuracySweep("cvodes", ("speed",)), P,
         "values", "numbers", "'speed'"),
    case("work_precision-horizon", lambda: work_precision(full(), x_full(), 0.0, []), P,
         "horizon", "positive", "0"),
    # --- optimal control
    case("ocp-bounds-crossed", lambda: ocp(u_lower=1.0, u_upper=-1.0), P,
         "u_lower must not exceed u_upper", "[1.0, 1.0]"),
    case("ocp-bounds-shape", lambda: ocp(u_lower=[-1, -1, -1]), P, "u_lower", "2 entries"),
    case("ocp-bounds-nan", lambda: ocp(u_upper=NAN), P, "u_upper", "nan"),
    case("ocp-T-negative", lambda: ocp(T=-1.0), P, "T must satisfy", "-1.0"),
    case("ocp-T-reversed", lambda: ocp(T=(3.0, 1.0)), P, "T must satisfy", "(3.0, 1.0)"),
    case("ocp-T-str", lambda: ocp(T="long"), P, "T must", "'long'"),
    case("ocp-x0-not-tangent", lambda: ocp(x0=np.r_[0, 0, 0, 0, 0, 0, 1.0, 1.0, 0, 1.0]), M,
         "x0", "not on TS2"),
    case("ocp-target-not-unit", lambda: TargetPoint(cart().manifold,
                                                    np.r_[0, 0, 0, 0, 0, 0, -1.1, 0, 0, 0]),
         M, "terminal state", "not on TS2"),
    case("ocp-N-zero", lambda: Collocation(N=0), P, "N must be", "0"),
    case("ocp-degree-zero", lambda: Collocation(degree=0), P, "degree must be", "0"),
    case("ocp-tol", lambda: ocp_solve(tol=-1.0), P, "tol", "positive", "-1.0"),
    case("ocp-defect_tol", lambda: ocp_solve(defect_tol=NAN), P, "defect_tol", "nan"),
    case("ocp-max_iter", lambda: ocp_solve(max_iter=0), P, "max_iter", ">= 1", "0"),
    case("tvlqr-t-decreasing", lambda: tv(t=np.linspace(1, 0, 11)), P,
         "t", "strictly increasing", "1.0"),
    case("tvlqr-t-one-sample", lambda: tv(t=[0.0], x_ref=np.zeros((1, 10)),
                                          u_ref=np.zeros((0, 2))), P, "t", "two", "[0.0]"),
    case("tvlqr-u-shape", lambda: tv(u_ref=np.zeros((3, 2))), P,
         "u_ref", "10 x 2", "(3, 2)"),
    case("tvlqr-u-nan", lambda: tv(u_ref=np.full((10, 2), NAN)), P, "u_ref", "non-finite"),
    case("tvlqr-x-not-unit", lambda: tv(x_ref=np.tile(np.r_[0, 0, 0, 0, 0, 0, -2.0, 0, 0, 0],
                                                      (11, 1))), M,
         "x_ref[0]['link1']", "not on TS2"),
    case("tvlqr-Q-nan", lambda: tv(Q=NAN), P, "Q", "finite", "nan"),
    case("tvlqr-R-zero", lambda: tv(R=0.0), P, "R", "positive definite", "0.0"),
    case("tvlqr-x_eq-not-equilibrium",
         lambda: tv(x_eq=np.r_[0, 0, 0, 0, 1.0, 0, 0, 0, 0, 0]), P,
         "x_eq", "not an equilibrium", "98.1"),
    # --- reports
    case("report-out-is-a-file", lambda: check_out_dir(__file__), ReportInputError,
         "not a directory"),
]


@pytest.mark.parametrize("bad", CASES, ids=[c.id for c in CASES])
def test_bad_input_raises_a_documented_error_naming_argument_expectation_and_value(bad):
    with pytest.raises(bad.error) as info:
        bad.call()
    err = info.value
    assert isinstance(err, WorkbenchError), f"{type(err).__name__} is not a WorkbenchError"
    msg = str(err)
    missing = [w for w in bad.words if w.lower() not in msg.lower()]
    assert not missing, f"message lacks {missing}: {msg!r}"


def test_case_ids_are_unique_and_the_table_covers_every_kind_of_bad_input():
    ids = [c.id for c in CASES]
    assert len(ids) == len(set(ids))
    kinds = {"str", "shape", "nan", "inf", "non-unit", "not-orthonormal", "reflection",
             "negative", "zero", "unknown"}
    present = {k for k in kinds if any(k in i for i in ids)}
    assert present == kinds, f"no case of {kinds - present}"


def test_solver_errors_carry_the_solvers_status():
    with pytest.raises(SolverError) as info:
        find_equilibrium(red(), red().state(Gamma=[1, 0, 0], omega=[5, 5, 5]), max_iterations=2)
    assert info.value.status == "max_iterations"
    with pytest.raises(SolverError) as info:
        sim(x0=full().state(R=np.eye(3), omega=[1, 2, 3]), t=[0, 10], max_steps=3)
    assert info.value.status


def test_unknown_keywords_are_refused_by_the_keyword_only_signatures():
    # Python itself answers: TypeError naming the keyword (the entry points are keyword-only)
    with pytest.raises(TypeError, match="mass"):
        p3.full(J=J0, rho=RHO0, mass=1.0)
    with pytest.raises(TypeError, match="stepsize"):
        simulate(full(), x_full(), [0, 1], stepsize=0.1)


def test_correct_calls_next_to_the_bad_ones_still_work():
    # the validation added for the table does not refuse good input
    R = so3_exp([0.3, -0.2, 0.1])
    assert np.allclose(so3_exp(so3_log(R)), R, atol=1e-15)
    assert np.allclose(vee(hat([1.0, 2.0, 3.0])), [1, 2, 3])
    assert np.allclose(S1().project([3.0, 4.0]), [0.6, 0.8])
    assert np.allclose(SO3.matrix(SO3().project(SO3.flat(2 * R))), R, atol=1e-15)
    assert full().rhs(x_full()).shape == (12,)
    assert kalman_rank(lin()).rank == 5
    x = full().manifold.join({"R": R, "omega": [0.0, 0.0, 1.0]})
    assert x.shape == (12,)
    holo, fibre = holonomy_angle(R, so3_exp([0.0, 0.0, 0.5]) @ R)
    assert abs(holo - 0.5) < 1e-14 and fibre < 1e-15


# ----------------------------------------------------------------------------------------
# writers leave nothing behind on bad input


def _listing(path):
    return sorted(p.relative_to(path).as_posix() for p in path.rglob("*"))


def test_write_json_writes_nothing_when_the_values_cannot_be_serialised(tmp_path):
    res = Result("x", "t")
    res.values = {"bad": object()}
    with pytest.raises(TypeError, match="not JSON serializable"):
        res.write_json(tmp_path / "r.json")
    assert _listing(tmp_path) == []
    res.values = {"nan": NAN, "ok": 1.0}
    res.write_json(tmp_path / "r.json")
    assert json.loads((tmp_path / "r.json").read_text())["values"] == {"nan": "nan", "ok": 1.0}
    assert _listing(tmp_path) == ["r.json"]


@pytest.mark.parametrize("kw, words", [
    ({"names": ["nope"]}, ("unknown problem", "'nope'")),
    ({"names": ["pendulum3d_invariants"], "formats": ["docx"]}, ("formats", "'docx'")),
    ({"names": ["pendulum3d_invariants"], "formats": []}, ("no output format",)),
])
def test_build_report_refuses_bad_input_before_running_or_writing(tmp_path, kw, words):
    out = tmp_path / "out"
    with pytest.raises(ReportInputError) as info:
        build_report(out_dir=out, progress=False, **kw)
    assert all(w in str(info.value) for w in words), str(info.value)
    assert not out.exists() or _listing(out) == []


@pytest.mark.parametrize("controller, binding, words", [
    ("nope", "frozen", ("'nope'", "known")),
    ("s2_pd", "bad", ("binding", "'bad'", "frozen")),
    ("s2_pd", "name", ("ExportableController", "str", "'s2_pd'")),
])
def test_export_c_writes_nothing_on_bad_input(tmp_path, controller, binding, words):
    from workbench.app.catalogue import build
    from workbench.codegen.api import export_c

    with pytest.raises(ModelError) as info:
        # the engine takes built controllers; a bare name is refused
        c = controller if binding == "name" else build(controller)
        export_c(c, tmp_path, binding="frozen" if binding == "name" else binding,
                 cache_dir=tmp_path / "cache")
    assert all(w in str(info.value) for w in words), str(info.value)
    assert [p for p in _listing(tmp_path) if not p.startswith("cache")] == []
