"""Compile generated C into a shared library, cached by a content hash.

Cache entry: ``<build dir>/<key[:16]>/`` with ``coordarm.c``, ``libcoordarm.so`` and
``meta.json`` (the full key and the library's SHA-256). The key hashes everything that
determines the library: the generated source, the compiler (path and version), the
flags, the CasADi version and the code-generation options. Every file is written under
a temporary name and renamed into place, and a library is loaded only when its checksum
matches ``meta.json``: a stale or half-written entry is rebuilt, never loaded, and two
processes building the same key both end with a valid library.
"""
from __future__ import annotations

import functools
import json
import os
import platform
import re
import shutil
import sys
import time
import warnings
from pathlib import Path

import casadi as ca

from coordarm.symbolic import BuildError
from coordarm.symbolic.digests import sha256
from coordarm.symbolic.errors import shown
from coordarm.symbolic.records import record

from .cache_dir import own_group, root_problem  # noqa: F401 (re-exported)
from .source import CODEGEN_OPTIONS, Source
from .compiler_memo import DIGESTS, MEMO, SOURCES, VALUES, compiler_version, write_atomic

#: Optimisation flags (see benchmarks/RESULTS.md); override with COORDARM_CFLAGS. ``-fno-math-errno``
#: lets the link angles' cosines and sines vectorise (glibc libmvec), ``-march=native`` uses the
#: widest vectors of this CPU (and FMA). No ``-ffast-math``: the non-finite checks need IEEE NaN.
DEFAULT_FLAGS = ("-O3", "-fno-math-errno", "-march=native")
#: Flags every build needs: position-independent shared object, only the glue API exported.
REQUIRED_FLAGS = ("-fPIC", "-shared", "-fvisibility=hidden")   # before the user flags
#: Flags that make gcc link start-up objects which change the floating-point mode of the whole
#: process that loads the library (``crtfastmath.o``: flush-to-zero; ``crtprec*.o``: x87
#: precision). They are kept for compiling and left out of the link, which is a separate step.
PROCESS_MODE_FLAGS = frozenset({"-Ofast", "-ffast-math", "-funsafe-math-optimizations", "-mpc32", "-mpc64",
                                "-mpc80"})
LIBRARY, SOURCE, META = "libcoordarm.so", "coordarm.c", "meta.json"
#: A build's temporary files in a cache entry, named after the building process: ``<pid>-<random>``.
STALE_NAME = re.compile(rf"^{re.escape(LIBRARY)}\.(\d+)-[^.]+\.(tmp|o)$")
#: Seconds the compiler gets to answer ``--version`` [s].
VERSION_TIMEOUT = 30.0
#: Seconds a compilation may take before it is stopped (a hanging compiler) [s]; override with
#: ``COORDARM_COMPILE_TIMEOUT``.
COMPILE_TIMEOUT = 900.0


@record(frozen=True)
class Library:
    """A compiled controller library in the cache.

    Attributes
    ----------
    path : Path
        The shared library.
    key : str
        Its cache key (SHA-256 hex).
    cache_hit : bool
        True when it was found in the cache, False when it was compiled now.
    compile_seconds : float
        Wall time of the compiler run (0 on a cache hit).
    """

    path: Path
    key: str
    cache_hit: bool
    compile_seconds: float


def build_root(build_dir: str | os.PathLike | None = None) -> Path:
    """The cache directory of compiled libraries: a per-user cache, never inside the installed package.

    Parameters
    ----------
    build_dir : path, optional
        Used as it is when given.

    Returns
    -------
    Path
        ``build_dir``, else ``$COORDARM_BUILD_DIR``, else the platform's user cache directory
        (platformdirs) for ``coordarm``: on Linux ``$XDG_CACHE_HOME/coordarm`` (an absolute
        ``XDG_CACHE_HOME``), else ``~/.cache/coordarm``.
    """
    if build_dir is not None:
        return Path(build_dir)
    env = os.environ.get("COORDARM_BUILD_DIR")
    if env:
        return Path(env)
    from .cache_dir import user_cache_dir

    return Path(user_cache_dir("coordarm"))


class CacheWarning(UserWarning):
    """The build cache is not private to this user; libraries are built in a private temporary directory."""


