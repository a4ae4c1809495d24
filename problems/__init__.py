"""Define-and-solve scripts, one per reproduced paper result or study.

Each module ``problems/NAME.py`` defines ``TITLE`` (one line) and
``solve(*, quick=False) -> workbench.study.Result``, and runs as a script
(``python -m problems.NAME [--quick] [--json PATH]``). The registry that lists and loads
them is :mod:`workbench.app.registry`, in the application layer above this package.
"""
