"""Optimal control on manifolds: a declarative problem, pluggable transcriptions, Ipopt.

>>> ocp = OCP(model, x0=x0, target=TargetPoint(model.manifold, xf), u_lower=-10,
...           u_upper=10, T=(0.5, 3.0), running_cost=lambda x, u: u.T @ u,
...           terminal_cost=lambda x, T: T)                      # doctest: +SKIP
>>> sol = solve(ocp, Collocation(N=40, degree=3))                # doctest: +SKIP
>>> sol = solve(ocp, HermiteSimpson(N=40))      # Drake's transcription # doctest: +SKIP
>>> sol.status, sol.message                                      # doctest: +SKIP
"""

from workbench.control.ocp.auto import Auto, Direct
from workbench.control.ocp.compiled import Compiled
from workbench.control.ocp.expand import sx_function
from workbench.control.ocp.guess import Guess
from workbench.control.ocp.hermite_simpson import HermiteSimpson
from workbench.control.ocp.initial import StructuredGuess, structured_guesses
from workbench.control.ocp.local import ProductLocal, local_for
from workbench.control.ocp.problem import OCP, PathConstraint, TargetPoint, TargetSet
from workbench.control.ocp.pumping import energy_pumping
from workbench.control.ocp.solve import OCPSolution, OCPStatus, solve, transcribe
from workbench.control.ocp.stepper import Stepper
from workbench.control.ocp.strategies import coarse_to_fine, homotopy, multistart, refine
from workbench.control.ocp.symmetry import Symmetry, detect_symmetry
from workbench.control.ocp.transcription import (
    Collocation,
    Integrator,
    ManifoldHandling,
    MultipleShooting,
    Scheme,
    Transcription,
)

__all__ = [
    "OCP",
    "Auto",
    "Collocation",
    "Direct",
    "Compiled",
    "Guess",
    "HermiteSimpson",
    "Integrator",
    "ManifoldHandling",
    "MultipleShooting",
    "OCPSolution",
    "OCPStatus",
    "PathConstraint",
    "ProductLocal",
    "Scheme",
    "Stepper",
    "StructuredGuess",
    "Symmetry",
    "TargetPoint",
    "TargetSet",
    "Transcription",
    "coarse_to_fine",
    "homotopy",
    "detect_symmetry",
    "energy_pumping",
    "local_for",
    "multistart",
    "refine",
    "solve",
    "structured_guesses",
    "sx_function",
    "transcribe",
]
