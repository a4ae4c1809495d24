"""The one file writer of the workbench: complete files or nothing, never another's file.

Every writer (``Result.write_json``, the command line's ``--json``, the C export, the
report) goes through :func:`write_atomic`:

- the data go to a *unique* temporary name in the target folder (``mkstemp``), which is
  renamed over the target in one atomic step when complete;
- nothing is deleted that the writer did not create: no probe files, no fixed
  ``.partial`` names that could be a user's file;
- a new file gets the mode ``0o666 & ~umask``, like any file the user's shell creates;
  new folders (:func:`make_dir`, :func:`temp_dir`) get ``0o777 & ~umask``;
- a file that is replaced keeps its permission bits, its owner and its group (a private
  file of mode 0600 stays private). Its extended attributes and ACLs are not carried over;
- a read-only file (no write bit for its owner, whoever runs the writer, root included,
  or not writable by this process) is refused, as the shell's ``>`` refuses it: the
  rename would succeed in a writable folder, but the file says it is not to be changed;
- a file owned by another user, or by a group this process is not in, is refused unless
  this process may give the new file that owner and group (root): the new file would
  otherwise change hands, and who may read it;
- a file with more than one hard link is refused: replacing it would leave its other
  names with the old content (a stale copy, as a replaced symbolic link would be), and
  writing into it in place would not be atomic (an interrupted or failed write would
  leave a partial file under every name). Remove the other names, or write elsewhere;
- on any failure, including a full disk or a KeyboardInterrupt mid-write, the temporary
  file is removed and the target is left as it was; an :class:`OSError` becomes an
  :class:`~workbench.core.errors.OutputError` whose one-line message names the path and
  the reason;
- an empty output path is refused (it is not "the current directory");
- a path that is a symbolic link is written *through*: the link stays, and the file it
  points to (the end of its chain of links) is replaced atomically, by a temporary file
  in the target's own folder. A dangling link creates its target when the target's folder
  exists (as ``echo > link`` does), and is refused otherwise; a loop of links is refused;
- anything at the path (or at a link's target) that is not a regular file is refused
  before anything is written, naming what it is: a directory, a FIFO (named pipe), a
  socket, a character device (``/dev/null``, a terminal) or a block device. Replacing one
  with a regular file would destroy what another program owns, and writing into it would
  not be atomic. (Checked before the rename: an entry swapped in between by another
  process is replaced.)
- a path that names an open file descriptor of a process, at any step of its resolution
  (``/dev/stdout``, ``/dev/stderr``, ``/dev/stdin``, ``/dev/fd/N``, ``/proc/PID/fd/N``,
  ``/proc/PID/task/TID/fd/N``, or a link whose chain passes through one), is refused
  before anything is written (:func:`descriptor_step`). Such a name is a stream, not a
  file: when the shell redirected it to a file (``>> log.txt``), following it leads to
  that file, and replacing the file would discard its earlier content and everything
  written to the descriptor (the shell's log keeps writing to the replaced, unlinked
  file). The same holds for a folder named through a descriptor. Write to standard
  output by the writer's own means (the command line's ``--json -``), or name the file.
"""

from __future__ import annotations

import os
import re
import stat
import tempfile
from pathlib import Path
from typing import Any

from workbench.core._proc import proc_status
from workbench.core.errors import OutputError, WorkbenchError
from workbench.core.validate import output_path

__all__ = ["write_atomic", "writable_file", "writable_dir", "make_dir", "temp_dir", "umask",
           "apply_umask", "descriptor_step", "refuse_descriptor"]


