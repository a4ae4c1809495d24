"""Transcriptions of an OCP into a nonlinear program: collocation and multiple shooting.

Both split ``[0, T]`` into ``N`` equal intervals of length ``h = T/N`` with a piecewise
constant control, and both come in two manifold handlings:

``ManifoldHandling.AMBIENT``
    The node (and collocation) states are ambient coordinates, free in ``R^N``; the
    manifold constraints are carried by the dynamics. Gauss-Legendre collocation conserves
    quadratic first integrals exactly, and ``|q|^2``, ``q . w`` (the chain) and the rows of
    ``R R^T`` (``R' = R hat(omega)``) are quadratic and conserved by the ambient vector fields
    of the models for every ambient state, so the nodes stay on the manifold to rounding
    error; Radau collocation and Runge-Kutta shooting leave a residual of the order of
    their local error, which the solution reports.
``ManifoldHandling.PROJECTED``
    As ``AMBIENT``, with continuity imposed on the interval's end point projected onto the
    manifold, ``X_(k+1) = Pi(x_end)`` (:mod:`workbench.control.ocp.projection`): every
    node is on the manifold for every scheme, at the ambient NLP's size and cost.
``ManifoldHandling.LIE_GROUP``
    On each interval the state is ``x(t) = act(x_k, y(t))`` with ``y(0) = 0`` in the Lie
    algebra of the group acting on each factor (:mod:`workbench.control.ocp.local`); the
    transcription integrates ``y`` (collocation or shooting on a vector space, RKMK) and
    sets ``x_{k+1} = act(x_k, y(h))``, so every node is exactly on the manifold.

The initial state is fixed through the variable bounds of ``X_0`` (an ambient point on the
manifold: consistent and independent), the terminal condition is imposed through the
target's chart (:mod:`workbench.control.ocp.problem`). The NLP's graph depends on the model, the
costs, the target and the transcription only: bounds, the initial state and the model's
parameters are data, so continuation in a bound or the horizon reuses one build.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from enum import Enum
from typing import Any

import casadi as ca
import numpy as np

from workbench.control.ocp._coefficients import collocation_coefficients
from workbench.control.ocp.compiled import Compiled, compiled_solver
from workbench.control.ocp.derivatives import IntervalLayout, structured_derivatives
from workbench.control.ocp.expand import sx_function
from workbench.control.ocp.hermite_simpson import HermiteSimpson, hermite_simpson_interval
from workbench.control.ocp.local import ProductLocal
from workbench.control.ocp.problem import OCP
from workbench.control.ocp.projection import projection_function
from workbench.core import validate
from workbench.core._model import Symbolic
from workbench.core.errors import ModelError, ParameterError

__all__ = [
    "Scheme",
    "ManifoldHandling",
    "Integrator",
    "Collocation",
    "MultipleShooting",
    "Transcription",
    "TranscriptionMethod",
]


class Scheme(Enum):
    """Collocation points: Gauss-Legendre (order 2d) or Radau IIA (order 2d - 1)."""

    LEGENDRE = "legendre"
    RADAU = "radau"


class ManifoldHandling(Enum):
    """How the transcription keeps the state on the manifold (see the module docstring)."""

    AMBIENT = "ambient"
    LIE_GROUP = "lie_group"
    PROJECTED = "projected"


class Integrator(Enum):
    """Integrator of multiple shooting: casadi ``rk`` (RK4, SX-expandable) or ``cvodes``."""

    RK4 = "rk"
    CVODES = "cvodes"


def _check_int(value: Any, name: str, minimum: int, maximum: int | None = None) -> int:
    if (isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum
            or (maximum is not None and value > maximum)):
        span = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise ParameterError(f"{name} must be an integer {span}; got {value!r}")
    return int(value)


MAX_DEGREE = 9
"""casadi's collocation points exist up to degree 9 (``collocation_points``: order < 10)."""

MAX_INTERVALS = 100_000
"""More intervals than this would build a graph of millions of nodes (memory runs out)."""

