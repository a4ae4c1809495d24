"""The 3D pendulum and its reduced models (paper 000; paper 001 (1)-(2) with control).

A rigid body on a fixed frictionless pivot under uniform gravity ``g e3`` (``e3`` points
down, along gravity), with inertia ``J`` about the pivot (any symmetric positive-definite
matrix, not only a diagonal one), centre of mass at ``rho`` in the body frame, mass ``m``,
and a body-fixed control moment ``u``:

* :func:`full` on TSO(3) = SO(3) x R^3, state ``(R, omega)``: (3.1)-(3.2), derived from the
  Lagrangian by :mod:`workbench.mechanics` (the printed form is the independent check
  :func:`models.paper_forms.pendulum3d_full_printed`);
* :func:`reduced` (Lagrange-Poincare) on S^2 x R^3, state ``(Gamma, omega)``: (4.3)-(4.4);
* :func:`routh` (Lagrange-Routh) on TS^2 for a momentum value ``mu``, state
  ``(Gamma, Gamma-dot)``: (5.7)-(5.9); with :func:`routh_reconstruction` and
  :func:`reconstruct` for Prop. 17;
* the special cases of Section 4.1: :func:`spinning_top`, :func:`spherical` (on
  S^2 x R^2) and :func:`planar` (on S^1 x R, the circle as a unit 2-vector, no angle).

Invariants: energy ``E`` and vertical angular momentum ``h`` (Prop. 1, 8); the Routh
energy (5.16).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import casadi as ca
import numpy as np

from workbench import mechanics
from workbench.control import as_states, state_function
from workbench.core import Context, Model, Parameter, finite, positive, spd3, validate
from workbench.core.errors import ModelError, ParameterError
from workbench.core.manifolds import S1, S2, SO3, TS2, ProductManifold, Rn, hat, so3_exp
from workbench.core.types import ArrayLike

__all__ = [
    "phase_density",
    "full",
    "reduced",
    "routh",
    "routh_reconstruction",
    "reconstruct",
    "spinning_top",
    "spherical",
    "planar",
    "PARAMETERS",
    "E3",
]

E3 = np.array([0.0, 0.0, 1.0])

PARAMETERS = (
    Parameter("J", (3, 3), "inertia about the pivot, body frame [kg m^2]", spd3),
    Parameter("rho", (3,), "pivot to centre of mass, body frame [m]", finite),
    Parameter("m", (), "mass [kg]", positive),
    Parameter("g", (), "gravitational acceleration [m/s^2]", positive),
)


# the builders refuse complex, bool, str, None and NaN before any conversion (never truncated)
_ARRAY = validate.parameter(validate.array)
_SCALAR = validate.parameter(validate.array, shape=())


def _values(J: ArrayLike, rho: ArrayLike, m: float, g: float) -> dict[str, ArrayLike]:
    try:
        Jm = np.asarray(J, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(
            f"parameter 'J' (inertia about the pivot) must be a numeric 3x3 matrix; got {J!r}"
        ) from exc
    if Jm.shape == (3,):
        raise ParameterError(
            "parameter 'J' (inertia about the pivot) must be a 3x3 matrix; got a 3-vector "
            "(pass np.diag(J) for principal moments)"
        )
    return {"J": Jm, "rho": rho, "m": m, "g": g}


def _euler(ctx: Context, gamma: ca.SX, omega: ca.SX) -> ca.SX:
    """J^-1 (J w x w + m g rho x Gamma + u): (3.1) / (4.3) with the control moment."""
    J, rho, m, g = ctx["J"], ctx["rho"], ctx["m"], ctx["g"]
    moment = ca.cross(J @ omega, omega) + m * g * ca.cross(rho, gamma) + ctx.u
    return ca.solve(J, moment)


def _energy(ctx: Context, gamma: ca.SX, omega: ca.SX) -> ca.SX:
    return 0.5 * ca.dot(omega, ctx["J"] @ omega) - ctx["m"] * ctx["g"] * ca.dot(ctx["rho"], gamma)


@validate.arguments(J=_ARRAY, rho=_ARRAY, m=_SCALAR, g=_SCALAR)
def full(
    *, J: ArrayLike, rho: ArrayLike, m: float = 1.0, g: float = 9.81
) -> Model:
    """The full 3D pendulum on TSO(3), paper 000 (3.1)-(3.2), paper 001 (1)-(2).

    Parameters
    ----------
    J : array-like, shape=(3, 3)
        Inertia about the pivot in the body frame, symmetric positive definite.
    rho : array-like, shape=(3,)
        Vector from the pivot to the centre of mass in the body frame [m].
    m : float
        Mass [kg], positive.
    g : float
        Gravitational acceleration [m/s^2], positive.

    Returns
    -------
    Model
        State ``R`` (SO3, 9 stored numbers) and ``omega`` (R^3); input ``u``, the body
        control moment (R^3); invariants ``energy`` and ``h`` (vertical angular momentum,
        conserved when ``u = 0``).
    """
    vals = _values(J, rho, m, g)
    s = mechanics.System("pendulum3d_full")
    body = s.so3("R", velocity="omega")
    pars = {p.name: s.parameter(p.name, vals[p.name], p.description, check=p.check,
                               shape=p.shape) for p in PARAMETERS}
    s.rigid_body(pars["m"], pars["J"], body, com=pars["rho"], inertia_about="origin",
                 name="body")
    s.gravity(pars["g"], direction=E3)
    s.moment(body, s.input(3, "body-fixed control moment u [N m]"))
    s.momentum("h", rotate=E3)
    return s.model(
        description="3D pendulum on TSO(3) (paper 000 (3.1)-(3.2); paper 001 (1)-(2); derived "
        "from its Lagrangian by workbench.mechanics)",
        equations=(
            r"L = \tfrac12\omega^T J\omega + mg\,\rho^T R^T e_3,\quad \dot R = R\hat\omega"
            r"\quad (3.2)",
            r"J\dot\omega = J\omega\times\omega + mg\,\rho\times R^T e_3 + u \quad (3.1)"
            r"\text{ (Euler-Poincare, derived)}",
            r"E = \tfrac12\omega^T J\omega - mg\,\rho^T R^T e_3,\; h = \omega^T J R^T e_3"
            r"\quad \text{(Prop. 1)}",
        ),
        input_description="body-fixed control moment u [N m]",
    )


@validate.arguments(J=_ARRAY, rho=_ARRAY, m=_SCALAR, g=_SCALAR)
def reduced(
    *, J: ArrayLike, rho: ArrayLike, m: float = 1.0, g: float = 9.81
) -> Model:
    """The Lagrange-Poincare reduced 3D pendulum on S^2 x R^3, paper 000 (4.3)-(4.4).

    Parameters
    ----------
    J, rho, m, g
        As in :func:`full`.

    Returns
    -------
    Model
        State ``Gamma = R^T e3`` (S2) and ``omega`` (R^3); input ``u`` (body moment);
        invariants ``energy`` (4.6) and ``h``.
    """

    def field(ctx: Context) -> ca.SX:
        gam, w = ctx["Gamma"], ctx["omega"]
        return ca.vertcat(ca.cross(gam, w), _euler(ctx, gam, w))

    return Model(
        name="pendulum3d_reduced",
        manifold=ProductManifold([("Gamma", S2()), ("omega", Rn(3))]),
        n_inputs=3,
        parameters=PARAMETERS,
        values=_values(J, rho, m, g),
        vector_field=field,
        invariants={
            "energy": lambda ctx: _energy(ctx, ctx["Gamma"], ctx["omega"]),
            "h": lambda ctx: ca.dot(ctx["omega"], ctx["J"] @ ctx["Gamma"]),
        },
        description="Lagrange-Poincare reduced 3D pendulum on S^2 x R^3 (paper 000 (4.3)-(4.4))",
        equations=(
            r"J\dot\omega = J\omega\times\omega + mg\,\rho\times\Gamma + u \quad (4.3)",
            r"\dot\Gamma = \Gamma\times\omega \quad (4.4)",
        ),
        input_description="body-fixed control moment u [N m]",
    )


ROUTH_PARAMETERS = (*PARAMETERS, Parameter("mu", (), "vertical angular momentum [kg m^2/s]"))


def _routh_terms(ctx: Context) -> dict[str, ca.SX]:
    """b, nu, c and omega_hor of (5.9), (5.11) at the symbolic state."""
    J, mu = ctx["J"], ctx["mu"]
    x = ctx["Gamma"]
    gam, gdot = x[0:3], x[3:6]
    JG = J @ gam
    gJg = ca.dot(gam, JG)
    gxg = ca.cross(gdot, gam)  # Gamma-dot x Gamma
    b = ca.dot(JG, gxg) / gJg
    nu = mu / gJg
    c = nu * (ca.trace(J) - 2 * ca.dot(JG, JG) / gJg)
    return {"gam": gam, "gdot": gdot, "JG": JG, "gxg": gxg, "b": b, "nu": nu, "c": c,
            "omega_hor": gxg - b * gam}


@validate.arguments(J=_ARRAY, rho=_ARRAY, m=_SCALAR, g=_SCALAR, mu=_SCALAR)
def routh(
    *, J: ArrayLike, rho: ArrayLike, mu: float, m: float = 1.0, g: float = 9.81
) -> Model:
    """The Lagrange-Routh reduced 3D pendulum on TS^2, paper 000 (5.7)-(5.9).

    Parameters
    ----------
    J, rho, m, g
        As in :func:`full`.
    mu : float
        Value of the momentum map (vertical angular momentum, (5.1)).

    Returns
    -------
    Model
        State ``Gamma``, a TS2 factor storing ``(Gamma, Gamma-dot)``; no input (a body
        moment would change ``mu``); invariant ``energy`` (5.16).
    """

    def field(ctx: Context) -> ca.SX:
        t = _routh_terms(ctx)
        J, rho, m, g = ctx["J"], ctx["rho"], ctx["m"], ctx["g"]
        gam, gdot, b, nu, c = t["gam"], t["gdot"], t["b"], t["nu"], t["c"]
        inner = (
            ca.cross(J @ t["gxg"] - b * t["JG"], t["gxg"] - b * gam)
            + nu**2 * ca.cross(t["JG"], gam)
            - m * g * ca.cross(gam, rho)
            - c * gdot
        )
        sigma = b * gdot + ca.solve(J, inner)
        gddot = -ca.dot(gdot, gdot) * gam + ca.cross(gam, sigma)
        return ca.vertcat(gdot, gddot)

    def energy(ctx: Context) -> ca.SX:
        t = _routh_terms(ctx)
        w = t["omega_hor"] + t["nu"] * t["gam"]  # (5.14): omega = omega_hor + nu Gamma
        return 0.5 * ca.dot(w, ctx["J"] @ w) - ctx["m"] * ctx["g"] * ca.dot(ctx["rho"], t["gam"])

    return Model(
        name="pendulum3d_routh",
        manifold=ProductManifold([("Gamma", TS2())]),
        n_inputs=0,
        parameters=ROUTH_PARAMETERS,
        values={**_values(J, rho, m, g), "mu": mu},
        vector_field=field,
        invariants={"energy": energy},
        description="Lagrange-Routh reduced 3D pendulum on TS^2 (paper 000 (5.7)-(5.9))",
        equations=(
            r"\ddot\Gamma = -\|\dot\Gamma\|^2\Gamma + \Gamma\times\Sigma \quad (5.7)",
            r"\Sigma = b\dot\Gamma + J^{-1}[(J(\dot\Gamma\times\Gamma) - bJ\Gamma)\times"
            r"(\dot\Gamma\times\Gamma - b\Gamma) + \nu^2 J\Gamma\times\Gamma - mg\Gamma\times\rho"
            r" - c\dot\Gamma] \quad (5.8)",
            r"c = \nu(\mathrm{tr}J - 2\|J\Gamma\|^2/\Gamma\cdot J\Gamma),\; "
            r"b = J\Gamma\cdot(\dot\Gamma\times\Gamma)/\Gamma\cdot J\Gamma,\; "
            r"\nu = \mu/\Gamma\cdot J\Gamma \quad (5.9)",
        ),
    )


def routh_reconstruction(
    *, J: ArrayLike, rho: ArrayLike, mu: float, m: float = 1.0, g: float = 9.81
) -> Model:
    """The Routh model augmented with the reconstruction equations of Prop. 17.

    State ``(Gamma, Gamma-dot)`` (TS2), the horizontal lift ``R_hor`` (SO3) with
    ``R_hor-dot = R_hor hat(omega_hor)`` (5.10)-(5.11), and the dynamic phase ``theta``
    (R^1) with ``theta-dot = nu`` (5.12). :func:`reconstruct` maps a trajectory of it to
    ``(R, omega)`` by (5.13)-(5.14).

    Parameters
    ----------
    J, rho, mu, m, g
        As in :func:`routh`.

    Returns
    -------
    Model
    """
    base = routh(J=J, rho=rho, mu=mu, m=m, g=g)

    def field(ctx: Context) -> ca.SX:
        sub = Context(base, ctx.x[0:6], ctx.u, ctx.p)
        t = _routh_terms(sub)
        Rh = SO3.matrix(ctx["R_hor"])
        return ca.vertcat(
            base._vector_field(sub), ca.vec(Rh @ hat(t["omega_hor"])), t["nu"]
        )

    return Model(
        name="pendulum3d_routh_reconstruction",
        manifold=ProductManifold([("Gamma", TS2()), ("R_hor", SO3()), ("theta", Rn(1))]),
        n_inputs=0,
        parameters=ROUTH_PARAMETERS,
        values=dict(base.values),
        vector_field=field,
        invariants={"energy": lambda ctx: base._invariants["energy"](
            Context(base, ctx.x[0:6], ctx.u, ctx.p))},
        description="Routh model with the reconstruction of paper 000 Prop. 17 (5.10)-(5.14)",
        equations=(
            r"\dot R_{hor} = R_{hor}\hat\omega_{hor},\; \omega_{hor} = \dot\Gamma\times\Gamma"
            r" - b\Gamma \quad (5.10)\text{-}(5.11)",
            r"\theta_{dyn}(t) = \int_0^t \mu/(\Gamma\cdot J\Gamma)\,ds \quad (5.12)",
            r"R = \exp(\theta_{dyn}\hat e_3) R_{hor},\; \omega = \omega_{hor} + \nu\Gamma"
            r"\quad (5.13)\text{-}(5.14)",
        ),
    )


def routh_state_from_full(model: Model, x_full: ArrayLike) -> tuple[np.ndarray, float]:
    """Map a full state ``(R, omega)`` to ``(Gamma, Gamma-dot)`` and ``mu``.

    Parameters
    ----------
    model : Model
        The full model (for its parameters).
    x_full : array-like, shape=(12,)
        ``(vec(R), omega)``.

    Returns
    -------
    (ndarray, float)
        The TS2 state (6,) and the momentum value ``mu = Gamma^T J omega``.
    """
    x = model.check_state(x_full)
    R, w = SO3.matrix(x[:9]), x[9:]
    gam = R.T @ E3
    J = model.values["J"]
    return np.concatenate([gam, np.cross(gam, w)]), float(gam @ J @ w)


def reconstruct(
    model: Model, states: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(5.13)-(5.14): attitudes and angular velocities from reconstruction states.

    ``R = exp(theta hat(e3)) R_hor`` and ``omega = omega_hor + nu Gamma``, evaluated by a
    casadi function built from the same terms (:func:`_routh_terms`) as the model's field,
    mapped over the states.

    Parameters
    ----------
    model : Model
        A :func:`routh_reconstruction` model.
    states : ndarray, shape=(n_times, 16)
        Its trajectory states ``(Gamma, Gamma-dot, vec(R_hor), theta)``.

    Returns
    -------
    R : ndarray, shape=(n_times, 3, 3)
    omega : ndarray, shape=(n_times, 3)

    Raises
    ------
    ModelError
        ``model`` is not a reconstruction model, or ``states`` has the wrong shape or is
        not finite.
    """
    if model.manifold.names != ["Gamma", "R_hor", "theta"]:
        raise ModelError(f"model must be a routh_reconstruction model (factors Gamma, R_hor, "
                         f"theta); got {model.name!r} with factors {model.manifold.names}")
    X = as_states(model, states)

    def build(ctx: Context) -> ca.SX:
        t = _routh_terms(ctx)
        R = so3_exp(ctx["theta"] * ca.DM(E3)) @ SO3.matrix(ctx["R_hor"])
        return ca.vertcat(ca.vec(R), t["omega_hor"] + t["nu"] * t["gam"])

    fn = state_function(model, "reconstruct", build, out="R_omega")
    out = np.asarray(fn.map(X.shape[0])(X.T, model.p)).T
    # vec(R) is column-major: row k of out[:, :9] reshaped row-major is R^T
    return out[:, :9].reshape(-1, 3, 3).transpose(0, 2, 1), out[:, 9:]