_private_fallback: list[Path] = []


def private_root(root: Path) -> Path:
    """``root`` (created 0700) if it is owned by this user and writable by no one else, else a private
    temporary directory (made once per process) with a :class:`CacheWarning`.

    Group write permission is accepted when the group is the user's own (:func:`own_group`), as
    ``umask 002`` leaves it. A library is loaded into this process: one that others can replace
    must never be loaded.

    Parameters
    ----------
    root : Path
        The wanted cache directory (:func:`build_root`); created with its parents when missing.

    Returns
    -------
    Path
        ``root``, or the process's private temporary directory when ``root`` is unusable, owned by
        another user or writable by others.

    Warns
    -----
    CacheWarning
        When the private temporary directory is returned.
    """
    try:
        root.mkdir(mode=0o700, parents=True, exist_ok=True)
        problem = root_problem(root)
    except OSError as exc:
        problem = f"unusable ({exc.strerror or exc})"
    if problem is None:
        return root
    if not _private_fallback:
        import tempfile
        _private_fallback.append(Path(tempfile.mkdtemp(prefix="coordarm-build-")))
    warnings.warn(f"build cache {root} is {problem}: building in the private directory {_private_fallback[0]} "
                  "instead", CacheWarning, stacklevel=3)
    return _private_fallback[0]


def compile_timeout() -> float:
    """Seconds a compilation may take: ``$COORDARM_COMPILE_TIMEOUT``, else :data:`COMPILE_TIMEOUT`.

    Returns
    -------
    float
        The time limit [s], positive and finite.

    Raises
    ------
    BuildError
        The variable is not a positive number.
    """
    env = os.environ.get("COORDARM_COMPILE_TIMEOUT")
    if not env:
        return COMPILE_TIMEOUT
    try:
        value = float(env)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise BuildError(f"COORDARM_COMPILE_TIMEOUT: need a positive number of seconds, got {shown(env)}")
    return value


def find_compiler(cc: str | None = None) -> str:
    """Absolute path of the C compiler: ``cc``, else ``$CC``, else ``cc``, ``gcc`` or ``clang`` on the PATH.

    Parameters
    ----------
    cc : str, optional
        Compiler name or path (looked up on the PATH when it is a bare name).

    Returns
    -------
    str
        The compiler's absolute path (as :func:`shutil.which` gives it).

    Raises
    ------
    BuildError
        No such compiler.
    """
    names = [cc] if cc else ([os.environ["CC"]] if os.environ.get("CC") else ["cc", "gcc", "clang"])
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    raise BuildError(f"no C compiler found (tried {', '.join(names)}; set CC to one); "
                     "the compiled backend needs one")


@functools.lru_cache(maxsize=None)
def _compiler_version(path: str) -> str:
    import subprocess

    try:
        res = _run_compiler([path, "--version"], VERSION_TIMEOUT)
    except OSError as exc:
        raise BuildError(f"C compiler {path} does not run: {exc}") from None
    except subprocess.TimeoutExpired:
        raise BuildError(f"C compiler {path} does not answer --version within {VERSION_TIMEOUT:g} s "
                         "(set CC to a working compiler)") from None
    return res.stdout.strip()


def compile_flags(flags: tuple[str, ...] | list[str] | str | None = None) -> tuple[str, ...]:
    """Optimisation flags: ``flags``, else ``$COORDARM_CFLAGS``, else :data:`DEFAULT_FLAGS`.

    Parameters
    ----------
    flags : sequence of str or str, optional
        The flags; a string is split like a shell command line.

    Returns
    -------
    tuple of str
        The flags, one per element.

    Raises
    ------
    BuildError
        Flags that do not split as a shell command line (an unclosed quote).
    """
    name = "flags"
    if flags is None:
        flags, name = os.environ.get("COORDARM_CFLAGS"), "COORDARM_CFLAGS"
        if not flags:
            return DEFAULT_FLAGS
    if not isinstance(flags, str):
        return tuple(flags)
    import shlex

    try:
        return tuple(shlex.split(flags))
    except ValueError as exc:
        raise BuildError(f"{name}: cannot split {shown(flags)} into flags: {exc}") from None


