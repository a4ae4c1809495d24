"""The scenes of the problem model_choice.

The 3D pendulum's special cases (Lagrange top, spherical, planar: their checked
assumptions and state maps) are :func:`models.pendulum3d_levels.special_cases`; the
outputs and the tilted states are :mod:`models.pendulum3d_levels`' too.
"""

from __future__ import annotations

import numpy as np

from models import pendulum3d as p3
from models.pendulum3d_cart import at_rest, pendulum3d_cart
from models.pendulum3d_levels import at_tilt, com_position, gamma, special_cases
from workbench import Model, mechanics, so3_exp
from workbench.study import Scene

__all__ = ["pendulum_scenes", "top_scenes", "cart_scene", "cart_position_and_gamma", "TOP"]

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
