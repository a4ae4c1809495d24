"""The 3D pendulum's special cases as model levels for :func:`workbench.study.compare_models`.

Paper 000 Section 4.1: for an axisymmetric body with its centre of mass on the axis
(``J = diag(Jt, Jt, Ja)``, ``rho = rho_s e3``, ``rho_s > 0``) the axial spin ``omega_3``
is conserved and the motion is the Lagrange top (:func:`models.pendulum3d.spinning_top`)
at that spin, the spherical pendulum (:func:`models.pendulum3d.spherical`) at zero spin,
and the planar pendulum (:func:`models.pendulum3d.planar`) when moreover ``Gamma_2 = 0``
and ``omega = omega_2 e2`` (then only ``J e2 = Jt e2`` and ``rho = rho_s e3`` matter).

:func:`special_cases` makes the three levels of a :func:`models.pendulum3d.full` model.
Each checks its assumptions numerically on the full model's parameters and the scene's
states (to :data:`SHAPE_TOL`) and says which one fails. The state maps: a full state
``(R, omega)`` goes to ``(Gamma, omega_1, omega_2)`` (top, spherical; ``Gamma = R^T e3``)
or to ``((Gamma_1, Gamma_3), omega_2)`` (planar), and back to the full state over that
``(Gamma, omega)`` on the Lagrange-Poincare section (``workbench.mechanics.reduce``'s
lift), which is the scene's state up to a rotation about gravity: each level checks that
the scene's outputs are invariant under it.

Usage::

    from models import pendulum3d
    from models.pendulum3d_levels import gamma, special_cases
    from workbench.study import Scene, compare_models

    full = pendulum3d.full(J=np.diag([0.28, 0.28, 0.13]), rho=[0, 0, 0.3])
    scene = Scene(full, x0, 10.0, gamma, 1e-6)
    choice = compare_models(scene, special_cases=special_cases(full))
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from models import pendulum3d as p3
from workbench import Model, mechanics, so3_exp
from workbench.core.errors import ModelError
from workbench.study import CaseMaps, Scene, SpecialCase

__all__ = ["special_cases", "gamma", "com_position", "at_tilt", "SHAPE_TOL"]

SHAPE_TOL = 1e-9
"""Relative tolerance of the checks on ``J``, ``rho`` and the states."""


def gamma(X: np.ndarray) -> np.ndarray:
    """``Gamma = R^T e3`` of full pendulum states (R stored column-major): the third row.

    Parameters
    ----------
    X : ndarray, shape=(n, 12)
        Full states ``(vec(R), omega)``.

    Returns
    -------
    ndarray, shape=(n, 3)
    """
    return X[:, [2, 5, 8]]


def com_position(rho: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """``R rho``: the centre of mass in space, as an output of full pendulum states.

    Parameters
    ----------
    rho : array-like, shape=(3,)
        The centre of mass in the body frame.

    Returns
    -------
    callable
        ``X (n, 12) -> (n, 3)``.
    """
    rho = np.asarray(rho, dtype=float)

    def out(X: np.ndarray) -> np.ndarray:
        R = X[:, :9].reshape(-1, 3, 3).transpose(0, 2, 1)
        return R @ rho

    return out


def at_tilt(lp: mechanics.Reduction, direction: np.ndarray, tilt: np.ndarray,
            omega: np.ndarray) -> np.ndarray:
    """The full state over ``Gamma = exp(hat(tilt)) direction`` and body rate ``omega``.

    Parameters
    ----------
    lp : Reduction
        A Lagrange-Poincare reduction of the full model (its lift).
    direction : array-like, shape=(3,)
        A unit vector (e.g. the hanging ``Gamma``).
    tilt : array-like, shape=(3,)
        The rotation vector applied to it [rad].
    omega : array-like, shape=(3,)
        The body angular velocity [rad/s].

    Returns
    -------
    ndarray, shape=(12,)
    """
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


def _states(what: str, values: np.ndarray, target: float) -> str | None:
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
        A :func:`models.pendulum3d.full` model (any parameter values: the assumptions
        are checked per scene, not assumed).

    Returns
    -------
    list of SpecialCase
        ``"Lagrange top"``, ``"spherical"`` and ``"planar"``, for
        ``compare_models(..., special_cases=...)``.

    Raises
    ------
    ModelError
        If ``full`` is not a 3D pendulum on TSO(3) with the parameters ``J, rho, m, g``.
    """
    if not isinstance(full, Model) or full.manifold.names != ["R", "omega"] or not {
            "J", "rho", "m", "g"} <= set(full.values):
        raise ModelError(f"full must be a models.pendulum3d.full model (state R, omega; "
                         f"parameters J, rho, m, g); got {getattr(full, 'name', full)!r}")
    J, rho = np.asarray(full.values["J"]), np.asarray(full.values["rho"])
    m, g = float(full.values["m"]), float(full.values["g"])
    lp = mechanics.reduce(full, "h", kind="lagrange_poincare")

    def lifted(gam: np.ndarray, omega: np.ndarray) -> np.ndarray:
        r = np.column_stack([gam, omega]).T
        return np.asarray(lp.lift.map(r.shape[1])(r, full.p, 0.0)).T

    def spin(scene: Scene) -> float:
        return float(scene.states[0, 11])

    def top_assumption(scene: Scene) -> str | None:
        return _axisymmetric(J, rho) or _states("the axial spin omega_3",
                                                scene.states[:, 11], spin(scene))

    def top(scene: Scene, c: float | None = None) -> CaseMaps:
        axi = {"Jt": J[0, 0], "Ja": J[2, 2], "rho_s": rho[2], "m": m, "g": g}
        model = p3.spherical(**axi) if c == 0.0 else p3.spinning_top(**axi, spin=spin(scene))
        c = spin(scene) if c is None else c
        return CaseMaps(model, lambda x: np.r_[gamma(x[None])[0], x[9:11]],
                        lambda S: lifted(S[:, :3], np.column_stack([S[:, 3:5], np.full(
                            len(S), c)])))

    def spherical_assumption(scene: Scene) -> str | None:
        return _axisymmetric(J, rho) or _states("the axial spin omega_3",
                                                scene.states[:, 11], 0.0)

    def planar_assumption(scene: Scene) -> str | None:
        principal = max(abs(J[0, 1]), abs(J[1, 2]))
        if principal > SHAPE_TOL * float(np.max(np.abs(J))):
            return f"e2 is not a principal axis of J (J12, J23 = {J[0, 1]:.3g}, {J[1, 2]:.3g})"
        X = scene.states
        return (_on_axis(rho) or _states("Gamma_2", gamma(X)[:, 1], 0.0)
                or _states("omega_1", X[:, 9], 0.0)
                or _states("omega_3", X[:, 11], 0.0))

    def planar(scene: Scene) -> CaseMaps:
        model = p3.planar(Jt=J[1, 1], rho_s=rho[2], m=m, g=g)
        zero = np.zeros

        def back(S: np.ndarray) -> np.ndarray:
            n = len(S)
            return lifted(np.column_stack([S[:, 0], zero(n), S[:, 1]]),
                          np.column_stack([zero(n), S[:, 2], zero(n)]))

        return CaseMaps(model, lambda x: np.r_[x[2], x[8], x[10]], back)

    def turn(x: np.ndarray, th: float) -> np.ndarray:
        return np.asarray(lp.act(x, th)).ravel()

    return [
        SpecialCase("Lagrange top", full, assumption=top_assumption, build=top, symmetry=turn),
        SpecialCase("spherical", full, assumption=spherical_assumption,
                    build=lambda scene: top(scene, 0.0), symmetry=turn),
        SpecialCase("planar", full, assumption=planar_assumption, build=planar, symmetry=turn),
    ]