# ----------------------------------------------------------------------------------------
# special cases of Section 4.1 (axisymmetric body, pivot on the axis: J = diag(Jt, Jt, Ja),
# rho = rho_s e3)

_AXI = (
    Parameter("Jt", (), "transverse moment of inertia about the pivot [kg m^2]", positive),
    Parameter("Ja", (), "axial moment of inertia [kg m^2]", positive),
    Parameter("rho_s", (), "distance pivot to centre of mass along the axis [m]", positive),
    Parameter("m", (), "mass [kg]", positive),
    Parameter("g", (), "gravitational acceleration [m/s^2]", positive),
)


def _axi_values(Jt: float, Ja: float, rho_s: float, m: float, g: float) -> Mapping[str, float]:
    return {"Jt": Jt, "Ja": Ja, "rho_s": rho_s, "m": m, "g": g}


def spinning_top(
    *, Jt: float, Ja: float, rho_s: float, spin: float, m: float = 1.0, g: float = 9.81
) -> Model:
    """Spinning top, paper 000 Prop. 5: the invariant manifold ``omega_z = spin``.

    Parameters
    ----------
    Jt, Ja : float
        Transverse and axial moments of inertia about the pivot (``J = diag(Jt, Jt, Ja)``).
    rho_s : float
        Centre of mass at ``rho = rho_s e3``.
    spin : float
        The constant axial spin rate ``c`` [rad/s].
    m, g : float
        Mass and gravity.

    Returns
    -------
    Model
        State ``Gamma`` (S2) and ``omega_xy`` (R^2); no input; invariant ``energy``.
    """
    params = (*_AXI, Parameter("spin", (), "axial spin rate c [rad/s]", finite))

    def field(ctx: Context) -> ca.SX:
        gam, wxy = ctx["Gamma"], ctx["omega_xy"]
        Jt, Ja, c = ctx["Jt"], ctx["Ja"], ctx["spin"]
        mgr = ctx["m"] * ctx["g"] * ctx["rho_s"]
        w = ca.vertcat(wxy, c)
        dwx = (c * (Jt - Ja) * wxy[1] - mgr * gam[1]) / Jt
        dwy = (c * (Ja - Jt) * wxy[0] + mgr * gam[0]) / Jt
        return ca.vertcat(ca.cross(gam, w), dwx, dwy)

    def energy(ctx: Context) -> ca.SX:
        wxy = ctx["omega_xy"]
        return 0.5 * ctx["Jt"] * ca.dot(wxy, wxy) - ctx["m"] * ctx["g"] * ctx["rho_s"] * ctx[
            "Gamma"
        ][2]

    return Model(
        name="spinning_top",
        manifold=ProductManifold([("Gamma", S2()), ("omega_xy", Rn(2))]),
        n_inputs=0,
        parameters=params,
        values={**_axi_values(Jt, Ja, rho_s, m, g), "spin": spin},
        vector_field=field,
        invariants={"energy": energy},
        description="spinning top, axisymmetric 3D pendulum with omega_z = c (paper 000 Prop. 5)",
        equations=(
            r"J_t\dot\omega_x = c(J_t - J_a)\omega_y - mg\rho_s\Gamma_y,\;"
            r"J_t\dot\omega_y = c(J_a - J_t)\omega_x + mg\rho_s\Gamma_x \quad \text{(Prop. 5)}",
            r"\dot\Gamma = \Gamma\times[\omega_x, \omega_y, c]^T",
        ),
    )


