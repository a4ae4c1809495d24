"""The module paths of 0.1.0 that the rooms of 0.2.0 replaced.

In 0.1.0 the engine was a flat folder (``workbench/model.py``, ``workbench/poincare.py``,
...); 0.2.0 groups it into rooms (``workbench.core``, ``workbench.global_dynamics``, ...) whose
implementation modules are private. Scripts written against 0.1.0 keep working through one
import hook, :class:`MovedPaths`, placed first on :data:`sys.meta_path` when ``workbench`` is
imported:

- :data:`ALIASES` — documented paths that stay, silently: ``workbench.manifolds``,
  ``.errors``, ``.symbolic``, ``.ocp`` and their submodules are the very module objects of
  their rooms (``import workbench.manifolds.lie`` is ``workbench.core.manifolds.lie``, not a
  second copy whose classes would fail ``isinstance``).
- :data:`DEPRECATED` — the other 0.1.0 modules: importing one issues a
  :class:`DeprecationWarning` naming the new path (attributed to the importing line, so a
  script's ``__main__`` shows it by default) and gives a module with exactly the names that
  module exported in 0.1.0, the same objects as in their new homes. They go in
  :data:`REMOVED_IN`.
- :data:`GONE` — paths that cannot return, imported with an error naming the new path:
  ``workbench.simulate``, ``.linearize``, ``.lqr``, ``.sweep`` and ``.tvlqr`` are public
  functions of the package, which a module of the same name would replace on import; the
  rigid body's relative equilibria moved to ``models`` (the engine knows no concrete model).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys
import types
import warnings

MOVED_IN = "0.2.0"
REMOVED_IN = "0.3.0"

#: Documented paths kept for good, without a warning: old prefix -> new prefix.
ALIASES = {
    "workbench.manifolds": "workbench.core.manifolds",
    "workbench.errors": "workbench.core.errors",
    "workbench.symbolic": "workbench.linear.symbolic",
    "workbench.ocp": "workbench.control.ocp",
}

#: Deprecated 0.1.0 modules: path -> (new module, the names the module exported in 0.1.0).
#: ``name=module`` takes the name from another module, ``name=module:new`` a renamed one.
DEPRECATED: dict[str, tuple[str, str]] = {
    "workbench.accuracy": ("workbench.simulation.accuracy",
        "Knob Cost Sweep=workbench.simulation.accuracy:AccuracySweep Run Reference WorkPrecision "
        "LongRun LongTime default_reference work_precision long_time"),
    "workbench.accuracy.long_time": ("workbench.simulation.accuracy.long_time",
        "LongRun LongTime long_time"),
    "workbench.accuracy.sweep": ("workbench.simulation.accuracy.sweep",
        "Knob Sweep=workbench.simulation.accuracy.sweep:AccuracySweep"),
    "workbench.accuracy.work_precision": ("workbench.simulation.accuracy.work_precision",
        "Cost Run Reference WorkPrecision default_reference work_precision"),
    "workbench.ambient_linearization": ("workbench.linear",
        "AmbientLinearization linearize_ambient closed_loop_jacobians EQUILIBRIUM_TOL"),
    "workbench.attraction": ("workbench.control",
        "Constraint Extremum optimize optimize_lyapunov level_in_domain ConvergenceReport "
        "check_convergence BasinEstimate estimate_basin clopper_pearson"),
    "workbench.branch": ("workbench.equilibria",
        "StepControl EndReason PointKind SpecialPoint Branch BranchSwitch"),
    "workbench.cli": ("workbench.app.cli",
        "main run_script=workbench.study build_parser benchmark_scripts"),
    "workbench.codegen_cli": ("workbench.app.export_cli", "add_export_c_parser main run_export_c"),
    "workbench.continuation": ("workbench.equilibria",
        "StepControl EndReason PointKind SpecialPoint Branch BranchSwitch continue_branch "
        "switch_branch correct_point locate_on_branch"),
    "workbench.controllability": ("workbench.linear",
        "ModeTest PBHResult KalmanResult SecondOrderForm pbh pbh_second_order kalman_rank "
        "second_order_form PBH_TOL"),
    "workbench.eigen": ("workbench.linear",
        "Stability Subspace Eigenstructure eigenstructure default_tol"),
    "workbench.evaluator": ("workbench.core", "Evaluator DenseEvaluator"),
    "workbench.feedback": ("workbench.core", "feedback_function"),
    "workbench.ftle": ("workbench.global_dynamics", "LyapunovEstimate lyapunov_exponent"),
    "workbench.integrators": ("workbench.simulation.integrators",
        "CHUNK NEWTON_MAX_ITER NEWTON_TOL Integration "
        "Scheme=workbench.simulation.integrators:DiscreteFlow integrate lgvi rkmk4 s2_variational"),
    "workbench.integrators.common": ("workbench.simulation.integrators.common",
        "Scheme=workbench.simulation.integrators.common:DiscreteFlow Integration NEWTON_TOL "
        "NEWTON_MAX_ITER CHUNK feedback_function controller_key newton integrate "
        "check_newton_options"),
    "workbench.integrators.lgvi": ("workbench.simulation.integrators.lgvi",
        "lgvi rigid_body_factors"),
    "workbench.integrators.rkmk": ("workbench.simulation.integrators.rkmk", "rkmk4 se3_v"),
    "workbench.integrators.s2_variational": ("workbench.simulation.integrators.s2_variational",
        "s2_variational"),
    "workbench.invariant_manifolds": ("workbench.global_dynamics",
        "InvariantManifold Subspace=workbench.linear VECTORISED_METHODS invariant_manifold "
        "stable_manifold unstable_manifold"),
    "workbench.lyapunov": ("workbench.control",
        "Lyapunov Monotonicity as_states state_function SublevelSet ray_extent"),
    "workbench.manifold_seeds": ("workbench.global_dynamics",
        "sphere_directions direction_spread equilibrium_distance distances ball_points "
        "batch_evaluate"),
    "workbench.manifold_validation": ("workbench.global_dynamics",
        "Validation validate compare_per_point"),
    "workbench.model": ("workbench.core",
        "Symbolic Parameter BuildRecord BuildLog Context Model positive nonnegative spd3 finite "
        "Evaluator"),
    "workbench.phase": ("workbench.global_dynamics",
        "cone_integral holonomy_angle wrap_angle first_self_intersection PhaseCheck "
        "geometric_phase_check"),
    "workbench.plots": ("workbench.study",
        "MAX_SEGMENTS decimate sphere_axes sphere_curves mark_directions body_axis_curves "
        "s2_manifold_figure so3_manifold_figure"),
    "workbench.poincare": ("workbench.global_dynamics",
        "Direction Stepper=workbench.simulation:Multistep OrbitStatus Section turning_section "
        "turning_section_state stabilized_field PoincareOrbit poincare_map"),
    "workbench.report": ("workbench.app.report",
        "DEFAULT_OUT Document Format ProblemRun Report ReportError ReportInputError Status "
        "build_report check_out_dir document models_of rebuild run_problem run_problems "
        "write_atomic"),
    "workbench.report.build": ("workbench.app.report.build",
        "Format Report DEFAULT_OUT build_report check_out_dir rebuild write_atomic"),
    "workbench.report.collect": ("workbench.app.report.collect",
        "Status ProblemRun models_of figure_svg run_problem run_problems"),
    "workbench.report.document": ("workbench.app.report.document",
        "Math ModelSheet ProblemSection Document=workbench.app.report.frontpage math model_sheet "
        "problem_section document=workbench.app.report.frontpage"),
    "workbench.report.environment": ("workbench.app.report.environment", "environment PACKAGES"),
    "workbench.report.errors": ("workbench.app.report.errors", "ReportError ReportInputError"),
    "workbench.report.html": ("workbench.app.report.html", "TEMPLATES render_html"),
    "workbench.report.latexmath": ("workbench.app.report.latexmath",
        "LatexError parse to_mathml to_typst"),
    "workbench.report.latexparse": ("workbench.app.report.latexparse",
        "LatexError parse Node Row Ident Num Op Text Space Frac Sqrt Accent Style Func Scripts "
        "Fenced Matrix ACCENTS SPACES"),
    "workbench.report.pdf": ("workbench.app.report.pdf", "render_pdf typst_data"),
    "workbench.report.symbolic": ("workbench.app.report.symbolic",
        "SymbolicError casadi_to_sympy state_symbols parameter_symbols ParameterRow FieldRow "
        "parameter_rows vector_field_rows MAX_NODES MAX_SIZE MAX_CONVERT MAX_LATEX"),
    "workbench.report.tables": ("workbench.app.report.tables",
        "Table fmt comparison_table value_tables cost_accuracy_table build_table MAX_ROWS "
        "MAX_COLS"),
    "workbench.result": ("workbench.study",
        "Comparison Result ResultStatus to_jsonable format_result"),
    "workbench.roots": ("workbench.equilibria",
        "RootStatus Root DenseEvaluator=workbench.core ZeroProblem newton_on_manifold "
        "check_positive=workbench.core.validate:positive "
        "check_count=workbench.core.validate:count"),
    "workbench.sections": ("workbench.global_dynamics",
        "Direction Section turning_section turning_section_state stabilized_field"),
}

#: 0.1.0 modules that were packages (their submodules are deprecated paths too).
_PACKAGES = {"workbench.accuracy", "workbench.integrators", "workbench.report"}

#: Paths that cannot return: path -> (why, new module, the names it exported in 0.1.0);
#: why is _FUNCTION (the package's function of that name) or _MODELS (moved to models).
_FUNCTION, _MODELS = "function", "models"
GONE: dict[str, tuple[str, str, str]] = {
    "workbench.simulate": (_FUNCTION, "workbench.simulation",
                           "simulate Trajectory Method Multistep GEOMETRIC_METHODS "
                           "closed_loop_function constraint_residuals"),
    "workbench.linearize": (_FUNCTION, "workbench.linear",
                            "linearize LinearModel AmbientLinearization linearize_ambient "
                            "tangent_labels mechanical_order closed_loop_jacobians "
                            "EQUILIBRIUM_TOL"),
    "workbench.lqr": (_FUNCTION, "workbench.linear",
                      "lqr LQRResult Requirement geometric_feedback riccati_residual"),
    "workbench.sweep": (_FUNCTION, "workbench.simulation",
                        "sweep grid SweepResult ItemStatus OnError StartMethod Outcome "
                        "SweepError MissingDependencyError InlineExecutor local_cluster"),
    "workbench.tvlqr": (_FUNCTION, "workbench.control",
                        "tvlqr tvlqr_along TVLQR ClosedLoopRun closed_loop perturbed_starts"),
    "workbench.relative_equilibria": (_MODELS, "models.relative_equilibria",
                                      "rotation_problem alpha sphere_points SliceZero "
                                      "slice_zeros static_equilibria stability_label "
                                      "limit_at_infinity"),
    "workbench.relative_families": (_MODELS, "models.relative_families",
                                    "RelativeEquilibria trace_relative_equilibria at_alpha"),
    # names the 0.1.0 package root exported: ``from workbench import at_alpha``
    "workbench.at_alpha": (_MODELS, "models.relative_families", "at_alpha"),
    "workbench.trace_relative_equilibria": (_MODELS, "models.relative_families",
                                            "trace_relative_equilibria"),
}
_ROOT_NAMES = {"workbench.at_alpha", "workbench.trace_relative_equilibria"}


def _sources(path: str) -> list[tuple[str, str, str]]:
    """(old name, new module, new name) for each name a deprecated module exported."""
    new, names = DEPRECATED[path]
    out = []
    for token in names.split():
        old, _, where = token.partition("=")
        module, _, attr = (where or new).partition(":")
        out.append((old, module, attr or old))
    return out


def deprecation_message(path: str) -> str:
    """What importing the deprecated module ``path`` says: where its names live now."""
    new = DEPRECATED[path][0]
    elsewhere = [f"{old} is {module}.{attr}" for old, module, attr in _sources(path)
                 if module != new or attr != old]
    return (f"{path} is deprecated: it moved to {new} in {MOVED_IN} and this path will be "
            f"removed in {REMOVED_IN}; import from {new} instead"
            + (f" ({'; '.join(elsewhere)})" if elsewhere else ""))


def gone_message(path: str) -> str:
    """The error for a path of :data:`GONE`: why it cannot return and where to import from."""
    why, new, names = GONE[path]
    name = path.rsplit(".", 1)[1]
    fix = f"import {', '.join(names.split())} from {new}"
    if path in _ROOT_NAMES:
        return (f"cannot import name {name!r} from 'workbench': in {MOVED_IN} it moved to {new}, "
                f"out of the engine, which knows no concrete model; {fix}")
    if why == _FUNCTION:
        return (f"No module named {path!r}: since {MOVED_IN} {path} is the function {name} (a "
                f"module at this path would replace it); {fix}")
    return (f"No module named {path!r}: in {MOVED_IN} it moved to {new}, out of the engine, "
            f"which knows no concrete model; {fix}")


_INTERNAL = (os.path.dirname(importlib.__file__), "<frozen importlib")


def _warn(message: str) -> None:
    """A DeprecationWarning attributed to the line that imported, not to the import system."""
    frame = sys._getframe(1)
    while frame is not None and (frame.f_code.co_filename == __file__
                                 or frame.f_code.co_filename.startswith(_INTERNAL)):
        frame = frame.f_back
    if frame is None:
        warnings.warn(message, DeprecationWarning, stacklevel=2)
        return
    g = frame.f_globals
    warnings.warn_explicit(message, DeprecationWarning, frame.f_code.co_filename,
                           frame.f_lineno, module=g.get("__name__", "<unknown>"),
                           registry=g.setdefault("__warningregistry__", {}))


def _alias_target(path: str) -> str | None:
    for old, new in ALIASES.items():
        if path == old or path.startswith(old + "."):
            return new + path[len(old):]
    return None


class _AliasLoader(importlib.abc.Loader):
    """Puts the room's own module under the old path (no second copy, no warning)."""

    def __init__(self, target: str) -> None:
        self.target = target

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None

    def exec_module(self, module: types.ModuleType) -> None:
        # the import system returns what sys.modules holds after exec_module: the target
        sys.modules[module.__name__] = importlib.import_module(self.target)


