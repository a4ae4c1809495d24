"""The report's runner: problems in parallel processes, cached by what they depend on.

Synthetic problems are written as real module files (so that their source is hashed):
one counts its runs in a file, one waits for another to start (possible only when they
run at the same time), one sleeps past its time limit, one kills its own process, one
holds a large array (its peak memory shows).
"""

from __future__ import annotations

import importlib.util
import io
import os
import re
import types
from pathlib import Path

import pytest

from workbench.app.report import Format, ReportInputError, Status, build_report, runner
from workbench.app.report import cache as report_cache

HEADER = '''
import os, sys, time
import numpy as np
from workbench.study import Result
TITLE = "{title}"
'''

BODIES = {
    "cores": '''
def solve(*, quick=False):
    from workbench.study import cores
    with open(os.environ["RUNNER_TEST_DIR"] + "/cores.log", "a") as fh:
        fh.write(f"{cores()}\\n")
    return Result("cores", TITLE, quick=quick).finish()
''',
    "counted": '''
def solve(*, quick=False):
    with open(os.environ["RUNNER_TEST_DIR"] + "/counted.log", "a") as fh:
        fh.write("run\\n")
    res = Result("counted", TITLE, quick=quick)
    res.compare("one", 1.0, 1.0, tolerance=1e-12, source="closed form")
    return res.finish()
''',
    "waits_for_partner": '''
def solve(*, quick=False):
    d = os.environ["RUNNER_TEST_DIR"]
    open(d + "/waits_for_partner.started", "w").close()
    for _ in range(400):
        if os.path.exists(d + "/partner.started"):
            break
        time.sleep(0.05)
    else:
        raise RuntimeError("partner never started: the problems did not run at the same time")
    res = Result("waits_for_partner", TITLE, quick=quick)
    res.values["pid"] = os.getpid()
    return res.finish()
''',
    "partner": '''
def solve(*, quick=False):
    d = os.environ["RUNNER_TEST_DIR"]
    open(d + "/partner.started", "w").close()
    for _ in range(400):
        if os.path.exists(d + "/waits_for_partner.started"):
            break
        time.sleep(0.05)
    else:
        raise RuntimeError("the other problem never started")
    res = Result("partner", TITLE, quick=quick)
    res.values["pid"] = os.getpid()
    return res.finish()
''',
    "sleeps": '''
def solve(*, quick=False):
    time.sleep(120)
    return Result("sleeps", TITLE, quick=quick).finish()
''',
    "spins": '''
def solve(*, quick=False):
    x = 0
    while True:  # computes for ever: stopped by its CPU-time limit
        x += 1
''',
    "dies": '''
def solve(*, quick=False):
    os._exit(3)
''',
    "big": '''
def solve(*, quick=False):
    a = np.ones(40_000_000)          # 320 MB, touched
    res = Result("big", TITLE, quick=quick)
    res.values["sum"] = float(a.sum())
    return res.finish()
''',
    "small": '''
def solve(*, quick=False):
    res = Result("small", TITLE, quick=quick)
    res.values["sum"] = 1.0
    return res.finish()
''',
}


