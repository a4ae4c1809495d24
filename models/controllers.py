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
  ``e_R = vee(G R_d^T R - R^T R_d G) / 2`` and gravity cancellation.
"""

from __future__ import annotations

from collections.abc import Callable

import casadi as ca
import numpy as np

from workbench._types import ArrayLike
from workbench.errors import ModelError, ParameterError
from workbench.manifolds import S2, SO3, TS2, Rn, vee
from workbench.model import Model

__all__ = [
    "angular_velocity_feedback",
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
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{name} must be finite ({condition}); got {a.tolist()}")
    scale = max(float(np.max(np.abs(a))), 1e-300)
    asym = float(np.max(np.abs(a - a.T)))
    if asym > 1e-12 * scale:
        raise ParameterError(
            f"{name} must be symmetric positive definite ({condition}); got a non-symmetric "
            f"matrix (max |{name} - {name}^T| = {asym:.3g})"
        )
    eig = np.linalg.eigvalsh(a)
    if np.any(eig <= 0):
        raise ParameterError(
            f"{name} must be symmetric positive definite ({condition}); got eigenvalues "
            f"{np.array2string(eig, precision=6)}"
        )
    return a


def _require_factor(model: Model, name: str, kind: type, who: str) -> None:
    man = model.manifold
    if name not in man.names or not isinstance(man.factor(name), kind):
        raise ModelError(
            f"{who} needs a model with a {kind.__name__} state factor {name!r}; model "
            f"{model.name!r} has factors {man.names} ({man.describe()})"
        )


def _require_parameters(model: Model, names: tuple[str, ...], who: str) -> None:
    have = [p.name for p in model.parameters]
    missing = [n for n in names if n not in have]
    if missing:
        raise ModelError(
            f"{who} cancels gravity with the model parameters {list(names)}; model "
            f"{model.name!r} lacks {missing} (has {have})"
        )


def _require_inputs(model: Model, n: int, who: str) -> None:
    if model.n_inputs != n:
        raise ModelError(
            f"{who} returns {n} inputs; model {model.name!r} has {model.n_inputs} inputs"
        )


def _norm_c1(v):
    """``|v|_2`` written so that automatic differentiation is finite at ``v = 0``.

    ``sqrt(v . v)`` has the derivative ``0/0`` at 0; here the branch ``v = 0`` returns the
    constant 0 (casadi ``if_else`` does not propagate the other branch's NaN). In
    ``P w / (1 + |P w|)``, which is C^1 at 0 with Jacobian ``P``, this makes the graph's
    Jacobian at 0 exact.
    """
    s = ca.dot(v, v)
    return ca.if_else(s > 0, ca.sqrt(s), 0)


def _function(model: Model, name: str, build: Callable) -> ca.Function:
    """Wrap ``build(ctx) -> u`` into ``casadi.Function(name, [x, p], [u])``."""
    ctx = model.context()
    u = ca.vec(build(ctx))
    return ca.Function(name, [ctx.x, ctx.p], [u], ["x", "p"], ["u"])


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
    _require_factor(model, "omega", Rn, who)
    _require_inputs(model, 3, who)
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

    return _function(model, name, build)


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
    _require_factor(model, "q", TS2, who)
    _require_parameters(model, ("m", "l", "g"), who)
    _require_inputs(model, 3, who)
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

    return _function(model, "s2_pd", build)


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

    _require_factor(model, "R", SO3, who)
    _require_factor(model, "omega", Rn, who)
    _require_parameters(model, ("rho", "m", "g"), who)
    _require_inputs(model, 3, who)
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

    return _function(model, "so3_pd", build)
