"""What identifies the package's files without reading them: keys for memos of values computed from them.

A value computed from source files (the log's ``code_hash``, a controller's generated C) can be
remembered (:func:`coordarm.generated.compiler_memo.recall`) under a key that changes whenever any of
the files does: :func:`files_key` hashes each file's path and identity (device, inode, size,
modification and change times [ns]), what Python itself trusts to reuse a
module's bytecode (with less: its path, size and modification second). A change of content keeps
neither the inode (a file replaced, as editors, git and pip do) nor the change time (a file written
in place; it cannot be set back), except within one tick of the file system's clock: so a key whose
files changed less than :data:`SETTLE_SECONDS` ago is not remembered (``settled`` False), as git
does with "racily clean" entries.
"""
from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Callable, Iterable, Sequence

from coordarm.symbolic.digests import sha256

from .compiler_memo import DIGESTS, recall

#: Seconds a file must be left alone before a key built from its identity is remembered [s].
SETTLE_SECONDS = 2.0
#: Most digests remembered.
DIGEST_ENTRIES = 64


def files_key(paths: Iterable[str], *extra: str) -> tuple[str, bool]:
    """A key that changes whenever one of ``paths`` (or the list, or ``extra``) does.

    Parameters
    ----------
    paths : iterable of str
        The files, in a fixed order.
    *extra : str
        Further text the key depends on (versions, names).

    Returns
    -------
    key : str
        SHA-256 hex over each path with its identity (or ``missing``), then ``extra``.
    settled : bool
        Whether every file was last changed at least :data:`SETTLE_SECONDS` ago (and exists): only
        then may a value be remembered under ``key``.
    """
    lines, newest = [], 0
    for path in paths:
        try:
            st = os.stat(path)
        except OSError:
            lines.append(f"{path}\0missing")
            newest = time.time_ns()
            continue
        lines.append(f"{path}\0{st.st_dev} {st.st_ino} {st.st_size} {st.st_mtime_ns} {st.st_ctime_ns}")
        newest = max(newest, st.st_mtime_ns, st.st_ctime_ns)
    digest = sha256("\n".join(lines).encode())
    for part in extra:
        digest.update(b"\0" + part.encode())
    return digest.hexdigest(), newest < time.time_ns() - SETTLE_SECONDS * 1e9


def package_files(root: str | os.PathLike, folders: Sequence[str], suffix: str = ".py",
                  recursive: bool = False) -> list[str]:
    """The files of ``folders`` of ``root`` whose names end with ``suffix``, sorted (``__pycache__`` left out).

    Parameters
    ----------
    root : str or path-like
        The folder holding the packages (symbolic links to folders are followed).
    folders : sequence of str
        Its sub-folders to list, in this order.
    suffix : str
        End of the names listed ("" for every file).
    recursive : bool
        Include the sub-folders' files (templates, presets).

    Returns
    -------
    list of str
        Per folder, its files' paths, sorted.
    """
    found: list[str] = []
    for folder in folders:
        names: list[str] = []
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, folder), followlinks=True):
            dirnames[:] = [d for d in dirnames if d != "__pycache__"] if recursive else []
            names += [os.path.join(dirpath, f) for f in filenames if f.endswith(suffix)]
        found += sorted(names)
    return found


def memo_root() -> Path | None:
    """The build cache directory when it exists and is this user's alone (memos go there), else None.

    Returns
    -------
    Path or None
        :func:`~coordarm.generated.build.build_root`, never created here (nor warned about: a build
        does both).
    """
    from .build import build_root
    from .cache_dir import root_problem

    root = build_root()
    return root if root_problem(root) is None else None


def remembered_digest(name: str, paths: Sequence[str], compute: Callable[[], str], *extra: str) -> str:
    """``compute()``, a value that depends only on the files ``paths`` (and ``extra``), remembered in the
    private build cache under :func:`files_key` of them.

    Parameters
    ----------
    name : str
        What the value is (it prefixes the key in the memo file :data:`~.compiler_memo.DIGESTS`).
    paths : sequence of str
        The files the value is computed from.
    compute : callable
        ``compute() -> str``.
    *extra : str
        Further text the value depends on.

    Returns
    -------
    str
        The value: remembered when the files are unchanged, else computed (and remembered when they
        are settled, :data:`SETTLE_SECONDS`, and the cache is private, :func:`memo_root`).
    """
    root = memo_root()
    if root is None:
        return compute()
    key, settled = files_key(paths, *extra)
    return recall(root, DIGESTS, f"{name} {key}", compute, entries=DIGEST_ENTRIES, store=settled)


def sources_digest(root: str | os.PathLike, folders: Sequence[str]) -> str:
    """SHA-256 over each ``*.py`` file of ``folders`` of ``root`` (:func:`package_files` order): its
    ``folder/name``, a NUL byte and its content; remembered while they are unchanged
    (:func:`remembered_digest`: a call then reads none of them).

    Parameters
    ----------
    root : str or path-like
        The folder holding the packages.
    folders : sequence of str
        The packages, in this order.

    Returns
    -------
    str
        64 hex digits.
    """
    files = package_files(root, folders)

    def digest() -> str:
        h = sha256()
        for path in files:
            h.update(f"{os.path.basename(os.path.dirname(path))}/{os.path.basename(path)}\0".encode())
            with open(path, "rb") as f:
                h.update(f.read())
        return h.hexdigest()
    return remembered_digest("sources", files, digest)
