"""Paths that name an open file descriptor are never replaced; ``--json -`` is the stream.

``/dev/stdout`` is a link to ``/proc/self/fd/1``, whose own link names whatever the shell
opened: with ``>> log.txt`` that is the log, a regular file. Following the links and
renaming a temporary file over their end replaced the log (its earlier lines lost, and the
command's printed results sent to the unlinked old file). Every file writer goes through
:func:`workbench.core.files.writable_file` (and the C export checks its ``--out`` with
:func:`~workbench.core.files.refuse_descriptor`), which refuses a path that names a
descriptor at any step of its resolution; the command line writes ``--json -`` to
standard output through descriptor 1, as the shell opened it.

The command-line cases run in a subprocess whose standard output the shell appends to a
log with two earlier lines: after the command the log is the same file (same inode) with
those lines first.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from workbench.core import files
from workbench.core.errors import OutputError
from workbench.study._result import Result

ROOT = Path(__file__).resolve().parents[2]
PRIOR = "IMPORTANT LOG LINE 1\nIMPORTANT LOG LINE 2\n"

# a stand-in problem for the command line, solved in a subprocess: it prints through
# Python and through descriptor 1 directly (as a compiled solver's banner does)
TINY = textwrap.dedent("""
    import os, sys
    from workbench.app import cli
    from workbench.study._result import Result

    class Tiny:
        def solve(self, quick=False):
            print("python print while solving")
            sys.stdout.flush()
            os.write(1, b"fd-1 write while solving\\n")
            res = Result("tiny", "a stand-in problem")
            res.values = {"x": 1.5, "y": [1, 2, 3]}
            res.timings["total"] = 0.25
            return res

    cli._problems = lambda: type("P", (), {"names": staticmethod(lambda: ["tiny"]),
                                          "load": staticmethod(lambda name: Tiny())})
    sys.exit(cli.main(sys.argv[1:]))