@functools.lru_cache(maxsize=None)
def cpu_identity() -> str:
    """This machine's CPU model and feature flags (part of the key of ``-march=native`` builds)."""
    keep = ("model name", "flags", "Features", "CPU part")
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.machine() + " " + platform.processor()
    seen: dict[str, str] = {}
    for line in lines:
        name, _, value = line.partition(":")
        if name.strip() in keep:
            seen.setdefault(name.strip(), value.strip())
    return platform.machine() + " " + json.dumps(seen, sort_keys=True)


def cache_key(source: Source, cc: str, flags: tuple[str, ...], memo_dir: Path | None = None) -> str:
    """SHA-256 over source, compiler path and version, flags, CasADi version, codegen options,
    the CPU when a flag asks for ``native`` code (a shared cache then never serves another CPU), and
    with a flag of :data:`PROCESS_MODE_FLAGS` the separate link (older entries were linked with it).

    Parameters
    ----------
    source : Source
        The generated C source.
    cc : str
        Absolute path of the compiler (:func:`find_compiler`); it is run for ``--version`` once per
        process, or once per executable with ``memo_dir``.
    flags : tuple of str
        The optimisation flags (:func:`compile_flags`).
    memo_dir : Path, optional
        The private cache directory that remembers the version of an unchanged compiler executable
        (:func:`~coordarm.generated.compiler_memo.compiler_version`); None: the compiler is asked.

    Returns
    -------
    str
        The key, 64 hex digits.

    Raises
    ------
    BuildError
        The compiler does not run or does not answer ``--version`` in time.
    """
    h = sha256()
    cpu = cpu_identity() if any("native" in f for f in flags) else ""
    # Libraries of such flags were linked with them before compile_and_link: never serve those again.
    link = "linked without " + " ".join(sorted(PROCESS_MODE_FLAGS)) if set(flags) & PROCESS_MODE_FLAGS else ""
    version = compiler_version(cc, _compiler_version, memo_dir)
    for part in (source.text, cc, version, json.dumps(list(flags)), ca.__version__,
                 json.dumps(CODEGEN_OPTIONS, sort_keys=True), json.dumps(list(REQUIRED_FLAGS)), cpu, link):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()


def _sha256(path: Path) -> str:
    return sha256(path.read_bytes()).hexdigest()


def cached(entry: Path, key: str) -> bool:
    """True if ``entry`` holds a complete library for ``key`` whose checksum matches its metadata.

    Parameters
    ----------
    entry : Path
        A cache entry directory.
    key : str
        The full cache key (:func:`cache_key`).

    Returns
    -------
    bool
        False when the metadata or the library is missing or unreadable, or either does not match.
    """
    try:
        meta = json.loads((entry / META).read_text())
        return meta.get("key") == key and meta.get("sha256") == _sha256(entry / LIBRARY)
    except (OSError, ValueError):
        return False