def catalogue(folder: Path, names: list[str]) -> types.ModuleType:
    """A catalogue of real module files in ``folder`` (their sources are hashed)."""
    folder.mkdir(exist_ok=True)
    mods = {}
    for name in names:
        path = folder / f"{name}.py"
        if not path.exists():
            path.write_text(HEADER.format(title=f"synthetic {name}") + BODIES[name])
        spec = importlib.util.spec_from_file_location(f"runner_test_{name}", path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        mods[name] = mod
    cat = types.ModuleType("catalogue")
    cat.names = lambda: sorted(mods)
    cat.load = lambda n: mods[n]
    cat.title = lambda n: mods[n].TITLE
    return cat


@pytest.fixture()
def env(tmp_path, monkeypatch):
    monkeypatch.setenv("RUNNER_TEST_DIR", str(tmp_path))
    # the key hashes the engine's sources too; others editing the shared checkout while the
    # test runs must not change it, so these tests hash an empty engine
    (tmp_path / "root" / "workbench").mkdir(parents=True)
    monkeypatch.setattr(report_cache, "ROOT", tmp_path / "root")
    return tmp_path


def report(env: Path, names: list[str], **kw):
    stream = io.StringIO()
    rep = build_report(names, quick=True, formats=[Format.HTML], out_dir=env / "out",
                       catalogue=catalogue(env / "problems", names), stream=stream, **kw)
    return rep, stream.getvalue()


def test_second_run_reuses_every_result_and_a_change_reruns(env):
    rep1, err1 = report(env, ["counted", "small"], cache_dir=env / "cache")
    assert all(not r.cached for r in rep1.runs) and rep1.ok
    rep2, err2 = report(env, ["counted", "small"], cache_dir=env / "cache")
    assert all(r.cached for r in rep2.runs)
    assert (env / "counted.log").read_text().count("run") == 1  # not run again
    assert rep2.stats.reused == 2 and rep2.stats.ran == 0
    assert "re-used" in err2 and "peak memory" in err2.splitlines()[-1]
    # the same document: the comparison re-used is the one computed
    assert rep2.runs[0].summary["headline"] == rep1.runs[0].summary["headline"]
    # a change to the problem's source runs it again and replaces its cache entry
    path = env / "problems" / "counted.py"
    path.write_text(path.read_text() + "\n# changed\n")
    rep3, _ = report(env, ["counted", "small"], cache_dir=env / "cache")
    assert [r.cached for r in rep3.runs] == [False, True]
    assert (env / "counted.log").read_text().count("run") == 2
    entries = sorted(p.name for p in (env / "cache").glob("counted-quick-*.pkl"))
    assert len(entries) == 1


def test_without_a_cache_everything_runs(env):
    report(env, ["counted"], cache_dir=None)
    report(env, ["counted"], cache_dir=None)
    assert (env / "counted.log").read_text().count("run") == 2


def test_problems_run_at_the_same_time_in_other_processes(env):
    rep, _ = report(env, ["partner", "waits_for_partner"], cache_dir=None, jobs=2,
                    timeout=60)
    assert [r.status for r in rep.runs] == [Status.OK, Status.OK], [r.error for r in rep.runs]
    pids = {r.section.values[0].rows[0][1] for r in rep.runs}
    assert len(pids) == 2 and str(os.getpid()) not in pids


def test_timeout_and_crash_are_reported_and_the_others_go_on(env):
    rep, err = report(env, ["dies", "sleeps", "small"], cache_dir=env / "cache", jobs=2,
                      timeout=3)
    status = {r.name: r.status for r in rep.runs}
    assert status == {"dies": Status.FAILED, "sleeps": Status.TIMED_OUT, "small": Status.OK}
    by = {r.name: r for r in rep.runs}
    assert "exit code 3" in by["dies"].error
    assert "timed out" in by["sleeps"].error and "--timeout" in by["sleeps"].error
    text = (env / "out" / "report-quick.html").read_text()
    assert "timed out" in text and "exit code 3" in text
    assert sorted(rep.failed) == ["dies", "sleeps"]
    # every outcome is cached, the failures too: a second report runs nothing
    assert sorted(p.name.split("-")[0] for p in (env / "cache").glob("*.pkl")) == [
        "dies", "sleeps", "small"]
    rep2, err2 = report(env, ["dies", "sleeps", "small"], cache_dir=env / "cache", jobs=2,
                        timeout=3)
    assert rep2.stats.ran == 0 and all(r.cached for r in rep2.runs)
    assert {r.name: r.status for r in rep2.runs} == status  # still shown as failed
    assert "--rerun sleeps" in err2 and "--rerun dies" in err2
    text = (env / "out" / "report-quick.html").read_text()
    assert "re-used from the cache" in text and "exit code 3" in text
    # a larger time limit runs the time-out again (it may finish now); the rest is re-used
    rep3, _ = report(env, ["dies", "sleeps", "small"], cache_dir=env / "cache", jobs=2,
                     timeout=4)
    assert [r.name for r in rep3.runs if not r.cached] == ["sleeps"]
    # --rerun: named problems, 'failed', 'all'
    rep4, _ = report(env, ["dies", "small"], cache_dir=env / "cache", timeout=4,
                     rerun=["small"])
    assert [r.cached for r in rep4.runs] == [True, False]
    rep5, _ = report(env, ["dies", "small"], cache_dir=env / "cache", timeout=4,
                     rerun="failed")
    assert [r.cached for r in rep5.runs] == [False, True]
    rep6, _ = report(env, ["dies", "small"], cache_dir=env / "cache", timeout=4,
                     rerun="all")
    assert [r.cached for r in rep6.runs] == [False, False]


def test_the_time_limit_is_cpu_time_and_a_waiting_problem_is_stopped_at_three_times_it(
        env, monkeypatch):
    # the spinning problem must reach 2 s of CPU before the wall guard: on shared cores at
    # load 8 it gets a quarter of a core, so its guard is widened here (runner's factor)
    monkeypatch.setattr(runner, "WALL_FACTOR", 30.0)
    rep, _ = report(env, ["spins"], cache_dir=None, jobs=1, timeout=2)
    spins = rep.runs[0]
    assert spins.status is Status.TIMED_OUT
    assert "stopped after 2 s of CPU time" in spins.error
    # stopped by its CPU time, not earlier by the wall guard (how promptly after the limit
    # it is stopped depends on the machine's load: not asserted here)
    assert spins.cpu_seconds >= 2.0
    monkeypatch.setattr(runner, "WALL_FACTOR", 3.0)
    rep, err = report(env, ["sleeps"], cache_dir=None, jobs=1, timeout=2)
    by = {r.name: r for r in rep.runs}
    assert by["sleeps"].status is Status.TIMED_OUT
    # sleeping uses no CPU: stopped by the wall-time guard, 3 times the limit
    # the guard is checked at each poll, so how long after 6 s it fires depends on the load:
    # the test reads which guard fired, not how fast
    assert re.search(r"after \d+ s wall, 3 times the limit, having used only 0 s of CPU",
                     by["sleeps"].error), by["sleeps"].error
    assert by["sleeps"].seconds >= 6.0


def test_rerun_of_an_unknown_problem_is_refused_before_anything_runs(env):
    with pytest.raises(ReportInputError, match=r"--rerun: 'nope'.*'failed' or 'all'"):
        report(env, ["small"], cache_dir=env / "cache", rerun=["nope"])
    assert not list((env / "cache").glob("*.pkl"))


def test_peak_memory_of_each_problem_is_measured(env):
    rep, err = report(env, ["big", "small"], cache_dir=None)
    by = {r.name: r for r in rep.runs}
    assert by["big"].peak_mb - by["small"].peak_mb > 250  # the 320 MB array shows
    assert rep.stats.peak_problem[1] == "big"
    assert f"peak {by['big'].peak_mb:.0f} MB" in err


def test_the_key_follows_mode_and_sources(tmp_path):
    root = tmp_path / "root"
    (root / "workbench").mkdir(parents=True)
    engine = root / "workbench" / "engine.py"
    engine.write_text("A = 1\n")
    f = tmp_path / "p.py"
    f.write_text("TITLE = 'x'\n")
    k_quick = report_cache.problem_key(f, quick=True, root=root)
    assert k_quick == report_cache.problem_key(f, quick=True, root=root)
    assert k_quick != report_cache.problem_key(f, quick=False, root=root)
    engine.write_text("A = 2\n")  # the engine changed
    k_engine = report_cache.problem_key(f, quick=True, root=root)
    assert k_engine != k_quick
    f.write_text("TITLE = 'y'\n")  # the problem changed
    assert report_cache.problem_key(f, quick=True, root=root) not in (k_quick, k_engine)
    assert report_cache.problem_key(None, quick=True) is None  # no source: never cached
    assert set(report_cache.versions()) >= {"python", "casadi", "ipopt", "numpy"}


def test_problems_run_together_only_while_their_last_peaks_fit_the_memory_budget():
    from workbench.app.report.runner import _Job, _next_job

    todo = [_Job(n, None, n) for n in ["huge", "big", "small"]]  # longest first
    peaks = {"huge": 1700.0, "big": 700.0, "small": 170.0}
    assert _next_job(todo, [], peaks, 1300.0) == 0          # alone, even over the budget
    assert _next_job(todo[1:], [todo[0]], peaks, 1300.0) == 1  # beside it only small ones
    assert _next_job(todo[1:2], [todo[0]], peaks, 1300.0) is None  # 'big' waits
    running = [_Job("other", None, "other")]                # never measured: counts 0
    assert _next_job(todo, running, peaks, 1300.0) == 1     # 'huge' waits, 'big' fits
    assert _next_job(todo[:2], [todo[1]], peaks, 1300.0) is None  # 'big' + 'huge' too much
    assert _next_job(todo, [todo[1]], peaks, 1300.0) == 2   # beside 'big' only 'small'
    assert _next_job([], running, peaks, 1300.0) is None


def test_a_killed_report_takes_its_running_problems_with_it(env):
    import signal
    import subprocess
    import sys
    import textwrap
    import time

    script = env / "killed.py"
    script.write_text(textwrap.dedent(f'''
        import importlib.util, io, sys, types
        from pathlib import Path
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_report_runner import catalogue
        from workbench.app.report import Format, build_report
        build_report(["sleeps"], quick=True, formats=[Format.HTML],
                     out_dir={str(env / "out")!r}, cache_dir=None, stream=io.StringIO(),
                     catalogue=catalogue(Path({str(env / "problems")!r}), ["sleeps"]))
    '''))
    proc = subprocess.Popen([sys.executable, str(script)], env={**os.environ})
    try:
        child = None
        for _ in range(300):  # the problem's process: a child of the report's, own group
            out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(proc.pid)],
                                 capture_output=True, text=True).stdout.split()
            if out:
                child = int(out[0])
                break
            time.sleep(0.1)
        assert child is not None, "the problem never started"
        proc.send_signal(signal.SIGKILL)  # no clean-up runs in the report's process
        proc.wait(10)
        for _ in range(50):
            if not os.path.exists(f"/proc/{child}"):
                break
            with open(f"/proc/{child}/stat") as fh:
                if fh.read().rsplit(")", 1)[1].split()[0] == "Z":
                    break  # a zombie: dead, waiting to be reaped by init
            time.sleep(0.1)
        else:
            os.kill(child, signal.SIGKILL)
            raise AssertionError("the problem's process outlived the report's")
    finally:
        if proc.poll() is None:
            proc.kill()


