"""The entry points of the hostile pass: a valid call of each, and which arguments to attack.

Every name of ``workbench.__all__`` is classified here: an :class:`Entry` (a callable that
takes user input), or an exclusion with its reason (a namespace module, an exception class,
a result record that the workbench builds). The models' builders, the papers' controllers
and the command line are entries too. Each entry is a valid call (``good()`` returns its
arguments) and a map from the argument names to attack to their :class:`Kind`; the pass
(``test_hostile.py``) replaces one argument at a time by a value drawn from the grammar of
bad values of that kind.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from functools import cache
from typing import Any

import casadi as ca
import numpy as np

import workbench as wb
from models import chain_cart as cc
from models import controllers as C
from models import pendulum3d as p3
from models import spherical as sp
from workbench import mechanics
from workbench.equilibria._roots import ZeroProblem
from workbench.simulation._sweep import InlineExecutor


class Kind(Enum):
    """What an argument is, which decides the bad values drawn for it."""

    NUMBER = "a real number (any sign)"
    SCALE = "a positive real number (a physical scale, a step, a horizon)"
    TOL = "a tolerance or threshold"
    COUNT = "an integer count"
    ARRAY = "a real array of a fixed shape"
    ENUM = "a choice among named options"
    OBJECT = "a workbench object (model, controller, manifold, linear model, OCP)"
    NAME = "a name (identifier)"
    TEXT = "free text (a str; escaped wherever it is written)"
    BOUND = "a real bound (+-inf allowed)"
    SEQUENCE = "a sequence of values"
    PATH = "an output path"


@dataclass(frozen=True)
class Entry:
    """One public entry point.

    Attributes
    ----------
    name : str
        How it is listed (``"simulate"``, ``"models.pendulum3d.full"``, ``"cli"``).
    call : callable
        ``call(args)`` with the arguments as a dict.
    good : callable
        Valid arguments.
    attack : dict of str to Kind
        Arguments to replace by bad values.
    optional : frozenset of str
        Arguments for which ``None`` is a documented value.
    words : dict of str to tuple of str
        Other words that name an argument in a message (e.g. ``J`` for ``J`` inside ``x0``).
    valid : dict of str to frozenset of str
        Labels of drawn values that are documented as valid for an argument (e.g. a pair
        ``(T_min, T_max)`` for a free final time).
    """

    name: str
    call: Callable[[dict[str, Any]], Any]
    good: Callable[[], dict[str, Any]]
    attack: dict[str, Kind]
    optional: frozenset[str] = frozenset()
    words: dict[str, tuple[str, ...]] = field(default_factory=dict)
    valid: dict[str, frozenset[str]] = field(default_factory=dict)


J0 = np.diag([3.0, 2.0, 1.0])
RHO0 = np.array([0.1, 0.2, 0.3])


@cache
def full() -> wb.Model:
    return p3.full(J=J0, rho=RHO0)


@cache
def red() -> wb.Model:
    return p3.reduced(J=J0, rho=RHO0)


@cache
def sph() -> wb.Model:
    return sp.spherical_pendulum(m=1.0, l=1.0, g=9.81)


@cache
def cart() -> wb.Model:
    return cc.chain_cart(1, m=0.5, masses=0.1, lengths=0.1, g=9.81)


@cache
def routh() -> wb.Model:
    return p3.routh(J=J0, rho=RHO0, mu=0.3)


def hang() -> np.ndarray:
    return red().state(Gamma=RHO0 / np.linalg.norm(RHO0), omega=np.zeros(3))


def x_full() -> np.ndarray:
    return full().state(R=np.eye(3), omega=[0.1, 0.2, 0.3])


@cache
def lin() -> wb.LinearModel:
    return wb.linearize(red(), hang())


@cache
def cart_lin() -> wb.LinearModel:
    xe = np.r_[0, 0, 0, 0, 0, 0, -1.0, 0, 0, 0]
    return wb.linearize(cart(), xe)


CART_UP = np.r_[0, 0, 0, 0, 0, 0, -1.0, 0, 0, 0]
CART_DOWN = np.r_[0, 0, 0, 0, 0, 0, 1.0, 0, 0, 0]


def _circle() -> ZeroProblem:
    y = ca.SX.sym("y", 2)
    F = ca.dot(y, y) - 1
    fn = ca.Function("F", [y, ca.SX.sym("u", 0), ca.SX.sym("p", 0)], [F, ca.jacobian(F, y)])
    return ZeroProblem(name="circle", manifold=wb.ProductManifold([("y", wb.Rn(2))]),
                       function=fn, u=[], p=[])


def _decay_model(a: dict[str, Any]) -> wb.Model:
    return wb.Model(name=a["name"], manifold=wb.ProductManifold([("y", wb.Rn(1))]),
                    n_inputs=a["n_inputs"],
                    parameters=[wb.Parameter("k", (), "rate, 1/s")],
                    values={"k": a["k"]}, vector_field=lambda c: -c["k"] * c["y"],
                    invariants={a["invariant"]: lambda c: c["y"][0] ** 2})


def _factor_calls(factor: Any) -> Callable[[dict[str, Any]], Any]:
    def call(a: dict[str, Any]) -> Any:
        x = factor.check(a["x"], tol=a["tol"])
        return x, factor.retract(x, a["v"]), factor.project(a["x"]), factor.belongs(
            a["x"], tol=a["tol"])
    return call


def _factor_entry(name: str, factor: Any, x: Any, v: Any) -> Entry:
    return Entry(name, _factor_calls(factor), lambda: {"x": x, "v": v, "tol": 1e-9},
                 {"x": Kind.ARRAY, "v": Kind.ARRAY, "tol": Kind.TOL})


@cache
def _ocp() -> wb.OCP:
    return wb.OCP(cart(), x0=CART_DOWN, target=wb.TargetPoint(cart().manifold, CART_UP),
                  u_lower=-10.0, u_upper=10.0, T=(0.5, 3.0))


def _ocp_solution() -> Any:
    """What tvlqr_along reads of an OCPSolution (model, nodes, controls, T), at rest at the
    inverted equilibrium: the pass attacks tvlqr_along's own arguments, not Ipopt."""
    from types import SimpleNamespace

    return SimpleNamespace(ocp=SimpleNamespace(model=cart()), x=np.tile(CART_UP, (5, 1)),
                           u=np.zeros((4, 2)), T=1.0)


