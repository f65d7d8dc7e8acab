"""The build cache's small files: written atomically, and memos kept in them (:func:`recall`), the
compiler's version among them.

The cache key holds the compiler's ``--version`` (:func:`coordarm.generated.build.cache_key`). Asking
it costs a compiler run under the compiler guard (two processes, 30-130 ms): more than everything
else a cache hit does. The answer is a property of the executable, so :func:`compiler_version`
keeps it in :data:`MEMO` in the cache directory under the executable's identity (its resolved
path, device, inode, size, modification and change times) and asks again as soon as any of them
changes (an upgraded or switched compiler). A script (``#!``, e.g. a ccache wrapper, whose answer
can depend on what it runs) is asked every time.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Callable

#: File of the cache directory holding the memoised versions: ``{identity: version}``.
MEMO = "compilers.json"
#: Most executables remembered (the least recently asked go first).
MEMO_ENTRIES = 16
#: Memo file of the digests remembered under files' identities (:mod:`.code_identity`): ``{"<name> <key>": value}``.
DIGESTS = "digests.json"
#: Memo file of the libraries of controllers' recipes (:mod:`.source_memo`): ``{recipe key: library key}``.
SOURCES = "sources.json"
#: Memo file of values a recipe determines (:func:`.source_memo.remembered_values`): ``{key: float64 bytes as hex}``.
VALUES = "values.json"


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` under a temporary name in its directory, then rename it into place.

    Parameters
    ----------
    path : Path
        The file to write; a reader sees either the old or the new content, never part of it.
    data : bytes
        Its content.

    Raises
    ------
    OSError
        The directory is not writable (the temporary file is removed).
    """
    import tempfile                                     # 1.6 ms to import: only a write needs it

    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def compiler_identity(path: str) -> str | None:
    """What identifies the executable ``path`` runs: its resolved path and its file's metadata.

    Parameters
    ----------
    path : str
        The compiler's absolute path (a symbolic link is followed to its file).

    Returns
    -------
    str or None
        ``path``, the resolved path, device, inode, size, modification and change times [ns]; None
        for a script (it starts with ``#!``) or a file that cannot be read.
    """
    real = os.path.realpath(path)
    try:
        with open(real, "rb") as f:
            if f.read(2) == b"#!":
                return None
            st = os.fstat(f.fileno())
    except OSError:
        return None
    return "\0".join(str(v) for v in (path, real, st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns))


def lookup(memo_dir: Path, name: str, key: str) -> str | None:
    """The value remembered under ``key`` in the memo file ``name`` of ``memo_dir`` (:func:`remember`).

    Parameters
    ----------
    memo_dir : Path
        The (private) cache directory holding the memo file.
    name : str
        The memo file: a JSON object ``{key: value}``, the most recently remembered last.
    key : str
        What identifies the value.

    Returns
    -------
    str or None
        None when the file is missing or unreadable or does not hold ``key``.
    """
    try:
        memo = json.loads((Path(memo_dir) / name).read_text())
    except (OSError, ValueError):
        return None
    value = memo.get(key) if isinstance(memo, dict) else None
    return value if isinstance(value, str) else None


def remember(memo_dir: Path, name: str, key: str, value: str, entries: int = MEMO_ENTRIES) -> None:
    """Remember ``value`` under ``key`` in the memo file ``name`` of ``memo_dir`` (atomically replaced).

    Parameters
    ----------
    memo_dir : Path
        The (private) cache directory holding the memo file.
    name : str
        The memo file (see :func:`lookup`).
    key : str
        What identifies the value; it must change whenever the value would.
    value : str
        The value.
    entries : int
        Most values kept (the least recently remembered go first). A read-only cache keeps none.
    """
    memo_file = Path(memo_dir) / name
    try:
        memo = json.loads(memo_file.read_text())
        memo = memo if isinstance(memo, dict) else {}
    except (OSError, ValueError):
        memo = {}
    memo.pop(key, None)
    memo[key] = value                                   # last: the most recently remembered
    try:
        write_atomic(memo_file, json.dumps(dict(list(memo.items())[-entries:])).encode())
    except OSError:
        pass                                            # a read-only cache: computed again next time


def recall(memo_dir: Path, name: str, key: str, compute: Callable[[], str], *, entries: int = MEMO_ENTRIES,
           store: bool = True) -> str:
    """The value remembered under ``key`` (:func:`lookup`), else ``compute()``'s, remembered (:func:`remember`).

    Parameters
    ----------
    memo_dir : Path
        The (private) cache directory holding the memo file.
    name : str
        The memo file.
    key : str
        What identifies the value; it must change whenever the value would.
    compute : callable
        ``compute() -> str``, called when ``key`` is not remembered.
    entries : int
        Most values kept.
    store : bool
        Remember a computed value (False: compute it and leave the file alone).

    Returns
    -------
    str
        The value; a missing, unreadable or read-only memo file only costs the computation.
    """
    value = lookup(memo_dir, name, key)
    if value is None:
        value = compute()
        if store:
            remember(memo_dir, name, key, value, entries)
    return value


def compiler_version(path: str, ask: Callable[[str], str], memo_dir: Path | None = None) -> str:
    """The compiler's ``--version`` text: from :data:`MEMO` in ``memo_dir`` when its identity is unchanged.

    Parameters
    ----------
    path : str
        The compiler's absolute path.
    ask : callable
        Runs the compiler for its version: ``ask(path) -> str`` (raises when it does not run).
    memo_dir : Path, optional
        The (private) cache directory holding :data:`MEMO`; None: always ask.

    Returns
    -------
    str
        The version text.
    """
    ident = compiler_identity(path) if memo_dir is not None else None
    if ident is None:
        return ask(path)
    return recall(memo_dir, MEMO, ident, lambda: ask(path))