""")


def _shell(command: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.run(command, shell=True, cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300, check=False)


def _log(tmp_path: Path) -> tuple[Path, int]:
    log = tmp_path / "mylog.txt"
    log.write_text(PRIOR)
    return log, log.stat().st_ino


# ----------------------------------------------------------------------------------------
# the command line, as the shell runs it


@pytest.mark.parametrize("json_path, redirect", [
    ("/dev/stdout", ">> mylog.txt"),
    ("/dev/fd/1", ">> mylog.txt"),
    ("/proc/self/fd/1", ">> mylog.txt"),
    ("/dev/stderr", "2>> mylog.txt"),
    ("/dev/fd/3", "3>> mylog.txt"),
    ("out.json", ">> mylog.txt"),            # out.json -> stdout.lnk -> /dev/stdout
    ("fds/1", ">> mylog.txt"),               # fds -> /dev/fd: a folder link on the way
])
def test_run_refuses_a_descriptor_and_keeps_the_shells_log(tmp_path, json_path, redirect):
    log, inode = _log(tmp_path)
    (tmp_path / "stdout.lnk").symlink_to("/dev/stdout")
    (tmp_path / "out.json").symlink_to("stdout.lnk")
    (tmp_path / "fds").symlink_to("/dev/fd")
    py = shlex.quote(sys.executable)
    on_stderr = redirect.startswith("2")
    streams = f"> out.txt {redirect}" if on_stderr else f"{redirect} 2> err.txt"
    proc = _shell(f"{py} -m workbench.app.cli run swingup_furuta --quick --json {json_path} "
                  f"{streams}", tmp_path)
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert log.stat().st_ino == inode, "the log is the same file"
    text = log.read_text()
    assert text.startswith(PRIOR), "the log's earlier lines are kept"
    if on_stderr:  # the log is stderr: the one-line error is appended after its lines
        message = text[len(PRIOR):]
    else:  # refused before any problem ran: nothing at all was written to the log
        assert text == PRIOR
        message = (tmp_path / "err.txt").read_text()
    assert "--json: " in message and "names file descriptor" in message
    assert "for standard output use '--json -'" in message
    assert len(message.strip().splitlines()) == 1
    assert (tmp_path / "stdout.lnk").is_symlink() and (tmp_path / "out.json").is_symlink()


def test_json_dash_appends_the_json_to_the_shells_log(tmp_path):
    (tmp_path / "tiny.py").write_text(TINY)
    log, inode = _log(tmp_path)
    py = shlex.quote(sys.executable)
    to_stdout = _shell(f"{py} tiny.py run tiny --json - >> mylog.txt 2> err.txt", tmp_path)
    assert to_stdout.returncode == 0, (tmp_path / "err.txt").read_text()
    to_file = _shell(f"{py} tiny.py run tiny --json out.json > printed.txt 2> err2.txt",
                     tmp_path)
    assert to_file.returncode == 0, (tmp_path / "err2.txt").read_text()
    file_text = (tmp_path / "out.json").read_text()

    assert log.stat().st_ino == inode, "the log is the same file, appended to"
    text = log.read_text()
    assert text.startswith(PRIOR)
    appended = text[len(PRIOR):]
    assert appended == file_text + "\n", "the same JSON as --json FILE writes, one newline"
    data = json.loads(appended)
    assert data["values"] == {"x": 1.5, "y": [1, 2, 3]} and data["name"] == "tiny"

    # whatever the problem printed (through Python or descriptor 1) and the printed
    # results went to stderr, so standard output carries the JSON alone
    err = (tmp_path / "err.txt").read_text()
    assert "python print while solving" in err and "fd-1 write while solving" in err
    printed = (tmp_path / "printed.txt").read_text()
    assert "fd-1 write while solving" in printed  # with --json FILE: stdout as before
    results_line = printed.splitlines()[-1]
    assert results_line and results_line in err


def test_json_dash_into_a_pipe_is_the_json_alone(tmp_path):
    (tmp_path / "tiny.py").write_text(TINY)
    py = shlex.quote(sys.executable)
    proc = _shell(f"{py} tiny.py run tiny --json - | cat", tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["values"]["x"] == 1.5
    assert "wrote" not in proc.stderr


# ----------------------------------------------------------------------------------------
# the writer itself


@pytest.fixture
def open_file(tmp_path):
    """A file with content, open for appending on a descriptor of this process."""
    path = tmp_path / "stream.txt"
    path.write_text("kept\n")
    fd = os.open(path, os.O_WRONLY | os.O_APPEND)
    try:
        yield path, fd
    finally:
        os.close(fd)


@pytest.mark.parametrize("name", ["/dev/fd/{fd}", "/proc/self/fd/{fd}",
                                  "/proc/thread-self/fd/{fd}", "/proc/{pid}/fd/{fd}",
                                  "/dev/fd/../fd/{fd}"])
def test_a_descriptor_is_refused_and_its_file_kept(open_file, name):
    path, fd = open_file
    inode = path.stat().st_ino
    target = name.format(fd=fd, pid=os.getpid())
    with pytest.raises(OutputError, match=rf"names file descriptor {fd} of process "
                                          rf"{os.getpid()} .*open on '{path}'"):
        files.write_atomic(target, "replacement")
    with pytest.raises(OutputError, match="names file descriptor"):
        Result("r", "r").write_json(target)
    assert path.read_text() == "kept\n" and path.stat().st_ino == inode
    assert sorted(p.name for p in path.parent.iterdir()) == ["stream.txt"]


def test_a_chain_of_links_through_a_descriptor_is_refused(open_file, tmp_path):
    path, fd = open_file
    (tmp_path / "b").symlink_to(f"/proc/self/fd/{fd}")
    (tmp_path / "a").symlink_to("b")
    (tmp_path / "fds").symlink_to("/dev/fd")
    (tmp_path / "here").symlink_to(".")
    for via in ("a", f"fds/{fd}", "here/here/a"):
        assert files.descriptor_step(tmp_path / via) == f"/proc/{os.getpid()}/fd/{fd}"
        with pytest.raises(OutputError, match="names file descriptor"):
            files.writable_file(tmp_path / via, name="--json", hint="use '--json -'")
    assert path.read_text() == "kept\n"


def test_a_folder_named_through_a_descriptor_is_refused(tmp_path):
    fd = os.open(tmp_path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        folder = f"/dev/fd/{fd}"
        for check in (files.writable_dir, files.make_dir):
            with pytest.raises(OutputError, match="open descriptor, not a folder's path"):
                check(folder)
        with pytest.raises(OutputError, match="names file descriptor"):
            files.make_dir(f"{folder}/sub")
        with pytest.raises(OutputError, match="names file descriptor"):
            files.write_atomic(f"{folder}/x.json", "x")
    finally:
        os.close(fd)
    assert list(tmp_path.iterdir()) == []


def test_ordinary_paths_and_other_proc_links_are_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "data").mkdir()
    (tmp_path / "link.json").symlink_to(Path("data") / "x.json")
    for p in ("plain.json", "data/../plain.json", "link.json",
              "/proc/self/cwd/via_cwd.json"):
        assert files.descriptor_step(p) is None, p
        files.write_atomic(p, "{}")
    assert files.descriptor_step("/dev/null") is None  # a device: refused as one
    assert sorted(p.name for p in tmp_path.rglob("*.json")) == [
        "link.json", "plain.json", "via_cwd.json", "x.json"]


def test_cli_refuses_a_descriptor_before_any_problem_runs(open_file, monkeypatch, capsys):
    from workbench.app import cli

    path, fd = open_file
    solved: list = []

    class Tiny:
        def solve(self, quick=False):
            solved.append(quick)
            return Result("tiny", "tiny")

    monkeypatch.setattr(cli, "_problems", lambda: type(
        "P", (), {"names": staticmethod(lambda: ["tiny"]),
                  "load": staticmethod(lambda name: Tiny())}))
    code = cli.main(["run", "tiny", "--json", f"/dev/fd/{fd}"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and solved == [], "refused before the problem ran"
    assert err.startswith(f"error: --json: '/dev/fd/{fd}' names file descriptor {fd}")
    assert err.endswith("for standard output use '--json -')") and "\n" not in err
    assert path.read_text() == "kept\n"


def test_export_c_refuses_a_folder_named_through_a_descriptor(tmp_path, capsys):
    from workbench.app import cli

    fd = os.open(tmp_path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        code = cli.main(["export-c", "s2_pd", "--out", f"/dev/fd/{fd}/sub", "--verify", "0"])
    finally:
        os.close(fd)
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err
    assert err.startswith(f"error: --out: '/dev/fd/{fd}/sub' names file descriptor {fd}")
    assert err.endswith("(expected the path of a folder)")
    assert list(tmp_path.iterdir()) == [], "refused before anything was built or written"


@pytest.mark.parametrize("path", ["/dev/stdout", "/dev/fd/1"])
def test_a_problem_script_refuses_a_descriptor_before_it_runs(path, capsys):
    from workbench.study._script import run_script

    ran = []

    def solve(*, quick=False):  # never reached: the path is refused first
        ran.append(quick)
        raise AssertionError("the problem ran")

    with pytest.raises(SystemExit) as stop:
        run_script(solve, ["--quick", "--json", path])
    assert stop.value.code == 2 and ran == []
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--json" in err and "descriptor" in err


_BIND = r"""
set -e
cd "$1"
printf 'line 1\nline 2\n' > log.txt
sleep 30 >> log.txt &
SP=$!
mkdir -p descs
mount --bind /proc/$SP/fd descs
"$2" -c 'import sys
from workbench.core import files
try:
    files.write_atomic(sys.argv[1], "{}\n")
    print("WRITTEN")
except files.OutputError as exc:
    print("REFUSED", exc)' "$1/descs/1"
kill $SP
umount descs
"""


def test_a_descriptor_table_bind_mounted_under_another_name_is_refused(tmp_path):
    """``mount --bind /proc/PID/fd DIR``: DIR/1 is a descriptor (procfs's device, a number)."""
    probe = subprocess.run(["unshare", "-m", "--propagation", "private", "true"],
                           capture_output=True)
    if probe.returncode != 0:
        pytest.skip("a private mount namespace (unshare -m) is not permitted here")
    log = tmp_path / "log.txt"
    run = subprocess.run(["unshare", "-m", "--propagation", "private", "bash", "-c", _BIND,
                          "bind", str(tmp_path), sys.executable], capture_output=True,
                         text=True, timeout=60, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert "REFUSED" in run.stdout and "descriptor" in run.stdout, run.stdout + run.stderr
    assert log.read_text().startswith("line 1\nline 2\n")