def build(source: Source, *, cc: str | None = None, flags: tuple[str, ...] | list[str] | str | None = None,
          build_dir: str | os.PathLike | None = None,
          force: bool = False, timeout: float | None = None) -> Library:
    """Compile ``source`` (or take it from the cache) and return the library.

    Parameters
    ----------
    source : Source
        From :func:`generated.codegen.generate_source`.
    cc : str, optional
        C compiler (default ``$CC``, else ``cc``/``gcc``/``clang``).
    flags : sequence of str or str, optional
        Optimisation flags (default ``$COORDARM_CFLAGS``, else :data:`DEFAULT_FLAGS`).
    build_dir : path, optional
        Cache directory (default :func:`build_root`).
    force : bool
        Recompile even if the cache holds the library.
    timeout : float, optional
        Give up (and stop the compiler) after this many seconds [s] (default
        :func:`compile_timeout`).

    Returns
    -------
    Library
        The library's path and key, whether it came from the cache, and the compile time.

    Raises
    ------
    BuildError
        No compiler, it failed (its message included) or it exceeded ``timeout``; a bad
        ``$COORDARM_COMPILE_TIMEOUT`` or flags; an unwritable build directory.
    """
    cc_path = find_compiler(cc)
    flags = compile_flags(flags)
    timeout = compile_timeout() if timeout is None else timeout
    root = private_root(build_root(build_dir))
    key = cache_key(source, cc_path, flags, memo_dir=root)
    entry = root / key[:16]
    if not force and cached(entry, key):
        return Library(entry / LIBRARY, key, True, 0.0)
    try:
        entry.mkdir(mode=0o700, parents=True, exist_ok=True)
        src = entry / SOURCE
        write_atomic(src, source.text.encode())
        remove_stale_temporaries(entry)
        import tempfile
        fd, tmp = tempfile.mkstemp(dir=entry, prefix=f"{LIBRARY}.{os.getpid()}-", suffix=".tmp")
        os.close(fd)
    except OSError as exc:
        raise BuildError(f"build directory {entry}: {exc}") from None
    obj = tmp[:-len(".tmp")] + ".o"
    start = time.perf_counter()
    placed = False
    try:
        for cmd in compile_and_link(cc_path, flags, src, obj, tmp):
            _compile_step(cmd, src, max(1e-3, timeout - (time.perf_counter() - start)), timeout)
        seconds = time.perf_counter() - start
        digest = _sha256(Path(tmp))
        os.replace(tmp, entry / LIBRARY)
        placed = True
    finally:
        Path(obj).unlink(missing_ok=True)
        if not placed:   # any failure or an interrupt: no half-written library left
            Path(tmp).unlink(missing_ok=True)
    meta = {"key": key, "sha256": digest, "compiler": cc_path,
            "compiler_version": compiler_version(cc_path, _compiler_version, root),
            "flags": list(flags), "casadi": ca.__version__, "codegen_options": CODEGEN_OPTIONS,
            "form": source.form, "links": source.m, "compile_seconds": seconds}
    try:
        write_atomic(entry / META, json.dumps(meta, indent=1).encode())
    except OSError as exc:
        raise BuildError(f"{entry / META}: cannot write it: {exc.strerror or exc}") from None
    return Library(entry / LIBRARY, key, False, seconds)


def _compile_step(cmd: list[str], src: Path, left: float, timeout: float) -> None:
    """Run one compiler command of a build with ``left`` seconds; BuildError when it fails, times out or does not run."""
    import shlex
    import subprocess

    try:
        res = _run_compiler(cmd, left)
    except subprocess.TimeoutExpired:
        raise BuildError(f"compiling {src} took longer than {timeout:g} s; stopped "
                         "(COORDARM_COMPILE_TIMEOUT sets the limit)") from None
    except OSError as exc:
        raise BuildError(f"C compiler {cmd[0]} did not run: {exc}") from None
    if res.returncode != 0:
        raise BuildError(f"compiling {src} failed ({shlex.join(cmd)}):\n{res.stderr.strip()[-4000:]}")


def remove_stale_temporaries(entry: Path) -> int:
    """Remove the temporary files of builds whose process is gone (killed while compiling).

    A build names its files ``libcoordarm.so.<pid>-<random>.tmp`` and ``.o``; those of a process
    that no longer exists are removed (a build of the same library by a live process keeps its own).

    Parameters
    ----------
    entry : Path
        A cache entry (one library's directory).

    Returns
    -------
    int
        Files removed.
    """
    from .compiler_guard import process_alive

    removed = 0
    for path in entry.glob(f"{LIBRARY}.*"):
        found = STALE_NAME.match(path.name)
        if found is None or process_alive(int(found.group(1))):
            continue
        path.unlink(missing_ok=True)
        removed += 1
    return removed


def compile_and_link(cc: str, flags: tuple[str, ...], src: str | Path, obj: str | Path,
                     out: str | Path) -> list[list[str]]:
    """The two compiler runs of a build: compile ``src`` to the object ``obj`` with every flag, then
    link ``obj`` into the shared library ``out`` without :data:`PROCESS_MODE_FLAGS`.

    Linked with ``-ffast-math`` (gcc < 13), a shared library carries ``crtfastmath.o``, whose
    constructor sets flush-to-zero for the whole process that loads it; linked separately it
    never changes the process's floating-point mode, whatever the flags.

    Parameters
    ----------
    cc : str
        The compiler.
    flags : tuple of str
        The optimisation flags (:func:`compile_flags`).
    src, obj, out : path
        The C source, the object file to write, the library to write.

    Returns
    -------
    list of list of str
        The compile command, then the link command.
    """
    link_flags = [f for f in flags if f not in PROCESS_MODE_FLAGS]
    return [[cc, "-c", *REQUIRED_FLAGS, *flags, "-o", str(obj), str(src)],   # later flags win
            [cc, *REQUIRED_FLAGS, *link_flags, "-o", str(out), str(obj), "-lm"]]


