"""What an exportable controller is: its function, its documentation, its bindings.

An :class:`ExportableController` holds a controller (a ``casadi.Function``
``u = k(x, p)``), the model it controls with the parameter values of an example, the
default gains of that example, the units and meaning of every input and output entry (for
the C header), an example state, and a sampler of test states that crowds the
controller's singular or saturated regions. The engine knows no concrete controller: the
papers' controllers are built by :func:`workbench.app.catalogue.build`.

For :attr:`Binding.PARAMETERS_AND_GAINS` the gains become run-time inputs: the entry's
``law`` builds the same law with the gains as casadi symbols (for the papers' controllers,
the ``*_law`` functions of :mod:`models.controllers` that their builders also use); at the
default gains it must reproduce the controller, which ``tests/test_codegen.py`` checks to
1e-12 on sampled states.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import casadi as ca
import numpy as np

from workbench.core import validate
from workbench.core._model import Context, Model
from workbench.core.errors import ModelError

__all__ = ["Binding", "Entry", "ExportableController", "Law", "Sampler", "MAX_SAMPLES"]

E3 = np.array([0.0, 0.0, 1.0])

MAX_SAMPLES = 1_000_000
"""Most test states of one :meth:`ExportableController.sample_states` (and of ``workbench
export-c --verify``): checking 10^5 states of a small controller against casadi takes
about 0.7 s, so the bound is about ten seconds of checking and, for a state of 100
entries, 0.8 GB of states."""


class Binding(str, Enum):
    """What the exported code takes at run time besides the state.

    Attributes
    ----------
    FROZEN
        Model parameters and gains are constants of the generated code (smallest, fastest
        code); the run-time vector ``p`` is empty. Changing a value means exporting again.

    Parameters
    ----------
        The model's parameters (:attr:`Model.p`, in its storage order) are the run-time
        vector ``p``; the gains are constants.
    PARAMETERS_AND_GAINS
        ``p`` holds the model's parameters followed by the gains (each flattened row-major).
        The generated code does not check the gains against the papers' conditions.
    """

    FROZEN = "frozen"
    PARAMETERS = "parameters"
    PARAMETERS_AND_GAINS = "parameters-and-gains"

    @classmethod
    def _missing_(cls, value: object) -> Binding:
        raise ModelError(f"binding must be one of {[b.value for b in cls]} (or a Binding); "
                         f"got {value!r}")


@dataclass(frozen=True)
class Entry:
    """One named block of an input or output vector, for the C header.

    Attributes
    ----------
    name : str
        Name, e.g. ``"omega"``.
    size : int
        Number of scalars.
    description : str
        Meaning, unit and storage order.
    """

    name: str
    size: int
    description: str

    def __post_init__(self) -> None:
        validate.identifier("Entry name (a C identifier in the generated code)", self.name,
                            error=ModelError)
        validate.count(f"size of entry {self.name!r}", self.size, minimum=0, error=ModelError)
        if not isinstance(self.description, str):
            raise ModelError(f"description of entry {self.name!r} must be a str; got "
                             f"{type(self.description).__name__}")


Law = Callable[[Context, dict[str, Any]], Any]
Sampler = Callable[[np.random.Generator, int], np.ndarray]


C_RESERVED = frozenset({
    # C99/C11 keywords and macros of the headers the generated code includes
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch",
    "typedef", "union", "unsigned", "void", "volatile", "while", "bool", "true", "false",
    "NULL", "EOF", "errno", "assert",
    # functions and files of the generated project and the C library it calls
    "main", "bench", "example", "printf", "fprintf", "exit", "malloc", "free", "memcpy",
    "memset", "time", "clock", "sqrt", "fabs", "sin", "cos", "tan", "exp", "log", "pow",
    "atan2", "floor", "fmin", "fmax", "casadi",
})
"""Names refused as the C prefix of an export: they collide in the generated code."""

MAX_NAME = 64
"""Longest C prefix (file names and symbols are built from it)."""


@dataclass
class ExportableController:
    """A controller of the workbench with everything an export needs.

    Attributes
    ----------
    name : str
        Export name, a C identifier (the prefix of every C symbol).
    title : str
        One line: what it is, with the paper's equation numbers.
    model : Model
        The controlled model, with the paper's parameter values.
    function : casadi.Function
        The workbench's controller ``(x, p) -> u`` (the reference of every check).
    gains : dict of str to ndarray
        The default gains (the paper's example), in the order of :attr:`gain_entries`.
    gain_entries : tuple of Entry
        Documentation of the gains as run-time inputs.
    law : callable
        ``law(ctx, gains) -> u``: the same law with symbolic ``gains`` (dict by name).
    state_entries : tuple of Entry
        Documentation of the stored state ``x``.
    output : Entry
        Documentation of ``u``.
    example_state : ndarray
        A state on the model's manifold (the paper's initial condition).
    example_note : str
        Where the example state comes from.
    singular : str
        Where the law is singular or saturates (for the header and the tests).
    sampler : callable
        ``sampler(rng, n) -> states, shape=(n, nx)``: generic and near-singular states.
    """

    name: str
    title: str
    model: Model
    function: ca.Function
    gains: dict[str, np.ndarray]
    gain_entries: tuple[Entry, ...]
    law: Law
    state_entries: tuple[Entry, ...]
    output: Entry
    example_state: np.ndarray
    example_note: str
    singular: str
    sampler: Sampler
    _cache: dict[Binding, ca.Function] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        # the name prefixes every C symbol and file: a C identifier, checked, never mangled
        validate.identifier("name (the C prefix of the export)", self.name, error=ModelError)
        if (self.name in C_RESERVED or self.name.startswith("_") or "__" in self.name
                or len(self.name) > MAX_NAME):
            raise ModelError(
                f"name (the C prefix of the export) must not be a C keyword or a name the "
                f"generated code uses ({', '.join(sorted(C_RESERVED)[:8])}, ...), start with "
                f"'_', contain '__' (reserved in C and by casadi) or exceed {MAX_NAME} "
                f"characters; got {self.name!r}")
        if not isinstance(self.model, Model):
            raise ModelError(f"model must be a workbench Model; got {type(self.model).__name__}")
        for label in ("title", "example_note", "singular"):
            if not isinstance(getattr(self, label), str):
                raise ModelError(f"{label} must be a str; got "
                                 f"{type(getattr(self, label)).__name__}")

    @property
    def nx(self) -> int:
        """Size of the stored state."""
        return int(self.model.manifold.ambient_dim)

    @property
    def nu(self) -> int:
        """Number of inputs of the model (size of ``u``)."""
        return int(self.model.n_inputs)

    def parameter_entries(self) -> tuple[Entry, ...]:
        """The model's parameters as header entries (matrices row-major)."""
        return tuple(Entry(p.name, p.size, p.description + (
            ", row-major" if len(p.shape) == 2 else "")) for p in self.model.parameters)

    def runtime_entries(self, binding: Binding) -> tuple[Entry, ...]:
        """Layout of the run-time vector ``p`` for a binding."""
        binding = Binding(binding)
        if binding is Binding.FROZEN:
            return ()
        if binding is Binding.PARAMETERS:
            return self.parameter_entries()
        return self.parameter_entries() + self.gain_entries

    def runtime_values(self, binding: Binding) -> np.ndarray:
        """The run-time vector ``p`` holding the model's values and the default gains."""
        binding = Binding(binding)
        if binding is Binding.FROZEN:
            return np.zeros(0)
        if binding is Binding.PARAMETERS:
            return np.asarray(self.model.p, dtype=float)
        flat = [np.asarray(self.gains[e.name], dtype=float).reshape(-1) for e in
                self.gain_entries]
        return np.concatenate([self.model.p, *flat])

    def function_for(self, binding: Binding) -> ca.Function:
        """The SX function exported for a binding, named :attr:`name`.

        ``FROZEN``: ``x -> u`` with the model's values substituted (constants folded);
        ``PARAMETERS``: the workbench's controller ``(x, p) -> u`` (expanded to SX);
        ``PARAMETERS_AND_GAINS``: ``(x, p) -> u`` from :attr:`law` with ``p`` the model's
        parameters followed by the gains.
        """
        binding = Binding(binding)
        if binding in self._cache:
            return self._cache[binding]
        x = ca.SX.sym("x", self.nx)
        ref = self.function.expand() if self.function.is_a("MXFunction") else self.function
        if binding is Binding.FROZEN:
            fn = ca.Function(self.name, [x], [ref(x, ca.DM(self.model.p))], ["x"], ["u"])
        elif binding is Binding.PARAMETERS:
            p = ca.SX.sym("p", self.model.n_params)
            fn = ca.Function(self.name, [x, p], [ref(x, p)], ["x", "p"], ["u"])
        else:
            n_par = self.model.n_params
            n_all = n_par + sum(e.size for e in self.gain_entries)
            p = ca.SX.sym("p", n_all)
            ctx = Context(self.model, x, ca.SX.sym("u", self.nu), p[:n_par])
            gains, k = {}, n_par
            for e in self.gain_entries:
                shape = np.shape(self.gains[e.name])
                piece = p[k:k + e.size]
                gains[e.name] = (ca.reshape(piece, shape[1], shape[0]).T
                                 if len(shape) == 2 else piece)
                k += e.size
            fn = ca.Function(self.name, [x, p], [ca.vec(self.law(ctx, gains))], ["x", "p"],
                             ["u"], {"cse": True})
        self._cache[binding] = fn
        return fn

    def sample_states(self, n: int, *, seed: int) -> np.ndarray:
        """``n`` seeded test states, shape ``(n, nx)`` (see :attr:`sampler`).

        Parameters
        ----------
        n : int
            Number of states, 1 to :data:`MAX_SAMPLES` (checked before any is drawn).
        seed : int
            Seed of the generator (>= 0).

        Returns
        -------
        ndarray, shape=(n, nx)

        Raises
        ------
        ModelError
            ``n`` or ``seed`` is not a whole number in range.
        """
        n = validate.count("n", n, maximum=MAX_SAMPLES, error=ModelError)
        seed = validate.count("seed", seed, minimum=0, error=ModelError)
        return np.asarray(self.sampler(np.random.default_rng(seed), n), dtype=float)
