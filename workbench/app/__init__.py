"""The application layer, above the problems: CLI, report, export catalogue, problem registry.

Nothing in the engine, in ``models`` or in ``problems`` imports this package (the layering
contract in ``pyproject.toml`` is checked by the tests).
"""
