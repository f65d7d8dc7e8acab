"""Run one compiler command so that it dies with the process that started it.

``python -I -S compiler_guard.py PARENT_PID CC ARGS...``: the guard asks the kernel for SIGTERM
when its parent dies (``prctl(PR_SET_PDEATHSIG)``), starts the compiler (in the same process
group, so a terminal's Ctrl-C or a kill of the group still reaches it directly) and, on that
signal (or SIGINT, SIGTERM, SIGHUP), SIGKILLs every process it started, found through ``/proc``:
the driver and the ``cc1``/``as`` the driver started, which a signal to the driver alone would
leave running. Its exit status is the compiler's. Standard library only, and no ``site`` import:
it starts in about 20 ms. (A ``PR_SET_PDEATHSIG`` of the driver itself would not reach ``cc1``:
the setting is not inherited.)
"""
from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys

#: ``prctl`` option: the signal this process gets when its parent dies (linux/prctl.h).
PR_SET_PDEATHSIG = 1
#: The signals that stop the compiler's group.
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)


def die_with_parent(parent: int) -> bool:
    """Ask for SIGTERM when the parent dies; whether the parent ``parent`` is still alive (no race).

    Parameters
    ----------
    parent : int
        The process id of the process that started the guard.

    Returns
    -------
    bool
        False when the parent is already gone (or the request failed on a system without prctl).
    """
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):
        return False
    return os.getppid() == parent


def descendants(pid: int) -> list[int]:
    """Every process started by ``pid``, its children's children and so on (read from ``/proc``).

    Parameters
    ----------
    pid : int
        The root process.

    Returns
    -------
    list of int
        Their process ids, parents before children.
    """
    children: dict[int, list[int]] = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue
        children.setdefault(ppid, []).append(int(name))
    found, todo = [], list(children.get(pid, []))
    while todo:
        p = todo.pop(0)
        found.append(p)
        todo += children.get(p, [])
    return found


def kill_descendants() -> None:
    """SIGKILL every process this one started (twice: a driver may fork while it is stopped)."""
    for _ in range(2):
        for pid in descendants(os.getpid()):
            try:
                os.kill(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass


def main(argv: list[str]) -> int:
    """Run ``argv[1:]`` (the compiler) guarded for the parent ``argv[0]``; return its exit status.

    Parameters
    ----------
    argv : list of str
        The parent's process id, then the compiler command.

    Returns
    -------
    int
        The compiler's exit status (128 + the signal if it was stopped).
    """
    def stop(signum: int, frame: object) -> None:
        kill_descendants()
        os._exit(128 + signum)

    for signum in STOP_SIGNALS:
        signal.signal(signum, stop)
    if not die_with_parent(int(argv[0])):
        return 128 + int(signal.SIGTERM)
    return subprocess.call(argv[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` exists (also one of another user).

    Parameters
    ----------
    pid : int
        A process id.

    Returns
    -------
    bool
    """
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return pid > 0


def kill_process_tree(pid: int) -> None:
    """SIGKILL process ``pid`` and every process it started, recursively (children looked up first).

    The compiler shares this process's group (so that a terminal's Ctrl-C reaches it), so the
    group cannot be killed as a whole; psutil finds the descendants.

    Parameters
    ----------
    pid : int
        The process (the compiler driver).
    """
    import psutil

    try:
        root = psutil.Process(pid)
        tree = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return
    for proc in tree:
        try:
            proc.kill()
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            pass
