"""The hostile pass: bad values drawn for every public entry point (issue 16).

For each entry of :mod:`tests.extremes.hostile_entries` (every callable of
``workbench.__all__``, the models' builders and controllers, the command line), hypothesis
replaces one argument of a valid call by a value from a grammar of bad values and checks:

- a value that is never valid (NaN, +-inf, complex, bool or str for a number, None where
  None is not documented, wrong shapes and sizes, empty, ragged or object arrays, a
  tolerance or scale <= 0, unknown choices, non-identifier names) raises a documented
  domain error (a :class:`~workbench.core.errors.WorkbenchError`) whose message names the
  argument; returning anything is a silent acceptance and fails the pass;
- a value that may be valid but is extreme (1e300, 1e-300, negative or zero numbers, 0-d
  arrays, float32, huge counts) either returns a result without NaN or raises a
  WorkbenchError;
- nothing raises a raw numpy/casadi/scipy/Python error (TypeError, RuntimeError,
  IndexError, ...), and no call hangs (an alarm stops a call after ``CALL_SECONDS``).

The command line is attacked with bad command lines: it must exit non-zero with one line
on stderr and no traceback. The draws are derandomized (fixed) and bounded (``DRAWS``
per entry); the count per entry is printed at the end of the run
(``tests/extremes/conftest.py``) and checked by the last test.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import resource
import signal
from dataclasses import fields, is_dataclass
from typing import Any

import casadi as ca
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import workbench as wb
from tests.extremes.hostile_entries import ENTRIES, EXCLUDED, Entry, Kind
from workbench.core.errors import WorkbenchError

DRAWS = 14
"""Draws per entry point (the grammar is finite: an entry with a smaller space gets all)."""

CALL_SECONDS = 30
"""A call that has not returned after this long is a hang."""

MEMORY_BYTES = 4 << 30
"""Address space a call may add: beyond it numpy/casadi raise MemoryError (a missing size
guard, reported as a raw error) instead of the machine running out of memory."""

DRAWN: dict[str, int] = {}
FAILURES: dict[str, list[str]] = {}
SPACE: dict[str, int] = {}


class Hang(Exception):
    """Raised by the alarm inside a call that runs too long."""


def _alarm(signum: int, frame: Any) -> None:
    raise Hang(f"no answer after {CALL_SECONDS} s")


# ----------------------------------------------------------------------------------------
# the grammar of bad values


class Bad:
    """A drawn value, whether it is never valid, and a label for the report."""

    def __init__(self, label: str, value: Any, invalid: bool) -> None:
        self.label, self.value, self.invalid = label, value, invalid

    def __repr__(self) -> str:
        return self.label


def _number_values(g: Any, kind: Kind, optional: bool) -> list[Bad]:
    g = float(np.ravel(g)[0]) if g is not None and not isinstance(g, str) else 1.0
    out = [Bad("nan", float("nan"), True), Bad("inf", float("inf"), True),
           Bad("-inf", float("-inf"), True), Bad("complex", complex(g, 1.0), True),
           Bad("complex-0j", np.complex128(g), True), Bad("bool", True, True),
           Bad("str", str(g), True), Bad("pair", [g, g], True),
           Bad("empty", np.zeros(0), True), Bad("object", object(), True),
           Bad("0-d", np.array(g), False), Bad("float32", np.float32(g), False),
           Bad("huge", 1e300, False), Bad("tiny", 1e-300, False)]
    if not optional:
        out.append(Bad("None", None, True))
    scale = kind in (Kind.SCALE, Kind.TOL)
    out += [Bad("zero", 0.0, scale), Bad("negative", -abs(g) if g else -1.0, scale)]
    return out


def _count_values(g: Any, optional: bool) -> list[Bad]:
    out = [Bad("float", 1.5, True), Bad("bool", True, True), Bad("str", "3", True),
           Bad("nan", float("nan"), True), Bad("complex", 2 + 0j, True),
           Bad("negative", -1, True), Bad("zero", 0, False), Bad("np.int64", np.int64(g or 1),
                                                               False),
           Bad("huge", 10**9, False)]
    if not optional:
        out.append(Bad("None", None, True))
    return out


def _array_values(g: Any, optional: bool) -> list[Bad]:
    a = np.array(g, dtype=float)
    flat = a.ravel()
    nan, inf = a.copy(), a.copy()
    nan.flat[0], inf.flat[-1] = np.nan, np.inf
    out = [Bad("nan-entry", nan, True), Bad("inf-entry", inf, True),
           Bad("complex", a + 1j, True), Bad("complex-0j", a.astype(complex), True),
           Bad("bool", a != 0, True), Bad("str", a.astype(str), True),
           Bad("short", flat[:-1], True), Bad("empty", np.zeros(0), True),
           Bad("ragged", [[1.0], [1.0, 2.0]], True),
           Bad("object", np.array([object()] * max(1, flat.size), dtype=object), True),
           Bad("scalar-str", "x", True), Bad("huge", a * 1e300 + 1e300, False),
           Bad("tiny", a * 1e-300, False), Bad("negated", -a, False),
           Bad("list", a.tolist(), False), Bad("extra-axis", a[..., None], False)]
    if flat.size > 1:
        out.append(Bad("long", np.r_[flat, 1.0], True))
    if not optional:
        out.append(Bad("None", None, True))
    return out


def _enum_values(optional: bool) -> list[Bad]:
    out = [Bad("unknown", "nope", True), Bad("int", 3, True), Bad("bool", True, True),
           Bad("float", 1.5, True)]
    if not optional:
        out.append(Bad("None", None, True))
    return out


def _object_values(optional: bool) -> list[Bad]:
    out = [Bad("str", "thing", True), Bad("int", 3, True), Bad("array", np.zeros(3), True),
           Bad("object", object(), True), Bad("dict", {}, True)]
    if not optional:
        out.append(Bad("None", None, True))
    return out


def _text_values(optional: bool) -> list[Bad]:
    out = [Bad("int", 3, True), Bad("bool", True, True), Bad("bytes", b"x", True),
           Bad("empty", "", False), Bad("newline", "a\nb", False),
           Bad("comment-close", "x*/y", False), Bad("long", "x" * 10_000, False)]
    if not optional:
        out.append(Bad("None", None, True))
    return out


def _bound_values(g: Any) -> list[Bad]:
    out = _number_values(g, Kind.NUMBER, False)
    return [Bad(b.label, b.value, False) if b.label in ("inf", "-inf") else b for b in out]


def _sequence_values() -> list[Bad]:
    return [Bad("int", 3, True), Bad("None", None, True), Bad("object", object(), True),
            Bad("float", 1.5, True), Bad("bool", True, True), Bad("empty", [], False),
            Bad("str", "abc", False)]


def _name_values(optional: bool) -> list[Bad]:
    out = [Bad("empty", "", True), Bad("space", "a b", True), Bad("digit", "1x", True),
           Bad("comment-close", "x*/y", True), Bad("newline", "a\nb", True),
           Bad("int", 3, True), Bad("bool", True, True), Bad("bytes", b"x", True)]
    if not optional:
        out.append(Bad("None", None, True))
    return out


BAD_COMMAND_LINES = [
    ["run", "nope"], ["run", "pendulum3d_invariants", "--json", ""],
    ["run", "pendulum3d_invariants", "--json", "/nonexistent-dir/x.json"],
    ["export-c", "nope", "--out", "/tmp/hostile-never"], ["export-c", "s2_pd", "--out", ""],
    ["export-c", "s2_pd", "--out", "/proc/hostile"], ["report", "nope", "--out", "/tmp/h"],
    ["report", "--out", ""], ["bench", "nope"], ["list", "--bogus"], [], ["run"],
    ["export-c", "s2_pd", "--binding", "bad", "--out", "/tmp/hostile-never"],
]


def grammar(entry: Entry, arg: str) -> list[Bad]:
    """The bad values drawn for ``arg`` of ``entry`` (documented-valid ones marked so)."""
    valid = entry.valid.get(arg, frozenset())
    return [Bad(b.label, b.value, False) if b.label in valid else b
            for b in _grammar(entry, arg)]


def _grammar(entry: Entry, arg: str) -> list[Bad]:
    kind, good = entry.attack[arg], entry.good()[arg]
    optional = arg in entry.optional
    if entry.name == "cli":
        return [Bad(" ".join(c) or "<empty>", c, True) for c in BAD_COMMAND_LINES]
    if kind in (Kind.NUMBER, Kind.SCALE, Kind.TOL):
        return _number_values(good, kind, optional)
    if kind is Kind.COUNT:
        return _count_values(good, optional)
    if kind is Kind.ARRAY:
        return _array_values(good, optional)
    if kind is Kind.ENUM:
        return _enum_values(optional)
    if kind is Kind.NAME:
        return _name_values(optional)
    if kind is Kind.TEXT:
        return _text_values(optional)
    if kind is Kind.BOUND:
        return _bound_values(good)
    if kind is Kind.SEQUENCE:
        return _sequence_values()
    return _object_values(optional)


# ----------------------------------------------------------------------------------------
# judging one call


def _nans(obj: Any, path: str = "result", depth: int = 0) -> list[str]:
    """Paths of NaN values inside a result (numbers, arrays, dicts, sequences, dataclasses)."""
    if depth > 4 or isinstance(obj, (wb.Model, ca.Function, str, bytes, type)) or callable(
            obj) and not is_dataclass(obj):
        return []
    if isinstance(obj, (bool, np.bool_)):
        return []
    if isinstance(obj, (int, float, np.number)):
        return [path] if isinstance(obj, (float, np.floating)) and math.isnan(obj) else []
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "fc" and np.isnan(obj).any():
            return [path]
        return []
    if isinstance(obj, dict):
        return [p for k, v in list(obj.items())[:100] for p in _nans(v, f"{path}[{k!r}]",
                                                                   depth + 1)]
    if isinstance(obj, (list, tuple)):
        return [p for i, v in enumerate(obj[:100]) for p in _nans(v, f"{path}[{i}]", depth + 1)]
    if is_dataclass(obj) and not isinstance(obj, type):
        return [p for f in fields(obj) for p in _nans(getattr(obj, f.name, None),
                                                      f"{path}.{f.name}", depth + 1)]
    return []


def _names(message: str, arg: str, entry: Entry) -> bool:
    words = (arg, *entry.words.get(arg, ()))
    return any(re.search(rf"(?<![A-Za-z0-9_]){re.escape(w)}(?![A-Za-z0-9_])", message)
               for w in words)


def _judge_cli(bad: Bad) -> str | None:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = ENTRY_BY_NAME["cli"].call({"argv": bad.value})
        except SystemExit as exc:
            code = exc.code
    text = err.getvalue().strip()
    if code in (0, None):
        return f"exit status {code} for a bad command line"
    if "Traceback" in text or len(text.splitlines()) != 1:
        return f"stderr is not one line: {text[:300]!r}"
    return None


def judge(entry: Entry, arg: str, bad: Bad) -> str | None:
    """None if the call behaved, else what went wrong."""
    if entry.name == "cli":
        return _judge_cli(bad)
    args = entry.good()
    args[arg] = bad.value
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CALL_SECONDS)
    limits = resource.getrlimit(resource.RLIMIT_AS)
    with open("/proc/self/statm") as fh:
        used = int(fh.read().split()[0]) * resource.getpagesize()
    resource.setrlimit(resource.RLIMIT_AS, (used + MEMORY_BYTES, limits[1]))
    try:
        result = entry.call(args)
    except WorkbenchError as exc:
        if bad.invalid and not _names(str(exc), arg, entry):
            return f"{type(exc).__name__} does not name {arg!r}: {str(exc)[:200]!r}"
        return None
    except Hang as exc:
        return f"hang: {exc}"
    except Exception as exc:  # noqa: BLE001 - the point: no raw library error
        return f"raw {type(exc).__module__}.{type(exc).__name__}: {str(exc)[:200]!r}"
    finally:
        resource.setrlimit(resource.RLIMIT_AS, limits)
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    if bad.invalid:
        return "silently accepted (returned a result)"
    nans = _nans(result)
    if nans:
        return f"NaN in the result at {nans[:3]}"
    return None


# ----------------------------------------------------------------------------------------
# the pass

ENTRY_BY_NAME = {e.name: e for e in ENTRIES}


def _space(entry: Entry) -> list[tuple[str, int]]:
    return [(arg, i) for arg in sorted(entry.attack) for i in range(len(grammar(entry, arg)))]


@pytest.mark.parametrize("entry", ENTRIES, ids=[e.name for e in ENTRIES])
def test_hostile_values_raise_a_domain_error_naming_the_argument(entry):
    space = _space(entry)
    SPACE[entry.name] = len(space)
    grammars = {arg: grammar(entry, arg) for arg in entry.attack}
    failures: list[str] = []
    seen: set[tuple[str, int]] = set()

    @settings(max_examples=DRAWS, derandomize=True, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(st.sampled_from(space))
    def attack(pick: tuple[str, int]) -> None:
        if pick in seen:  # hypothesis may replay an example; judge each once
            return
        seen.add(pick)
        arg, i = pick
        bad = grammars[arg][i]
        why = judge(entry, arg, bad)
        if why:
            failures.append(f"{entry.name}({arg}={bad.label}): {why}")

    attack()
    DRAWN[entry.name] = len(seen)
    FAILURES[entry.name] = failures
    assert not failures, "\n".join(failures)


def test_every_public_name_is_an_entry_or_excluded_with_a_reason():
    names = {e.name for e in ENTRIES}
    unclassified = set(wb.__all__) - names - set(EXCLUDED)
    assert not unclassified, f"public names without an entry: {sorted(unclassified)}"
    assert not names & set(EXCLUDED)
    assert all(reason for reason in EXCLUDED.values())


def test_every_entry_point_got_its_draws():
    if not DRAWN:
        pytest.skip("the hostile pass did not run in this session (deselected)")
    short = {n: DRAWN.get(n, 0) for n in ENTRY_BY_NAME
             if n in SPACE and DRAWN.get(n, 0) < min(DRAWS, SPACE[n]) // 2}
    assert not short, f"entry points with too few distinct draws: {short}"
