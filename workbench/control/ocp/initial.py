"""Initial guesses derived from the model and the OCP: the default strategy's starts.

No guess here comes from an axis convention. Each is a path of the *configuration* from
``x0`` to the target, made dynamically consistent as far as the model allows:

1. **The second-order structure is read off the field.** The rows of ``f`` that do not depend
   on the input are the kinematics (``q-dot = w x q``, ``R-dot = R hat(Omega)``,
   ``p-dot = theta-dot J p``, ``x-dot = v``); the state entries they depend on, outside
   themselves, are the velocities. The kinematics is linear in the velocities,
   ``c-dot = K(c) v``.
2. **A configuration path** ``c(s)``, ``s`` in ``[0, 1]``, factor by factor: a straight line on
   ``R^k``, a great circle on ``S^2``, a one-parameter subgroup ``R0 exp(th hat(a))`` on
   ``SO(3)``, a rotation by ``th`` on ``S^1``. A factor that must turn by more than a right
   angle (a link to be inverted, an angle to be wrapped) follows the *pumping* schedule

       th(s) = Theta s cos(pi k (1 - s)),

   ``k`` reversals of growing amplitude (``k = 0``: the direct path); the others follow
   ``th = Theta s``.
3. **The great circle is the one the inputs can drive.** For a factor going to its antipode
   the circle is not unique; its plane is the direction of the factor's largest
   controllable motion at ``x0`` (or, failing that, at the target): the leading left
   singular vector of the factor's rows of ``basis @ [B, AB, A^2 B, ...]`` (the block
   columns of the Krylov matrix normalised), from the linearisation at that equilibrium. An
   antipodal ``S^1`` angle is wrapped both ways (two guesses).
4. **Velocities by kinematics, controls by inverse dynamics.** The velocities solve
   ``K(c) v = dc/dt`` (least squares, minimal norm: on ``TS^2`` this keeps ``w`` tangent),
   the controls solve ``(df_v/du) u = dv/dt - f_v(x, 0)`` (least squares), clipped into the
   bounds (a guess, not the problem's data).
5. **The horizon** of a free final time grows with the swings: ``T_k = (k + 1) pi / omega``
   with ``omega`` the frequency of the oscillation of the linearisation at ``x0`` that moves
   the factors to invert most (clipped into the allowed range); else the middle of the
   range.

Models without this structure (no inputs, or a field whose input enters every row) get the
geodesic guess of :meth:`~workbench.control.ocp.guess.Guess.geodesic` with the
controllable axes.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.control.ocp.expand import sx_function
from workbench.control.ocp.guess import Guess
from workbench.control.ocp.local import ProductLocal
from workbench.control.ocp.problem import OCP
from workbench.core import validate
from workbench.core.errors import ManifoldError, ModelError, ParameterError, SolverError
from workbench.core.manifolds import S1, S2, SO3, TS2, Rn, so3_exp, so3_log
from workbench.core.types import Vector

__all__ = ["StructuredGuess", "structured_guesses", "iter_structured_guesses", "pumping",
           "Structure", "structure", "controllable_axes", "natural_frequency"]

INVERT_ANGLE = np.pi / 2
"""A factor that must turn by more than this (radians) is pumped (see the module docstring)."""

SAMPLES = 201
"""Samples of a structured guess along ``[0, 1]``."""

MAX_SAMPLES = 100_000
"""At most this many samples of a structured guess (each is a linear solve of the model)."""

MAX_SWINGS = 20
"""At most this many reversals in a pumping path (the strategy's ``swings`` has the same)."""

@dataclass(frozen=True)
class StructuredGuess:
    """A guess with the account of how it was made.

    Attributes
    ----------
    name : str
        Short name, e.g. ``"pumping k=2"``.
    guess : Guess or OCPSolution
        The guess (a solution only where the caller gave one).
    description : str
        How it was made (axes, wrap directions, horizon).
    demand : float
        The largest input the path asks for by inverse dynamics, in units of the bounds'
        half-range about their middle (above 1 the path asks for more than the bounds
        allow; the guess holds the clipped inputs); NaN where not computed.
    """

    name: str
    guess: Any  # a Guess; a solution given by the caller for the "given" start
    description: str
    demand: float = float("nan")


@dataclass
class Structure:
    """The second-order structure of a model's field (see the module docstring).

    Attributes
    ----------
    config : ndarray of int
        State entries whose rates do not depend on the input (the kinematics).
    velocity : ndarray of int
        The other entries the kinematics depends on.
    kinematics : casadi.Function
        ``(x, p) -> K`` with ``c-dot = K v`` (``len(config)`` x ``len(velocity)``).
    drift : casadi.Function
        ``(x, p) -> (f_v(x, 0), df_v/du)``: the velocities' rates without input and their
        input matrix.
    pattern : ndarray of bool
        The structural nonzeros of ``K`` (``pattern[i, j]``: the rate of ``config[i]``
        depends on ``velocity[j]`` somewhere, not only at one state).
    """

    config: np.ndarray
    velocity: np.ndarray
    kinematics: ca.Function
    drift: ca.Function
    pattern: np.ndarray


def structure(model: Any) -> Structure | None:
    """Read the second-order structure of ``model``'s field; ``None`` if it has none."""
    cache = model.__dict__.setdefault("_ocp_structure", {})
    if "value" in cache:
        return cache["value"]
    cache["value"] = value = _structure(model)
    return value


def _structure(model: Any) -> Structure | None:
    if model.n_inputs == 0:
        return None
    f = sx_function(model.function("f"), spd=model.spd_solves)
    nx = model.manifold.ambient_dim
    x, u, p = ca.SX.sym("x", nx), ca.SX.sym("u", model.n_inputs), ca.SX.sym("p", model.n_params)
    fx = f(x, u, p)
    config = [i for i in range(nx) if not ca.depends_on(fx[i], u)]
    if not config or len(config) == nx:
        return None
    rest = [j for j in range(nx) if j not in config]
    fc = fx[config]
    velocity = [j for j in rest if ca.depends_on(fc, x[j])]
    if not velocity:
        return None
    xv = ca.vertcat(*[x[j] for j in velocity])
    K = ca.jacobian(fc, xv)
    if ca.depends_on(K, xv):  # kinematics not linear in the velocities
        return None
    fv = ca.vertcat(*[fx[j] for j in velocity])
    zero = ca.substitute(fv, u, ca.DM.zeros(model.n_inputs))
    Bv = ca.substitute(ca.jacobian(fv, u), u, ca.DM.zeros(model.n_inputs))
    pattern = np.array(ca.DM(K.sparsity(), 1.0)) != 0  # structural: every state
    return Structure(np.array(config), np.array(velocity),
                     ca.Function("kinematics", [x, p], [K]),
                     ca.Function("drift", [x, p], [zero, Bv]), pattern)


# the configuration path ---------------------------------------------------------------------


@dataclass
class _Turn:
    """How one factor's configuration moves: an axis (or sign) and a total angle."""

    name: str
    kind: str  # "sphere", "rotation", "angle", "line", "geodesic"
    angle: float = 0.0
    axis: np.ndarray = field(default_factory=lambda: np.zeros(3))
    pumped: bool = False
    note: str = ""


def _turns(ocp: OCP, axes: dict[str, np.ndarray], wrap: float) -> list[_Turn]:
    """Per factor, the turn from ``x0`` to the target's witness."""
    man = ocp.model.manifold
    x0, xf = ocp.x0, ocp.target.witness
    out = []
    for name, f in man.factors:
        sl = man.slices[name]
        a, b = x0[sl], xf[sl]
        if isinstance(f, (S2, TS2)):
            q0, q1 = a[:3], b[:3]
            c = np.cross(q0, q1)
            angle = float(np.arctan2(np.linalg.norm(c), q0 @ q1))
            antipodal = np.linalg.norm(c) <= 1e-9 and q0 @ q1 < 0
            if antipodal and name in axes:
                ax = axes[name] - (axes[name] @ q0) * q0
                note = "axis of the largest controllable motion"
            elif np.linalg.norm(c) > 1e-9:
                ax, note = c, "great circle"
            else:
                ax = np.cross(q0, np.eye(3)[int(np.argmin(np.abs(q0)))])
                note = "no controllable direction known: a deterministic normal"
            ax = ax / np.linalg.norm(ax)
            out.append(_Turn(name, "sphere", angle, ax, angle > INVERT_ANGLE,
                             f"{note} {np.round(ax, 3).tolist()}"))
        elif isinstance(f, SO3):
            y = so3_log(SO3.matrix(a).T @ SO3.matrix(b))
            angle = float(np.linalg.norm(y))
            if angle > 1e-9:  # the one-parameter subgroup through the target's witness
                ax, note = y / angle, "the axis of log(R0^T Rf)"
            else:
                ax, note = np.array([1.0, 0.0, 0.0]), "no rotation"
            out.append(_Turn(name, "rotation", angle, ax, angle > INVERT_ANGLE,
                             f"{note} {np.round(ax, 3).tolist()}"))
        elif isinstance(f, S1):
            d = float(np.arctan2(a[0] * b[1] - a[1] * b[0], a @ b))
            if abs(abs(d) - np.pi) < 1e-6:
                d = wrap * np.pi
            out.append(_Turn(name, "angle", d, pumped=abs(d) > INVERT_ANGLE,
                             note=f"turn {d:+.3f} rad"))
        elif isinstance(f, Rn):
            out.append(_Turn(name, "line"))
        else:
            out.append(_Turn(name, "geodesic"))
    return out


def _schedule(angle: float, k: int, s: np.ndarray, pumped: bool) -> np.ndarray:
    return angle * s * (np.cos(np.pi * k * (1 - s)) if pumped else 1.0)


def _path(ocp: OCP, turns: list[_Turn], k: int) -> Callable[[np.ndarray], np.ndarray]:
    """``s -> x(s)`` (rows), configuration by the turns, the rest along the geodesic."""
    man = ocp.model.manifold
    x0, xf = ocp.x0, ocp.target.witness
    local = ProductLocal(man)
    y = local.log(x0, xf, axes={t.name: t.axis for t in turns if t.kind == "sphere"})

    def at(s: np.ndarray) -> np.ndarray:
        X = np.array([np.asarray(local.act(x0, si * y), float).ravel() for si in s])
        for t in turns:
            sl = man.slices[t.name]
            th = _schedule(t.angle, k, s, t.pumped)
            if t.kind == "sphere":
                q0 = x0[sl][:3]
                b = np.cross(t.axis, q0)
                X[:, sl.start: sl.start + 3] = (np.cos(th)[:, None] * q0
                                                + np.sin(th)[:, None] * b)
            elif t.kind == "rotation":
                R0 = SO3.matrix(x0[sl])
                X[:, sl] = np.array([SO3.flat(R0 @ so3_exp(ti * t.axis)) for ti in th])
            elif t.kind == "angle":
                c0 = np.arctan2(x0[sl][1], x0[sl][0])
                X[:, sl] = np.column_stack([np.cos(c0 + th), np.sin(c0 + th)])
        return X

    return at


def _dynamic(ocp: OCP, st: Structure | None, at: Callable, T: float,
             samples: int) -> tuple[Guess, float]:
    """Samples of the path with kinematic velocities and inverse-dynamics controls.

    Also the path's demand: its largest inverse-dynamics input relative to the bounds.
    """
    model = ocp.model
    s = np.linspace(0.0, 1.0, samples)
    X = at(s)
    if st is None:
        return Guess(s, X, np.zeros((samples - 1, model.n_inputs)), T,
                     ProductLocal(model.manifold)), float("nan")
    eps = 1e-5
    dc = (at(np.clip(s + eps, 0, 1))[:, st.config] - at(np.clip(s - eps, 0, 1))[:, st.config])
    dc /= ((np.clip(s + eps, 0, 1) - np.clip(s - eps, 0, 1)) * T)[:, None]
    p = model.p
    for i in range(samples):
        K = np.asarray(st.kinematics(X[i], p), float)
        X[i, st.velocity] = np.linalg.lstsq(K, dc[i], rcond=None)[0]
    dv = np.gradient(X[:, st.velocity], s * T, axis=0)
    U = np.zeros((samples, model.n_inputs))
    for i in range(samples):
        fv0, Bv = (np.asarray(v, float) for v in st.drift(X[i], p))
        U[i] = np.linalg.lstsq(Bv, dv[i] - fv0.ravel(), rcond=None)[0]
    half = 0.5 * (ocp.u_upper - ocp.u_lower)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.abs(U - 0.5 * (ocp.u_upper + ocp.u_lower)) / half
    demand = float(np.max(np.where(np.isfinite(half), ratio, 0.0), initial=0.0))
    U = np.clip(U, ocp.u_lower, ocp.u_upper)
    return Guess(s, X, U, T, ProductLocal(model.manifold)), demand


# where the inputs drive ---------------------------------------------------------------------


def controllable_axes(ocp: OCP) -> tuple[dict[str, np.ndarray], str]:
    """Per sphere factor: the axis about which its largest controllable motion turns.

    Returns
    -------
    (dict, str)
        Great-circle axes (world frame) by factor name, and at which equilibrium they were
        read (``"x0"``, ``"target"`` or ``""`` when neither is an equilibrium). An SO(3)
        factor turns about the axis of ``log(R0^T Rf)`` (a target set's witness fixes
        ``Rf``).
    """
    from workbench.linear import linearize

    man = ocp.model.manifold
    for where, x in (("x0", ocp.x0), ("target", ocp.target.witness)):
        try:
            lin = linearize(ocp.model, x)
        except (ModelError, ManifoldError, SolverError, ValueError):
            continue
        A, B, N = lin.A, lin.B, lin.basis
        blocks, M = [], B
        for _ in range(A.shape[0]):
            scale = np.linalg.norm(M)
            if not scale > 0:
                break
            blocks.append(M / scale)
            M = A @ M
        if not blocks:
            continue
        dX = N @ np.hstack(blocks)  # ambient displacements the inputs reach
        axes = {}
        for name, f in man.factors:
            sl = man.slices[name]
            if isinstance(f, (S2, TS2)):
                q0 = x[sl][:3]
                dq = dX[sl.start: sl.start + 3]
                if np.linalg.norm(dq) > 1e-9:
                    d = np.linalg.svd(dq)[0][:, 0]
                    axes[name] = np.cross(q0, d)
        return axes, where
    return {}, ""


def natural_frequency(ocp: OCP, factors: list[str] | None = None) -> float | None:
    """The frequency (rad/s) of the linearisation's oscillation at ``x0`` moving ``factors`` most.

    ``x0`` must be an equilibrium (else None); ``factors`` None means all. Among the
    oscillatory eigenvectors, the one with the largest share of its ambient
    displacement in ``factors``; its ``|Im lambda|``.
    """
    from workbench.linear import linearize

    try:
        lin = linearize(ocp.model, ocp.x0)
    except (ModelError, ManifoldError, SolverError, ValueError):
        return None
    lam, V = np.linalg.eig(lin.A)
    osc = np.flatnonzero(np.abs(lam.imag) > 1e-9)
    if not osc.size:
        return None
    man = ocp.model.manifold
    names = factors or list(man.names)
    idx = np.concatenate([np.arange(man.slices[n].start, man.slices[n].stop) for n in names])
    dX = lin.basis @ V[:, osc]
    share = np.linalg.norm(dX[idx], axis=0) / np.maximum(np.linalg.norm(dX, axis=0), 1e-300)
    return float(np.abs(lam[osc[int(np.argmax(share))]].imag))


# the guesses ---------------------------------------------------------------------------------


def pumping(ocp: OCP, *, half_swings: int, wrap: float = 1.0, T: float | None = None,
            axes: dict[str, Vector] | None = None, where: str = "given",
            samples: int = SAMPLES) -> StructuredGuess:
    """The guess with ``half_swings`` reversals of the factors to invert or wrap.

    Parameters
    ----------
    ocp : OCP
        The problem.
    half_swings : int
        ``k >= 0`` (0: the direct path).
    wrap : float
        ``+1`` or ``-1``: the sense of an antipodal angle's turn.
    T : float, optional
        The guess's horizon (default: see the module docstring).
    axes : dict, optional
        Axes by factor name (default: :func:`controllable_axes`).
    where : str
        Where ``axes`` were read (for the description).
    samples : int
        Samples along ``[0, 1]``.

    Returns
    -------
    StructuredGuess
    """
    half_swings = validate.count("half_swings", half_swings, minimum=0, maximum=MAX_SWINGS)
    samples = validate.count("samples", samples, minimum=2, maximum=MAX_SAMPLES)
    if wrap not in (1.0, -1.0):
        raise ParameterError(f"wrap must be +1 or -1 (the sense of an antipodal angle's "
                             f"turn); got {wrap!r}")
    if T is not None:
        T = validate.positive("T", T)
    if axes is None:
        axes, where = controllable_axes(ocp)
    axes = {k: np.asarray(v, float) for k, v in axes.items()}
    turns = _turns(ocp, axes, wrap)
    if T is None:
        lo, hi = ocp.T_range
        omega = natural_frequency(ocp, [t.name for t in turns if t.pumped] or None)
        T = float(np.mean(ocp.T_range)) if omega is None else \
            float(np.clip((half_swings + 1) * np.pi / omega, lo, hi))
    guess, demand = _dynamic(ocp, structure(ocp.model), _path(ocp, turns, half_swings), T,
                             samples)
    pumped = [t for t in turns if t.pumped]
    text = "; ".join(f"{t.name}: {t.note}" for t in turns if t.kind != "line") or "geodesic"
    name = f"pumping k={half_swings}" if pumped and half_swings else "direct path"
    if any(t.kind == "angle" and abs(abs(t.angle) - np.pi) < 1e-9 for t in turns):
        name += " (+)" if wrap > 0 else " (-)"
    return StructuredGuess(name, guess, f"{text}; T = {T:.3g} s; axes read at "
                                        f"{where or 'no equilibrium'}; input demand "
                                        f"{demand:.3g} x the bounds", demand)


def structured_guesses(ocp: OCP, *, swings: int = 3) -> list[StructuredGuess]:
    """The default strategy's starts, in order (all of :func:`iter_structured_guesses`)."""
    return list(iter_structured_guesses(ocp, swings=swings))


def iter_structured_guesses(ocp: OCP, *, swings: int = 3) -> Iterator[StructuredGuess]:
    """The default strategy's starts, in order, each made when it is asked for.

    The energy-pumping feedback's trajectory
    (:func:`~workbench.control.ocp.pumping.energy_pumping`, where it applies), the direct
    path, then paths with 1..``swings`` reversals; an antipodal angle gives each path in
    both senses of its turn. Where the direct path's inverse-dynamics inputs lie within
    the bounds (its ``demand`` at most 1: the inputs can follow it), it comes before the
    pumping (the acrobot's elbow needs 0.35 of its bound: its pumping start converged to
    a trajectory its transcription does not follow, in 294 iterations, before the direct
    path succeeded in 86). A start the caller does not ask for (an earlier one solved the
    problem) is never built, except the direct path, whose demand decides the order.
    """
    swings = validate.count("swings", swings, minimum=0, maximum=MAX_SWINGS)
    axes, where = controllable_axes(ocp)
    turns = _turns(ocp, {k: np.asarray(v, float) for k, v in axes.items()}, 1.0)
    pumped = any(t.pumped for t in turns)
    senses = (1.0, -1.0) if any(t.kind == "angle" and abs(abs(t.angle) - np.pi) < 1e-9
                                for t in turns) else (1.0,)
    direct = [pumping(ocp, half_swings=0, wrap=sense, axes=axes, where=where)
              for sense in senses]
    if not pumped:
        yield from direct
        return
    from workbench.control.ocp.pumping import energy_pumping

    admissible = any(d.demand <= 1.0 for d in direct)  # NaN (no bounds): not admissible
    if admissible:
        yield from direct
    pump = energy_pumping(ocp, axes=axes)
    if pump is not None:
        yield pump
    if not admissible:
        yield from direct
    for k in range(1, swings + 1):
        for sense in senses:
            yield pumping(ocp, half_swings=k, wrap=sense, axes=axes, where=where)
