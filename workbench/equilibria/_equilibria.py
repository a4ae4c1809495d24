"""Equilibria of models: ``f(x, u) = 0`` by Newton on the state manifold.

:func:`find_equilibrium` applies :func:`workbench.equilibria._roots.newton_on_manifold` to
the model's cached ``f`` and ``f_x`` graphs (the retraction keeps every iterate on the manifold; the
minimum-norm step handles non-isolated equilibria, whose local dimension it reports);
:func:`enumerate_equilibria` solves from a list of guesses, for models whose structure names
the candidates (the ``2^n`` vertical configurations of a chain), and keeps the distinct
ones and the failures with their status. Relative equilibria and branches of equilibria are
in :mod:`models.relative_equilibria` and :mod:`workbench.equilibria._continuation`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from workbench.core import validate
from workbench.core._model import Model
from workbench.core.errors import ModelError, SolverError
from workbench.core.manifolds import DEFAULT_TOL
from workbench.core.types import ArrayLike, Matrix, Vector
from workbench.equilibria._roots import (
    Root,
    RootStatus,
    ZeroProblem,
    check_count,
    check_positive,
    newton_on_manifold,
)

__all__ = [
    "Equilibrium",
    "EquilibriumSet",
    "find_equilibrium",
    "enumerate_equilibria",
    "RootStatus",
]


# ----------------------------------------------------------------------------------------
# equilibria of models


@dataclass
class Equilibrium(Root):
    """A zero of a model's vector field, with the model's name and input.

    Attributes
    ----------
    model : str
        The model's name.
    u : ndarray
        The input at which it is an equilibrium.
    parts : dict of str to ndarray
        The state split by factor name.
    """

    model: str = ""
    u: Vector = field(default_factory=lambda: np.zeros(0))
    parts: dict[str, Vector] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:  # noqa: D102
        out = super().summary()
        out.update(model=self.model, u=self.u.tolist(),
                   parts={k: v.tolist() for k, v in self.parts.items()})
        return out


def _prepare(model: Model, params: Mapping[str, ArrayLike] | None) -> Model:
    if not isinstance(model, Model):
        raise ModelError(f"model must be a workbench Model; got {type(model).__name__}")
    if params:
        return model.with_parameters(**dict(params))
    return model


@validate.arguments(
    model=validate.instance(Model, "a workbench Model", ModelError), tol=validate.tolerance,
    rank_rtol=validate.tolerance, guess_tol=validate.tolerance, max_iterations=validate.count
)
def find_equilibrium(
    model: Model,
    guess: ArrayLike,
    *,
    u: ArrayLike | None = None,
    params: Mapping[str, ArrayLike] | None = None,
    tol: float = 1e-12,
    max_iterations: int = 50,
    rank_rtol: float = 1e-8,
    max_step: float | None = None,
    guess_tol: float = DEFAULT_TOL,
    raise_on_failure: bool = True,
) -> Equilibrium:
    """An equilibrium ``f(x, u) = 0`` of a model near a guess, by Newton on the manifold.

    Parameters
    ----------
    model : Model
        The model; its cached ``f`` and ``f_x`` graphs are used.
    guess : array-like, shape=(ambient_dim,)
        Start, on the model's manifold to ``guess_tol`` (never projected silently).
    u : array-like, optional
        Constant input (zero by default).
    params : mapping, optional
        Parameter values overriding the model's (graphs shared).
    tol : float
        Convergence when ``max |f| <= tol`` (absolute, in the stored coordinates).
    max_iterations : int
        Newton iteration limit.
    rank_rtol : float
        Relative singular-value cutoff for the step and the reported rank.
    max_step : float, optional
        Largest tangent step norm per iteration.
    guess_tol : float
        Largest accepted constraint residual of the guess.
    raise_on_failure : bool
        Raise :class:`SolverError` (with the status) when not converged; with False the
        result carries the status and message instead.

    Returns
    -------
    Equilibrium
        With ``local_dimension`` the dimension of the equilibrium set near the point
        (0 when isolated; 1 on a family of relative equilibria; 2 for the free cart
        position of a chain).

    Raises
    ------
    ManifoldError
        If the guess is off the manifold.
    SolverError
        If Newton does not converge and ``raise_on_failure``.
    """
    model = _prepare(model, params)
    x0 = model.check_state(guess, name="guess", tol=guess_tol)
    tol = check_positive("tol", tol)
    max_iterations = check_count("max_iterations", max_iterations)
    rank_rtol = check_positive("rank_rtol", rank_rtol)
    if max_step is not None:
        max_step = check_positive("max_step", max_step)
    problem = ZeroProblem.equilibria(model, u=u)

    def fun(y: Vector) -> tuple[Vector, Matrix]:
        F, A, _ = problem.linearization(y)
        return F, A

    root = newton_on_manifold(fun, model.manifold, x0, tol=tol, max_iterations=max_iterations,
                              rank_rtol=rank_rtol, max_step=max_step,
                              raise_on_failure=False)
    eq = Equilibrium(**root.__dict__, model=model.name, u=problem.u,
                     parts={k: np.asarray(v) for k, v in model.manifold.split(root.x).items()})
    if not eq.ok and raise_on_failure:
        raise SolverError(
            f"find_equilibrium({model.name}): {eq.message}. Pass raise_on_failure=False to "
            f"get the last iterate with its status, or start nearer an equilibrium",
            status=eq.status.code,
        )
    return eq


@dataclass
class EquilibriumSet:
    """Distinct equilibria found from a list of guesses.

    Attributes
    ----------
    equilibria : list of Equilibrium
        Distinct converged equilibria, in the order first found.
    sources : list of list of int
        For each equilibrium, the indices of the guesses that converged to it.
    failures : dict of int to Equilibrium
        Non-converged solves by guess index (status and message inside).
    wall_time : float
        Seconds for all solves.
    """

    equilibria: list[Equilibrium]
    sources: list[list[int]]
    failures: dict[int, Equilibrium]
    wall_time: float

    def __len__(self) -> int:
        return len(self.equilibria)


@validate.arguments(
    model=validate.instance(Model, "a workbench Model", ModelError),
    distinct_tol=validate.tolerance,
    tol=validate.tolerance, rank_rtol=validate.tolerance, guess_tol=validate.tolerance,
    guesses=lambda name, value, error: list(validate.array(
        name, value, allow_empty=False, finite=False, error=error)),
)
def enumerate_equilibria(
    model: Model,
    guesses: Sequence[ArrayLike],
    *,
    u: ArrayLike | None = None,
    params: Mapping[str, ArrayLike] | None = None,
    distinct_tol: float = 1e-6,
    tol: float = 1e-12,
    max_iterations: int = 50,
    rank_rtol: float = 1e-8,
    guess_tol: float = DEFAULT_TOL,
    max_step: float | None = None,
) -> EquilibriumSet:
    """Solve from every guess and keep the distinct equilibria.

    Parameters
    ----------
    model : Model
        The model.
    guesses : sequence of array-like
        Starting points on the manifold (for example the product of the candidate
        configurations a model's structure names).
    u, params, tol, max_iterations, rank_rtol, guess_tol, max_step
        As in :func:`find_equilibrium`; ``max_step`` (the largest tangent step norm per
        Newton iteration) keeps each solve near its guess when the basins are small.
    distinct_tol : float
        Two solutions closer than this (max-norm of the stored coordinates) are the same.

    Returns
    -------
    EquilibriumSet
        Failures are kept with their status, never dropped silently.
    """
    model = _prepare(model, params)
    distinct_tol = check_positive("distinct_tol", distinct_tol)
    t0 = time.perf_counter()
    found: list[Equilibrium] = []
    sources: list[list[int]] = []
    failures: dict[int, Equilibrium] = {}
    for i, g in enumerate(guesses):
        eq = find_equilibrium(model, g, u=u, tol=tol, max_iterations=max_iterations,
                              rank_rtol=rank_rtol, guess_tol=guess_tol,
                              max_step=max_step, raise_on_failure=False)
        if not eq.ok:
            failures[i] = eq
            continue
        for j, other in enumerate(found):
            if float(np.max(np.abs(other.x - eq.x))) <= distinct_tol:
                sources[j].append(i)
                break
        else:
            found.append(eq)
            sources.append([i])
    return EquilibriumSet(found, sources, failures, time.perf_counter() - t0)
