"""The papers' feedback laws as casadi graphs ``u = k(x, p)`` of a model's stored state.

Every function here returns a ``casadi.Function`` with inputs ``x`` (the model's stored
ambient state) and ``p`` (the model's parameter vector, :attr:`Model.p`) and output ``u``,
so a controller can be put in the loop by :func:`workbench.simulate.simulate`, linearised
by automatic differentiation together with the model, and exported to C. Gains are
constants of the graph (validated here against the papers' conditions); model parameters
used for cancellation (``m``, ``g``, ``l``, ``rho``) are read from ``p``, so the
controller always cancels the model it is evaluated with.

* :func:`angular_velocity_feedback`, :func:`psi_feedback`: paper 001 (14),
  ``u = -Psi(omega)`` with ``Psi`` meeting (13);
* :func:`saturated_velocity_feedback`: paper 001 (34), ``u = -k P omega / (1 + |P omega|)``;
* :func:`s2_pd`: paper 002 Section II-A, geometric PD on S^2 with gravity cancellation;
* :func:`so3_pd`: paper 002 Section III-A, geometric PD on SO(3) with the attitude error
  ``e_R = vee(G R_d^T R - R^T R_d G) / 2`` and gravity cancellation;
* :func:`cart_inverted_feedback`: paper 003 (21) (with the erratum) and (26), the nonlinear
  stabilisation of the inverted spherical pendulum on a cart (n = 1), gains checked by
  :class:`CartGains`; :func:`cart_domain` is the domain D of (43).

Lyapunov functions (:class:`~workbench.lyapunov.Lyapunov`, derivatives from the graph):
:func:`velocity_feedback_lyapunov` (paper 001 (30); :func:`hanging_set_level` gives the
levels of H_eps (29) and N (33)) and :func:`cart_lyapunov` (paper 003 (25)). The chain
feedback (19) of paper 003 is :func:`workbench.lqr.geometric_feedback` (LQR gains through
the chart).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from workbench._types import ArrayLike
from workbench.errors import ModelError, ParameterError
from workbench.lyapunov import Lyapunov, state_function
from workbench.manifolds import S2, SO3, TS2, Rn, vee
from workbench.model import Context, Model, spd3

__all__ = [
    "CartGains",
    "angular_velocity_feedback",
    "cart_domain",
    "cart_inverted_feedback",
    "cart_lyapunov",
    "hanging_set_level",
    "velocity_feedback_lyapunov",
    "psi_feedback",
    "saturated_velocity_feedback",
    "s2_pd",
    "so3_pd",
    "E3",
]

E3 = np.array([0.0, 0.0, 1.0])


# ----------------------------------------------------------------------------------------
# validation helpers


def _positive_scalar(value: float, name: str, condition: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a positive number ({condition}); got {value!r}") \
            from exc
    if not np.isfinite(v) or v <= 0:
        raise ParameterError(f"{name} must be positive and finite ({condition}); got {v!r}")
    return v


def _spd(value: ArrayLike, name: str, condition: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a 3x3 matrix ({condition}); got {value!r}") from exc
    if a.shape != (3, 3):
        raise ParameterError(f"{name} must be a 3x3 matrix ({condition}); got shape {a.shape}")
    msg = spd3(a)
    if msg:
        raise ParameterError(f"{name} {msg.replace('; got', f' ({condition}); got', 1)}")
    return a


def _require(model: Model, who: str, *, factors: dict[str, type] | None = None,
             params: tuple[str, ...] = (), inputs: int | None = None) -> None:
    """Check that ``model`` has the state factors, parameters and inputs a law needs."""
    man, have = model.manifold, [p.name for p in model.parameters]
    for name, kind in (factors or {}).items():
        if name not in man.names or not isinstance(man.factor(name), kind):
            raise ModelError(f"{who} needs a model with a {kind.__name__} state factor "
                             f"{name!r}; model {model.name!r} has factors {man.names} "
                             f"({man.describe()})")
    missing = [n for n in params if n not in have]
    if missing:
        raise ModelError(f"{who} uses the model parameters {list(params)}; model "
                         f"{model.name!r} lacks {missing} (has {have})")
    if inputs is not None and model.n_inputs != inputs:
        raise ModelError(f"{who} returns {inputs} inputs; model {model.name!r} has "
                         f"{model.n_inputs} inputs")


def _norm_c1(v):
    """``|v|_2`` written so that automatic differentiation is finite at ``v = 0``.

    ``sqrt(v . v)`` has the derivative ``0/0`` at 0; here the branch ``v = 0`` returns the
    constant 0 (casadi ``if_else`` does not propagate the other branch's NaN). In
    ``P w / (1 + |P w|)``, which is C^1 at 0 with Jacobian ``P``, this makes the graph's
    Jacobian at 0 exact.
    """
    s = ca.dot(v, v)
    return ca.if_else(s > 0, ca.sqrt(s), 0)


# ----------------------------------------------------------------------------------------
# paper 001: angular-velocity feedback


def psi_feedback(
    model: Model,
    psi: Callable,
    *,
    check_samples: int = 256,
    check_radius: float = 1e3,
    seed: int = 0,
    name: str = "psi_feedback",
) -> ca.Function:
    """Angular-velocity feedback ``u = -Psi(omega)``, paper 001 (14), for any ``Psi``.

    Condition (13) asks that ``Psi'(0)`` be symmetric positive definite and that
    ``P(x) <= x^T Psi(x) <= alpha(|x|)`` with ``P`` positive definite and ``alpha`` of
    class K. The first part is checked exactly (``Psi'(0)`` from the graph by automatic
    differentiation); the second is necessary-checked on ``check_samples`` seeded points
    (``x^T Psi(x) > 0``, log-spread radii up to ``check_radius``), which can refute but
    not prove it.

    Parameters
    ----------
    model : Model
        A 3D pendulum model with a state factor ``omega`` (R^3) and 3 inputs
        (:func:`models.pendulum3d.full` or :func:`models.pendulum3d.reduced`).
    psi : callable
        ``psi(omega) -> casadi expression, shape=(3, 1)`` for a casadi ``omega`` of shape
        (3, 1); must use casadi operations only.
    check_samples : int
        Number of sampled points for the sign condition of (13); 0 skips it.
    check_radius : float
        Largest sampled ``|omega|``.
    seed : int
        Seed of the sample.
    name : str
        Name of the returned function.

    Returns
    -------
    casadi.Function
        ``(x, p) -> u``, ``x`` shape=(ambient_dim,), ``u`` shape=(3,).

    Raises
    ------
    ModelError
        The model has no ``omega`` factor or not 3 inputs, or ``psi`` is not casadi-expressible.
    ParameterError
        ``Psi(0) != 0``, ``Psi'(0)`` not symmetric positive definite, or a sample with
        ``x^T Psi(x) <= 0``.
    """
    who = "angular-velocity feedback (paper 001 (14))"
    _require(model, who, factors={"omega": Rn}, inputs=3)
    w = ca.SX.sym("w", 3)
    try:
        out = ca.vec(psi(w))
    except Exception as exc:  # noqa: BLE001 - any failure means "not casadi-expressible"
        raise ModelError(
            f"psi must map a casadi 3-vector to a casadi 3-vector using casadi operations; "
            f"calling it on a casadi SX symbol failed with {type(exc).__name__}: {exc}"
        ) from exc
    if out.shape != (3, 1):
        raise ModelError(f"psi(omega) must have shape (3, 1); got {out.shape}")
    f_psi = ca.Function("psi", [w], [out, ca.jacobian(out, w)])
    psi0, dpsi0 = (np.asarray(v) for v in f_psi(np.zeros(3)))
    if np.max(np.abs(psi0)) > 1e-12:
        raise ParameterError(
            f"Psi(0) must be 0 (paper 001 (13): the hanging equilibrium must stay an "
            f"equilibrium of u = -Psi(omega)); got Psi(0) = {psi0.ravel().tolist()}"
        )
    _spd(dpsi0, "Psi'(0)", "paper 001 (13): Psi'(0) symmetric positive definite")
    if check_samples:
        rng = np.random.default_rng(seed)
        dirs = rng.standard_normal((int(check_samples), 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        radii = np.exp(rng.uniform(np.log(1e-6), np.log(check_radius), int(check_samples)))
        pts = dirs * radii[:, None]
        vals = np.asarray(f_psi.map(int(check_samples))(pts.T)[0])
        inner = np.einsum("ij,ji->i", pts, vals)
        bad = np.flatnonzero(~(inner > 0))
        if bad.size:
            i = int(bad[0])
            raise ParameterError(
                f"psi violates paper 001 (13) (x^T Psi(x) must be positive definite): "
                f"x^T Psi(x) = {inner[i]:.6g} at x = {pts[i].tolist()} "
                f"({bad.size} of {check_samples} seeded samples)"
            )

    def build(ctx):
        return -f_psi(ctx["omega"])[0]

    return state_function(model, name, build)


def angular_velocity_feedback(model: Model, D: ArrayLike) -> ca.Function:
    """Linear angular-velocity feedback ``u = -D omega``, paper 001 (14) with ``Psi = D``.

    Parameters
    ----------
    model : Model
        A model with a state factor ``omega`` and 3 inputs (full or reduced 3D pendulum).
    D : array-like, shape=(3, 3)
        Damping gain, symmetric positive definite (paper 001 (13): ``Psi'(0) = D``).

    Returns
    -------
    casadi.Function
        ``(x, p) -> u``.

    Raises
    ------
    ParameterError
        ``D`` is not symmetric positive definite.
    """
    Dm = _spd(D, "D", "paper 001 (13): Psi'(0) = D must be symmetric positive definite")
    return psi_feedback(
        model, lambda w: ca.DM(Dm) @ w, check_samples=0, name="angular_velocity_feedback"
    )


def saturated_velocity_feedback(model: Model, P: ArrayLike, k: float) -> ca.Function:
    """Saturated angular-velocity feedback, paper 001 (34).

    ``u = -k P omega / (1 + |P omega|)``, which satisfies (13) and ``|u| <= k``.

    Parameters
    ----------
    model : Model
        A model with a state factor ``omega`` and 3 inputs.
    P : array-like, shape=(3, 3)
        Symmetric positive definite (paper 001 Section 7).
    k : float
        Saturation level ``|u|_2 <= k``, positive.

    Returns
    -------
    casadi.Function
        ``(x, p) -> u``.

    Raises
    ------
    ParameterError
        ``P`` not symmetric positive definite or ``k <= 0``.
    """
    cond = "paper 001 (34): P symmetric positive definite, k > 0"
    Pm = ca.DM(_spd(P, "P", cond))
    kv = _positive_scalar(k, "k", cond)

    def psi(w):
        Pw = Pm @ w
        return kv * Pw / (1 + _norm_c1(Pw))

    return psi_feedback(model, psi, check_samples=0, name="saturated_velocity_feedback")


# ----------------------------------------------------------------------------------------
# paper 002: geometric PD with cancellation


def s2_pd(model: Model, q_d: ArrayLike, k_q: float, k_w: float) -> ca.Function:
    """Geometric PD on S^2 with gravity cancellation, paper 002 Section II-A.

    ``u = m l^2 (-k_q q_d x q - k_w omega - (g/l) q x e3)``, giving the closed loop (1)-(2)
    ``omega-dot = -k_w omega - k_q q_d x q``, ``q-dot = omega x q``.

    Parameters
    ----------
    model : Model
        :func:`models.spherical.spherical_pendulum` (a TS2 factor ``q`` storing
        ``(q, omega)``; parameters ``m``, ``l``, ``g``; 3 inputs).
    q_d : array-like, shape=(3,)
        Desired direction, a unit vector (checked, not normalised).
    k_q, k_w : float
        Positive gains (paper 002 Section II-A).

    Returns
    -------
    casadi.Function
        ``(x, p) -> u``.

    Raises
    ------
    ManifoldError
        ``q_d`` is not a unit vector.
    ParameterError
        A gain is not positive.
    """
    who = "geometric PD on S^2 (paper 002 Sec. II-A)"
    _require(model, who, factors={"q": TS2}, params=("m", "l", "g"), inputs=3)
    qd = S2().check(q_d, name="q_d")
    cond = "paper 002 Sec. II-A: positive constants k_q, k_omega"
    kq = _positive_scalar(k_q, "k_q", cond)
    kw = _positive_scalar(k_w, "k_w", cond)

    def build(ctx):
        x = ctx["q"]
        q, w = x[0:3], x[3:6]
        m, l_, g = ctx["m"], ctx["l"], ctx["g"]
        return m * l_**2 * (
            -kq * ca.cross(ca.DM(qd), q) - kw * w - (g / l_) * ca.cross(q, ca.DM(E3))
        )

    return state_function(model, "s2_pd", build)


def _diag_gain(G: ArrayLike) -> np.ndarray:
    cond = "paper 002 Sec. III-A: G = diag[g1, g2, g3] with g1, g2, g3 > 0"
    try:
        a = np.asarray(G, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"G must be numeric ({cond}); got {G!r}") from exc
    if a.shape == (3, 3):
        off = a - np.diag(np.diag(a))
        if np.any(off != 0):
            raise ParameterError(
                f"G must be diagonal ({cond}); got off-diagonal entries up to "
                f"{np.max(np.abs(off)):.3g}"
            )
        a = np.diag(a)
    if a.shape != (3,):
        raise ParameterError(f"G must be a 3-vector or a 3x3 diagonal matrix ({cond}); "
                             f"got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise ParameterError(f"G must have positive finite diagonal ({cond}); got {a.tolist()}")
    return a


def so3_pd(
    model: Model, R_d: ArrayLike, k_R: float, k_Omega: float, G: ArrayLike
) -> ca.Function:
    """Geometric PD on SO(3) with gravity cancellation, paper 002 Section III-A.

    ``u = -k_R e_R - k_Omega Omega - m g rho x R^T e3`` with the attitude error vector
    ``e_R = vee(G R_d^T R - R^T R_d G) / 2`` of the error function
    ``Psi = tr[(I - R_d^T R) G] / 2``; the closed loop is (13)-(14),
    ``J Omega-dot = J Omega x Omega - k_R e_R - k_Omega Omega`` (the paper's (13) reads
    ``-Omega x J Omega``, the same term). Its equilibria are ``(R_d, 0)`` (stable) and
    ``(R_d exp(pi hat(e_i)), 0)``, ``i = 1, 2, 3`` (saddles when the ``g_i`` are distinct).

    Parameters
    ----------
    model : Model
        :func:`models.pendulum3d.full` (factors ``R`` (SO3) and ``omega``; parameters
        ``rho``, ``m``, ``g``; 3 inputs).
    R_d : array-like, shape=(3, 3)
        Desired attitude, a rotation matrix (checked, not projected).
    k_R, k_Omega : float
        Positive gains.
    G : array-like, shape=(3,) or (3, 3)
        The diagonal ``(g1, g2, g3)`` of ``G``, all positive (or ``G`` itself, diagonal).

    Returns
    -------
    casadi.Function
        ``(x, p) -> u``.

    Raises
    ------
    ManifoldError
        ``R_d`` is not a rotation.
    ParameterError
        A gain is not positive or ``G`` is not diagonal positive.
    """
    who = "geometric PD on SO(3) (paper 002 Sec. III-A)"

    _require(model, who, factors={"R": SO3, "omega": Rn}, params=("rho", "m", "g"), inputs=3)
    Rd = ca.DM(SO3.matrix(SO3().check(R_d, name="R_d")))
    cond = "paper 002 Sec. III-A: positive constants k_R, k_Omega"
    kR = _positive_scalar(k_R, "k_R", cond)
    kW = _positive_scalar(k_Omega, "k_Omega", cond)
    Gm = ca.DM(np.diag(_diag_gain(G)))

    def build(ctx):
        R, w = SO3.matrix(ctx["R"]), ctx["omega"]
        e_R = vee(Gm @ Rd.T @ R - R.T @ Rd @ Gm) / 2
        gravity = ctx["m"] * ctx["g"] * ca.cross(ctx["rho"], R.T @ ca.DM(E3))
        return -kR * e_R - kW * w - gravity

    return state_function(model, "so3_pd", build)


# ----------------------------------------------------------------------------------------
# paper 003: nonlinear controller for the inverted spherical pendulum on a cart (n = 1)

C2 = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])  # C = [e1, e2], R^2 -> R^3


@dataclass(frozen=True)
class CartGains:
    """Gains of paper 003 Proposition 5, checked against its conditions.

    Attributes
    ----------
    k_y, k_ydot, k_w, k_q : float
        Positive constants with ``k_q > 1 + k_w``.
    """

    k_y: float
    k_ydot: float
    k_w: float
    k_q: float

    def __post_init__(self) -> None:
        cond = "paper 003 Prop. 5: positive constants k_y, k_ydot, k_q, k_w with k_q > 1 + k_w"
        for name in ("k_y", "k_ydot", "k_w", "k_q"):
            object.__setattr__(self, name, _positive_scalar(getattr(self, name), name, cond))
        if not self.k_q > 1 + self.k_w:
            raise ParameterError(
                f"k_q must exceed 1 + k_w ({cond}; it makes V of (25) positive definite on "
                f"the domain D of (43)); got k_q = {self.k_q}, 1 + k_w = {1 + self.k_w}"
            )

    @property
    def s(self) -> float:
        """``sqrt((1 + k_w) / k_q)``: ``D = {q1 . e3 < -s}`` of (43)."""
        return float(np.sqrt((1 + self.k_w) / self.k_q))


def _cart_terms(ctx: Context, gains: CartGains) -> dict[str, Any]:
    """Build the output y (24), y-dot (44) and the pieces of (21), (26) on the n = 1 chain model."""
    Cd, e3 = ca.DM(C2), ca.DM(E3)
    x, v, link = ctx["x"], ctx["v"], ctx["link1"]
    q, w = link[0:3], link[3:6]
    l1, m1 = ctx["lengths"][0], ctx["masses"][0]
    qh2 = ca.skew(q) @ ca.skew(q)
    y = x + gains.k_q * l1 * (Cd.T @ q)
    ydot = v - gains.k_q * l1 * (Cd.T @ ca.cross(q, w))
    return {"C": Cd, "e3": e3, "x": x, "v": v, "q": q, "w": w, "l1": l1, "m1": m1,
            "qh2": qh2, "y": y, "ydot": ydot, "w2": ca.dot(w, w)}


def _require_cart(model: Model, who: str) -> None:
    _require(model, who, factors={"x": Rn, "v": Rn, "link1": TS2},
             params=("m", "masses", "lengths", "g"), inputs=2)
    if "link2" in model.manifold.names:
        raise ModelError(f"{who} is for one link (n = 1); model {model.name!r} has "
                         f"factors {model.manifold.names}")


def cart_inverted_feedback(
    model: Model, *, k_y: float, k_ydot: float, k_w: float, k_q: float
) -> ca.Function:
    """Nonlinear stabilisation of the inverted spherical pendulum on a cart, paper 003.

    The transformed input (26)
    ``mu = ((1 + k_w) I + k_q C^T hat(q)^2 C)^-1 (-k_y y - k_ydot y-dot
    + k_q g C^T hat(q)^2 e3 + k_q l |omega|^2 C^T q)`` with ``y = x + k_q l C^T q`` (24),
    put through the feedback transformation (21) with the erratum (no inverse):
    ``u = ((m + m1) I + m1 C^T hat(q)^2 C) mu - m1 g C^T hat(q)^2 e3
    - m1 l |omega|^2 C^T q``. The matrix inverted in (26) has the eigenvalues
    ``1 + k_w - k_q`` and ``1 + k_w - k_q (q . e3)^2``: it is singular on the boundary of
    the domain ``D = {q . e3 < -sqrt((1 + k_w)/k_q)}`` of (43) and invertible inside.

    Parameters
    ----------
    model : Model
        :func:`models.chain_cart.chain_cart` with ``n = 1``.
    k_y, k_ydot, k_w, k_q : float
        Positive gains with ``k_q > 1 + k_w`` (Prop. 5).

    Returns
    -------
    casadi.Function
        ``(x, p) -> u``, ``u`` shape=(2,).

    Raises
    ------
    ParameterError
        A gain breaks the conditions of Prop. 5.
    """
    who = "nonlinear cart controller (paper 003 (21), (26))"
    _require_cart(model, who)
    G = CartGains(k_y, k_ydot, k_w, k_q)

    def build(ctx: Context) -> ca.SX:
        t = _cart_terms(ctx, G)
        Cd, e3, q, qh2, l1, m1, g = t["C"], t["e3"], t["q"], t["qh2"], t["l1"], t["m1"], \
            ctx["g"]
        A = (1 + G.k_w) * ca.DM.eye(2) + G.k_q * (Cd.T @ qh2 @ Cd)
        b = (-G.k_y * t["y"] - G.k_ydot * t["ydot"] + G.k_q * g * (Cd.T @ qh2 @ e3)
             + G.k_q * l1 * t["w2"] * (Cd.T @ q))
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        mu = ca.vertcat(A[1, 1] * b[0] - A[0, 1] * b[1], A[0, 0] * b[1] - A[1, 0] * b[0]) / det
        M = (ctx["m"] + m1) * ca.DM.eye(2) + m1 * (Cd.T @ qh2 @ Cd)
        return M @ mu - m1 * g * (Cd.T @ qh2 @ e3) - m1 * l1 * t["w2"] * (Cd.T @ q)

    return state_function(model, "cart_inverted_feedback", build)


def cart_domain(model: Model, *, k_w: float, k_q: float) -> ca.Function:
    """``b(x, p) = q1 . e3 + sqrt((1 + k_w)/k_q)``: the domain (43) is ``D = {b < 0}``.

    Parameters
    ----------
    model : Model
        :func:`models.chain_cart.chain_cart` with ``n = 1``.
    k_w, k_q : float
        Gains of Prop. 5 (``k_q > 1 + k_w``).

    Returns
    -------
    casadi.Function
        ``(x, p) -> b``.
    """
    _require_cart(model, "domain D of paper 003 (43)")
    s = CartGains(1.0, 1.0, k_w, k_q).s
    return state_function(model, "cart_domain_D", lambda ctx: ctx["link1"][2] + s, out="b")


# ----------------------------------------------------------------------------------------
# Lyapunov functions of the papers (their derivatives come from the graph)


def velocity_feedback_lyapunov(model: Model) -> Lyapunov:
    """Paper 001 (30): ``V = (omega^T J omega + m g |rho| |Gamma - Gamma_h|^2) / 2``.

    ``Gamma_h = rho / |rho|``; ``Gamma`` is the factor ``Gamma`` of the reduced model or
    ``R^T e3`` of the full one. Along ``u = -Psi(omega)`` the paper finds
    ``V-dot = -omega^T Psi(omega)``; here ``V-dot`` comes from the graph.

    Parameters
    ----------
    model : Model
        :func:`models.pendulum3d.full` or :func:`models.pendulum3d.reduced`.

    Returns
    -------
    Lyapunov
    """
    _require(model, "Lyapunov function (30) of paper 001", factors={"omega": Rn},
             params=("J", "rho", "m", "g"))
    names = model.manifold.names
    if "Gamma" not in names and "R" not in names:
        raise ModelError(f"Lyapunov function (30) needs a factor 'Gamma' (S2) or 'R' (SO3); "
                         f"model {model.name!r} has {names}")
    if not np.linalg.norm(model.values["rho"]) > 0:
        raise ParameterError("rho must be nonzero for (30) (Gamma_h = rho/|rho|); got rho = 0 "
                             "(the balanced case has no hanging equilibrium)")

    def V(ctx: Context) -> Any:
        gam = ctx["Gamma"] if "Gamma" in names else SO3.matrix(ctx["R"]).T @ ca.DM(E3)
        rho, w = ctx["rho"], ctx["omega"]
        nrho = ca.norm_2(rho)
        d = gam - rho / nrho
        return 0.5 * (ca.dot(w, ctx["J"] @ w) + ctx["m"] * ctx["g"] * nrho * ca.dot(d, d))

    return Lyapunov(model, V, name="V30", description="paper 001 (30)",
                    equation=r"V = \tfrac12[\omega^TJ\omega + mg\|\rho\|\|\Gamma-\Gamma_h\|^2]")


def hanging_set_level(model: Model, *, eps: float = 0.0) -> float:
    """Level ``2 m g |rho| - eps`` of the sets ``H_eps`` (29) and ``N = H_0`` (33).

    Parameters
    ----------
    model : Model
        A 3D pendulum model (its current ``m``, ``g``, ``rho``).
    eps : float
        ``0 <= eps < 2 m g |rho|``; 0 gives ``N``.

    Returns
    -------
    float
    """
    top = 2 * float(model.values["m"] * model.values["g"] * np.linalg.norm(model.values["rho"]))
    if not (0 <= eps < top):
        raise ParameterError(f"eps must lie in [0, 2 m g |rho|) = [0, {top:.6g}) (paper 001 "
                             f"Lemma 5); got {eps!r}")
    return top - float(eps)


def cart_lyapunov(model: Model, *, k_y: float, k_ydot: float, k_w: float, k_q: float
                  ) -> Lyapunov:
    """Paper 003 (25): ``V = k_y |y|^2 / 2 + |y-dot|^2 / 2 + k_w W``.

    ``W = -k_q l^2 |omega|^2 / 2 + k_q g l (1 + q . e3) + |x-dot|^2 / 2``, ``y`` of (24).
    Along (21), (26) the paper finds ``V-dot = -k_ydot |y-dot|^2``; here ``V-dot`` comes
    from the graph.

    Parameters
    ----------
    model : Model
        :func:`models.chain_cart.chain_cart` with ``n = 1``.
    k_y, k_ydot, k_w, k_q : float
        Gains of Prop. 5.

    Returns
    -------
    Lyapunov
    """
    _require_cart(model, "control Lyapunov function (25) of paper 003")
    G = CartGains(k_y, k_ydot, k_w, k_q)
    core = state_function(model, "V25", lambda ctx: _cart_V(ctx, G), out="V", record=False)
    return Lyapunov(model, lambda ctx: core(ctx.x, ctx.p), name="V25",
                    description="paper 003 (25)",
                    equation=r"\mathcal V = \tfrac12 k_y\|y\|^2 + \tfrac12\|\dot y\|^2 + k_w"
                    r"\mathcal W")


def _cart_V(ctx: Context, G: CartGains) -> ca.SX:
    t = _cart_terms(ctx, G)
    W = (-0.5 * G.k_q * t["l1"] ** 2 * t["w2"] + G.k_q * ctx["g"] * t["l1"] * (1 + t["q"][2])
         + 0.5 * ca.dot(t["v"], t["v"]))
    return 0.5 * G.k_y * ca.dot(t["y"], t["y"]) + 0.5 * ca.dot(t["ydot"], t["ydot"]) + G.k_w * W
