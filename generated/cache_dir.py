"""The per-user cache directory as :func:`platformdirs.user_cache_dir` gives it, without importing it on Linux.

platformdirs takes 3-5 ms to import (its modules, regular expressions), more than a cache hit of the
compiled law costs otherwise. On Linux (not Android) with ``XDG_CACHE_HOME`` absolute, or else an
absolute ``HOME``, its answer is a join of those variables, computed here the same way
(``tests/test_cache_dir.py`` compares the two); in every other case platformdirs answers.
"""
from __future__ import annotations

import os
import posixpath
import sys


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
