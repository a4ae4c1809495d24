"""Faults while writing: full, read-only and shared folders, links, FIFOs, devices, interrupts.

Every writer (Result.write_json, the command line's --json, the report, the C export) goes
through :func:`workbench.core.files.write_atomic`; these tests attack it and its users:

- a full disk (a real 64 kB tmpfs where this process may mount one, and ENOSPC injected
  into ``os.write`` everywhere) and a read-only folder (a tmpfs remounted read-only, which
  even root cannot write) give one clear error, leave no file behind and the target as it
  was;
- a KeyboardInterrupt in the middle of a write leaves nothing partial;
- a user's files next to the target (``PATH.probe``, ``PATH.partial``) are never touched;
- a symbolic link is written through (its target replaced atomically, the link kept; a
  dangling link creates its target only in an existing folder; a loop is refused), and a
  FIFO, a socket, a directory or a device (``/dev/null``), at the path or at a link's
  target, is refused before anything is written (before any problem runs, on the command
  line) and left as it was;
- new files and folders get the umask's mode, not 0600/0700; a replaced file keeps its
  mode, owner and group; a read-only file, a file with other hard links and one of another
  user or group (that the new file could not be given to) are refused and kept;
- generated C and Makefiles do not carry injected code from free-text fields;
- a corrupt compile-cache entry is found by content hash, rebuilt with a warning;
- two processes exporting the same controller into the same folder and cache at once both
  succeed with complete, identical files.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import multiprocessing as mp
import os
import re
import stat
import subprocess
import tempfile
from pathlib import Path

import pytest

from workbench.core import files
from workbench.core.errors import OutputError
from workbench.study._result import Result


def _listing(path: Path) -> list[str]:
    return sorted(p.relative_to(path).as_posix() for p in path.rglob("*"))


def _result() -> Result:
    res = Result("faults", "writer faults")
    res.values = {"x": 1.0, "y": [1, 2, 3]}
    return res


@pytest.fixture
def tiny_tmpfs(tmp_path):
    """A 64 kB tmpfs (a full disk is easy to reach); skipped where mounting is not allowed."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)],
                          capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {proc.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


# ----------------------------------------------------------------------------------------
# the writer itself


def test_full_disk_real_tmpfs_leaves_nothing_and_keeps_the_old_file(tiny_tmpfs):
    target = tiny_tmpfs / "r.json"
    target.write_text("old")
    with pytest.raises(OutputError, match=r"r\.json.*No space left") as info:
        files.write_atomic(target, "x" * 200_000)
    assert "\n" not in str(info.value)
    assert target.read_text() == "old"
    assert _listing(tiny_tmpfs) == ["r.json"]


def test_read_only_folder_real_tmpfs(tiny_tmpfs):
    (tiny_tmpfs / "keep.txt").write_text("mine")
    subprocess.run(["mount", "-o", "remount,ro", str(tiny_tmpfs)], check=True)
    with pytest.raises(OutputError, match="Read-only file system"):
        files.write_atomic(tiny_tmpfs / "r.json", "{}")
    with pytest.raises(OutputError, match="Read-only"):
        _result().write_json(tiny_tmpfs / "r.json")
    assert _listing(tiny_tmpfs) == ["keep.txt"]


@pytest.mark.parametrize("fault", [OSError(errno.ENOSPC, "No space left on device"),
                                   KeyboardInterrupt()])
def test_a_fault_mid_write_leaves_nothing_partial(tmp_path, monkeypatch, fault):
    target = tmp_path / "r.json"
    target.write_text("old")
    real_write, calls = os.write, []

    def write(fd, data):  # the first chunk goes through, then the fault
        calls.append(len(data))
        if len(calls) > 1:
            raise fault
        return real_write(fd, bytes(data[:10]))

    monkeypatch.setattr(os, "write", write)
    expected = OutputError if isinstance(fault, OSError) else KeyboardInterrupt
    with pytest.raises(expected):
        files.write_atomic(target, "y" * 1000)
    monkeypatch.undo()
    assert len(calls) == 2, "the fault must hit in the middle of the write"
    assert target.read_text() == "old"
    assert _listing(tmp_path) == ["r.json"]


def test_interrupt_at_the_rename_leaves_nothing(tmp_path, monkeypatch):
    def replace(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        _result().write_json(tmp_path / "r.json")
    monkeypatch.undo()
    assert _listing(tmp_path) == []


def test_the_users_files_next_to_the_target_are_never_touched(tmp_path):
    for name in ("r.json.probe", "r.json.partial", ".r.json.partial"):
        (tmp_path / name).write_text(f"user data {name}")
    _result().write_json(tmp_path / "r.json")
    for name in ("r.json.probe", "r.json.partial", ".r.json.partial"):
        assert (tmp_path / name).read_text() == f"user data {name}"
    assert json.loads((tmp_path / "r.json").read_text())["name"] == "faults"
    assert _listing(tmp_path) == sorted(["r.json", "r.json.probe", "r.json.partial",
                                         ".r.json.partial"])


def test_new_files_and_folders_follow_the_umask(tmp_path):
    old = os.umask(0o027)
    try:
        f = files.write_atomic(tmp_path / "a.txt", "a")
        d = files.temp_dir(tmp_path, "d-")
        m = files.make_dir(tmp_path / "made")
    finally:
        os.umask(old)
    assert stat.S_IMODE(f.stat().st_mode) == 0o640
    assert stat.S_IMODE(d.stat().st_mode) == 0o750
    assert stat.S_IMODE(m.stat().st_mode) == 0o750


@pytest.mark.parametrize("bad", ["", "   ", None, 3])
def test_an_empty_or_non_path_output_is_an_error(tmp_path, bad):
    with pytest.raises(OutputError, match="path"):
        files.write_atomic(bad, "x")
    with pytest.raises(OutputError, match="path"):
        _result().write_json(bad)
    assert _listing(tmp_path) == []


# ----------------------------------------------------------------------------------------
# what the writer does not own: links are written through, nothing else is replaced


def test_a_symlink_is_written_through_to_its_target_atomically(tmp_path):
    """The link stays a link; its target (in another folder) gets the new content, through
    a temporary file in the target's folder; nothing is left in either folder."""
    real, links = tmp_path / "real", tmp_path / "links"
    real.mkdir()
    links.mkdir()
    (real / "r.json").write_text("old")
    link = links / "r.json"
    link.symlink_to(Path("..") / "real" / "r.json")  # relative, as users make them
    _result().write_json(link)
    assert link.is_symlink() and os.readlink(link) == os.path.join("..", "real", "r.json")
    assert json.loads((real / "r.json").read_text())["name"] == "faults"
    assert _listing(real) == ["r.json"] and _listing(links) == ["r.json"]


def test_a_chain_of_links_is_followed_to_its_end(tmp_path):
    (tmp_path / "file.txt").write_text("old")
    (tmp_path / "l2").symlink_to("file.txt")
    (tmp_path / "l1").symlink_to("l2")
    assert files.write_atomic(tmp_path / "l1", "new") == tmp_path / "l1"
    assert (tmp_path / "l1").is_symlink() and (tmp_path / "l2").is_symlink()
    assert (tmp_path / "file.txt").read_text() == "new"
    assert not (tmp_path / "file.txt").is_symlink()
    assert _listing(tmp_path) == ["file.txt", "l1", "l2"]


def test_a_dangling_link_creates_its_target_only_in_an_existing_folder(tmp_path):
    (tmp_path / "new").symlink_to("made.txt")
    files.write_atomic(tmp_path / "new", "made")
    assert (tmp_path / "made.txt").read_text() == "made" and (tmp_path / "new").is_symlink()
    (tmp_path / "nowhere").symlink_to(tmp_path / "missing" / "x.txt")
    with pytest.raises(OutputError, match=r"symbolic link to .*missing/x\.txt.*does not "
                                          r"exist"):
        files.write_atomic(tmp_path / "nowhere", "x")
    assert not (tmp_path / "missing").exists()
    assert _listing(tmp_path) == ["made.txt", "new", "nowhere"]


def test_a_loop_of_links_is_refused(tmp_path):
    (tmp_path / "a").symlink_to("b")
    (tmp_path / "b").symlink_to("a")
    with pytest.raises(OutputError, match="loop of links"):
        files.write_atomic(tmp_path / "a", "x")
    assert _listing(tmp_path) == ["a", "b"]
    assert os.readlink(tmp_path / "a") == "b" and os.readlink(tmp_path / "b") == "a"


def _socket_at(path: Path):
    import socket

    if len(os.fsencode(path)) >= 100:  # sun_path holds 108 bytes
        pytest.skip("the temporary folder's path is too long for a unix socket")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.bind(str(path))
    return sock


@pytest.mark.parametrize("kind", ["fifo", "socket", "directory"])
@pytest.mark.parametrize("via_link", [False, True])
def test_a_fifo_socket_or_directory_is_refused_and_kept(tmp_path, kind, via_link):
    """Refused before anything is written, naming what it is; it stays what it was."""
    entry = tmp_path / "thing"
    sock = None
    if kind == "fifo":
        os.mkfifo(entry)
    elif kind == "socket":
        sock = _socket_at(entry)
    else:
        entry.mkdir()
    what = {"fifo": r"a FIFO \(named pipe\)", "socket": "a socket",
            "directory": "a directory"}[kind]
    path = entry
    if via_link:
        path = tmp_path / "link"
        path.symlink_to(entry)
    try:
        with pytest.raises(OutputError, match=rf"is {what}, expected a file path") as info:
            files.write_atomic(path, "x")
        with pytest.raises(OutputError, match=rf"is {what}"):
            _result().write_json(path)
    finally:
        if sock is not None:
            sock.close()
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    if via_link:
        assert "symbolic link to" in str(info.value) and path.is_symlink()
    test = {"fifo": stat.S_ISFIFO, "socket": stat.S_ISSOCK, "directory": stat.S_ISDIR}[kind]
    assert test(os.lstat(entry).st_mode)
    assert _listing(tmp_path) == sorted(["thing", *(["link"] if via_link else [])])


@pytest.fixture
def dev_guarded(monkeypatch):
    """A writer that regressed must not replace /dev/null for the whole machine (as root
    it could): a temporary file or a rename in /dev fails the test instead."""
    real_mkstemp, real_replace = tempfile.mkstemp, os.replace

    def in_dev(path) -> bool:
        return (os.path.realpath(path) + "/").startswith("/dev/")

    def mkstemp(*args, dir=None, **kwargs):
        assert dir is None or not in_dev(dir), f"a temporary file in {dir}"
        return real_mkstemp(*args, dir=dir, **kwargs)

    def replace(src, dst):
        assert not in_dev(dst), f"{dst} replaced"
        return real_replace(src, dst)

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    monkeypatch.setattr(os, "replace", replace)


@pytest.mark.parametrize("via_link", [False, True])
def test_a_device_is_refused_and_kept(tmp_path, via_link, dev_guarded):
    """/dev/null (a character device) is never replaced by a regular file, even as root."""
    before = os.stat("/dev/null")
    assert stat.S_ISCHR(before.st_mode)
    path = Path("/dev/null")
    if via_link:
        path = tmp_path / "null"
        path.symlink_to("/dev/null")
    with pytest.raises(OutputError, match="is a character device, expected a file path"):
        files.write_atomic(path, "x")
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev
    assert _listing(tmp_path) == (["null"] if via_link else [])


# ----------------------------------------------------------------------------------------
# a replaced file keeps what it was: its mode, owner and group; nor is a read-only or
# hard-linked file replaced (the tests may run as root: the mode bits are checked, not
# just what os.access says)


@pytest.mark.parametrize("mode", [0o600, 0o640, 0o604, 0o755, 0o2660])
@pytest.mark.parametrize("via_link", [False, True])
def test_a_replaced_file_keeps_its_mode(tmp_path, mode, via_link):
    """A private file stays private whatever the umask; the new content is complete."""
    target = tmp_path / "r.json"
    target.write_text("old")
    os.chmod(target, mode)
    path = target
    if via_link:
        path = tmp_path / "link.json"
        path.symlink_to("r.json")
    old = os.umask(0o000)  # the umask would give 0666: the file's own mode must win
    try:
        _result().write_json(path)
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(target).st_mode) == mode
    assert json.loads(target.read_text())["name"] == "faults"
    assert _listing(tmp_path) == sorted(["r.json", *(["link.json"] if via_link else [])])


@pytest.mark.skipif(os.geteuid() != 0, reason="only root may give a file to another owner")
def test_a_replaced_file_keeps_its_owner_and_group(tmp_path):
    target = tmp_path / "r.json"
    target.write_text("old")
    os.chown(target, 12345, 23456)
    os.chmod(target, 0o640)
    files.write_atomic(target, "new")
    st = os.stat(target)
    assert (st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode)) == (12345, 23456, 0o640)
    assert target.read_text() == "new"


