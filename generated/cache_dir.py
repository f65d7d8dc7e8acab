"""The per-user cache directory: where it is (:func:`platformdirs.user_cache_dir`'s answer, without importing
it on Linux) and whether it is this user's alone (:func:`root_problem`).

platformdirs takes 3-5 ms to import (its modules, regular expressions), more than a cache hit of the
compiled law costs otherwise. On Linux (not Android) with ``XDG_CACHE_HOME`` absolute, or else an
absolute ``HOME``, its answer is a join of those variables, computed here the same way
(``tests/test_cache_dir.py`` compares the two); in every other case platformdirs answers.
"""
from __future__ import annotations

import os
import posixpath
import stat
import sys
from pathlib import Path


def user_cache_dir(app: str) -> str:
    """``platformdirs.user_cache_dir(app, appauthor=False)``.

    Parameters
    ----------
    app : str
        The application's name (the last component).

    Returns
    -------
    str
        ``$XDG_CACHE_HOME/app`` (an absolute ``XDG_CACHE_HOME``), else ``~/.cache/app`` on Linux; elsewhere
        what platformdirs says.
    """
    linux = (sys.platform == "linux" and not hasattr(sys, "getandroidapilevel")
             and not (os.environ.get("ANDROID_DATA") == "/data" and os.environ.get("ANDROID_ROOT") == "/system"))
    if linux:
        xdg = os.environ.get("XDG_CACHE_HOME", "")
        if posixpath.isabs(xdg):
            return os.path.join(xdg, app)
        home = os.environ.get("HOME")
        if home is not None and posixpath.isabs(home):
            return os.path.join(os.path.expanduser("~/.cache"), app)
    from platformdirs import user_cache_dir as platform_cache_dir
    return platform_cache_dir(app, appauthor=False)


def own_group(gid: int) -> bool:
    """Whether group ``gid`` is this user's own: the user's primary group, with no other members listed
    (the "user private group" of most Linux systems, where ``umask 002`` makes directories group-writable).

    Parameters
    ----------
    gid : int
        A group id.

    Returns
    -------
    bool
        False for any other group, or when the group database does not know ``gid``.
    """
    if gid != os.getgid():
        return False
    import grp
    import pwd

    try:
        members = set(grp.getgrgid(gid).gr_mem)
        name = pwd.getpwuid(os.getuid()).pw_name
    except KeyError:
        return False
    return members <= {name}


def root_problem(root: Path) -> str | None:
    """Why the directory ``root`` is not this user's alone, or None when it is.

    Parameters
    ----------
    root : Path
        A cache directory.

    Returns
    -------
    str or None
        ``"owned by uid ..."``, ``"writable by others"``, ``"writable by group ..."`` (a group not the
        user's own, :func:`own_group`) or ``"unusable (...)"`` (missing or unreadable); None: private.
    """
    try:
        st = root.stat()
    except OSError as exc:
        return f"unusable ({exc.strerror or exc})"
    return (f"owned by uid {st.st_uid}, not {os.getuid()}" if st.st_uid != os.getuid() else
            "writable by others" if st.st_mode & stat.S_IWOTH else
            f"writable by group {st.st_gid}" if st.st_mode & stat.S_IWGRP and not own_group(st.st_gid)
            else None)
