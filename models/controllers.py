"""The papers' feedback laws as casadi graphs ``u = k(x, p)`` of a model's stored state.

Every function here returns a ``casadi.Function`` with inputs ``x`` (the model's stored
ambient state) and ``p`` (the model's parameter vector, :attr:`Model.p`) and output ``u``,
so a controller can be put in the loop by :func:`workbench.simulation._simulate.simulate`,
linearised by automatic differentiation together with the model, and exported to C. Gains are
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

The cart laws live in :mod:`models.cart_feedback`. Lyapunov functions
(:class:`~workbench.control._lyapunov.Lyapunov`, derivatives from the graph) live in
:mod:`models.lyapunov_functions`: :func:`velocity_feedback_lyapunov` (paper 001 (30);
:func:`hanging_set_level` gives the levels of H_eps (29) and N (33)) and
:func:`cart_lyapunov` (paper 003 (25)). All are re-exported here. The chain
feedback (19) of paper 003 is :func:`workbench.linear._lqr.geometric_feedback` (LQR gains through
the chart).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from models._checks import E3, positive_scalar, require_model, spd_matrix
from models.cart_feedback import CartGains, cart_domain, cart_inverted_feedback, cart_inverted_law
from models.lyapunov_functions import (
    cart_lyapunov,
    hanging_set_level,
    velocity_feedback_lyapunov,
)
from workbench.control import state_function
from workbench.core import Context, Model, validate
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import S2, SO3, TS2, Rn, vee
from workbench.core.types import ArrayLike

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
    "s2_pd_law",
    "saturated_velocity_law",
    "so3_pd",
    "so3_pd_law",
    "cart_inverted_law",
    "E3",
]


NORM_FLOOR = 1e-40
"""Added under the square root of ``1 + |P omega|`` in (34): see :func:`_one_plus_norm`."""


def _one_plus_norm(v):
    """``1 + |v|_2`` without a branch, exact to the last bit, differentiable at ``v = 0``.

    Written ``1 + sqrt(v . v + 1e-40)``. The floor never changes the double ``1 + |v|``
    by more than a rounding tie could (it changes ``v . v`` only below 1e-24, where
    ``sqrt`` is below 1e-12 and moves by at most 5e-25, far under the half-ulp 1.1e-16 of
    1), and at ``v = 0`` it gives ``1 + 1e-20 = 1``. Unlike ``sqrt(v . v)``, whose
    derivative is ``0/0`` at 0, its derivative there is ``0 / 2e-20 = 0`` (second
    derivatives stay finite too): so ``P w / (1 + |P w|)``, C^1 at 0 with Jacobian ``P``,
    keeps an exact Jacobian at rest without an ``if_else`` on a zero norm, and its C code
    has no branch.
    """
    return 1 + ca.sqrt(ca.dot(v, v) + NORM_FLOOR)


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
    require_model(model, who, factors={"omega": Rn}, inputs=3)
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
    spd_matrix(dpsi0, "Psi'(0)", "paper 001 (13): Psi'(0) symmetric positive definite")
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


@validate.arguments(error=ModelError, model=validate.instance(Model, "a workbench Model"))
def angular_velocity_feedback(model: Model, *, D: ArrayLike) -> ca.Function:
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
    Dm = spd_matrix(D, "D", "paper 001 (13): Psi'(0) = D must be symmetric positive definite")
    return psi_feedback(
        model, lambda w: ca.DM(Dm) @ w, check_samples=0, name="angular_velocity_feedback"
    )


@validate.arguments(error=ModelError, model=validate.instance(Model, "a workbench Model"))
def saturated_velocity_feedback(model: Model, *, P: ArrayLike, k: float) -> ca.Function:
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
    Pm = ca.DM(spd_matrix(P, "P", cond))
    kv = positive_scalar(k, "k", cond)
    # psi_feedback checks (13) on Psi; the function is the law itself, whose sign sits in
    # the one factor -k / (1 + |P w|) (no negation of each component)
    psi_feedback(model, lambda w: -_saturated_u(w, Pm, kv), check_samples=0)
    return state_function(model, "saturated_velocity_feedback",
                          lambda ctx: saturated_velocity_law(ctx, P=Pm, k=kv))


def _saturated_u(w, P, k):
    """``u = -k P omega / (1 + |P omega|)`` of paper 001 (34).

    One division (the factor ``-k / (1 + |P omega|)``, then three products) and no branch
    (:func:`_one_plus_norm`): the exported C is within 1.2x of the law written by hand.
    """
    Pw = P @ w
    return (-k / _one_plus_norm(Pw)) * Pw


def saturated_velocity_law(ctx: Context, *, P: Any, k: Any) -> Any:
    """The law (34) ``u = -k P omega / (1 + |P omega|)`` as an expression, gains unchecked.

    The one definition used by :func:`saturated_velocity_feedback` (with validated numeric
    gains) and by exports whose gains are run-time inputs (casadi symbols).

    Parameters
    ----------
    ctx : Context
        Symbols of a model with a state factor ``omega``.
    P : casadi matrix, shape=(3, 3)
        Gain (numeric ``DM`` or symbolic).
    k : casadi scalar or float
        Saturation level.

    Returns
    -------
    casadi expression, shape=(3, 1)
    """
    return _saturated_u(ctx["omega"], P, k)


# ----------------------------------------------------------------------------------------
# paper 002: geometric PD with cancellation


@validate.arguments(error=ModelError, model=validate.instance(Model, "a workbench Model"))
def s2_pd(model: Model, q_d: ArrayLike, *, k_q: float, k_w: float) -> ca.Function:
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
    require_model(model, who, factors={"q": TS2}, params=("m", "l", "g"), inputs=3)
    qd = S2().check(q_d, name="q_d")
    cond = "paper 002 Sec. II-A: positive constants k_q, k_omega"
    kq = positive_scalar(k_q, "k_q", cond)
    kw = positive_scalar(k_w, "k_w", cond)

    return state_function(model, "s2_pd",
                          lambda ctx: s2_pd_law(ctx, q_d=ca.DM(qd), k_q=kq, k_w=kw))


def s2_pd_law(ctx: Context, *, q_d: Any, k_q: Any, k_w: Any) -> Any:
    """The PD law of paper 002 Section II-A as an expression, gains unchecked.

    ``u = m l^2 (-k_q q_d x q - k_w omega - (g/l) q x e3)``: the one definition used by
    :func:`s2_pd` (validated numeric gains) and by exports with run-time gains.

    Parameters
    ----------
    ctx : Context
        Symbols of the spherical pendulum (factor ``q`` storing ``(q, omega)``).
    q_d : casadi vector, shape=(3, 1)
        Desired direction (numeric ``DM`` or symbolic).
    k_q, k_w : casadi scalar or float
        Gains.

    Returns
    -------
    casadi expression, shape=(3, 1)
    """
    x = ctx["q"]
    q, w = x[0:3], x[3:6]
    m, l_, g = ctx["m"], ctx["l"], ctx["g"]
    return m * l_**2 * (-k_q * ca.cross(q_d, q) - k_w * w - (g / l_) * ca.cross(q, ca.DM(E3)))


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


@validate.arguments(error=ModelError, model=validate.instance(Model, "a workbench Model"),
                    G=validate.array)
def so3_pd(
    model: Model, R_d: ArrayLike, *, k_R: float, k_Omega: float, G: ArrayLike
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

    require_model(model, who, factors={"R": SO3, "omega": Rn}, params=("rho", "m", "g"), inputs=3)
    Rd = ca.DM(SO3.matrix(SO3().check(R_d, name="R_d")))
    cond = "paper 002 Sec. III-A: positive constants k_R, k_Omega"
    kR = positive_scalar(k_R, "k_R", cond)
    kW = positive_scalar(k_Omega, "k_Omega", cond)
    Gv = ca.DM(_diag_gain(G))
    return state_function(model, "so3_pd",
                          lambda ctx: so3_pd_law(ctx, R_d=Rd, k_R=kR, k_Omega=kW, G=Gv))


def so3_pd_law(ctx: Context, *, R_d: Any, k_R: Any, k_Omega: Any, G: Any) -> Any:
    """The PD law of paper 002 Section III-A as an expression, gains unchecked.

    ``u = -k_R e_R - k_Omega Omega - m g rho x R^T e3``,
    ``e_R = vee(G R_d^T R - R^T R_d G) / 2``: the one definition used by :func:`so3_pd`
    (validated numeric gains) and by exports with run-time gains.

    Parameters
    ----------
    ctx : Context
        Symbols of the full 3D pendulum (factors ``R``, ``omega``).
    R_d : casadi matrix, shape=(3, 3)
        Desired attitude (numeric ``DM`` or symbolic).
    k_R, k_Omega : casadi scalar or float
        Gains.
    G : casadi vector, shape=(3, 1)
        The diagonal of ``G``.

    Returns
    -------
    casadi expression, shape=(3, 1)
    """
    R, w = SO3.matrix(ctx["R"]), ctx["omega"]
    Gm = ca.diag(G)
    e_R = vee(Gm @ R_d.T @ R - R.T @ R_d @ Gm) / 2
    gravity = ctx["m"] * ctx["g"] * ca.cross(ctx["rho"], R.T @ ca.DM(E3))
    return -k_R * e_R - k_Omega * w - gravity