MAX_STEPS = 1_000
"""RK4 steps per shooting interval: each is unrolled into the interval's graph."""

MAX_SHOOTING_STEPS = 100_000
"""RK4 steps per NLP evaluation (``N * steps``): a pendulum takes ~1 s per Ipopt iteration at
40 x 1000 (at 99999 x 1000, ~40 min). The problems use 40 x 1; N = 50000 x 2 steps fits."""

MAX_NLP_VARIABLES = 400_000
"""Decision variables of one NLP (intervals x (state + collocation states + input)):
checked with the model's sizes before anything is built (a 10^5-interval, degree-9
collocation of a 6-state model would need ~6 10^6 and several GB)."""


@dataclass(frozen=True)
class Collocation:
    """Direct collocation with ``N`` intervals and ``degree`` collocation points each.

    Parameters
    ----------
    N : int
        Number of intervals.
    degree : int
        Collocation points per interval.
    scheme : Scheme
        ``Scheme.LEGENDRE`` or ``Scheme.RADAU``.
    """

    N: int = 40
    degree: int = 3
    scheme: Scheme = Scheme.LEGENDRE

    def __post_init__(self) -> None:
        _check_int(self.N, "N", 1, MAX_INTERVALS)
        _check_int(self.degree, "degree", 1, MAX_DEGREE)
        if not isinstance(self.scheme, Scheme):
            raise ParameterError(f"scheme must be a Scheme; got {self.scheme!r}")

    def describe(self) -> str:
        """E.g. ``"collocation legendre d=3 N=40"``."""
        return f"collocation {self.scheme.value} d={self.degree} N={self.N}"


@dataclass(frozen=True)
class MultipleShooting:
    """Multiple shooting with ``N`` intervals, a casadi integrator on each.

    Parameters
    ----------
    N : int
        Number of intervals.
    integrator : Integrator
        ``Integrator.RK4`` (fixed step, expanded into the NLP's graph) or
        ``Integrator.CVODES`` (adaptive; a black-box node with sensitivities).
    steps : int
        RK4 steps per interval (at most :data:`MAX_STEPS`: each is unrolled; with RK4,
        ``N * steps`` at most :data:`MAX_SHOOTING_STEPS`).
    rtol : float
        CVODES' tolerances (relative and absolute).
    """

    N: int = 40
    integrator: Integrator = Integrator.RK4
    steps: int = 2
    rtol: float = 1e-8

    def __post_init__(self) -> None:
        _check_int(self.N, "N", 1, MAX_INTERVALS)
        _check_int(self.steps, "steps", 1, MAX_STEPS)
        object.__setattr__(self, "rtol", validate.tolerance("rtol", self.rtol))
        if not isinstance(self.integrator, Integrator):
            raise ParameterError(f"integrator must be an Integrator; got {self.integrator!r}")
        if self.integrator is Integrator.RK4 and self.N * self.steps > MAX_SHOOTING_STEPS:
            raise ParameterError(f"N * steps must be at most {MAX_SHOOTING_STEPS} (RK4 steps of "
                                 f"one NLP evaluation); got N = {self.N} x steps = {self.steps}"
                                 f" = {self.N * self.steps}: fewer intervals or steps")

    def describe(self) -> str:
        """E.g. ``"shooting rk x2 N=40"``."""
        extra = f"x{self.steps}" if self.integrator is Integrator.RK4 else f"rtol={self.rtol:g}"
        return f"shooting {self.integrator.value} {extra} N={self.N}"


TranscriptionMethod = Collocation | MultipleShooting | HermiteSimpson
"""A transcription method (named apart from the simulation's integration ``Method``)."""
METHODS = (Collocation, MultipleShooting, HermiteSimpson)


