"""One status protocol (workbench/core/status.py) for every solver-like result of the engine.

The result types are found by scanning the rooms' public names for classes with a
``status``, so a new result type that does not conform fails here; the status enums are
found the same way. Then: ``.ok`` agrees with the status, a status's value reads as a
message, and the solvers raise on failure by default and not with ``raise_on_failure=False``.
"""

from __future__ import annotations

import dataclasses
import enum
import importlib
import inspect
import math
import pkgutil
import typing

import casadi as ca
import numpy as np
import pytest
from test_continuation import plane_problem
from test_poincare import _pos, oscillator

import workbench
from workbench.control._certify import Constraint, ExtremumStatus, optimize
from workbench.core.errors import SolverError
from workbench.core.manifolds import ProductManifold, Rn
from workbench.core.status import Record, SolverResult, StatusEnum, StatusResult, raise_if
from workbench.equilibria._branch import EndReason, StepControl
from workbench.equilibria._continuation import continue_branch
from workbench.equilibria._roots import RootStatus, newton_on_manifold
from workbench.global_dynamics._poincare import OrbitStatus, Section, poincare_map
from workbench.simulation._sweep import InlineExecutor, ItemStatus, OnError, SweepError, sweep

ENGINE_ROOMS = sorted(m.name for m in pkgutil.iter_modules(workbench.__path__)
                      if m.ispkg and m.name != "app" and not m.name.startswith("_"))