def _phase_start() -> np.ndarray:
    g0 = np.array([0.8, 0.2, 0.3]) / np.linalg.norm([0.8, 0.2, 0.3])
    gd0 = np.array([0.0, 3.0, 1.0]) - (np.array([0.0, 3.0, 1.0]) @ g0) * g0
    ax = np.cross(g0, [0.0, 0.0, 1.0])
    R0 = wb.so3_exp(ax / np.linalg.norm(ax) * np.arctan2(np.linalg.norm(ax), g0[2]))
    return np.r_[g0, gd0, wb.SO3.flat(R0), 0.0]


def _ocp_args() -> dict[str, Any]:
    return {"model": cart(), "x0": CART_DOWN, "target": wb.TargetPoint(cart().manifold,
                                                                         CART_UP),
            "u_lower": -10.0, "u_upper": 10.0, "T": 2.0, "tol": 1e-9, "name": "swing"}


def _sim_args() -> dict[str, Any]:
    return {"model": full(), "x0": x_full(), "t": np.array([0.0, 0.5]), "method": "cvodes",
            "rtol": 1e-8, "atol": 1e-8, "max_steps": 10_000, "tol": 1e-9}


def _sim(a: dict[str, Any]) -> Any:
    return wb.simulate(a.pop("model"), a.pop("x0"), a.pop("t"), **a)


def _tv_args() -> dict[str, Any]:
    return {"model": cart(), "t": np.linspace(0, 1, 6), "x_ref": np.tile(CART_UP, (6, 1)),
            "u_ref": np.zeros((5, 2)), "x_eq": CART_UP, "Q": 1.0, "R": 1.0, "rtol": 1e-8}


def _tv(a: dict[str, Any]) -> Any:
    return wb.tvlqr(a.pop("model"), a.pop("t"), a.pop("x_ref"), a.pop("u_ref"), **a)


@cache
def _pd() -> ca.Function:
    return C.s2_pd(sph(), [0.0, 0.0, 1.0], k_q=1.0, k_w=1.0)


def _im_args() -> dict[str, Any]:
    return {"model": sph(), "x_e": np.r_[0, 0, -1.0, 0, 0, 0], "controller": _pd(),
            "delta": 1e-6, "n_points": 4, "horizon": 0.2, "step": 0.05, "output_step": 0.1}


def _negate(x: float) -> float:
    return -x


def _im(fn: Callable[..., Any]) -> Callable[[dict[str, Any]], Any]:
    def call(a: dict[str, Any]) -> Any:
        return fn(a.pop("model"), a.pop("x_e"), **a)
    return call


def _poincare_args() -> dict[str, Any]:
    return {"model": routh(), "x0": [np.sin(1.0), 0.0, np.cos(1.0), 0.0, 1.0, 0.0],
            "section": wb.turning_section(), "n_crossings": 2, "t_max": 20.0, "rtol": 1e-8,
            "atol": 1e-8, "constraint_tol": 1e-6, "stabilization": 10.0}


def _poincare(a: dict[str, Any]) -> Any:
    return wb.poincare_map(a.pop("model"), a.pop("x0"), a.pop("section"), **a)


def _cli(a: dict[str, Any]) -> Any:
    from workbench.app.cli import main

    argv = [str(v) for v in a["argv"]]
    return main(argv)