def _run_compiler(cmd: list[str], timeout: float | None) -> "subprocess.CompletedProcess":
    """Run the compiler under :mod:`.compiler_guard` (in this process's group, so a Ctrl-C or a kill of
    the group reaches the guard, which stops the compiler's own group; and when this process dies,
    even by SIGKILL, the kernel tells the guard to), with its temporary files in a private directory
    that is removed afterwards; on a timeout or an interrupt kill it and every process it started
    (``gcc`` is a driver: ``cc1`` would compile on)."""
    import subprocess

    from .compiler_guard import kill_process_tree

    import tempfile

    tmpdir = tempfile.mkdtemp(prefix="coordarm-cc-")
    env = dict(os.environ, TMPDIR=tmpdir, TMP=tmpdir, TEMP=tmpdir)
    guarded = [sys.executable, "-I", "-S", str(Path(__file__).with_name("compiler_guard.py")), str(os.getpid()), *cmd]
    try:
        proc = subprocess.Popen(guarded, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        try:
            out, err = proc.communicate(timeout=timeout)
        except BaseException:
            kill_process_tree(proc.pid)
            proc.communicate()
            raise
        return subprocess.CompletedProcess(cmd, proc.returncode, out, err)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)


def clean(build_dir: str | os.PathLike | None = None) -> int:
    """Delete every cached library in the cache the builds use; return how many entries went.

    The cache is :func:`private_root` of :func:`build_root`, the directory :func:`build` writes to (a
    private temporary one, with a :class:`CacheWarning`, when the wanted one is not this user's alone;
    it is not created when missing). Only cache entries (:func:`is_cache_entry`) and the memo files (regular
    files: the compiler versions :data:`~coordarm.generated.compiler_memo.MEMO`, the digests
    :data:`~coordarm.generated.compiler_memo.DIGESTS`, the recipes' libraries
    :data:`~coordarm.generated.compiler_memo.SOURCES` and values
    :data:`~coordarm.generated.compiler_memo.VALUES`) are deleted:
    nothing else in the directory, no symbolic link and nothing a link points to.

    Parameters
    ----------
    build_dir : path, optional
        The cache directory (default :func:`build_root`).

    Returns
    -------
    int
        Entries removed; 0 when the directory does not exist.
    """
    wanted = build_root(build_dir)
    if not wanted.is_dir():
        return 0
    root = private_root(wanted)
    n = 0
    for entry in root.iterdir():
        if is_cache_entry(entry):
            shutil.rmtree(entry, ignore_errors=True)
            n += not entry.exists()
    for memo in (root / MEMO, root / DIGESTS, root / SOURCES, root / VALUES):
        if memo.is_file() and not memo.is_symlink():
            memo.unlink(missing_ok=True)
    return n


def is_cache_entry(entry: Path) -> bool:
    """Whether ``entry`` is a directory :func:`build` made: named by 16 hex digits of its key, not a symbolic
    link, holding only regular files a build writes (the source, the library, the metadata and their
    temporary files).

    Parameters
    ----------
    entry : Path
        A directory entry of the cache.

    Returns
    -------
    bool
        False for anything else (a user's directory that happens to have a 16-character name).
    """
    if len(entry.name) != 16 or entry.name.strip("0123456789abcdef") or entry.is_symlink() or not entry.is_dir():
        return False
    names = (LIBRARY, SOURCE, META)
    try:
        return all(child.is_file() and not child.is_symlink()
                   and (child.name in names or child.name.startswith(tuple(n + "." for n in names)))
                   for child in entry.iterdir())
    except OSError:
        return False
