"""A process's own figures from Linux's ``/proc`` (memory, umask)."""

from __future__ import annotations

__all__ = ["proc_status", "proc_status_mb", "reset_peak_rss"]


def proc_status(field: str, pid: int | str = "self") -> str:
    """The value of ``field`` in ``/proc/<pid>/status``, as written there.

    Raises
    ------
    OSError
        If the file cannot be read (not Linux, no such process) or has no such field.
    """
    with open(f"/proc/{pid}/status", encoding="ascii") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return line.split(":", 1)[1].strip()
    raise OSError(f"/proc/{pid}/status has no {field}")


def proc_status_mb(field: str, pid: int | str = "self") -> float:
    """A memory field of ``/proc/<pid>/status`` (``VmRSS``, ``VmHWM``, ...) [MB].

    Raises
    ------
    OSError
        As :func:`proc_status`, or if the value is not a size in kB.
    """
    value = proc_status(field, pid)
    try:
        return int(value.split()[0]) / 1024.0
    except (ValueError, IndexError):
        raise OSError(f"/proc/{pid}/status: {field} is {value!r}, not a size in kB") from None


def reset_peak_rss() -> float:
    """Reset this process's peak RSS (``VmHWM``) to its current RSS; return that [MB].

    Linux >= 4.0 (``/proc/self/clear_refs``). It changes what ``resource.getrusage``
    reports as this process's peak from then on: call it in a process of its own.

    Raises
    ------
    OSError
        Where ``/proc`` cannot do it.
    """
    with open("/proc/self/clear_refs", "w", encoding="ascii") as fh:
        fh.write("5")
    return proc_status_mb("VmRSS")
