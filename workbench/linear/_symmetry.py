"""Which centre directions of a linearisation come from a symmetry.

At an equilibrium ``x_e`` of a model with a conserved quantity ``J`` (``dJ/dt = 0`` for
every state), differentiating ``grad J . f = 0`` at ``x_e`` gives ``c^T A = 0`` with
``c = N^T grad J(x_e)`` in tangent coordinates: every conserved quantity whose
differential does not vanish there is a *left* null vector of ``A``, and forces a zero
eigenvalue. A symmetry whose group moves ``x_e`` (``delta x = xi(x_e) != 0``) maps
equilibria to equilibria, so its orbit direction ``v = N^+ xi(x_e)`` is a *right* null
vector, ``A v = 0``. Both are *verified* here, to a relative tolerance, before they are
reported: a momentum that a closed loop or an input does not conserve is said so, not
assumed.

The orbit directions need the symmetry's action on the state, which models made by
:mod:`workbench.mechanics` carry (``model.symmetry_actions``); for other models only the
conserved quantities (``model.invariant_names``) are read. The action is taken at rest
(velocities unchanged), so orbit directions are computed only at states at rest (every
velocity at most ``rtol``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import ModelError, validate

__all__ = ["SymmetryDirections", "symmetry_directions"]


@dataclass(frozen=True)
class SymmetryDirections:
    """The zero eigenvalues of a linearisation that symmetries and invariants account for.

    Attributes
    ----------
    n_zero : int
        Eigenvalues with ``|lambda| <= zero_tol``.
    zero_tol : float
        That threshold (``rtol * max(1, |A|_2)``).
    orbits : dict of str to ndarray, shape=(dim,)
        Verified orbit directions (tangent coordinates, ``A v ~ 0``), by symmetry name.
    conserved : dict of str to ndarray, shape=(dim,)
        Verified left null vectors ``c = N^T grad J`` (``c^T A ~ 0``), by invariant name.
    not_conserved : dict of str to float
        Invariants whose differential is not a left null vector here (closed loop, input
        at the point), with ``|c^T A| / (|c| |A|)``.
    vanishing : list of str
        Invariants whose differential vanishes at the point (no information).
    fixed : list of str
        Symmetries that leave the point fixed (orbit direction zero).
    notes : list of str
        What was not computed, and why.
    examined : bool
        Whether the orbit directions were computed (a model with symmetry actions, at a
        state at rest); without them :attr:`unexplained` is ``None``.
    rtol : float
        The relative tolerance of the checks (also of the ranks).
    """

    n_zero: int
    zero_tol: float
    orbits: dict = field(default_factory=dict)
    conserved: dict = field(default_factory=dict)
    not_conserved: dict = field(default_factory=dict)
    vanishing: list = field(default_factory=list)
    fixed: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    examined: bool = True
    rtol: float = 1e-8

    @property
    def orbit_rank(self) -> int:
        """Dimension spanned by the verified orbit directions."""
        return _rank(list(self.orbits.values()), self.rtol)

    @property
    def conserved_rank(self) -> int:
        """Dimension spanned by the verified left null vectors."""
        return _rank(list(self.conserved.values()), self.rtol)

    @property
    def unexplained(self) -> int | None:
        """Zero eigenvalues beyond one per orbit direction and one per conserved momentum.

        At a state at rest an orbit direction ``v`` and the momentum of the same symmetry
        ``c`` satisfy ``c . v = 0`` (the momentum is linear in the velocities), so they form
        a Jordan pair: one zero eigenvalue each. What is left over is a neutral direction
        of this equilibrium that no declared or detected symmetry explains. ``None`` when
        the orbits were not examined, or when fewer zero eigenvalues were counted than the
        verified directions account for (the count is then not to be trusted; see
        :attr:`notes`).
        """
        accounted = self.orbit_rank + self.conserved_rank
        if not self.examined or self.n_zero < accounted:
            return None
        return self.n_zero - accounted

    def describe(self) -> str:
        """One line for a table, e.g. ``"4 zero eigenvalues: orbits of px, py; ..."``."""
        parts = [f"{self.n_zero} zero eigenvalue{'s' if self.n_zero != 1 else ''}"]
        if self.orbits:
            parts.append(f"{self.orbit_rank} orbit direction(s) of {', '.join(self.orbits)}")
        if self.conserved:
            parts.append(f"{self.conserved_rank} conserved: {', '.join(self.conserved)}")
        if self.fixed:
            parts.append(f"fixed by {', '.join(self.fixed)}")
        if self.unexplained is None:
            parts.append("origin of the others not examined" if not self.examined
                         else "fewer zeros than the symmetries account for (see notes)")
        elif self.unexplained:
            parts.append(f"{self.unexplained} not from a symmetry")
        return "; ".join(parts)


def _rank(vectors: list, rtol: float) -> int:
    """Numerical rank of unit vectors, singular values above ``sqrt(rtol)`` counting."""
    if not vectors:
        return 0
    return int(np.linalg.matrix_rank(np.column_stack(vectors), tol=np.sqrt(rtol)))


def _gradient(model: Any, name: str) -> ca.Function:
    fn = model.function(name)
    x = ca.SX.sym("x", fn.size1_in(0))
    p = ca.SX.sym("p", fn.size1_in(1))
    return ca.Function(f"grad_{name}", [x, p], [ca.gradient(fn(x, p), x)])


def symmetry_directions(lin: Any, *, rtol: float = 1e-8) -> SymmetryDirections:
    """Account for the zero eigenvalues of a linearisation by symmetries and invariants.

    Parameters
    ----------
    lin : LinearModel
        A linearisation (:func:`workbench.linearize`), open or closed loop.
    rtol : float
        Relative tolerance of every check: ``|A v| <= rtol |A| |v|``,
        ``|c^T A| <= rtol |A| |c|``, vanishing differentials
        ``|N^T grad J| <= rtol max(1, |grad J|)``, velocities at rest ``<= rtol``. Zero
        eigenvalues are those with ``|lambda| <= sqrt(rtol) max(1, |A|)``: the symmetries'
        zeros come in Jordan pairs, which a perturbation ``delta`` of ``A`` splits into
        eigenvalues of size ``sqrt(delta)``.

    Returns
    -------
    SymmetryDirections

    Raises
    ------
    ModelError
        If ``lin`` is not a linearisation.
    """
    rtol = validate.tolerance("rtol", rtol)
    if not all(hasattr(lin, k) for k in ("A", "basis", "x_e", "model")):
        raise ModelError(f"lin must be a LinearModel (from linearize); got "
                         f"{type(lin).__name__}")
    A, N = np.asarray(lin.A, float), np.asarray(lin.basis, float)
    x, model = np.asarray(lin.x_e, float), lin.model
    a_norm = max(1.0, float(np.linalg.norm(A, 2)))
    zero_tol = np.sqrt(rtol) * a_norm
    n_zero = int(np.sum(np.abs(np.linalg.eigvals(A)) <= zero_tol)) if A.size else 0
    conserved, not_conserved, vanishing = {}, {}, []
    for name in model.invariant_names:
        g = np.asarray(_gradient(model, name)(x, model.p), float).ravel()
        c = N.T @ g
        if np.linalg.norm(c) <= rtol * max(1.0, float(np.linalg.norm(g))):
            vanishing.append(name)
            continue
        defect = float(np.linalg.norm(c @ A) / (np.linalg.norm(c) * a_norm))
        if defect <= rtol:
            conserved[name] = c / np.linalg.norm(c)
        else:
            not_conserved[name] = defect
    orbits, fixed, notes = {}, [], []
    actions = getattr(model, "symmetry_actions", {}) or {}
    at_rest = _at_rest(model, x, rtol)
    if actions and not at_rest:
        notes.append("orbit directions not computed: the point is not at rest")
    elif not actions:
        notes.append("orbit directions not computed: the model carries no symmetry actions "
                     "(models made by workbench.mechanics do)")
    for name, act in (actions.items() if at_rest else ()):
        dx = np.asarray(act(x, model.p), float).ravel()
        v, *_ = np.linalg.lstsq(N, dx, rcond=None)
        if np.linalg.norm(v) <= rtol * max(1.0, np.linalg.norm(dx)):
            fixed.append(name)
            continue
        defect = float(np.linalg.norm(A @ v) / (a_norm * np.linalg.norm(v)))
        if defect <= rtol:
            orbits[name] = v / np.linalg.norm(v)
        else:
            notes.append(f"the orbit of {name} is not in the kernel of A here "
                         f"(|A v|/(|A||v|) = {defect:.1e})")
    examined = bool(actions) and at_rest
    out = SymmetryDirections(n_zero=n_zero, zero_tol=zero_tol, orbits=orbits,
                             conserved=conserved, not_conserved=not_conserved,
                             vanishing=vanishing, fixed=fixed, notes=notes,
                             examined=examined, rtol=rtol)
    if n_zero < out.orbit_rank + out.conserved_rank:
        notes.append(f"{n_zero} eigenvalues within {zero_tol:.1e} of zero, fewer than the "
                     f"{out.orbit_rank + out.conserved_rank} verified directions account for:"
                     " A is not exact to rtol here")
    return out


def _at_rest(model: Any, x: np.ndarray, tol: float) -> bool:
    """True when every velocity of the state is at most ``tol`` (mechanics models).

    The action is taken with velocities unchanged, an error of the order of the
    velocities: an equilibrium from a Newton solve carries velocities of rounding size.
    """
    der = getattr(model, "mechanics", None)
    if der is None:
        return False
    nu = np.asarray(ca.Function("nu", [der.x], [der.nu])(x), dtype=float)
    return bool(np.all(np.abs(nu) <= tol))