@pytest.mark.parametrize("mode", [0o444, 0o400, 0o555, 0o044])
@pytest.mark.parametrize("via_link", [False, True])
def test_a_read_only_file_is_refused_and_kept(tmp_path, mode, via_link):
    """As the shell's ``>`` refuses it (even though the folder would allow the rename)."""
    target = tmp_path / "r.json"
    target.write_text("old")
    os.chmod(target, mode)
    inode = os.stat(target).st_ino
    path = target
    if via_link:
        path = tmp_path / "link.json"
        path.symlink_to("r.json")
    with pytest.raises(OutputError, match=rf"is read-only \(mode {mode:04o}\); nothing was "
                                          "written") as info:
        files.write_atomic(path, "new")
    with pytest.raises(OutputError, match="is read-only"):
        _result().write_json(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    st = os.stat(target)
    assert (st.st_ino, stat.S_IMODE(st.st_mode)) == (inode, mode)
    os.chmod(target, 0o644)  # 0044 is unreadable to its owner (unless root)
    assert target.read_text() == "old"
    assert _listing(tmp_path) == sorted(["r.json", *(["link.json"] if via_link else [])])


def test_a_file_with_other_hard_links_is_refused_and_every_name_kept(tmp_path):
    """Replacing it would leave the other name stale; writing in place is not atomic."""
    (tmp_path / "other").mkdir()
    target = tmp_path / "r.json"
    target.write_text("old")
    os.link(target, tmp_path / "other" / "same.json")
    os.link(target, tmp_path / "again.json")
    with pytest.raises(OutputError, match=r"r\.json' has 3 hard links; replacing it would "
                                          "leave its other names with the old content"):
        files.write_atomic(target, "new")
    with pytest.raises(OutputError, match="has 3 hard links"):
        _result().write_json(target)
    st = os.stat(target)
    assert st.st_nlink == 3 and st.st_ino == os.stat(tmp_path / "again.json").st_ino
    for name in ("r.json", "again.json", "other/same.json"):
        assert (tmp_path / name).read_text() == "old"
    assert _listing(tmp_path) == ["again.json", "other", "other/same.json", "r.json"]
    (tmp_path / "again.json").unlink()
    (tmp_path / "other" / "same.json").unlink()
    files.write_atomic(target, "new")  # its only name now: replaced as any file
    assert target.read_text() == "new"


def _as_nobody(call) -> tuple[int, str]:
    """Run ``call()`` in a child process as the user and group nobody (65534), no groups."""
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        code, text = 0, ""
        try:
            os.close(read)
            os.setgroups([])
            os.setgid(65534)
            os.setuid(65534)
            call()
        except OutputError as exc:
            code, text = 1, str(exc)
        except BaseException as exc:  # noqa: BLE001 - reported to the parent
            code, text = 2, f"{type(exc).__name__}: {exc}"
        os.write(write, text.encode())
        os._exit(code)
    os.close(write)
    with os.fdopen(read, "rb") as fh:
        text = fh.read().decode()
    return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), text