def spherical(*, Jt: float, Ja: float, rho_s: float, m: float = 1.0, g: float = 9.81) -> Model:
    """Spherical pendulum as the zero-spin top, paper 000 Prop. 6 (on S^2 x R^2).

    Parameters
    ----------
    Jt, Ja, rho_s, m, g : float
        As in :func:`spinning_top`.

    Returns
    -------
    Model
        :func:`spinning_top` with ``spin = 0``, renamed.
    """
    model = spinning_top(Jt=Jt, Ja=Ja, rho_s=rho_s, spin=0.0, m=m, g=g)
    model.name = "spherical_from_3d"
    model.description = "spherical pendulum, axisymmetric 3D pendulum with omega_z = 0 (Prop. 6)"
    return model


def planar(*, Jt: float, rho_s: float, m: float = 1.0, g: float = 9.81) -> Model:
    """Planar pendulum, paper 000 Prop. 7, on S^1 x R with no angle coordinate.

    The circle is the unit vector ``p = (Gamma_x, Gamma_z)`` (``Gamma_y = 0``), and
    ``omega_y`` the angular rate: ``p-dot = omega_y (-p_z, p_x)``,
    ``Jt omega_y-dot = m g rho_s p_x`` (the paper's ``-m g rho_s sin(theta)`` with
    ``p_x = -sin(theta)``).

    Parameters
    ----------
    Jt, rho_s, m, g : float
        Transverse inertia about the pivot, centre-of-mass distance, mass, gravity.

    Returns
    -------
    Model
        State ``p`` (S1) and ``omega_y`` (R^1); invariant ``energy``.
    """
    params = (_AXI[0], _AXI[2], _AXI[3], _AXI[4])

    def field(ctx: Context) -> ca.SX:
        p, w = ctx["p"], ctx["omega_y"]
        mgr = ctx["m"] * ctx["g"] * ctx["rho_s"]
        return ca.vertcat(-w * p[1], w * p[0], mgr * p[0] / ctx["Jt"])

    def energy(ctx: Context) -> ca.SX:
        w = ctx["omega_y"]
        return 0.5 * ctx["Jt"] * w**2 - ctx["m"] * ctx["g"] * ctx["rho_s"] * ctx["p"][1]

    return Model(
        name="planar_from_3d",
        manifold=ProductManifold([("p", S1()), ("omega_y", Rn(1))]),
        n_inputs=0,
        parameters=params,
        values={"Jt": Jt, "rho_s": rho_s, "m": m, "g": g},
        vector_field=field,
        invariants={"energy": energy},
        description="planar pendulum, axisymmetric 3D pendulum in a vertical plane (Prop. 7)",
        equations=(r"J_t\dot\omega_y = -mg\rho_s\sin\theta,\;\dot\theta = \omega_y"
                   r"\quad\text{(Prop. 7, written on } S^1)",),
    )