def _model_args() -> dict[str, Any]:
    return {"name": "decay", "n_inputs": 0, "k": 2.0, "invariant": "y2"}


def _cart_s1(name: str = "th", velocity: str | None = None) -> mechanics.System:
    """A pendulum on a rail: R^1 x S^1 (the S^1 factor's names attacked), momentum px."""
    s = mechanics.System("cart_s1")
    cart = s.rn("x", 1, velocity="v")
    th = s.s1(name, velocity=velocity)
    m, M, length = s.parameter("m", 0.2), s.parameter("M", 1.0), s.parameter("l", 0.5)
    s.point_mass(M, ca.vertcat(cart.x, 0, 0))
    s.point_mass(m, ca.vertcat(cart.x + length * th.sin, 0, -length * th.cos))
    s.gravity(s.parameter("g", 9.81))
    s.force(cart, s.input(1, "force on the cart [N]"))
    s.momentum("px", translate={cart: [1]})
    return s


@cache
def cart_s1() -> wb.Model:
    return _cart_s1().model()


def _s1_entry(a: dict[str, Any]) -> Any:
    model = _cart_s1(a["name"], a["velocity"]).model()
    return model.rhs(model.manifold.join({"x": [0.1], "v": [0.0], a["name"]: [0.6, 0.8],
                                          model.manifold.names[-1]: [0.2]}), [0.0])


def _reduce_args() -> dict[str, Any]:
    return {"source": cart_s1(), "symmetry": "px", "kind": "routh", "momentum": 0.3,
            "breaking_inputs": "hold_zero", "name": "cart_routh", "n_states": 3, "seed": 0,
            "rtol": 1e-8}


def _reduce(a: dict[str, Any]) -> Any:
    red = mechanics.reduce(a.pop("source"), a.pop("symmetry"), **a)
    return red.model.rhs(red.model.manifold.join({"th": [0.6, 0.8], "th_dot": [0.1]}))


@cache
def _pendulum_potential() -> ca.Function:
    """``V(c, p) = -p c_0`` on S^1: the pendulum's height, two critical points."""
    c, p = ca.SX.sym("c", 2), ca.SX.sym("p", 1)
    return ca.Function("V", [c, p], [-p * c[0]])


S1_MAN = wb.ProductManifold([("th", wb.S1())])


def _critical_args() -> dict[str, Any]:
    return {"target": _pendulum_potential(), "manifold": S1_MAN, "p": [9.81], "tol": 1e-11,
            "hessian_rtol": 1e-6, "symmetry_rtol": 1e-9, "max_starts": 4096,
            "deflation_starts": 8, "deflation_rounds": 8, "max_deflation_starts": 64,
            "max_iterations": 50, "seed": 0, "raise_on_failure": True}


def _energy_at_rest() -> ca.Function:
    """``(x, p) -> V`` of the cart_s1 model's state: its potential, for ``from_state``."""
    model = cart_s1()
    x, p = ca.SX.sym("x", model.manifold.ambient_dim), ca.SX.sym("p", model.n_params)
    return ca.Function("V_state", [x, p], [-p[0] * p[3] * p[2] * x[2]])


def _scene_args() -> dict[str, Any]:
    return {"model": cart_s1(), "states": cart_s1().state(x=[0.0], v=[0.0], th=0.3,
                                                          th_dot=[0.0]),
            "horizon": 0.5, "outputs": _scene_outputs, "tolerance": 1e-4, "n_times": 6,
            "name": "swing"}


def _scene_outputs(X: np.ndarray) -> np.ndarray:
    return X[:, 2:4]


def _compare_args() -> dict[str, Any]:
    return {"scene": wb.Scene(**_scene_args()), "levels": None, "special_cases": (),
            "symmetries": None, "equilibria": (), "radius": None, "method": "cvodes",
            "rtol": 1e-8, "atol": 1e-8, "multistep": "adams", "step": None,
            "max_steps": 10_000, "repeats": 1, "reference_rtol": 1e-12, "check_rtol": 1e-10,
            "reference_margin": 0.01, "seed": 0, "raise_on_failure": True}


def _auto_args() -> dict[str, Any]:
    return {"swings": 1, "relax": True, "relax_max_iter": 2, "attempt_max_iter": 2,
            "bound_factors": (2.0,), "terminal_slacks": (0.1,), "coarse_factor": 0,
            "max_attempts": 1}


def _solve_with(strategy: Any) -> Any:
    return wb.solve_ocp(_ocp(), wb.Collocation(N=4), strategy=strategy, max_iter=1,
                        raise_on_failure=False, defect_tol=1e3)


def _call(fn: Callable[..., Any], *positional: str) -> Callable[[dict[str, Any]], Any]:
    """``fn(*[a[p] for p in positional], **rest)``."""
    def call(a: dict[str, Any]) -> Any:
        return fn(*[a.pop(p) for p in positional], **a)
    return call


