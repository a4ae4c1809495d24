"""The registry of controllers exportable to C: names, one-line summaries, builders."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from workbench.codegen import catalogue
from workbench.codegen.spec import ExportableController
from workbench.errors import ModelError

__all__ = ["MAX_LINKS", "build", "describe", "names"]

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

# ----------------------------------------------------------------------------------------
# the registry


@dataclass(frozen=True)
class _Family:
    pattern: str
    summary: str
    make: Callable[[dict[str, Any]], ExportableController]


_REGISTRY: dict[str, _Family] = {
    "saturated_velocity_feedback": _Family(
        "saturated_velocity_feedback",
        "paper 001 (34): u = -k P omega/(1 + |P omega|) on the full 3D pendulum",
        catalogue.saturated_velocity_feedback),
    "s2_pd": _Family("s2_pd", "paper 002 Sec. II-A: geometric PD on S^2 (spherical "
                     "pendulum)", catalogue.s2_pd),
    "so3_pd": _Family("so3_pd", "paper 002 Sec. III-A: geometric PD on SO(3) (full 3D "
                      "pendulum)", catalogue.so3_pd),
    "chain_lqr": _Family("chain_lqr_n<N>", "paper 003 (19): geometric LQR feedback of the "
                         "N-link chain on a cart, any N >= 1 (e.g. chain_lqr_n5)",
                         catalogue.chain_lqr),
    "cart_nonlinear": _Family("cart_nonlinear", "paper 003 (21), (26): nonlinear inverted "
                              "pendulum on a cart (n = 1)", catalogue.cart_nonlinear),
}

_CHAIN = re.compile(r"^chain_lqr_n([0-9]+)$")
MAX_LINKS = 50
"""Largest chain exported (the graph and the gain grow like n^2)."""


def names() -> list[str]:
    """Export names; a family with an option appears as its pattern (``chain_lqr_n<N>``)."""
    return [f.pattern for f in _REGISTRY.values()]


def describe() -> list[tuple[str, str]]:
    """``(name or pattern, one-line summary)`` of every exportable controller."""
    return [(f.pattern, f.summary) for f in _REGISTRY.values()]


def build(name: str) -> ExportableController:
    """Build the exportable controller called ``name``.

    Parameters
    ----------
    name : str
        A name of :func:`names`; the chain family is ``chain_lqr_n<N>`` with the number of
        links ``N`` (1 to :data:`MAX_LINKS`), e.g. ``"chain_lqr_n5"``.

    Returns
    -------
    ExportableController

    Raises
    ------
    ModelError
        If ``name`` is not a controller of the workbench (the message lists them).
    """
    if not isinstance(name, str) or not _NAME.match(name):
        raise ModelError(f"controller name must be a C identifier naming a controller of "
                         f"the workbench ({', '.join(names())}); got {name!r}")
    m = _CHAIN.match(name)
    if m:
        n = int(m.group(1))
        if not 1 <= n <= MAX_LINKS:
            raise ModelError(f"chain_lqr_n<N> needs 1 <= N <= {MAX_LINKS} links; got "
                             f"N = {n} (from {name!r})")
        return _REGISTRY["chain_lqr"].make({"n": n})
    if name == "chain_lqr":
        raise ModelError("chain_lqr needs the number of links in its name: chain_lqr_n<N>, "
                         "e.g. chain_lqr_n5")
    if name not in _REGISTRY:
        raise ModelError(f"{name!r} is not an exportable controller of the workbench; "
                         f"known: {', '.join(names())} (see 'workbench export-c --list')")
    return _REGISTRY[name].make({})
