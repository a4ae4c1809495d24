"""The symbols of a system and the checks of what an expression may depend on.

Every symbol a :class:`~workbench.mechanics.System` hands out is registered here with its
kind (configuration, velocity, input, parameter) and a readable label, so that a message
can say *which* velocity a position depends on, or that an expression uses symbols this
system did not create.
"""

from __future__ import annotations

import casadi as ca

from workbench.mechanics._engine import ModelError

__all__ = ["SymbolTable", "CONFIG", "VELOCITY", "INPUT", "PARAMETER"]

CONFIG, VELOCITY, INPUT, PARAMETER = "configuration", "velocity", "input", "parameter"


class SymbolTable:
    """Registry of the SX symbols of one system, by identity.

    Not by name: another System's ``k`` has the same name and is not this one's.
    """

    def __init__(self) -> None:
        self._kind: dict[int, tuple[str, str]] = {}
        self._symbols: list[ca.SX] = []  # kept alive: the keys are their elements' addresses

    def new(self, prefix: str, n: int, kind: str, label: str) -> ca.SX:
        """A fresh column of ``n`` symbols named ``prefix_0 ..`` of the given kind."""
        sym = ca.SX.sym(prefix, n)
        self._symbols.append(sym)
        for el in ca.symvar(sym):
            self._kind[el.element_hash()] = (kind, label)
        return sym

    def kinds(self, expr: ca.SX, what: str) -> dict[str, set[str]]:
        """``{kind: labels}`` of the symbols ``expr`` uses; ModelError for foreign ones."""
        out: dict[str, set[str]] = {}
        foreign = []
        for el in ca.symvar(ca.SX(expr)):
            entry = self._kind.get(el.element_hash())
            if entry is None:
                foreign.append(el.name())
                continue
            out.setdefault(entry[0], set()).add(entry[1])
        if foreign:
            raise ModelError(
                f"{what} uses symbols this System did not create: {sorted(foreign)[:6]}; build "
                "expressions from the System's factors, parameters and inputs (a symbol of "
                "another System is not this one's, even with the same name)"
            )
        return out

    def require(self, expr: ca.SX, what: str, allowed: tuple[str, ...], hint: str = "") -> None:
        """ModelError when ``expr`` depends on a symbol kind not in ``allowed``."""
        for kind, labels in self.kinds(expr, what).items():
            if kind not in allowed:
                raise ModelError(
                    f"{what} must depend only on {' and '.join(allowed) or 'numbers'}; got a "
                    f"dependence on the {kind} {sorted(labels)}" + (f" ({hint})" if hint else "")
                )