def umask() -> int:
    """The process's file-creation mask (read without changing it where the OS allows).

    Returns
    -------
    int
    """
    try:
        return int(proc_status("Umask"), 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


def apply_umask(path: str | os.PathLike, *, directory: bool = False) -> None:
    """Give ``path`` (created by a ``mkstemp``/``mkdtemp``, mode 0600/0700) the umask's mode.

    Parameters
    ----------
    path : path-like
        A file or folder this process created.
    directory : bool
        Whether it is a folder (base mode 0o777 instead of 0o666).
    """
    base = 0o777 if directory else 0o666
    os.chmod(path, base & ~umask())


def _reason(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__


_FD_DIR = re.compile(r"/proc/(?P<pid>\d+|self|thread-self)(?:/task/\d+)?/fd")
"""A process's (or thread's) table of open file descriptors in Linux's procfs."""

_STD_NAMES = frozenset({"/dev/stdin", "/dev/stdout", "/dev/stderr"})
"""The standard streams' names (links into ``/dev/fd`` on Linux, devices elsewhere)."""

_MAX_LINKS = 40
"""Links followed while resolving a path (Linux's own bound); more is a loop."""


def _in_fd_table(step: str) -> bool:
    """Whether ``step`` (a path whose folder is resolved) is an entry of a descriptor table.

    Besides the tables' own names, any link named by a number in a folder of procfs counts
    (a table mounted elsewhere, or bind-mounted under another name, keeps procfs's
    device; procfs's other numbered entries, the processes, are folders).
    """
    folder = os.path.dirname(step)
    if folder == "/dev/fd" or _FD_DIR.fullmatch(folder):
        return True
    if not os.path.basename(step).isdigit():
        return False
    try:
        return (os.stat(folder).st_dev == os.stat("/proc/self/fd").st_dev
                and stat.S_ISLNK(os.lstat(step).st_mode))
    except OSError:  # no procfs here, or the entry is gone
        return False


def descriptor_step(path: Any) -> str | None:
    """The step of ``path``'s resolution that names an open file descriptor, or None.

    ``path`` is resolved one component at a time, as the kernel does, following every
    symbolic link (in the last component or in a folder on the way). The first entry met
    in a process's table of open descriptors (``/proc/PID/fd/N``, ``/proc/PID/task/TID/fd/N``,
    ``/dev/fd/N`` where that is a folder of its own) or a standard stream's name
    (``/dev/stdout``, ``/dev/stderr``, ``/dev/stdin``) is returned. Nothing is written.

    Parameters
    ----------
    path : path-like
        The path (relative to the current directory if not absolute).

    Returns
    -------
    str or None
        That entry's path (``/proc/1234/fd/1`` for ``/dev/stdout``), or None if no step of
        the resolution names a descriptor (a missing component ends the resolution; a loop
        of links ends it after 40 links).
    """
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if not os.path.isabs(text):
        try:
            text = os.path.join(os.getcwd(), text)
        except OSError:  # the current folder was removed: nothing can be written in it
            return None
    todo = text.split("/")[::-1]
    here, links = "/", 0
    while todo:
        part = todo.pop()
        if part in ("", "."):
            continue
        if part == "..":  # ``here`` holds no links: its parent is the kernel's ``..``
            here = os.path.dirname(here)
            continue
        step = os.path.join(here, part)
        if _in_fd_table(step):
            return step
        try:
            is_link = stat.S_ISLNK(os.lstat(step).st_mode)
            target = os.readlink(step) if is_link else ""
        except OSError:  # missing or not searchable: nothing further to follow
            is_link = False
        if step in _STD_NAMES and not is_link:  # a device of its own (not Linux)
            return step
        links += is_link
        if not is_link or links > _MAX_LINKS:
            here = step
            continue
        if target.startswith("/"):
            here = "/"
        todo.extend(reversed(target.split("/")))
    return None


def refuse_descriptor(
    path: Any, *, name: str, error: type[WorkbenchError] = OutputError, hint: str = "",
    folder: bool = False,
) -> None:
    """Refuse a path named through an open file descriptor (see :func:`descriptor_step`).

    Parameters
    ----------
    path : path-like
        The output path (a file, or a folder if ``folder``).
    name : str
        The argument's name, for the message.
    error : type of WorkbenchError
        Raised if a step of the path's resolution names a descriptor.
    hint : str
        Added to the message: what to do instead.
    folder : bool
        Whether ``path`` is to be a folder (for the message).

    Raises
    ------
    WorkbenchError
        Of class ``error``, naming the path, the descriptor, the process and what the
        descriptor is open on.
    """
    p = Path(os.fspath(path))
    step = descriptor_step(p)
    if step is None:
        return
    found = _FD_DIR.fullmatch(os.path.dirname(step))
    fd = os.path.basename(step)
    who = f"file descriptor {fd} of process {found['pid']}" if found else "a file descriptor"
    try:
        on = f", open on {os.readlink(step)!r}"
    except OSError:
        on = ""
    via = f"{on[2:]}" if step == str(p) else f"through {step!r}{on}"
    via = f" ({via})" if via else ""
    on_folder = folder or os.path.isdir(step)
    why = ("the name of an open descriptor, not a folder's path" if on_folder else
           "a stream, not a file: replacing the file behind it would discard what was "
           "written to it and what is still written to the descriptor")
    raise error(f"{name}: {str(p)!r} names {who}{via}, {why}; nothing was written (expected "
                f"the path of a {'folder' if folder else 'file'}{'; ' + hint if hint else ''})")


def writable_dir(
    path: Any, *, name: str = "out_dir", error: type[WorkbenchError] = OutputError
) -> Path:
    """An existing folder this process may create files in (checked without writing).

    Parameters
    ----------
    path : path-like
        The folder.
    name : str
        The argument's name, for the message.
    error : type of WorkbenchError
        Raised if it is not such a folder.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    WorkbenchError
        Of class ``error``: missing, a file, without write permission, or named through
        an open file descriptor (``/dev/fd/N``, ``/proc/PID/fd/N``).
    """
    p = output_path(name, path, error=error)
    refuse_descriptor(p, name=name, error=error, folder=True)
    if p.exists() and not p.is_dir():
        raise error(f"{name}: {str(p)!r} exists and is not a directory")
    if not p.is_dir():
        raise error(f"{name}: directory {str(p)!r} does not exist")
    if not os.access(p, os.W_OK | os.X_OK):
        raise error(f"{name}: directory {str(p)!r} is not writable (permission denied)")
    return p


def make_dir(
    path: Any, *, name: str = "out_dir", error: type[WorkbenchError] = OutputError
) -> Path:
    """Create a folder (and its parents) with the umask's mode if missing; check it.

    Parameters
    ----------
    path : path-like
        The folder.
    name : str
        The argument's name, for the message.
    error : type of WorkbenchError
        Raised if it cannot be created or written.

    Returns
    -------
    pathlib.Path
    """
    p = output_path(name, path, error=error)
    refuse_descriptor(p, name=name, error=error, folder=True)
    if p.exists() and not p.is_dir():
        raise error(f"{name}: {str(p)!r} exists and is not a directory")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise error(f"{name}: cannot create directory {str(p)!r} ({_reason(exc)})") from exc
    return writable_dir(p, name=name, error=error)


def temp_dir(
    parent: Path, prefix: str, *, name: str = "out_dir",
    error: type[WorkbenchError] = OutputError,
) -> Path:
    """A new uniquely named folder in ``parent`` with the umask's mode (to be renamed).

    Parameters
    ----------
    parent : Path
        Where to create it (the target's folder, so a rename is atomic).
    prefix : str
        Start of its name.
    name : str
        The argument's name, for the message.
    error : type of WorkbenchError
        Raised if it cannot be created.

    Returns
    -------
    pathlib.Path
    """
    try:
        tmp = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
    except OSError as exc:
        raise error(f"{name}: cannot create files in {str(parent)!r} ({_reason(exc)})"
                    ) from exc
    apply_umask(tmp, directory=True)
    return tmp


_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"))
"""What an entry that is not a regular file is, for the message."""


def _kind(mode: int) -> str:
    for test, what in _KINDS:
        if test(mode):
            return what
    return "not a regular file"


def _check_replaceable(
    target: Path, what: str, *, name: str, error: type[WorkbenchError]
) -> os.stat_result:
    """Refuse an existing regular file a replacement would change more than in content."""
    st = os.stat(target)
    if not st.st_mode & stat.S_IWUSR or not os.access(target, os.W_OK):
        raise error(f"{name}: {what} is read-only (mode {stat.S_IMODE(st.st_mode):04o}); "
                    f"nothing was written (make it writable, or choose another path)")
    if st.st_nlink > 1:
        raise error(f"{name}: {what} has {st.st_nlink} hard links; replacing it would leave "
                    f"its other names with the old content, and writing it in place would "
                    f"not be atomic; nothing was written (remove its other names, or choose "
                    f"another path)")
    euid = os.geteuid()
    if euid != 0 and st.st_uid != euid:
        raise error(f"{name}: {what} is owned by another user (uid {st.st_uid}); replacing "
                    f"it would make the new file yours; nothing was written (choose another "
                    f"path)")
    if euid != 0 and st.st_gid not in {os.getegid(), *os.getgroups()}:
        raise error(f"{name}: {what} belongs to group {st.st_gid}, which this process is "
                    f"not in; replacing it would change its group, and who may read it; "
                    f"nothing was written (choose another path)")
    return st


def writable_file(
    path: Any, *, name: str = "path", error: type[WorkbenchError] = OutputError,
    hint: str = "",
) -> Path:
    """The regular file a write to ``path`` replaces: ``path``, or the file its link names.

    Checked without writing anything. A symbolic link is followed to the end of its
    chain: the file there is the one written (a dangling link's target is created if its
    folder exists). Nothing that is not a regular file is ever replaced.

    Parameters
    ----------
    path : path-like
        The output path.
    name : str
        The argument's name, for the message.
    error : type of WorkbenchError
        Raised if ``path`` cannot be written as a regular file.
    hint : str
        Added to the message refusing a path named through a file descriptor (what to do
        instead, e.g. the writer's own way to standard output).

    Returns
    -------
    pathlib.Path
        ``path`` itself, or (for a symbolic link) the absolute path of its target.

    Raises
    ------
    WorkbenchError
        Of class ``error``: an empty path; a step of its resolution names an open file
        descriptor (``/dev/stdout``, ``/dev/fd/N``, ``/proc/PID/fd/N``, see
        :func:`descriptor_step`); ``path`` or its link's target is a directory,
        a FIFO, a socket or a device; a loop of links; the folder of the file to write
        does not exist; the file is read-only, has more than one hard link, or has an
        owner or group its replacement could not keep (see the module's description).
    """
    p = output_path(name, path, error=error)
    refuse_descriptor(p, name=name, error=error, hint=hint)
    target, what = p, f"{str(p)!r}"
    if p.is_symlink():
        target = Path(os.path.realpath(p))
        what = f"{str(p)!r} (a symbolic link to {str(target)!r})"
        if target.is_symlink():  # realpath stops where a chain of links loops
            raise error(f"{name}: {str(p)!r} is a symbolic link in a loop of links "
                        f"(through {str(target)!r}); nothing was written")
    try:
        mode: int | None = os.stat(target).st_mode
    except FileNotFoundError:
        mode = None
    except OSError as exc:  # e.g. a component that is a file, or no search permission
        raise error(f"{name}: cannot write {what} ({_reason(exc)}); nothing was "
                    f"written") from exc
    if mode is not None and not stat.S_ISREG(mode):
        raise error(f"{name}: {what} is {_kind(mode)}, expected a file path (only a regular "
                    f"file is replaced); nothing was written")
    if mode is not None:
        _check_replaceable(target, what, name=name, error=error)
    parent = target.parent
    if not parent.is_dir():
        raise error(f"{name}: directory {str(parent)!r} of {what} does not exist")
    return target


def _take_over(fd: int, old: os.stat_result | None) -> None:
    """Give the new file ``fd`` the mode, owner and group of the file it replaces.

    A new file (``old`` None) gets the umask's mode. The owner is set before the mode, as
    a change of owner may clear the set-user-ID bits.
    """
    if old is None:
        os.fchmod(fd, 0o666 & ~umask())
        return
    now = os.fstat(fd)
    if (now.st_uid, now.st_gid) != (old.st_uid, old.st_gid):
        os.fchown(fd, old.st_uid, old.st_gid)
    os.fchmod(fd, stat.S_IMODE(old.st_mode))


def write_atomic(
    path: Any,
    data: bytes | str,
    *,
    name: str = "path",
    error: type[WorkbenchError] = OutputError,
) -> Path:
    """Write a whole file under a unique temporary name in its folder, then rename it.

    Parameters
    ----------
    path : path-like
        The target file; its folder must exist. An existing regular file is replaced
        atomically, keeping its mode, owner and group; a symbolic link is written through
        (its target is replaced, the link kept; see :func:`writable_file`).
    data : bytes or str
        The content (str is written as UTF-8).
    name : str
        The argument's name, for the message.
    error : type of WorkbenchError
        Raised (from the OSError) if the file cannot be written.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    WorkbenchError
        Of class ``error``: an empty path; a path named through an open file descriptor
        (``/dev/stdout``, ``/dev/fd/N``, ``/proc/PID/fd/N``); a directory, FIFO, socket or
        device (at the path or at its link's target); a missing or read-only folder; a
        read-only file, one with more than one hard link, or one whose owner or group
        cannot be kept; a full disk. Nothing is left behind; the target is unchanged.
    """
    p = output_path(name, path, error=error)
    target = writable_file(p, name=name, error=error)
    shown = repr(str(p)) if target == p else \
        f"{str(p)!r} (a symbolic link to {str(target)!r})"
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        old = os.stat(target)
    except FileNotFoundError:
        old = None
    except OSError as exc:
        raise error(f"{name}: cannot write {shown} ({_reason(exc)}); nothing was "
                    f"written") from exc
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp",
                                   dir=target.parent)
    except OSError as exc:
        raise error(f"{name}: cannot write {shown} ({_reason(exc)})") from exc
    try:
        try:
            view = memoryview(payload)
            while view:
                view = view[os.write(fd, view):]
            _take_over(fd, old)
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except BaseException as exc:  # also KeyboardInterrupt: leave nothing behind
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            raise error(f"{name}: cannot write {shown} ({_reason(exc)}); nothing was "
                        f"written") from exc
        raise
    return p
