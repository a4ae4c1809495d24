"""Reports of the problems, as one self-contained HTML file and one PDF.

A document first, a record second: a first page in plain words with a figure (status of
every problem, each one's most telling comparison, the errata confirmed, findings beyond
the papers), then for each problem a short paragraph, its key numbers, its figures (animated
in the HTML) and its notes. The PDF is that body, for print; the HTML adds the full tables
and the models in a folded appendix, and every table is also a CSV file with every value
(``<stem>-tables/<problem>/<table>.csv``). Problems run in parallel processes, each with a time
limit and a memory report, and are re-used from an on-disk cache when nothing they depend
on changed.

>>> from workbench.app.report import build_report, Format      # doctest: +SKIP
>>> rep = build_report(["pendulum3d_invariants"], quick=True,  # doctest: +SKIP
...                    formats=[Format.HTML])
>>> rep.paths[Format.HTML]                                     # doctest: +SKIP
PosixPath('.../reports/out/report-quick.html')
"""

from workbench.app.report.build import (
    DEFAULT_CACHE,
    DEFAULT_OUT,
    Format,
    Report,
    build_report,
    check_out_dir,
    rebuild,
    write_atomic,
)
from workbench.app.report.collect import ProblemRun, Status, models_of, run_problem, run_problems
from workbench.app.report.document import ProblemSection, problem_section
from workbench.app.report.errors import ReportError, ReportInputError
from workbench.app.report.frontpage import Document, document
from workbench.app.report.runner import Outcome, RunStats, outcome_of, run_all

__all__ = [
    "DEFAULT_CACHE",
    "DEFAULT_OUT",
    "Document",
    "Format",
    "Outcome",
    "ProblemRun",
    "ProblemSection",
    "Report",
    "ReportError",
    "ReportInputError",
    "RunStats",
    "Status",
    "build_report",
    "check_out_dir",
    "document",
    "models_of",
    "outcome_of",
    "problem_section",
    "rebuild",
    "run_all",
    "run_problem",
    "run_problems",
    "write_atomic",
]
