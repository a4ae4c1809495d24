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

import time
from dataclasses import dataclass
from enum import Enum
from typing import Any

import casadi as ca
import numpy as np

from workbench.control.ocp.expand import sx_function
from workbench.control.ocp.local import ProductLocal
from workbench.control.ocp.problem import OCP
from workbench.core import validate
from workbench.core.errors import ModelError, ParameterError

__all__ = [
    "Scheme",
    "ManifoldHandling",
    "Graph",
    "Integrator",
    "Collocation",
    "MultipleShooting",
    "Transcription",
]


class Scheme(Enum):
    """Collocation points: Gauss-Legendre (order 2d) or Radau IIA (order 2d - 1)."""

    LEGENDRE = "legendre"
    RADAU = "radau"


class ManifoldHandling(Enum):
    """How the transcription keeps the state on the manifold (see the module docstring)."""

    AMBIENT = "ambient"
    LIE_GROUP = "lie_group"


class Graph(Enum):
    """Symbol class of the NLP.

    ``SX``: scalar graph (the model's MX linear solves replayed as symbolic solves by
    :func:`~workbench.control.ocp.expand.sx_function`); ``MX``: the model's own graph, linear
    solves kept as numeric nodes.
    """

    SX = "sx"
    MX = "mx"


class Integrator(Enum):
    """Integrator of multiple shooting: casadi ``rk`` (RK4, SX-expandable) or ``cvodes``."""

    RK4 = "rk"
    CVODES = "cvodes"