@pytest.mark.skipif(os.geteuid() != 0, reason="needs root to act as another user")
def test_a_file_of_another_user_or_group_is_refused_and_kept(tmp_path):
    """Its replacement would change hands (and who may read it): refused, not given away."""
    shared = Path(tempfile.mkdtemp(prefix="wb-shared-"))  # /tmp: reachable by nobody
    try:
        os.chmod(shared, 0o777)
        theirs, group = shared / "theirs.json", shared / "group.json"
        for path, owner, mode in ((theirs, (0, 0), 0o666), (group, (65534, 0), 0o664)):
            path.write_text("old")
            os.chown(path, *owner)
            os.chmod(path, mode)
        code, text = _as_nobody(lambda: files.write_atomic(theirs, "new"))
        assert code == 1 and "is owned by another user (uid 0)" in text, text
        code, text = _as_nobody(lambda: files.write_atomic(group, "new"))
        assert code == 1 and "belongs to group 0, which this process is not in" in text, text
        for path, owner in ((theirs, (0, 0)), (group, (65534, 0))):
            st = os.stat(path)
            assert (st.st_uid, st.st_gid, path.read_text()) == (*owner, "old")
        mine = shared / "mine.json"  # and nobody's own file is replaced, mode kept
        mine.write_text("old")
        os.chown(mine, 65534, 65534)
        os.chmod(mine, 0o600)
        assert _as_nobody(lambda: files.write_atomic(mine, "new")) == (0, "")
        st = os.stat(mine)
        assert (st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode)) == (65534, 65534, 0o600)
        assert mine.read_text() == "new"
        assert sorted(p.name for p in shared.iterdir()) == ["group.json", "mine.json",
                                                            "theirs.json"]
    finally:
        for p in shared.iterdir():
            p.unlink()
        shared.rmdir()


