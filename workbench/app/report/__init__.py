"""Reports of the problems, as one self-contained HTML file and one PDF.

For every problem: its models (manifold, state, parameters, equations, the vector field
read from the built graph), what was built, the results as tables, the figures, the
paper's values beside the workbench's, the cost and accuracy of each computation, and the
environment.

>>> from workbench.app.report import build_report, Format          # doctest: +SKIP
>>> rep = build_report(["pendulum3d_invariants"], quick=True,  # doctest: +SKIP
...                    formats=[Format.HTML])
>>> rep.paths[Format.HTML]                                     # doctest: +SKIP
PosixPath('.../reports/out/report-quick.html')
"""

from workbench.app.report.build import (
    DEFAULT_OUT,
    Format,
    Report,
    build_report,
    check_out_dir,
    rebuild,
    write_atomic,
)
from workbench.app.report.collect import ProblemRun, Status, models_of, run_problem, run_problems
from workbench.app.report.document import Document, document
from workbench.app.report.errors import ReportError, ReportInputError

__all__ = [
    "DEFAULT_OUT",
    "Document",
    "Format",
    "ProblemRun",
    "Report",
    "ReportError",
    "ReportInputError",
    "Status",
    "build_report",
    "check_out_dir",
    "document",
    "models_of",
    "rebuild",
    "run_problem",
    "run_problems",
    "write_atomic",
]