def _check_int(value: Any, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ParameterError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


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
        _check_int(self.N, "N", 1)
        _check_int(self.degree, "degree", 1)
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
        RK4 steps per interval.
    rtol : float
        CVODES' tolerances (relative and absolute).
    """

    N: int = 40
    integrator: Integrator = Integrator.RK4
    steps: int = 2
    rtol: float = 1e-8

    def __post_init__(self) -> None:
        _check_int(self.N, "N", 1)
        _check_int(self.steps, "steps", 1)
        object.__setattr__(self, "rtol", validate.tolerance("rtol", self.rtol))
        if not isinstance(self.integrator, Integrator):
            raise ParameterError(f"integrator must be an Integrator; got {self.integrator!r}")

    def describe(self) -> str:
        """E.g. ``"shooting rk x2 N=40"``."""
        extra = f"x{self.steps}" if self.integrator is Integrator.RK4 else f"rtol={self.rtol:g}"
        return f"shooting {self.integrator.value} {extra} N={self.N}"


Method = Collocation | MultipleShooting


def collocation_coefficients(degree: int, scheme: Scheme) -> tuple[np.ndarray, ...]:
    """Points ``tau`` (with 0), derivative matrix ``C``, end weights ``D``, quadrature ``B``.

    ``C[r, j]`` is the derivative at ``tau_j`` of the Lagrange polynomial of ``tau_r``;
    ``D[r]`` its value at 1; ``B[j]`` its integral over ``[0, 1]``.
    """
    tau = np.append(0.0, ca.collocation_points(degree, scheme.value))
    d = degree
    C = np.zeros((d + 1, d + 1))
    D = np.zeros(d + 1)
    B = np.zeros(d + 1)
    for r in range(d + 1):
        coeff = np.poly1d([1.0])
        for s in range(d + 1):
            if s != r:
                coeff *= np.poly1d([1.0, -tau[s]]) / (tau[r] - tau[s])
        D[r] = coeff(1.0)
        dp = np.polyder(coeff)
        for j in range(d + 1):
            C[r, j] = dp(tau[j])
        B[r] = np.polyint(coeff)(1.0)
    return tau, C, D, B


class Transcription:
    """An OCP transcribed into an NLP and its Ipopt solver (built once, solved many times).

    Parameters
    ----------
    ocp : OCP
        The problem.
    method : Collocation or MultipleShooting
        The transcription.
    handling : ManifoldHandling
        Ambient coordinates or local exponential coordinates.
    graph : Graph
        SX or MX NLP.
    ipopt : dict
        Ipopt options (prefix-free, e.g. ``{"tol": 1e-8}``).
    """

    def __init__(self, ocp: OCP, method: Method, handling: ManifoldHandling, graph: Graph,
                 ipopt: dict[str, Any]) -> None:
        if not isinstance(method, (Collocation, MultipleShooting)):
            raise ParameterError(
                f"method must be Collocation(...) or MultipleShooting(...); got {method!r}"
            )
        if not isinstance(handling, ManifoldHandling):
            raise ParameterError(f"handling must be a ManifoldHandling; got {handling!r}")
        if not isinstance(graph, Graph):
            raise ParameterError(f"graph must be a Graph; got {graph!r}")
        self.ocp, self.method, self.handling, self.graph = ocp, method, handling, graph
        model = ocp.model
        self.nx, self.nu, self.N = model.manifold.ambient_dim, model.n_inputs, method.N
        self.local = ProductLocal(model.manifold)
        t0 = time.perf_counter()
        f = model.function("f")
        if graph is Graph.SX:
            f = sx_function(f)
            self.S = ca.SX
        else:
            self.S = ca.MX
        self.f = f
        self._layout()
        self.nlp = self._build_nlp()
        self._solvers: dict[tuple, ca.Function] = {}
        self._derivatives: dict[str, ca.Function] = {}
        self.solver(ipopt)
        self.build_seconds = time.perf_counter() - t0

    def solver(self, ipopt: dict[str, Any]) -> ca.Function:
        """The Ipopt solver for these options (derivatives generated once, then shared).

        Parameters
        ----------
        ipopt : dict
            Ipopt options.
        """
        key = tuple(sorted((k, str(v)) for k, v in ipopt.items()))
        if key not in self._solvers:
            opts: dict[str, Any] = {"ipopt": dict(ipopt), "print_time": False,
                                    "show_eval_warnings": int(ipopt.get("print_level", 0)) > 0}
            opts.update(self._derivatives)
            solver = ca.nlpsol(f"ocp_{self.ocp.name}", "ipopt", self.nlp, opts)
            if not self._derivatives:
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
        if isinstance(m, Collocation):
            self.d = m.degree
            self.tau, self.C, self.D, self.B = collocation_coefficients(m.degree, m.scheme)
            ncol = self.local.ydim if self.handling is ManifoldHandling.LIE_GROUP else self.nx
            self.ncol = ncol
        else:
            self.d, self.ncol = 0, 0
        per = self.nx + self.d * self.ncol + self.nu
        self.per = per
        self.ix = [k * per for k in range(self.N)] + [self.N * per]
        self.ic = [k * per + self.nx for k in range(self.N)]
        self.iu = [k * per + self.nx + self.d * self.ncol for k in range(self.N)]
        self.iT = self.N * per + self.nx
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
        ydot_of = ca.Function("ydot", [xks, ys, xs, xds], [loc.ydot(xks, ys, xs, xds)],
                              {"cse": True})
        running = ocp.running_cost
        L = None if running is None else ca.Function("L", [xs, us], [running(xs, us)])

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
        return ca.Function("interval", [Xk, Z, U, h, p], [S.zeros(0, 1), x_end, res["qf"]],
                           self._fopts)

    def _build_nlp(self) -> dict[str, Any]:
        ocp, N = self.ocp, self.N
        S = self.S
        w = S.sym("w", self.nw)
        p = S.sym("p", ocp.model.n_params)
        T = w[self.iT]
        h = T / N
        F = self._interval()
        if self.graph is Graph.SX and F.is_a("MXFunction"):
            F = F.expand()
        g, lbg, ubg, kinds = [], [], [], []
        J = 0

        def add(expr: Any, lo: Any, hi: Any, kind: str) -> None:
            n = int(expr.numel())
            if n == 0:
                return
            g.append(ca.vec(expr))
            lbg.append(np.broadcast_to(np.asarray(lo, float), (n,)).copy())
            ubg.append(np.broadcast_to(np.asarray(hi, float), (n,)).copy())
            kinds.extend([kind] * n)

        per, nx, d, nc = self.per, self.nx, self.d, self.ncol
        W = ca.reshape(w[0: N * per], per, N)  # column k: (X_k, vec Z_k, U_k)
        Xs, Us = W[0:nx, :], W[nx + d * nc: per, :]
        Zs = ca.reshape(W[nx: nx + d * nc, :], nc, d * N) if d else S.zeros(0, N)
        X_next = ca.horzcat(W[0:nx, 1:N], w[self.ix[N]: self.ix[N] + nx])
        if S is ca.MX:  # one mapped call: a compact MX graph
            defects, x_end, cost = F.map(N, "serial")(Xs, Zs, Us, h, p)
            block = ca.vertcat(defects, X_next - x_end)
            J = J + ca.sum2(cost)
        else:  # SX: inline interval by interval
            cols = []
            for k in range(N):
                Z = Zs[:, k * d: (k + 1) * d] if d else S.zeros(0, 1)
                defects, x_end, cost = F(Xs[:, k], Z, Us[:, k], h, p)
                cols.append(ca.vertcat(defects, X_next[:, k] - x_end))
                J = J + cost
            block = ca.horzcat(*cols)
        nd = int(block.shape[0]) - nx
        g.append(ca.vec(block))
        n_block = int(block.numel())
        lbg.append(np.zeros(n_block))
        ubg.append(np.zeros(n_block))
        kinds.extend((["defect"] * nd + ["continuity"] * nx) * N)
        for k in range(N):
            for c in ocp.path_constraints:
                if c.applies(k, N):
                    add(c.function(Xs[:, k], Us[:, k]), c.lower, c.upper, c.name)
        XN = w[self.ix[N]: self.ix[N] + self.nx]
        UN = w[self.iu[N - 1]: self.iu[N - 1] + self.nu]
        for c in ocp.path_constraints:
            if c.applies(N, N):
                add(c.function(XN, UN), c.lower, c.upper, c.name)
        add(ocp.target.equations(XN), 0.0, 0.0, "terminal")
        for e in ocp.target.domain(XN):
            add(e, 0.0, np.inf, "terminal chart domain")
        if ocp.terminal_cost is not None:
            J = J + ocp.terminal_cost(XN, T)
        self.lbg, self.ubg = np.concatenate(lbg), np.concatenate(ubg)
        self.g_kinds = np.array(kinds)
        self.ng = len(self.lbg)
        G = ca.vertcat(*g)
        self.n_nodes = int(ca.Function("nlp", [w, p], [J, G]).n_nodes())
        return {"x": w, "p": p, "f": J, "g": G}

    # data ---------------------------------------------------------------------------------

    def bounds(self, ocp: OCP | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Variable bounds for ``ocp`` (this transcription's problem or one sharing its graph)."""
        ocp = ocp or self.ocp
        lbw, ubw = np.full(self.nw, -np.inf), np.full(self.nw, np.inf)
        lbw[0: self.nx] = ubw[0: self.nx] = ocp.x0
        for k in range(self.N):
            lbw[self.iu[k]: self.iu[k] + self.nu] = ocp.u_lower
            ubw[self.iu[k]: self.iu[k] + self.nu] = ocp.u_upper
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
        u : ndarray, shape=(N, n_inputs)
            Control on each interval.
        T : float
            Final time.
        """
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
        w[self.iT] = T
        return w

    def unpack(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """Node states ``(N+1, nx)``, controls ``(N, nu)`` and ``T`` of an NLP vector."""
        w = np.asarray(w, float).ravel()
        X = np.array([w[i: i + self.nx] for i in self.ix])
        U = np.array([w[i: i + self.nu] for i in self.iu])
        return X, U, float(w[self.iT])

    def describe(self) -> str:
        """E.g. ``"collocation legendre d=3 N=40, ambient, SX"``."""
        return f"{self.method.describe()}, {self.handling.value}, {self.graph.value.upper()}"


def check_method(method: Any) -> Method:
    """Validate a transcription object."""
    if not isinstance(method, (Collocation, MultipleShooting)):
        raise ModelError(
            f"method must be Collocation(N=..., degree=...) or MultipleShooting(N=...); "
            f"got {method!r}"
        )
    return method