E = Kind

ENTRIES: list[Entry] = [
    # --- core: manifolds, models
    _factor_entry("S1", wb.S1(), [0.6, 0.8], [0.1]),
    _factor_entry("S2", wb.S2(), [0.0, 0.6, 0.8], [0.1, -0.2]),
    _factor_entry("TS2", wb.TS2(), [0.0, 0.0, 1.0, 1.0, 2.0, 0.0], [0.1, 0.2, 0.3, 0.4]),
    dataclasses.replace(_factor_entry("SO3", wb.SO3(), np.eye(3), [0.1, 0.2, 0.3]),
                        words={"x": ("R",)}),
    Entry("Rn", lambda a: wb.Rn(a["n"]).check(np.zeros(3)), lambda: {"n": 3},
          {"n": E.COUNT}),
    Entry("ProductManifold", lambda a: wb.ProductManifold([(a["name"], wb.S2())]).check(
        [0, 0, 1.0]), lambda: {"name": "q"}, {"name": E.NAME}),
    Entry("Parameter", lambda a: wb.Parameter(a["name"], (), "a mass, kg").validate(a["value"]),
          lambda: {"name": "m", "value": 2.0}, {"name": E.NAME, "value": E.NUMBER},
          words={"value": ("'m'",)}),
    Entry("Model", lambda a: _decay_model(a).rhs([1.0]), _model_args,
          {"name": E.TEXT, "n_inputs": E.COUNT, "k": E.NUMBER, "invariant": E.NAME},
          words={"invariant": ("invariant",)}),
    Entry("Evaluator", lambda a: wb.Evaluator(a["fn"])(x_full(), np.zeros(3), full().p),
          lambda: {"fn": full().function("f")}, {"fn": E.OBJECT}),
    Entry("hat", lambda a: wb.hat(a["v"]), lambda: {"v": [1.0, 2.0, 3.0]}, {"v": E.ARRAY}),
    Entry("vee", lambda a: wb.vee(a["m"]), lambda: {"m": wb.hat([1.0, 2.0, 3.0])},
          {"m": E.ARRAY}),
    Entry("so3_exp", lambda a: wb.so3_exp(a["v"]), lambda: {"v": [0.1, 0.2, 0.3]},
          {"v": E.ARRAY}),
    Entry("so3_log", lambda a: wb.so3_log(a["R"], tol=a["tol"]),
          lambda: {"R": wb.so3_exp([0.1, 0.2, 0.3]), "tol": 1e-6},
          {"R": E.ARRAY, "tol": E.TOL}),
    # --- simulation
    Entry("simulate", _sim, _sim_args,
          {"model": E.OBJECT, "x0": E.ARRAY, "t": E.ARRAY, "method": E.ENUM, "rtol": E.TOL,
           "atol": E.TOL, "max_steps": E.COUNT, "tol": E.TOL},
          valid={"t": frozenset({"long"})}),
    Entry("Method", _sim, lambda: {**_sim_args(), "method": "cvodes"}, {"method": E.ENUM}),
    Entry("Multistep", _sim, lambda: {**_sim_args(), "multistep": "adams"},
          {"multistep": E.ENUM}),
    Entry("grid", lambda a: wb.grid(m=a["m"], g=[9.81]), lambda: {"m": [1.0, 2.0]},
          {"m": E.SEQUENCE}),
    Entry("sweep", lambda a: wb.sweep(_negate, a["items"], executor=InlineExecutor(),
                                      desc=a["desc"], progress=False),
          lambda: {"items": [{"x": -1.0}, {"x": 2.0}], "desc": "negate"},
          {"items": E.OBJECT, "desc": E.TEXT}),
    # --- linear
    Entry("linearize", _call(wb.linearize, "model", "x_e"),
          lambda: {"model": red(), "x_e": hang(), "u_e": None, "tol": 1e-8,
                   "manifold_tol": 1e-9},
          {"model": E.OBJECT, "x_e": E.ARRAY, "u_e": E.ARRAY, "tol": E.TOL,
           "manifold_tol": E.TOL}, optional=frozenset({"u_e"})),
    Entry("linearize_ambient", _call(wb.linearize_ambient, "model", "x_e"),
          lambda: {"model": red(), "x_e": hang(), "tol": 1e-8, "manifold_tol": 1e-9},
          {"model": E.OBJECT, "x_e": E.ARRAY, "tol": E.TOL, "manifold_tol": E.TOL}),
    Entry("eigenstructure", _call(wb.eigenstructure, "system"),
          lambda: {"system": lin(), "tol": 1e-7}, {"system": E.OBJECT, "tol": E.TOL},
          optional=frozenset({"tol"}), words={"system": ("A",)}),
    Entry("kalman_rank", _call(wb.kalman_rank, "system"),
          lambda: {"system": lin(), "tol": 1e-10}, {"system": E.OBJECT, "tol": E.TOL},
          words={"system": ("A", "B")}),
    Entry("pbh", _call(wb.pbh, "system"), lambda: {"system": lin(), "tol": 1e-8,
                                                   "cluster_tol": 1e-6},
          {"system": E.OBJECT, "tol": E.TOL, "cluster_tol": E.TOL},
          words={"system": ("A", "B")}),
    Entry("pbh_second_order", _call(wb.pbh_second_order, "M", "G", "B"),
          lambda: {"M": np.eye(2), "G": np.diag([1.0, 2.0]), "B": np.array([[1.0], [0.0]]),
                   "tol": 1e-8},
          {"M": E.ARRAY, "G": E.ARRAY, "B": E.ARRAY, "tol": E.TOL}),
    Entry("second_order_form", _call(wb.second_order_form, "model", "x_e"),
          lambda: {"model": sph(), "x_e": [0, 0, 1.0, 0, 0, 0], "tol": 1e-8},
          {"model": E.OBJECT, "x_e": E.ARRAY, "tol": E.TOL}),
    Entry("symmetry_directions", _call(wb.symmetry_directions, "lin"),
          lambda: {"lin": lin(), "rtol": 1e-8}, {"lin": E.OBJECT, "rtol": E.TOL},
          words={"lin": ("LinearModel",)}),
    Entry("lqr", _call(wb.lqr, "system", "Q", "R"),
          lambda: {"system": cart_lin(), "Q": np.eye(8), "R": np.eye(2), "pbh_tol": 1e-8},
          {"system": E.OBJECT, "Q": E.ARRAY, "R": E.ARRAY, "pbh_tol": E.TOL},
          words={"system": ("A", "B")}),
    Entry("geometric_feedback", _call(wb.geometric_feedback, "lin", "K"),
          lambda: {"lin": cart_lin(), "K": np.ones((2, 8)), "name": "k"},
          {"lin": E.OBJECT, "K": E.ARRAY, "name": E.NAME}),
    # --- equilibria
    Entry("find_equilibrium", _call(wb.find_equilibrium, "model", "guess"),
          lambda: {"model": red(), "guess": hang(), "tol": 1e-12, "max_iterations": 20,
                   "rank_rtol": 1e-8, "guess_tol": 1e-9},
          {"model": E.OBJECT, "guess": E.ARRAY, "tol": E.TOL, "max_iterations": E.COUNT,
           "rank_rtol": E.TOL, "guess_tol": E.TOL}),
    Entry("enumerate_equilibria", _call(wb.enumerate_equilibria, "model", "guesses"),
          lambda: {"model": red(), "guesses": [hang(), -hang() * np.r_[1, 1, 1, 0, 0, 0]],
                   "distinct_tol": 1e-6, "tol": 1e-12, "guess_tol": 1e-9},
          {"model": E.OBJECT, "guesses": E.ARRAY, "distinct_tol": E.TOL, "tol": E.TOL,
           "guess_tol": E.TOL}, words={"guesses": ("guess",)}),
    Entry("continue_branch", _call(wb.continue_branch, "problem", "start"),
          lambda: {"problem": _circle(), "start": [1.0, 0.0], "direction": [0.0, 1.0],
                   "max_points": 20, "start_tol": 1e-9},
          {"problem": E.OBJECT, "start": E.ARRAY, "direction": E.ARRAY, "max_points": E.COUNT,
           "start_tol": E.TOL}, optional=frozenset({"direction"})),
    Entry("StepControl", lambda a: wb.continue_branch(
        _circle(), [1.0, 0.0], control=wb.StepControl(**a), max_points=5),
          lambda: {"step": 0.02, "min_step": 1e-8, "max_step": 0.25, "tol": 1e-11},
          {"step": E.SCALE, "min_step": E.SCALE, "max_step": E.SCALE, "tol": E.TOL}),
    # --- global dynamics
    Entry("invariant_manifold", _im(wb.invariant_manifold), _im_args,
          {"model": E.OBJECT, "x_e": E.ARRAY, "delta": E.SCALE, "n_points": E.COUNT,
           "horizon": E.SCALE, "step": E.SCALE, "output_step": E.SCALE}),
    Entry("Subspace", _im(wb.invariant_manifold), lambda: {**_im_args(), "which": "stable"},
          {"which": E.ENUM}),
    Entry("stable_manifold", _im(wb.stable_manifold), _im_args,
          {"x_e": E.ARRAY, "delta": E.SCALE, "n_points": E.COUNT}),
    Entry("unstable_manifold", _im(wb.unstable_manifold), _im_args,
          {"x_e": E.ARRAY, "delta": E.SCALE, "horizon": E.SCALE}),
    Entry("poincare_map", _poincare, _poincare_args,
          {"model": E.OBJECT, "x0": E.ARRAY, "section": E.OBJECT, "n_crossings": E.COUNT,
           "t_max": E.SCALE, "rtol": E.TOL, "atol": E.TOL, "constraint_tol": E.TOL}),
    Entry("turning_section", lambda a: wb.turning_section(**a),
          lambda: {"factor": "Gamma", "axis": [0.0, 0.0, 1.0]},
          {"factor": E.NAME, "axis": E.ARRAY}),
    Entry("Section", lambda a: wb.poincare_map(
        routh(), _poincare_args()["x0"], wb.Section(a["name"], lambda c: c["Gamma"][1]),
        n_crossings=1, t_max=10.0), lambda: {"name": "q2"}, {"name": E.TEXT}),
    Entry("geometric_phase_check", lambda a: wb.geometric_phase_check(
        p3.routh_reconstruction(J=J0, rho=RHO0, mu=0.3), a["x0"], density=p3.phase_density(J0),
        t_max=a["t_max"], rtol=a["rtol"], panels=8, nodes=4, radial_nodes=8),
          lambda: {"x0": _phase_start(), "t_max": 10.0, "rtol": 1e-8},
          {"x0": E.ARRAY, "t_max": E.SCALE, "rtol": E.TOL}),
    # --- control
    Entry("OCP", lambda a: wb.OCP(**a), _ocp_args,
          {"model": E.OBJECT, "x0": E.ARRAY, "target": E.OBJECT, "u_lower": E.BOUND,
           "u_upper": E.BOUND, "T": E.SCALE, "tol": E.TOL, "name": E.TEXT},
          valid={"T": frozenset({"pair"}), "u_lower": frozenset({"pair"}),
                 "u_upper": frozenset({"pair"})}),
    Entry("TargetPoint", lambda a: wb.OCP(**{**_ocp_args(), "target": wb.TargetPoint(
        cart().manifold, a["point"])}), lambda: {"point": CART_UP}, {"point": E.ARRAY},
          words={"point": ("x_f", "point")}),
    Entry("TargetSet", lambda a: wb.OCP(**{**_ocp_args(), "target": wb.TargetSet(
        lambda x: x[4:7], wb.ProductManifold([("q", wb.S2())]), a["value"], a["witness"])}),
          lambda: {"value": np.r_[0, 0, -1.0], "witness": CART_UP},
          {"value": E.ARRAY, "witness": E.ARRAY}),
    Entry("Collocation", lambda a: wb.Collocation(**a), lambda: {"N": 4, "degree": 3},
          {"N": E.COUNT, "degree": E.COUNT}),
    Entry("HermiteSimpson", lambda a: wb.HermiteSimpson(**a), lambda: {"N": 4},
          {"N": E.COUNT}),
    Entry("MultipleShooting", lambda a: wb.MultipleShooting(**a),
          lambda: {"N": 4, "steps": 2, "rtol": 1e-8},
          {"N": E.COUNT, "steps": E.COUNT, "rtol": E.TOL}),
    Entry("solve_ocp", lambda a: wb.solve_ocp(a.pop("ocp"), wb.Collocation(N=4), **a),
          lambda: {"ocp": _ocp(), "tol": 1e-6, "max_iter": 5, "raise_on_failure": False,
                   "defect_tol": 1e3},
          {"ocp": E.OBJECT, "tol": E.TOL, "max_iter": E.COUNT, "defect_tol": E.TOL},
          optional=frozenset({"defect_tol"})),
    Entry("ManifoldHandling", lambda a: wb.solve_ocp(_ocp(), wb.Collocation(N=4),
                                                     handling=a["handling"], max_iter=1,
                                                     raise_on_failure=False, defect_tol=1e3),
          lambda: {"handling": wb.ManifoldHandling.AMBIENT}, {"handling": E.ENUM},
          optional=frozenset({"handling"})),  # None: the default (PROJECTED)
    Entry("Symbolic", lambda a: _decay_model(_model_args()).__class__(
        name="s", manifold=wb.ProductManifold([("y", wb.Rn(1))]), n_inputs=0, parameters=[],
        values={}, vector_field=lambda c: -c["y"], symbolic=a["symbolic"]).rhs([1.0]),
          lambda: {"symbolic": "SX"}, {"symbolic": E.ENUM}),
    Entry("tvlqr", _tv, _tv_args,
          {"model": E.OBJECT, "t": E.ARRAY, "x_ref": E.ARRAY, "u_ref": E.ARRAY,
           "x_eq": E.ARRAY, "Q": E.NUMBER, "R": E.NUMBER, "rtol": E.TOL},
          valid={"R": frozenset({"pair"})}, words={"t": ("t", "u_ref", "x_ref")}),
    Entry("tvlqr_along", lambda a: wb.tvlqr_along(a.pop("solution"), **a),
          lambda: {"solution": _ocp_solution(), "x_eq": CART_UP, "substeps": 1, "rtol": 1e-8},
          {"solution": E.OBJECT, "x_eq": E.ARRAY, "substeps": E.COUNT, "rtol": E.TOL}),
    Entry("Auto", lambda a: _solve_with(wb.Auto(**a)), _auto_args,
          {"swings": E.COUNT, "relax": E.OBJECT, "relax_max_iter": E.COUNT,
           "attempt_max_iter": E.COUNT, "bound_factors": E.SEQUENCE,
           "terminal_slacks": E.SEQUENCE, "coarse_factor": E.COUNT, "max_attempts": E.COUNT}),
    Entry("Direct", lambda a: _solve_with(a["strategy"]), lambda: {"strategy": wb.Direct()},
          {"strategy": E.OBJECT}, optional=frozenset({"strategy"})),  # None: Auto()
    # --- the critical sets of a potential, without guesses
    Entry("ConfigurationFunction", lambda a: wb.ConfigurationFunction(
        a.pop("manifold"), a.pop("function"), **a).value([0.6, 0.8]),
          lambda: {"manifold": S1_MAN, "function": _pendulum_potential(), "p": [9.81],
                   "name": "height"},
          {"manifold": E.OBJECT, "function": E.OBJECT, "p": E.ARRAY, "name": E.TEXT}),
    Entry("ConfigurationFunction.from_state", lambda a: wb.ConfigurationFunction.from_state(
        a.pop("model"), a.pop("function"), **a).value([0.6, 0.8]),
          lambda: {"model": cart_s1(), "function": _energy_at_rest(), "configuration": ["th"],
                   "p": cart_s1().p, "name": "height"},
          {"model": E.OBJECT, "function": E.OBJECT, "configuration": E.SEQUENCE,
           "p": E.ARRAY, "name": E.TEXT},
          optional=frozenset({"configuration", "p", "name"}),
          valid={"configuration": frozenset({"None"})}),
    Entry("critical_points", _call(wb.critical_points, "target"), _critical_args,
          {"target": E.OBJECT, "manifold": E.OBJECT, "p": E.ARRAY, "tol": E.TOL,
           "hessian_rtol": E.TOL, "symmetry_rtol": E.TOL, "max_starts": E.COUNT,
           "deflation_starts": E.COUNT, "deflation_rounds": E.COUNT,
           "max_deflation_starts": E.COUNT, "max_iterations": E.COUNT, "seed": E.COUNT,
           "raise_on_failure": E.OBJECT}, optional=frozenset({"p"})),
    Entry("find_all_equilibria", _call(wb.find_all_equilibria, "model"),
          lambda: {"model": cart_s1(), "params": {"g": 9.81}, "field_tol": 1e-9,
                   "raise_on_failure": True, "tol": 1e-11, "max_iterations": 50},
          {"model": E.OBJECT, "params": E.OBJECT, "field_tol": E.TOL,
           "raise_on_failure": E.OBJECT, "tol": E.TOL, "max_iterations": E.COUNT},
          optional=frozenset({"params"}), valid={"params": frozenset({"dict"})}),
    # --- choosing a model's level for a scene
    Entry("Scene", lambda a: wb.Scene(**a).times, _scene_args,
          {"model": E.OBJECT, "states": E.ARRAY, "horizon": E.SCALE, "outputs": E.OBJECT,
           "tolerance": E.TOL, "n_times": E.COUNT, "name": E.TEXT}),
    Entry("compare_models", _call(wb.compare_models, "scene"), _compare_args,
          {"scene": E.OBJECT, "levels": E.SEQUENCE, "special_cases": E.SEQUENCE,
           "symmetries": E.SEQUENCE, "equilibria": E.SEQUENCE, "radius": E.SCALE,
           "method": E.ENUM, "rtol": E.TOL, "atol": E.TOL, "multistep": E.ENUM,
           "step": E.SCALE, "max_steps": E.COUNT, "repeats": E.COUNT,
           "reference_rtol": E.TOL, "check_rtol": E.TOL, "reference_margin": E.TOL,
           "seed": E.COUNT, "raise_on_failure": E.OBJECT},
          optional=frozenset({"levels", "symmetries", "radius", "step"}),
          valid={"levels": frozenset({"None"}), "symmetries": frozenset({"None"})}),
    # --- mechanics: the S^1 factor, symmetry reduction
    Entry("mechanics.System.s1", _s1_entry, lambda: {"name": "th", "velocity": "th_dot"},
          {"name": E.NAME, "velocity": E.NAME}, optional=frozenset({"velocity"})),
    Entry("mechanics.reduce", _reduce, _reduce_args,
          {"source": E.OBJECT, "symmetry": E.NAME, "kind": E.ENUM, "momentum": E.NUMBER,
           "breaking_inputs": E.ENUM, "name": E.TEXT, "n_states": E.COUNT, "seed": E.COUNT,
           "rtol": E.TOL}, optional=frozenset({"name"})),
    # --- the models' builders
    Entry("models.pendulum3d.full", lambda a: p3.full(**a).rhs(x_full()),
          lambda: {"J": J0, "rho": RHO0, "m": 1.0, "g": 9.81},
          {"J": E.ARRAY, "rho": E.ARRAY, "m": E.SCALE, "g": E.NUMBER}),
    Entry("models.pendulum3d.reduced", lambda a: p3.reduced(**a).rhs(hang()),
          lambda: {"J": J0, "rho": RHO0, "m": 1.0, "g": 9.81},
          {"J": E.ARRAY, "rho": E.ARRAY, "m": E.SCALE, "g": E.NUMBER}),
    Entry("models.pendulum3d.routh", lambda a: p3.routh(**a).rhs([0, 0, 1.0, 0.1, 0.2, 0]),
          lambda: {"J": J0, "rho": RHO0, "mu": 0.3, "m": 1.0, "g": 9.81},
          {"J": E.ARRAY, "rho": E.ARRAY, "mu": E.NUMBER, "m": E.SCALE}),
    Entry("models.spherical.spherical_pendulum", lambda a: sp.spherical_pendulum(**a).rhs(
        [0, 0, 1.0, 0.1, 0.2, 0.0], [0.0, 0.0, 0.0]),
          lambda: {"m": 1.0, "l": 1.0, "g": 9.81},
          {"m": E.SCALE, "l": E.SCALE, "g": E.NUMBER}),
    Entry("models.chain_cart.chain_cart", lambda a: cc.chain_cart(a.pop("n"), **a).rhs(
        CART_DOWN), lambda: {"n": 1, "m": 0.5, "masses": 0.1, "lengths": 0.1, "g": 9.81},
          {"n": E.COUNT, "m": E.SCALE, "masses": E.SCALE, "lengths": E.SCALE, "g": E.NUMBER}),
    Entry("models.controllers.angular_velocity_feedback",
          lambda a: C.angular_velocity_feedback(a.pop("model"), **a),
          lambda: {"model": full(), "D": np.eye(3)}, {"model": E.OBJECT, "D": E.ARRAY}),
    Entry("models.controllers.saturated_velocity_feedback",
          lambda a: C.saturated_velocity_feedback(a.pop("model"), **a),
          lambda: {"model": full(), "P": np.eye(3), "k": 1.0},
          {"model": E.OBJECT, "P": E.ARRAY, "k": E.SCALE}),
    Entry("models.controllers.s2_pd", lambda a: C.s2_pd(a.pop("model"), a.pop("q_d"), **a),
          lambda: {"model": sph(), "q_d": [0.0, 0.0, -1.0], "k_q": 1.0, "k_w": 1.0},
          {"model": E.OBJECT, "q_d": E.ARRAY, "k_q": E.SCALE, "k_w": E.SCALE}),
    Entry("models.controllers.so3_pd", lambda a: C.so3_pd(a.pop("model"), a.pop("R_d"), **a),
          lambda: {"model": full(), "R_d": np.eye(3), "k_R": 1.0, "k_Omega": 1.0,
                   "G": np.eye(3)},
          {"model": E.OBJECT, "R_d": E.ARRAY, "k_R": E.SCALE, "k_Omega": E.SCALE,
           "G": E.ARRAY}),
    Entry("models.controllers.cart_inverted_feedback",
          lambda a: C.cart_inverted_feedback(a.pop("model"), **a),
          lambda: {"model": cart(), "k_y": 1.0, "k_ydot": 1.0, "k_w": 1.0, "k_q": 3.0},
          {"model": E.OBJECT, "k_y": E.SCALE, "k_ydot": E.SCALE, "k_w": E.SCALE,
           "k_q": E.SCALE}),
    # --- the command line (argv pieces are strings: attacked as names and paths)
    Entry("cli", _cli, lambda: {"argv": ["list"]}, {"argv": E.OBJECT}),
]

EXCLUDED: dict[str, str] = {
    **{m: "a namespace module (its functions are entries under their root names)"
       for m in ("codegen", "control", "core", "equilibria", "global_dynamics", "linear",
                 "simulation", "study")},
    **{e: "an exception class (raised, not called with user input)"
       for e in ("WorkbenchError", "ManifoldError", "ModelError", "ParameterError",
                 "SolverError")},
    **{r: "a result record the workbench builds (its inputs are the entries that return it)"
       for r in ("BuildLog", "CriticalPoints", "Eigenstructure", "InvariantManifold",
                 "LQRResult", "LinearModel", "ModelChoice", "OCPSolution", "PoincareOrbit",
                 "SweepResult", "TVLQR", "Trajectory")},
    "OCPStatus": "a result status enum (read from OCPSolution.status, never passed in)",
    "Stability": "a result enum (read from Eigenstructure.stability, never passed in)",
}
