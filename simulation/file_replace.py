"""Replacing a finished file by its final name: atomically, without ext4's forced write-out, and with the
storage of the file it replaces freed on a thread of its own (what ``coordarm run --overwrite`` does)."""
from __future__ import annotations

import errno
import functools
import os
import stat
import threading
from typing import Callable


#: Threads freeing the storage of files replaced by :func:`replace` with ``free_later`` (see :func:`wait_released`).
_releasing: list[threading.Thread] = []


@functools.cache
def _renameat2() -> Callable[..., int] | None:
    """The C library's ``renameat2`` (Linux, glibc 2.28+), or None where there is none."""
    import ctypes

    try:
        function = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return None
    function.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    function.restype = ctypes.c_int
    return function


#: ``renameat2``'s flag that swaps two names atomically, and its "relative to the working directory".
RENAME_EXCHANGE, AT_FDCWD = 2, -100


def exchange(src: str | os.PathLike, dst: str | os.PathLike) -> bool:
    """Swap the files at ``src`` and ``dst`` in one atomic step (``renameat2(RENAME_EXCHANGE)``).

    Both names exist throughout: ``dst`` names the old file, then the new one. Unlike a rename over
    ``dst``, this does not make ext4 write the new file's data out before returning (its
    ``auto_da_alloc``, meant for programs that replace a file without ``fsync``: 20-25 ms for a
    38 MB log here, ``benchmarks/RESULTS.md``); the data goes out as a new file's does.

    Parameters
    ----------
    src, dst : str or path-like
        Two existing names on one file system.

    Returns
    -------
    bool
        True when swapped; False where the system or file system cannot (nothing changed then).
    """
    import ctypes

    rename = _renameat2()
    if rename is None:
        return False
    if rename(AT_FDCWD, os.fsencode(src), AT_FDCWD, os.fsencode(dst), RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.EXDEV, errno.ENOENT, errno.EPERM):
        return False
    raise OSError(code, os.strerror(code), os.fsdecode(src), None, os.fsdecode(dst))


def replace(src: str | os.PathLike, dst: str | os.PathLike, *, free_later: bool = False) -> None:
    """``os.replace(src, dst)``, without ext4's forced write-out, optionally freeing the old file on a thread.

    A regular file at ``dst`` is swapped with ``src`` in one atomic step (:func:`exchange`), then
    its old name ``src`` is removed; elsewhere (no file there, another kind of file, a system or
    file system without the swap) it is ``os.replace``. Either way ``dst`` names the old file, then
    the new one, never nothing.

    Parameters
    ----------
    src, dst : str or path-like
        As for :func:`os.replace`.
    free_later : bool
        Free the old file's storage on a daemon thread: the kernel's freeing of its blocks and
        cached pages, which holding it open defers to the last close (20-30 ms for a 40 MB log on
        ext4), then runs while the caller goes on (e.g. with the run's summary).
        :func:`wait_released` waits for it; a process that ends first frees the file as it exits.

    Raises
    ------
    OSError
        As :func:`os.replace` raises it.
    """
    try:
        old = os.open(dst, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOFOLLOW", 0))
    except OSError:                 # nothing there (or not readable, or a symbolic link): a plain rename
        old = None
    try:
        if old is not None and stat.S_ISREG(os.fstat(old).st_mode) and exchange(src, dst):
            os.unlink(src)          # the old file's name now; its storage goes with the last close
        else:
            os.replace(src, dst)
    except BaseException:
        if old is not None:
            os.close(old)
        raise
    if old is None:
        return
    if not free_later:
        os.close(old)
        return
    thread = threading.Thread(target=os.close, args=(old,), name="coordarm-release", daemon=True)
    thread.start()
    _releasing.append(thread)


def wait_released() -> None:
    """Wait until the files replaced by :func:`replace` with ``free_later`` so far are freed (from any thread)."""
    while True:
        try:
            thread = _releasing.pop()
        except IndexError:       # none left (another thread may have taken the last one)
            return
        thread.join()
