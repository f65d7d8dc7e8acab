"""The machine a run is logged on, as the ``run`` metadata names it, without the costs of asking.

:func:`platform.platform` runs ``uname -p`` in a new process (about 5 ms) and :mod:`socket` takes
2 ms to import for :func:`socket.gethostname`: on Linux the platform string is remembered in the
private build cache (:func:`~coordarm.generated.code_identity.remembered_digest`) under everything it
is computed from, and the host name is the kernel's node name, which ``gethostname`` returns.
"""
from __future__ import annotations

import os
import platform
import shutil
import sys


def host_name() -> str:
    """The host name: :func:`socket.gethostname` (on Linux the kernel's node name, which it returns).

    Returns
    -------
    str
        The name.
    """
    if sys.platform.startswith("linux"):
        return os.uname().nodename
    import socket
    return socket.gethostname()


def host_platform() -> str:
    """:func:`platform.platform`, remembered on Linux while what it is computed from is unchanged.

    The key holds the kernel's ``uname`` (system, release, version, machine), the interpreter (its
    version, its file, whose libc it names) and the ``uname`` program on ``PATH`` (whose ``-p``
    answer it includes), so the remembered text is the one :func:`platform.platform` would give.

    Returns
    -------
    str
        E.g. ``"Linux-6.1.0-x86_64-with-glibc2.36"``.
    """
    if not sys.platform.startswith("linux"):
        return platform.platform()
    from coordarm.generated.code_identity import remembered_digest

    uname = shutil.which("uname") or ""
    return remembered_digest("platform", [sys.executable, *([uname] if uname else [])], platform.platform,
                             *os.uname()[:1], *os.uname()[2:], uname, sys.version, platform.__file__)