def test_warm_up_before_the_fork_leaves_no_figure_and_writes_nothing(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt

    from workbench.app.report.figures import warm_up

    monkeypatch.chdir(tmp_path)
    before = set(plt.get_fignums())
    warm_up()
    assert set(plt.get_fignums()) == before
    assert list(tmp_path.iterdir()) == []


def test_each_problem_is_told_its_share_of_the_cores(env, monkeypatch):
    # 4 cores (as the runner sees them), shared by the problems that run at once: one
    # problem alone gets 4; two at once 2 each; three at once (4 jobs) 1 each (4 // 3)
    monkeypatch.setattr(runner.os, "cpu_count", lambda: 4)
    report(env, ["cores"], cache_dir=None, jobs=2)
    report(env, ["cores", "small"], cache_dir=None, jobs=2)
    report(env, ["cores", "small", "counted"], cache_dir=None, jobs=4)
    report(env, ["cores", "small", "counted"], cache_dir=None, jobs=8)
    assert (env / "cores.log").read_text().split() == ["4", "2", "1", "1"]


def test_cores_reads_its_variable_and_refuses_anything_but_a_positive_integer(monkeypatch):
    from workbench.core.errors import ParameterError
    from workbench.study import cores
    from workbench.study._result import CORES_ENV

    monkeypatch.delenv(CORES_ENV, raising=False)
    assert cores() == (os.cpu_count() or 1)
    monkeypatch.setenv(CORES_ENV, "3")
    assert cores() == 3
    for bad in ("0", "-1", "", "two", "1.5", "\u00b2"):  # superscript 2: isdigit, not int
        monkeypatch.setenv(CORES_ENV, bad)
        with pytest.raises(ParameterError, match=f"{CORES_ENV} must be a positive integer"):
            cores()


def test_modules_the_problems_import_lazily_are_imported_once_before_the_fork(env, monkeypatch):
    import sys

    # a stand-in module on the path: imported by the report's process when two problems
    # run (each child then inherits it), not when one does (it would be its only user)
    (env / "preload_probe_mod.py").write_text("LOADED = True\n")
    monkeypatch.syspath_prepend(str(env))
    monkeypatch.setattr(runner, "PRELOAD", ("preload_probe_mod", "no_such_module_xyz"))
    monkeypatch.delitem(sys.modules, "preload_probe_mod", raising=False)
    report(env, ["small"], cache_dir=None)
    assert "preload_probe_mod" not in sys.modules
    rep, _ = report(env, ["small", "counted"], cache_dir=None)
    assert "preload_probe_mod" in sys.modules and rep.ok  # a missing one is skipped
    monkeypatch.delitem(sys.modules, "preload_probe_mod")


def test_the_cache_folder_must_be_the_reports_own(env):
    """The cache writes timings.json and removes entries by name: it refuses a folder of
    the user's, marks its own, and checks --cache before --out is created."""
    user = env / "mine"
    user.mkdir()
    (user / "timings.json").write_text('{"my": "data"}')
    (user / "counted-quick-0123456789abcdef.pkl").write_text("a user's file")
    with pytest.raises(ReportInputError, match=r"--cache: .*holds files the report did not "
                                               r"write \(counted-quick-.*timings\.json\)"):
        report(env, ["counted"], cache_dir=user)
    assert not (env / "out").exists()  # nothing created before the refusal
    assert (user / "timings.json").read_text() == '{"my": "data"}'
    afile = env / "afile"
    afile.write_text("x")
    with pytest.raises(ReportInputError, match=r"^--cache: .*afile' exists and is not a dir"):
        report(env, ["counted"], cache_dir=afile)
    empty = env / "empty"
    empty.mkdir()
    report(env, ["counted"], cache_dir=empty)  # an empty folder becomes the cache
    assert (empty / report_cache.MARKER).is_file() and (empty / "timings.json").is_file()
    report(env, ["counted"], cache_dir=empty)  # and is the report's own from then on
    entry = next(empty.glob("counted-quick-*.pkl"))
    assert entry.stat().st_mode & 0o777 == 0o666 & ~_umask()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
