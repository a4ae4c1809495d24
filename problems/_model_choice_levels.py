"""The 3D pendulum's special cases as model levels, and the scenes of the problem model_choice.

Paper 000 Section 4.1: for an axisymmetric body with its centre of mass on the axis
(``J = diag(Jt, Jt, Ja)``, ``rho = rho_s e3``, ``rho_s > 0``) the axial spin ``omega_3``
is conserved and the motion is the Lagrange top (:func:`models.pendulum3d.spinning_top`)
at that spin, the spherical pendulum at zero spin, and the planar pendulum when moreover
``Gamma_2 = 0`` and ``omega = omega_2 e2`` (then only ``J e2 = Jt e2`` matters, but the
model is the same). Each level checks these assumptions numerically on the full model's
parameters and the scene's states, and says which one fails. The cases give ``(Gamma,
omega)``: the full state is the Lagrange-Poincare lift (on the section), so the outputs
must be invariant under rotation about gravity (the level checks it).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from models import pendulum3d as p3
from models.pendulum3d_cart import at_rest, pendulum3d_cart
from workbench import Model, mechanics, so3_exp
from workbench.study import CaseMaps, Scene, SpecialCase

__all__ = ["special_cases", "gamma", "com_position", "at_tilt", "pendulum_scenes",
           "top_scenes", "cart_scene", "cart_position_and_gamma", "TOP"]

SHAPE_TOL = 1e-9
"""Relative tolerance of the checks on ``J``, ``rho`` and the states."""


def gamma(X: np.ndarray) -> np.ndarray:
    """``Gamma = R^T e3`` of full pendulum states (R stored column-major): the third row."""
    return X[:, [2, 5, 8]]


def com_position(rho: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """``R rho``: the centre of mass in space, as an output of full pendulum states."""

    def out(X: np.ndarray) -> np.ndarray:
        R = X[:, :9].reshape(-1, 3, 3).transpose(0, 2, 1)
        return R @ rho

    return out


def at_tilt(lp: mechanics.Reduction, direction: np.ndarray, tilt: np.ndarray,
            omega: np.ndarray) -> np.ndarray:
    """The full state over ``Gamma = exp(hat(tilt)) direction`` and body rate ``omega``."""
    g = np.asarray(so3_exp(np.asarray(tilt, dtype=float)), dtype=float) @ direction
    return lp.full_state(np.r_[g, omega])


def _axisymmetric(J: np.ndarray, rho: np.ndarray) -> str | None:
    scale = float(np.max(np.abs(J)))
    off = max(abs(J[0, 1]), abs(J[0, 2]), abs(J[1, 2]), abs(J[0, 0] - J[1, 1]))
    if off > SHAPE_TOL * scale:
        return (f"J is not axisymmetric about the body axis e3 (J = diag(Jt, Jt, Ja) needed; "
                f"off by {off:.3g}, principal moments "
                f"{np.array2string(np.linalg.eigvalsh(J), precision=4)})")
    return _on_axis(rho)


def _on_axis(rho: np.ndarray) -> str | None:
    if max(abs(rho[0]), abs(rho[1])) > SHAPE_TOL * float(np.linalg.norm(rho)) or rho[2] <= 0:
        return (f"the centre of mass rho = {np.array2string(rho, precision=4)} is not on the "
                "body axis e3 below the pivot (rho = rho_s e3, rho_s > 0 needed)")
    return None


def _states(scene: Scene, what: str, values: np.ndarray, target: float) -> str | None:
    off = float(np.max(np.abs(values - target)))
    if off > SHAPE_TOL * max(1.0, abs(target)):
        return (f"{what} is {float(values.min()):.6g} .. {float(values.max()):.6g} in the "
                f"scene, not {target:g}")
    return None


def special_cases(full: Model) -> list[SpecialCase]:
    """The Lagrange top, the spherical and the planar pendulum as levels of ``full``.

    Parameters
    ----------
    full : Model
        A :func:`models.pendulum3d.full` model.

    Returns
    -------
    list of SpecialCase
    """
    J, rho = np.asarray(full.values["J"]), np.asarray(full.values["rho"])
    m, g = float(full.values["m"]), float(full.values["g"])
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")

    def lifted(gam: np.ndarray, omega: np.ndarray) -> np.ndarray:
        r = np.column_stack([gam, omega]).T
        return np.asarray(lp.lift.map(r.shape[1])(r, full.p, 0.0)).T

    def spin(scene: Scene) -> float:
        return float(scene.states[0, 11])

    def top_assumption(scene: Scene) -> str | None:
        return _axisymmetric(J, rho) or _states(scene, "the axial spin omega_3",
                                               scene.states[:, 11], spin(scene))

    def top(scene: Scene, c: float | None = None) -> CaseMaps:
        axi = {"Jt": J[0, 0], "Ja": J[2, 2], "rho_s": rho[2], "m": m, "g": g}
        model = p3.spherical(**axi) if c == 0.0 else p3.spinning_top(**axi, spin=spin(scene))
        c = spin(scene) if c is None else c
        return CaseMaps(model, lambda x: np.r_[gamma(x[None])[0], x[9:11]],
                        lambda S: lifted(S[:, :3], np.column_stack([S[:, 3:5], np.full(
                            len(S), c)])))

    def spherical_assumption(scene: Scene) -> str | None:
        return _axisymmetric(J, rho) or _states(scene, "the axial spin omega_3",
                                               scene.states[:, 11], 0.0)

    def planar_assumption(scene: Scene) -> str | None:
        principal = max(abs(J[0, 1]), abs(J[1, 2]))
        if principal > SHAPE_TOL * float(np.max(np.abs(J))):
            return f"e2 is not a principal axis of J (J12, J23 = {J[0, 1]:.3g}, {J[1, 2]:.3g})"
        X = scene.states
        return (_on_axis(rho) or _states(scene, "Gamma_2", gamma(X)[:, 1], 0.0)
                or _states(scene, "omega_1", X[:, 9], 0.0)
                or _states(scene, "omega_3", X[:, 11], 0.0))

    def planar(scene: Scene) -> CaseMaps:
        model = p3.planar(Jt=J[1, 1], rho_s=rho[2], m=m, g=g)
        zero = np.zeros

        def back(S: np.ndarray) -> np.ndarray:
            n = len(S)
            return lifted(np.column_stack([S[:, 0], zero(n), S[:, 1]]),
                          np.column_stack([zero(n), S[:, 2], zero(n)]))

        return CaseMaps(model, lambda x: np.r_[x[2], x[8], x[10]], back)

    act = lp.act
    return [
        SpecialCase("Lagrange top", full, assumption=top_assumption, build=top,
                    symmetry=lambda x, th: np.asarray(act(x, th)).ravel()),
        SpecialCase("spherical", full, assumption=spherical_assumption,
                    build=lambda scene: top(scene, 0.0),
                    symmetry=lambda x, th: np.asarray(act(x, th)).ravel()),
        SpecialCase("planar", full, assumption=planar_assumption, build=planar,
                    symmetry=lambda x, th: np.asarray(act(x, th)).ravel()),
    ]


# ----------------------------------------------------------------------------------------
# the scenes of the problem

TOP = {"J": np.diag([0.28, 0.28, 0.13]), "rho": np.array([0.0, 0.0, 0.3]), "m": 1.0,
       "g": 9.81}
"""An axisymmetric body, its centre of mass on the axis 0.3 m below the pivot."""


def _tilted(lp: mechanics.Reduction, direction: np.ndarray, amplitude: float, n: int,
            seed: int) -> list[np.ndarray]:
    """``n`` states at rest tilted by ``amplitude`` about seeded random horizontal axes."""
    angles = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, n)
    return [at_tilt(lp, direction, amplitude * np.r_[np.cos(a), np.sin(a), 0.0], np.zeros(3))
            for a in angles]


def pendulum_scenes(body: dict, *, horizon: float, amplitude: float, n_states: int,
                    seed: int) -> tuple[Model, dict[str, dict]]:
    """The paper 000 body near hanging (Gamma) and tumbling (centre of mass); the top's.

    Parameters
    ----------
    body : dict
        ``J, rho, m, g`` of paper 000's body.
    horizon : float
        The long horizon [s] (the tumbling scene: a tenth of it).
    amplitude : float
        Tilt of the near-hanging states [rad].
    n_states : int
        States of the near-hanging scene.
    seed : int
        Seed of their tilt axes.

    Returns
    -------
    (Model, dict)
        The full model and, by scene name, the keywords of ``Scene`` and of
        ``compare_models`` (``equilibria``, ``radius``, ``special_cases``).
    """
    full = p3.full(**body)
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")
    down = body["rho"] / np.linalg.norm(body["rho"])
    hanging = lp.full_state(np.r_[down, 0.0, 0.0, 0.0])
    cases = special_cases(full)
    near = _tilted(lp, down, amplitude, n_states, seed)
    tumbling = at_tilt(lp, down, np.r_[0.8, 0.0, 0.0], np.r_[0.5, -0.3, 1.0])
    return full, {
        "near hanging": {"scene": Scene(full, near, horizon, gamma, 1e-5, n_times=401,
                                        name="000 body near hanging, Gamma"),
                         "equilibria": [hanging], "radius": 10 * amplitude,
                         "special_cases": cases},
        "tumbling": {"scene": Scene(full, tumbling, horizon / 10, com_position(body["rho"]),
                                    1e-6, n_times=201,
                                    name="000 body tumbling, centre of mass"),
                     "equilibria": [hanging], "radius": 10 * amplitude,
                     "special_cases": cases}}


def top_scenes(*, horizon: float) -> tuple[Model, dict[str, dict]]:
    """The axisymmetric body :data:`TOP` spinning (Lagrange top) and swinging in a plane.

    The swing runs over half the horizon: its reference (rtol 1e-13 against 1e-12) drifts
    in phase like the horizon, and at 100 s reaches 2/3 of the margin (1e-7) it must stay
    below.
    """
    full = p3.full(**TOP)
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")
    e3, cases = np.r_[0.0, 0.0, 1.0], special_cases(full)
    spinning = at_tilt(lp, e3, np.r_[0.6, 0.0, 0.0], np.r_[0.0, 0.3, 5.0])
    swinging = at_tilt(lp, e3, np.r_[0.0, 0.6, 0.0], np.r_[0.0, 0.8, 0.0])
    return full, {
        "top": {"scene": Scene(full, spinning, horizon, gamma, 1e-5, n_times=401,
                               name="top spinning at 5 rad/s, Gamma"),
                "special_cases": cases},
        "planar": {"scene": Scene(full, swinging, horizon / 2, gamma, 1e-5, n_times=401,
                                  name="top swinging in a plane, Gamma"),
                   "special_cases": cases}}


def cart_position_and_gamma(X: np.ndarray) -> np.ndarray:
    """Outputs of the pendulum on a cart: the cart position ``x`` and ``Gamma = R^T e3``."""
    return np.column_stack([X[:, 0:2], X[:, [6, 9, 12]]])


def cart_scene(*, horizon: float, amplitude: float, n_states: int, seed: int,
               drift: tuple[float, float] = (0.05, 0.02)) -> tuple[Model, dict[str, dict]]:
    """The 3D pendulum on a cart near hanging, the cart drifting at ``drift`` [m/s].

    States at rest relative to the cart (so all have the momenta ``p_x, p_y = (M + m)
    drift``), tilted by ``amplitude`` about seeded random horizontal axes; outputs the cart
    position and the attitude's ``Gamma``; the linearisation at hanging, radius ``0.1``.
    """
    full = pendulum3d_cart()
    angles = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, n_states)
    states = [full.state(x=[0.0, 0.0], v=list(drift), Omega=[0.0, 0.0, 0.0], R=np.asarray(
        so3_exp(amplitude * np.r_[np.cos(a), np.sin(a), 0.0]), dtype=float)) for a in angles]
    return full, {"cart": {
        "scene": Scene(full, states, horizon, cart_position_and_gamma, 1e-4, n_times=401,
                       name="3D pendulum on a cart near hanging, drifting"),
        "equilibria": [at_rest(full)], "radius": 0.1}}