# ----------------------------------------------------------------------------------------
# the command line


def test_cli_json_on_a_full_disk_is_one_line_and_nothing_partial(tmp_path, monkeypatch,
                                                                 capsys):
    from workbench.app import cli

    class Tiny:
        def solve(self, quick=False):
            return _result()

    monkeypatch.setattr(cli, "_problems", lambda: type(
        "P", (), {"names": staticmethod(lambda: ["tiny"]),
                  "load": staticmethod(lambda name: Tiny())}))

    def full(fd, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    (tmp_path / "out.json.probe").write_text("user")
    monkeypatch.setattr(os, "write", full)
    code = cli.main(["run", "tiny", "--json", str(tmp_path / "out.json")])
    monkeypatch.undo()
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "No space left" in err and "Traceback" not in err
    assert _listing(tmp_path) == ["out.json.probe"]


def _tiny_problems(monkeypatch, solved: list):
    from workbench.app import cli

    class Tiny:
        def solve(self, quick=False):
            solved.append(quick)
            return _result()

    monkeypatch.setattr(cli, "_problems", lambda: type(
        "P", (), {"names": staticmethod(lambda: ["tiny"]),
                  "load": staticmethod(lambda name: Tiny())}))
    return cli


@pytest.mark.parametrize("kind", ["read-only", "hard link"])
def test_cli_json_over_a_read_only_or_linked_file_is_refused_before_any_work(
        tmp_path, monkeypatch, capsys, kind):
    solved: list = []
    cli = _tiny_problems(monkeypatch, solved)
    path = tmp_path / "out.json"
    path.write_text("old")
    if kind == "read-only":
        os.chmod(path, 0o444)
    else:
        os.link(path, tmp_path / "other.json")
    code = cli.main(["run", "tiny", "--json", str(path)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and solved == [], "refused before the problem ran"
    what = r"is read-only \(mode 0444\)" if kind == "read-only" else "has 2 hard links"
    assert len(err.splitlines()) == 1 and re.search(rf"--json: .*out\.json' {what}", err), err
    assert path.read_text() == "old"
    assert _listing(tmp_path) == sorted(["out.json", *(["other.json"] if kind == "hard link"
                                                       else [])])


def test_cli_json_over_a_private_file_keeps_it_private(tmp_path, monkeypatch, capsys):
    solved: list = []
    cli = _tiny_problems(monkeypatch, solved)
    path = tmp_path / "out.json"
    path.write_text("old")
    os.chmod(path, 0o600)
    assert cli.main(["run", "tiny", "--json", str(path)]) == 0
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert json.loads(path.read_text())["values"]["x"] == 1.0


def test_cli_json_through_a_link_writes_its_target(tmp_path, monkeypatch, capsys):
    solved: list = []
    cli = _tiny_problems(monkeypatch, solved)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "out.json").write_text("stale")
    (tmp_path / "out.json").symlink_to(Path("data") / "out.json")
    assert cli.main(["run", "tiny", "--json", str(tmp_path / "out.json")]) == 0
    assert (tmp_path / "out.json").is_symlink()
    assert json.loads((tmp_path / "data" / "out.json").read_text())["values"]["x"] == 1.0
    assert _listing(tmp_path) == ["data", "data/out.json", "out.json"]


@pytest.mark.parametrize("kind", ["fifo", "device", "link to fifo"])
def test_cli_json_to_a_fifo_or_device_is_refused_before_any_work(tmp_path, monkeypatch,
                                                                 capsys, kind, dev_guarded):
    solved: list = []
    cli = _tiny_problems(monkeypatch, solved)
    path = tmp_path / "out.json"
    if kind == "device":
        path = Path("/dev/null")
    elif kind == "link to fifo":
        os.mkfifo(tmp_path / "fifo")
        path.symlink_to("fifo")
    else:
        os.mkfifo(path)
    code = cli.main(["run", "tiny", "--json", str(path)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and solved == [], "refused before the problem ran"
    what = "a character device" if kind == "device" else r"a FIFO \(named pipe\)"
    assert len(err.splitlines()) == 1 and re.search(rf"--json: .*is {what}", err), err
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    if kind != "device":
        assert stat.S_ISFIFO(os.stat(path).st_mode)


@pytest.mark.parametrize("argv", [["run", "pendulum3d_invariants", "--json", ""],
                                  ["report", "--out", ""]])
def test_cli_empty_output_path_is_an_error_before_any_work(argv, capsys):
    from workbench.app import cli

    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "non-empty path" in err


# ----------------------------------------------------------------------------------------
# generated files and the compile cache


def _strip_c_comments(code: str) -> str:
    return re.sub(r"/\*.*?\*/", "", code, flags=re.S)


def test_free_text_cannot_inject_c_code_or_make_recipes(tmp_path):
    from workbench.app.catalogue import build
    from workbench.codegen import Binding, compile_sources, generate

    base = build("s2_pd")
    evil = "x */ int injected_c = 1; /* y\nall:\n\techo injected_make \\"
    c = dataclasses.replace(base, title=evil, singular=evil, example_note=evil)
    src = generate(c, binding=Binding.FROZEN)
    for name, text in src.files.items():
        if name.endswith((".c", ".h")):
            assert "injected_c" not in _strip_c_comments(text), name
    mk = src.files["Makefile"]
    assert all(line.startswith("#") for line in mk.splitlines() if "injected" in line)
    # and the sources still compile warning-free (-Wall -Wextra -Werror: no nested /*)
    compiled = compile_sources(src, optimization="O2", cache_dir=tmp_path / "cache")
    assert compiled.library.is_file()


@pytest.mark.parametrize("name", ["1abc", "a b", "x*/", "", "name\n"])
def test_export_names_must_be_c_identifiers(name):
    from workbench.app.catalogue import build
    from workbench.core.errors import ModelError

    with pytest.raises(ModelError, match="identifier"):
        dataclasses.replace(build("s2_pd"), name=name)


def test_a_corrupt_cache_entry_is_found_by_content_and_rebuilt(tmp_path):
    from workbench.app.catalogue import build
    from workbench.codegen import Binding, compile_sources, generate

    src = generate(build("s2_pd"), binding=Binding.FROZEN)
    first = compile_sources(src, optimization="O2", cache_dir=tmp_path)
    again = compile_sources(src, optimization="O2", cache_dir=tmp_path)
    assert not first.cached and again.cached and again.directory == first.directory
    lib = first.library
    lib.write_bytes(lib.read_bytes()[:100])  # truncated: the manifest is still there
    with pytest.warns(RuntimeWarning, match="corrupt.*content hash differs"):
        rebuilt = compile_sources(src, optimization="O2", cache_dir=tmp_path)
    assert not rebuilt.cached and rebuilt.library.stat().st_size > 1000
    (first.directory / "manifest.json").write_text("{not json")
    with pytest.warns(RuntimeWarning, match="manifest unreadable"):
        assert not compile_sources(src, optimization="O2", cache_dir=tmp_path).cached
    assert compile_sources(src, optimization="O2", cache_dir=tmp_path).cached


def _export_worker(out: str, cache: str, queue) -> None:
    from workbench.app.catalogue import build
    from workbench.codegen import Binding, export_c

    try:
        res = export_c(build("s2_pd"), out, binding=Binding.FROZEN, cache_dir=cache)
        queue.put(("ok", sorted(p.name for p in res.files)))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent
        queue.put(("error", f"{type(exc).__name__}: {exc}"))


def test_two_processes_export_into_the_same_folder_and_cache_at_once(tmp_path):
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    out, cache = tmp_path / "out", tmp_path / "cache"
    procs = [ctx.Process(target=_export_worker, args=(str(out), str(cache), queue))
             for _ in range(2)]
    for p in procs:
        p.start()
    results = [queue.get(timeout=300) for _ in procs]
    for p in procs:
        p.join(timeout=60)
    assert [r[0] for r in results] == ["ok", "ok"], results
    names = results[0][1]
    assert sorted(p.name for p in out.iterdir()) == names  # no temp files left behind
    assert all((out / n).stat().st_size > 0 for n in names)
    entries = [p for p in cache.iterdir() if not p.name.startswith(".")]
    assert len(entries) == 1 and not [p for p in cache.iterdir() if p.name.startswith(".")]
    manifest = json.loads((entries[0] / "manifest.json").read_text())
    assert set(manifest["files"]) >= {"s2_pd.c", "libs2_pd.so"}