class _DeprecatedLoader(importlib.abc.Loader):
    """A module with the 0.1.0 names of a deprecated path; importing it warns."""

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None

    def exec_module(self, module: types.ModuleType) -> None:
        path = module.__name__
        _warn(deprecation_message(path))
        for old, source, attr in _sources(path):
            setattr(module, old, getattr(importlib.import_module(source), attr))
        module.__all__ = [old for old, _, _ in _sources(path)]
        module.__doc__ = (f"Deprecated: the 0.1.0 path of {DEPRECATED[path][0]}, removed in "
                          f"{REMOVED_IN}.")


class MovedPaths(importlib.abc.MetaPathFinder):
    """The import hook for the paths of 0.1.0: aliases, deprecated shims, clear errors."""

    marker = "workbench-moved-paths"

    def find_spec(self, fullname: str, path=None, target=None):
        """A spec for an old path, None for any other (the next finder then looks)."""
        if not fullname.startswith("workbench."):
            return None
        if fullname in GONE:
            if fullname in _ROOT_NAMES:  # `from workbench import at_alpha`
                raise ImportError(gone_message(fullname), name="workbench")
            raise ModuleNotFoundError(gone_message(fullname), name=fullname)
        if fullname in DEPRECATED:
            return importlib.util.spec_from_loader(fullname, _DeprecatedLoader(),
                                                   is_package=fullname in _PACKAGES)
        alias = _alias_target(fullname)
        if alias is not None:
            return importlib.util.spec_from_loader(fullname, _AliasLoader(alias))
        return None


def install() -> None:
    """Register the aliases and put :class:`MovedPaths` first on ``sys.meta_path`` (once)."""
    for old, new in ALIASES.items():
        sys.modules.setdefault(old, importlib.import_module(new))
    if not any(getattr(f, "marker", None) == MovedPaths.marker for f in sys.meta_path):
        sys.meta_path.insert(0, MovedPaths())
