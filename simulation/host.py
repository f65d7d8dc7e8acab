"""The machine a run is logged on and the versions it runs, as the metadata names them, without the costs of asking.

:func:`platform.platform` runs ``uname -p`` in a new process (about 5 ms) and :mod:`socket` takes
2 ms to import for :func:`socket.gethostname`: on Linux the platform string is remembered in the
private build cache (:func:`~coordarm.generated.code_identity.remembered_digest`) under everything it
is computed from, and the host name is the kernel's node name, which ``gethostname`` returns. A
package's version is its ``__version__``, remembered under its files' identity when it is not loaded
yet (importing zstandard for its version alone took ~3 ms of every run).
"""
from __future__ import annotations

import importlib.util
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


def installed_version(module: str) -> str:
    """The ``__version__`` of ``module`` (``"unknown"`` when it is not installed), without
    :mod:`importlib.metadata` (~20 ms to import) and, for a module not loaded yet, without loading it
    while its file is unchanged (remembered under the identity of the file its spec names:
    :func:`~coordarm.generated.code_identity.remembered_digest`; an install or upgrade replaces it).

    Parameters
    ----------
    module : str
        The module, e.g. ``"zstandard"`` or ``"coordarm.version"``.

    Returns
    -------
    str
        Its version.
    """
    def imported() -> str:
        try:
            return str(importlib.import_module(module).__version__)
        except (ImportError, AttributeError):
            return "unknown"
    if module in sys.modules:
        return imported()
    try:
        spec = importlib.util.find_spec(module)      # locates the module (a package's parent is imported)
    except (ImportError, ValueError):
        return "unknown"
    if spec is None or not spec.origin or not os.path.isfile(spec.origin):
        return imported()
    from coordarm.generated.code_identity import remembered_digest
    return remembered_digest(f"version {module}", [spec.origin], imported)