def _public_classes() -> dict[str, type]:
    found: dict[str, type] = {}
    for room in ENGINE_ROOMS:
        mod = importlib.import_module(f"workbench.{room}")
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if inspect.isclass(obj):
                found[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return found


PUBLIC = _public_classes()


def _has_status(cls: type) -> bool:
    if issubclass(cls, (enum.Enum, BaseException)) or cls in (StatusResult, SolverResult):
        return False
    fields = {f.name for f in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()
    return "status" in fields or isinstance(inspect.getattr_static(cls, "status", None),
                                            property)


RESULTS = sorted((c for c in PUBLIC.values() if _has_status(c)), key=lambda c: c.__name__)
STATUS_ENUMS = sorted(
    (c for c in PUBLIC.values() if inspect.isclass(c) and issubclass(c, enum.Enum)
     and (c.__name__.endswith("Status") or c.__name__ == "EndReason") and c is not StatusEnum),
    key=lambda c: c.__name__)


def _status_type(cls: type) -> object:
    """The declared type of ``cls.status`` (a dataclass field or a property's return)."""
    attr = inspect.getattr_static(cls, "status", None)
    if isinstance(attr, property):
        return typing.get_type_hints(attr.fget)["return"]
    return typing.get_type_hints(cls)["status"]


def test_the_scan_finds_the_known_results_and_enums():
    names = {c.__name__ for c in RESULTS}
    assert {"Root", "Equilibrium", "Branch", "PoincareOrbit", "Outcome", "SweepResult",
            "Run", "LongRun", "Result", "Extremum", "ConvergenceReport", "ClosedLoopRun",
            "OCPSolution"} <= names, names
    assert {"RootStatus", "EndReason", "OrbitStatus", "ItemStatus", "RunStatus",
            "ResultStatus", "ExtremumStatus", "ConvergenceStatus", "ClosedLoopStatus",
            "OCPStatus"} <= {c.__name__ for c in STATUS_ENUMS}


@pytest.mark.parametrize("cls", RESULTS, ids=lambda c: c.__name__)
def test_every_result_type_follows_the_protocol(cls):
    assert issubclass(cls, StatusResult), f"{cls.__name__} does not mix in StatusResult"
    for attr in ("ok", "raise_for_status"):
        assert callable(getattr(cls, attr, None)) or isinstance(
            inspect.getattr_static(cls, attr, None), property), (cls.__name__, attr)
    kind = _status_type(cls)
    assert inspect.isclass(kind) and issubclass(kind, StatusEnum), (
        f"{cls.__name__}.status is declared as {kind!r}, not a StatusEnum")


@pytest.mark.parametrize("kind", STATUS_ENUMS, ids=lambda c: c.__name__)
def test_every_status_enum_reads_as_a_message_and_names_its_successes(kind):
    assert issubclass(kind, StatusEnum), f"{kind.__name__} does not subclass StatusEnum"
    names = {m.name for m in kind}
    wins = kind.successes()
    assert wins and wins < names, f"{kind.__name__}: successes {set(wins)} of {names}"
    for member in kind:
        assert member.ok is (member.name in wins)
        assert member.code == member.name.lower()
        # a readable message: words, not a code
        assert isinstance(member.value, str) and len(member.value.split()) >= 2, member
        assert member.message == f"{member.name}: {member.value}"


# ----------------------------------------------------------------------------------------
# the mixin and the record on a minimal result


class _Outcome(StatusEnum):
    DONE = "it is done"
    BROKE = "it broke down"

    @classmethod
    def successes(cls) -> frozenset[str]:
        return frozenset({"DONE"})


@dataclasses.dataclass
class _Result(StatusResult):
    status: _Outcome
    message: str = ""


@pytest.mark.parametrize("status", list(_Outcome))
def test_ok_agrees_with_the_status_and_raise_for_status_with_it(status):
    r = _Result(status, "details")
    assert isinstance(r, SolverResult)
    assert r.ok is status.ok
    if status.ok:
        assert r.raise_for_status() is r and raise_if(r, True) is r
    else:
        with pytest.raises(SolverError, match="it broke down.*details") as err:
            r.raise_for_status()
        assert err.value.result is r and err.value.status == "broke"
    assert raise_if(r, False) is r


@dataclasses.dataclass(frozen=True)
class _Cost(Record):
    wall_seconds: float
    steps: int | None = None


def test_a_record_reads_as_the_dict_it_replaced():
    c = _Cost(0.5)
    assert c["wall_seconds"] == 0.5 and "steps" not in c and dict(c) == {"wall_seconds": 0.5}
    assert c.get("steps") is None and len(c) == 1
    with pytest.raises(KeyError):
        c["steps"]
    d = c.replace(steps=3)
    assert d.as_dict() == {"wall_seconds": 0.5, "steps": 3} and c.steps is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.steps = 4  # type: ignore[misc]
    with pytest.raises(TypeError, match="no fields"):
        _Cost.from_mapping({"wall_seconds": 1.0, "speed": 2.0})
    assert _Cost.from_mapping({"wall_seconds": 1.0}) == _Cost(1.0)


# ----------------------------------------------------------------------------------------
# the solvers: failure raises by default, not with the opt-out


def _no_zero(y):
    """F(y) = y^2 + 1 on R: no real zero; Newton stagnates at the minimum |F| = 1 (y = 0)."""
    return np.array([y[0] ** 2 + 1.0]), np.array([[2.0 * y[0]]])


def test_newton_raises_by_default_and_returns_the_failure_with_the_opt_out():
    line = ProductManifold([("y", Rn(1))])
    with pytest.raises(SolverError) as err:
        newton_on_manifold(_no_zero, line, np.array([0.3]))
    root = err.value.result
    assert root.status is RootStatus.STAGNATED and not root.ok
    # |F| >= 1 everywhere; it stopped near the minimum F(0) = 1 (no decrease found there)
    assert 1.0 <= root.residual < 1.001 and abs(root.x[0]) < 0.05
    kept = newton_on_manifold(_no_zero, line, np.array([0.3]), raise_on_failure=False)
    assert kept.status is RootStatus.STAGNATED and kept.ok is False
    good = newton_on_manifold(lambda y: (np.array([y[0] ** 2 - 2.0]), np.array([[2 * y[0]]])),
                              line, np.array([1.0]))
    assert good.ok and abs(good.x[0] - math.sqrt(2.0)) < 1e-12


def _cusp():
    # y^2 = x^3: the corrector cannot pass the cusp at the origin (ends STEP_TOO_SMALL)
    return plane_problem(lambda y: y[1] ** 2 - y[0] ** 3)


CUSP = {"direction": [-1.0, -1.0], "max_points": 500,
        "control": StepControl(step=0.05, max_step=0.1, min_step=1e-6)}


def test_continuation_raises_at_a_cusp_by_default_and_not_with_the_opt_out():
    with pytest.raises(SolverError, match="STEP_TOO_SMALL") as err:
        continue_branch(_cusp(), [1.0, 1.0], **CUSP)
    assert err.value.result.status is EndReason.STEP_TOO_SMALL
    b = continue_branch(_cusp(), [1.0, 1.0], raise_on_failure=False, **CUSP)
    assert b.status is b.end is EndReason.STEP_TOO_SMALL and not b.ok
    assert np.linalg.norm(b.points[-1]) < 0.05  # it reached the cusp before giving up
    assert b.iterations == int(np.sum(b.corrector_iterations)) > 0


def test_poincare_map_raises_at_the_horizon_by_default():
    # x = cos(2.3 t) crosses x = 0 at t = (k + 1/2) pi / 2.3: 7 crossings before t = 10
    args = (oscillator(2.3), [1.0, 0.0], Section("x=0", _pos))
    with pytest.raises(SolverError, match="HORIZON"):
        poincare_map(*args, n_crossings=50, t_max=10.0, chunk=2.0)
    orb = poincare_map(*args, n_crossings=50, t_max=10.0, chunk=2.0, raise_on_failure=False)
    assert orb.status is OrbitStatus.HORIZON and not orb.ok and orb.n == 7
    assert orb.cost["steps"] == orb.cost.steps > 0  # the typed cost reads as the old dict
    done = poincare_map(*args, n_crossings=3, t_max=10.0, chunk=2.0)
    assert done.ok and done.n == 3


def test_optimize_raises_when_every_start_fails_and_not_with_the_opt_out():
    model = oscillator(1.0)
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 1)
    objective = ca.Function("f", [x, p], [ca.sumsqr(x)])
    g = ca.Function("g", [x, p], [x[0]])
    contradiction = [Constraint(g, 2.0, 3.0, "x >= 2"), Constraint(g, -3.0, -2.0, "x <= -2")]
    starts = [[0.5, 0.0], [-0.5, 0.1]]
    with pytest.raises(SolverError, match="Ipopt failed from all 2 starts"):
        optimize(model, objective, starts, constraints=contradiction, max_iter=100)
    ext = optimize(model, objective, starts, constraints=contradiction, max_iter=100,
                   raise_on_failure=False)
    assert ext.status is ExtremumStatus.FAILED and not ext.ok and math.isnan(ext.value)
    best = optimize(model, objective, starts, constraints=contradiction[:1])
    # min |x|^2 with x_1 >= 2 is 4; Ipopt relaxes bounds by its bound_relax_factor 1e-8
    assert best.ok and abs(best.value - 4.0) < 1e-7
    assert best.iterations == best.cost["iterations"] > 0


def _half(x: float) -> float:
    if x < 0:
        raise ValueError("negative")
    return x / 2


def test_sweep_raises_on_failed_items_and_reports_them_with_the_opt_out():
    items = [{"x": 1.0}, {"x": -1.0}]
    with pytest.raises(SweepError) as err:
        sweep(_half, items, executor=InlineExecutor())
    assert isinstance(err.value, SolverError) and err.value.status == "failed"
    res = sweep(_half, items, executor=InlineExecutor(), on_error=OnError.REPORT)
    assert res.status is ItemStatus.FAILED and not res.ok
    assert [o.ok for o in res] == [True, False] and res.outcomes[0].value == 0.5
    assert res.cost["n_failed"] == res.cost.n_failed == 1
    with pytest.raises(SweepError):
        res.raise_for_status()