class Transcription:
    """An OCP transcribed into an NLP and its Ipopt solver (built once, solved many times).

    Parameters
    ----------
    ocp : OCP
        The problem.
    method : Collocation, MultipleShooting or HermiteSimpson
        The transcription.
    handling : ManifoldHandling
        Ambient coordinates or local exponential coordinates.
    graph : Symbolic
        SX or MX NLP.
    ipopt : dict
        Ipopt options (prefix-free, e.g. ``{"tol": 1e-8}``).

    Notes
    -----
    With ``ocp.symmetry`` (a verified rotation symmetry, gauged unless ``gauge=False``) the
    NLP has one more constraint, the phase condition ``<c, w> = c0`` whose coefficients
    ``c`` (the generator applied to the guess, see :mod:`workbench.control.ocp.symmetry`) are NLP
    parameters after the model's: data of each solve, not of the graph.
    """

    def __init__(self, ocp: OCP, method: TranscriptionMethod, handling: ManifoldHandling,
                 graph: Symbolic, ipopt: dict[str, Any]) -> None:
        if not isinstance(method, METHODS):
            raise ParameterError(
                f"method must be Collocation(...), MultipleShooting(...) or "
                f"HermiteSimpson(...); got {method!r}"
            )
        if not isinstance(handling, ManifoldHandling):
            raise ParameterError(f"handling must be a ManifoldHandling; got {handling!r}")
        if not isinstance(graph, Symbolic):
            raise ParameterError(f"graph must be a Symbolic (SX or MX); got {graph!r}")
        self.ocp, self.method, self.handling, self.graph = ocp, method, handling, graph
        model = ocp.model
        self.nx, self.nu, self.N = model.manifold.ambient_dim, model.n_inputs, method.N
        self.foh = isinstance(method, HermiteSimpson)
        self.symmetry = ocp.symmetry if ocp.gauge else None
        self.local = ProductLocal(model.manifold)
        self._layout()
        if self.nw > MAX_NLP_VARIABLES:
            raise ParameterError(
                f"{method.describe()} of {model.name} ({self.nx} state entries, {self.nu} "
                f"inputs, {self.handling.value}) would have {self.nw} NLP variables; at most "
                f"{MAX_NLP_VARIABLES}: fewer intervals N or a lower degree")
        t0 = time.perf_counter()
        f = model.function("f")
        if graph is Symbolic.SX:
            f = sx_function(f, spd=model.spd_solves)
        self.S = ca.SX if graph is Symbolic.SX else ca.MX
        self.f = f
        self.nlp = self._build_nlp()
        self._solvers: dict[tuple, ca.Function] = {}
        self.compile_info: dict[Compiled, dict[str, Any]] = {}
        self._derivatives: dict[str, ca.Function] = {}
        self.solver(ipopt)
        self.build_seconds = time.perf_counter() - t0

    def solver(self, ipopt: dict[str, Any], compiled: Compiled | None = None) -> ca.Function:
        """The Ipopt solver for these options (derivatives generated once, then shared).

        Parameters
        ----------
        ipopt : dict
            Ipopt options.
        compiled : Compiled, optional
            Run the NLP's functions from a compiled library (see
            :mod:`workbench.control.ocp.compiled`); its costs go to :attr:`compile_info`.
        """
        key = (tuple(sorted((k, str(v)) for k, v in ipopt.items())), compiled)
        if key not in self._solvers:
            opts: dict[str, Any] = {"ipopt": dict(ipopt), "print_time": False,
                                    "show_eval_warnings": int(ipopt.get("print_level", 0)) > 0}
            name = re.sub(r"\W", "_", f"ocp_{self.ocp.name}")
            if compiled is not None:
                if not isinstance(compiled, Compiled):
                    raise ParameterError(f"compiled must be a Compiled(...) or None; got "
                                         f"{compiled!r}")
                if not self._derivatives and self._structure is not None:
                    self._derivatives = self._structured(self.nlp)
                solver, info = compiled_solver(name, self.nlp, opts, compiled,
                                               graph_ok=self.graph is Symbolic.SX,
                                               derivatives=self._derivatives)
                self.compile_info[compiled] = info
                self._solvers[key] = solver
                return solver
            if not self._derivatives and self._structure is not None:
                self._derivatives = self._structured(self.nlp)
            opts.update(self._derivatives)
            solver = ca.nlpsol(name, "ipopt", self.nlp, opts)
            if "grad_f" not in self._derivatives:
                self._derivatives = {
                    "hess_lag": solver.get_function("nlp_hess_l"),
                    "jac_g": solver.get_function("nlp_jac_g"),
                    "grad_f": solver.get_function("nlp_grad_f"),
                }
            self._solvers[key] = solver
        return self._solvers[key]

    # layout ------------------------------------------------------------------------------

    def _layout(self) -> None:
        """Offsets of the decision variables, interval by interval."""
        m = self.method
        lie = self.handling is ManifoldHandling.LIE_GROUP
        if isinstance(m, Collocation):
            self.d = m.degree
            self.tau, self.C, self.D, self.B = collocation_coefficients(m.degree, m.scheme)
            self.ncol = self.local.ydim if lie else self.nx
        elif self.foh and lie:  # one end point y_1 of the local coordinates per interval
            self.d, self.ncol, self.tau = 1, self.local.ydim, np.array([0.0, 1.0])
        else:
            self.d, self.ncol = 0, 0
        per = self.nx + self.d * self.ncol + self.nu
        self.per = per
        self.ix = [k * per for k in range(self.N)] + [self.N * per]
        self.ic = [k * per + self.nx for k in range(self.N)]
        self.iu = [k * per + self.nx + self.d * self.ncol for k in range(self.N)]
        if self.foh:  # the control of the last knot follows the last state
            self.iu.append(self.N * per + self.nx)
        self.iT = self.N * per + self.nx + (self.nu if self.foh else 0)
        self.nw = self.iT + 1

    # graph --------------------------------------------------------------------------------

    def _interval(self) -> ca.Function:
        """``(X_k, Z_k, U_k, h, p) -> (defects, x_end, cost)`` of one interval."""
        S, nx, nu = self.S, self.nx, self.nu
        ocp, loc = self.ocp, self.local
        Xk, U, h, p = S.sym("Xk", nx), S.sym("U", nu), S.sym("h"), S.sym("p", ocp.model.n_params)
        lie = self.handling is ManifoldHandling.LIE_GROUP
        self._fopts = {"cse": True} if S is ca.SX else {}
        # scalar helpers (SX functions; inlined in an SX graph, one node each in an MX graph)
        xs, ys = ca.SX.sym("x", nx), ca.SX.sym("y", loc.ydim)
        xks, xds, us = ca.SX.sym("xk", nx), ca.SX.sym("xdot", nx), ca.SX.sym("u", nu)
        act = ca.Function("act", [xks, ys], [loc.act(xks, ys)], {"cse": True})
        proj = (projection_function(ocp.model.manifold)
                if self.handling is ManifoldHandling.PROJECTED else None)
        ydot_of = ca.Function("ydot", [xks, ys, xs, xds], [loc.ydot(xks, ys, xs, xds)],
                              {"cse": True})
        running = ocp.running_cost
        L = None if running is None else ca.Function("L", [xs, us], [running(xs, us)])
        if self.foh:
            return hermite_simpson_interval(S, nx, nu, ocp.model.n_params, self.f, L,
                                            (act, ydot_of) if lie else None, self._fopts,
                                            project=proj)

        def ydot(y: Any) -> Any:
            x = act(Xk, y)
            return ydot_of(Xk, y, x, self.f(x, U, p)), x

        if isinstance(self.method, Collocation):
            d = self.d
            Z = S.sym("Z", self.ncol, d)
            start = S.zeros(self.ncol) if lie else Xk
            pts = [start] + [Z[:, j] for j in range(d)]
            defects, cost = [], 0
            for j in range(1, d + 1):
                slope = sum(self.C[r, j] * pts[r] for r in range(d + 1))
                if lie:
                    rate, x = ydot(pts[j])
                else:
                    x = pts[j]
                    rate = self.f(x, U, p)
                defects.append(h * rate - slope)
                if L is not None:
                    cost = cost + self.B[j] * h * L(x, U)
            end = sum(self.D[r] * pts[r] for r in range(d + 1))
            x_end = act(Xk, end) if lie else end
            if proj is not None:
                x_end = proj(x_end)
            return ca.Function("interval", [Xk, Z, U, h, p],
                               [ca.vertcat(*defects), x_end, cost], self._fopts)
        # multiple shooting
        m = self.method
        if lie:
            state = S.sym("y", loc.ydim)
            rate, x = ydot(state)
            start = S.zeros(loc.ydim)
        else:
            state = S.sym("x", nx)
            x = state
            rate = self.f(x, U, p)
            start = Xk
        quad = h * L(x, U) if L is not None else S.zeros(1)
        params = ca.vertcat(Xk, U, h, p) if lie else ca.vertcat(U, h, p)
        dae = {"x": state, "p": params, "ode": h * rate, "quad": quad}
        if m.integrator is Integrator.RK4:
            opts = {"number_of_finite_elements": m.steps, "simplify": True}
        else:
            opts = {"reltol": m.rtol, "abstol": m.rtol}
        F = ca.integrator("phi", m.integrator.value, dae, 0.0, 1.0, opts)
        Z = S.sym("Z", 0, 1)
        res = F(x0=start, p=params)
        y_end = res["xf"]
        x_end = act(Xk, y_end) if lie else y_end
        if proj is not None:
            x_end = proj(x_end)
        return ca.Function("interval", [Xk, Z, U, h, p], [S.zeros(0, 1), x_end, res["qf"]],
                           self._fopts)

    def _build_nlp(self) -> dict[str, Any]:
        ocp, N = self.ocp, self.N
        F = self._interval()
        if self.graph is Symbolic.SX and F.is_a("MXFunction"):
            F = F.expand()
        # SX intervals: the NLP maps the one interval function (an MX graph of N calls)
        # and its derivatives are built per interval (see _structured); no N-fold inlining
        structured = self.graph is Symbolic.SX and F.is_a("SXFunction")
        S = ca.MX if structured else self.S
        w = S.sym("w", self.nw)
        p = S.sym("p", ocp.model.n_params)
        c_gauge = S.sym("c_gauge", self.nw if self.symmetry is not None else 0)
        T = w[self.iT]
        h = T / N
        g, lbg, ubg, kinds, knots = [], [], [], [], []
        J = 0

        def add(expr: Any, lo: Any, hi: Any, kind: str, knot: int) -> None:
            n = int(expr.numel())
            if n == 0:
                return
            g.append(ca.vec(expr))
            lbg.append(np.broadcast_to(np.asarray(lo, float), (n,)).copy())
            ubg.append(np.broadcast_to(np.asarray(hi, float), (n,)).copy())
            kinds.extend([kind] * n)
            knots.extend([knot] * n)

        per, nx, d, nc = self.per, self.nx, self.d, self.ncol
        W = ca.reshape(w[0: N * per], per, N)  # column k: (X_k, vec Z_k, U_k)
        Xs, Us = W[0:nx, :], W[nx + d * nc: per, :]
        Zs = ca.reshape(W[nx: nx + d * nc, :], nc, d * N) if d else S.zeros(0, N)
        X_next = ca.horzcat(W[0:nx, 1:N], w[self.ix[N]: self.ix[N] + nx])
        if self.foh:
            Us = ca.horzcat(Us, w[self.iu[N]: self.iu[N] + self.nu])
            F_args = lambda k: (Xs[:, k], X_next[:, k],  # noqa: E731
                                Zs[:, k * d: (k + 1) * d] if d else S.zeros(0, 1),
                                Us[:, k], Us[:, k + 1], h, p)
            all_args = (Xs, X_next, Zs, Us[:, 0:N], Us[:, 1: N + 1], h, p)
        else:
            F_args = lambda k: (Xs[:, k],  # noqa: E731
                                Zs[:, k * d: (k + 1) * d] if d else S.zeros(0, 1),
                                Us[:, k], h, p)
            all_args = (Xs, Zs, Us, h, p)
        if S is ca.MX:  # one mapped call: a compact MX graph
            defects, x_end, cost = F.map(N, "serial")(*all_args)
            block = ca.vertcat(defects, X_next - x_end)
            J = J + ca.sum2(cost)
        else:  # SX: inline interval by interval
            cols = []
            for k in range(N):
                defects, x_end, cost = F(*F_args(k))
                cols.append(ca.vertcat(defects, X_next[:, k] - x_end))
                J = J + cost
            block = ca.horzcat(*cols)
        nd = int(block.shape[0]) - nx
        g.append(ca.vec(block))
        n_block = int(block.numel())
        lbg.append(np.zeros(n_block))
        ubg.append(np.zeros(n_block))
        kinds.extend((["defect"] * nd + ["continuity"] * nx) * N)
        for k in range(N):  # a defect belongs to interval k, a continuity condition to knot k+1
            knots.extend([k] * nd + [k + 1] * nx)
        for k in range(N):
            for c in ocp.path_constraints:
                if c.applies(k, N):
                    add(c.function(Xs[:, k], Us[:, k]), c.lower, c.upper, c.name, k)
        XN = w[self.ix[N]: self.ix[N] + self.nx]
        UN = w[self.iu[-1]: self.iu[-1] + self.nu]
        for c in ocp.path_constraints:
            if c.applies(N, N):
                add(c.function(XN, UN), c.lower, c.upper, c.name, N)
        add(ocp.target.equations(XN), 0.0, 0.0, "terminal", N)
        for e in ocp.target.domain(XN):
            add(e, 0.0, np.inf, "terminal chart domain", N)
        f_rest = ocp.terminal_cost(XN, T) if ocp.terminal_cost is not None else S.zeros(1)
        J = J + f_rest
        self.i_gauge = None
        if self.symmetry is not None:
            self.i_gauge = len(kinds)
            add(ca.dot(c_gauge, w), 0.0, 0.0, "gauge", -1)
        self.lbg, self.ubg = np.concatenate(lbg), np.concatenate(ubg)
        self.g_kinds = np.array(kinds)
        self.g_knots = np.array(knots, dtype=int)  # the knot (or interval) of each row; -1: none
        self.ng = len(self.lbg)
        G = ca.vertcat(*g)
        P = ca.vertcat(p, c_gauge)
        self.n_nodes = int(ca.Function("nlp", [w, P], [J, G]).n_nodes())
        nlp = {"x": w, "p": P, "f": J, "g": G}
        self._structure = (F, n_block, f_rest, ca.vertcat(*g[1:])) if structured else None
        return nlp

    def _structured(self, nlp: dict[str, Any]) -> dict[str, ca.Function]:
        """Exact ``jac_g`` and ``hess_lag`` built per interval (:mod:`.derivatives`)."""
        F, n_block, f_rest, g_rest = self._structure
        nx, N, dn = self.nx, self.N, self.d * self.ncol
        if self.foh:
            blocks = [[(self.ix[k], nx), (self.ix[k + 1], nx), (self.ic[k], dn),
                       (self.iu[k], self.nu), (self.iu[k + 1], self.nu)] for k in range(N)]
        else:
            blocks = [[(self.ix[k], nx), (self.ic[k], dn), (self.iu[k], self.nu)]
                      for k in range(N)]
        layout = IntervalLayout(F, blocks, [(self.ix[k + 1], nx) for k in range(N)], self.iT)
        return structured_derivatives(layout, nlp, n_block, g_rest, f_rest,
                                      self.ocp.model.n_params)

    def gauge_direction(self, w0: np.ndarray) -> np.ndarray:
        """Unit coefficients ``c`` of the phase condition through ``w0`` (zeros: none).

        ``c`` is the symmetry's generator applied to the node states and controls of
        ``w0`` (the collocation variables and ``T`` get 0), normalised; the orbit of
        ``w0`` crosses the slice ``<c, w> = <c, w0>`` transversally when ``c != 0``.
        """
        c = np.zeros(self.nw)
        sym = self.symmetry
        if sym is None:
            return c
        for i in self.ix:
            c[i: i + self.nx] = sym.Ax @ w0[i: i + self.nx]
        for i in self.iu:
            c[i: i + self.nu] = sym.Au @ w0[i: i + self.nu]
        n = float(np.linalg.norm(c))
        return c / n if n > 1e-9 else np.zeros(self.nw)

    # data ---------------------------------------------------------------------------------

    def bounds(self, ocp: OCP | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds for ``ocp`` (this transcription's problem or one sharing its graph)."""
        ocp = ocp or self.ocp
        lbw, ubw = np.full(self.nw, -np.inf), np.full(self.nw, np.inf)
        lbw[0: self.nx] = ubw[0: self.nx] = ocp.x0
        for i in self.iu:
            lbw[i: i + self.nu] = ocp.u_lower
            ubw[i: i + self.nu] = ocp.u_upper
        lbw[self.iT], ubw[self.iT] = ocp.T_range
        return lbw, ubw

    def times(self, T: float) -> np.ndarray:
        """Node times ``k T / N``."""
        return np.linspace(0.0, T, self.N + 1)

    def pack(self, x_of_s: Any, u: np.ndarray, T: float) -> np.ndarray:
        """The NLP vector of a guess.

        Parameters
        ----------
        x_of_s : callable
            ``x(s)`` for normalised time ``s`` in ``[0, 1]``, a state on (or near) the manifold.
        u : ndarray, shape=(N, n_inputs) or (N + 1, n_inputs)
            Control on each interval (or at each knot, first-order hold).
        T : float
            Final time.
        """
        if u.shape[0] != len(self.iu):
            raise ParameterError(
                f"u must have {len(self.iu)} rows for {self.method.describe()}; got "
                f"{u.shape[0]}")
        w = np.zeros(self.nw)
        lie = self.handling is ManifoldHandling.LIE_GROUP
        for k in range(self.N + 1):
            xk = np.asarray(x_of_s(k / self.N), float)
            w[self.ix[k]: self.ix[k] + self.nx] = xk
            if k == self.N:
                break
            for j in range(self.d):
                xj = np.asarray(x_of_s((k + self.tau[j + 1]) / self.N), float)
                val = self.local.log(xk, xj) if lie else xj
                w[self.ic[k] + j * self.ncol: self.ic[k] + (j + 1) * self.ncol] = val
            w[self.iu[k]: self.iu[k] + self.nu] = u[k]
        if self.foh:
            w[self.iu[-1]: self.iu[-1] + self.nu] = u[-1]
        w[self.iT] = T
        return w

    def unpack(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """Node states ``(N+1, nx)``, controls and ``T`` of an NLP vector.

        The controls are ``(N, nu)``, or ``(N+1, nu)`` with a first-order hold.
        """
        w = np.asarray(w, float).ravel()
        X = np.array([w[i: i + self.nx] for i in self.ix])
        U = np.array([w[i: i + self.nu] for i in self.iu])
        return X, U, float(w[self.iT])

    def describe(self) -> str:
        """E.g. ``"collocation legendre d=3 N=40, ambient, SX"``."""
        return f"{self.method.describe()}, {self.handling.value}, {self.graph.value.upper()}"


def check_method(method: Any) -> TranscriptionMethod:
    """Validate a transcription object."""
    if not isinstance(method, METHODS):
        raise ModelError(
            f"method must be Collocation(N=..., degree=...), MultipleShooting(N=...) or "
            f"HermiteSimpson(N=...); got {method!r}"
        )
    return method