def phase_density(J: ArrayLike) -> Callable[[np.ndarray], np.ndarray]:
    """The integrand ``F`` of paper 000 (5.15) for an inertia ``J``, as a vectorised function.

    ``F(Gamma) = (2 |J Gamma|^2 - tr(J) Gamma.J Gamma) / (Gamma.J Gamma)^2``, the curvature of
    the mechanical connection (5.3);
    :func:`workbench.global_dynamics._phase.geometric_phase_check` takes it as ``density``
    and checks it against the reconstruction.

    Parameters
    ----------
    J : array-like, shape=(3, 3)
        Inertia, symmetric positive definite.

    Returns
    -------
    callable
        ``F(gamma)`` for ``gamma`` of shape ``(..., 3)`` (unit vectors), shape ``(...)``.
    """
    try:
        Jm = np.asarray(J, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"J must be a symmetric positive-definite 3x3 matrix; got {J!r}"
                             ) from exc
    if Jm.shape != (3, 3) or not np.all(np.isfinite(Jm)) or not np.allclose(Jm, Jm.T) \
            or np.any(np.linalg.eigvalsh(Jm) <= 0):
        raise ParameterError(f"J must be a symmetric positive-definite 3x3 matrix; got {J!r}")
    trJ = float(np.trace(Jm))

    def density(gamma: np.ndarray) -> np.ndarray:
        Jg = gamma @ Jm
        gJg = np.sum(gamma * Jg, axis=-1)
        return (2 * np.sum(Jg * Jg, axis=-1) - trJ * gJg) / gJg**2

    return density
