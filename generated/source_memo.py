"""A controller built from data finds its library without generating its C: the library's key, remembered.

Generating the C of a law (building its CasADi Functions, CasADi's code generator) takes about 10 ms
at 64 links, and a cache hit needs the source only for the library's key (:func:`.build.cache_key`).
A controller that declares its recipe (:meth:`~coordarm.symbolic.law_face.LawFace.set_recipe`: a
scenario's JSON, which with coordarm's code determines it) is looked up in :data:`~.compiler_memo.SOURCES` instead,
under a key (:func:`recipe_key`) over everything the generated text depends on: the recipe, the law's
form and path search, the identity of every file of ``symbolic``, ``generated`` (templates included)
and ``simulation`` (presets included; :mod:`.code_identity`), CasADi's and numpy's versions and
binaries, the interpreter, the C library and the CPU, plus the compiler, its version and the flags
(the parts of :func:`.build.cache_key`). What is remembered is the library's full key, written after
the library was built from the generated text: a hit loads only a library whose checksum matches
its metadata under that key, so a key that changes whenever the text would never loads a stale one
(``tests/test_source_memo.py`` checks it for every preset and changed parameters).

The same key over coordarm's code (:func:`code_key`) remembers other arrays a recipe determines
(:func:`remembered_values`): a start laid along the curve or projected onto it (``simulation.scenario``,
``simulation.spatial_scenario``).
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any, Callable

from .build import LIBRARY, Library, build, build_root, cache_key, cached, compile_flags, compile_timeout
from .build import cpu_identity, find_compiler, private_root
from .code_identity import files_key, memo_root, package_files
from .source import Source
from .compiler_memo import SOURCES, VALUES, lookup, remember

#: Most recipes remembered.
SOURCE_ENTRIES = 64
#: Most arrays remembered by :func:`remembered_values`.
VALUE_ENTRIES = 64
#: The folders whose files the generated C can depend on (recursively).
CODE_FOLDERS = ("symbolic", "generated", "simulation")


def recipe_key(ctrl: Any, form: str, path_search: bool) -> tuple[str, bool] | None:
    """A key over everything the generated C of ``ctrl`` depends on, when ``ctrl`` has a recipe.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The controller.
    form : {"structured", "dense"}
        Law form.
    path_search : bool
        See :func:`coordarm.generated.codegen.structured_law`.

    Returns
    -------
    (key, settled) or None
        SHA-256 hex and whether it may be remembered (:func:`.code_identity.files_key`: no file
        changed in the last seconds); None when ``ctrl`` declares no recipe (or was changed since).
    """
    recipe = getattr(ctrl, "recipe", None)
    if recipe is None:
        return None
    return code_key(recipe, form, repr(bool(path_search)))


def code_key(*text: str) -> tuple[str, bool]:
    """A key over ``text`` and everything coordarm's computations depend on: the identity of every file of
    ``symbolic``, ``generated`` and ``simulation``, CasADi's and numpy's versions and binaries, the
    interpreter, the C library and the CPU.

    Parameters
    ----------
    *text : str
        What else the value depends on (a recipe, a form).

    Returns
    -------
    (key, settled)
        SHA-256 hex and whether it may be remembered (:func:`.code_identity.files_key`).
    """
    import casadi
    import numpy

    root = Path(__file__).resolve().parent.parent
    binaries = [getattr(sys.modules.get(name), "__file__", None) or name
                for name in ("casadi.casadi", "casadi._casadi", "numpy._core._multiarray_umath")]
    libc = os.confstr("CS_GNU_LIBC_VERSION") if "CS_GNU_LIBC_VERSION" in os.confstr_names else ""
    return files_key([*package_files(root, CODE_FOLDERS, suffix="", recursive=True), *binaries, sys.executable],
                     *text, casadi.__version__, numpy.__version__, sys.version, libc or "", cpu_identity())


def remembered_values(name: str, recipe: str, compute: Callable[[], Any]) -> Any:
    """``compute()``'s float64 array, remembered in :data:`~.compiler_memo.VALUES` under :func:`code_key` of
    ``name`` and ``recipe`` (its exact bits, as hex), so a computation the recipe determines runs once.

    Parameters
    ----------
    name : str
        What the values are (e.g. ``"spatial start"``).
    recipe : str
        Everything they depend on besides coordarm's code and its libraries (a scenario's JSON).
    compute : callable
        ``compute()`` -> array_like of floats.

    Returns
    -------
    ndarray
        The values (a new float64 array of ``compute()``'s shape; a remembered one is 1-D).
    """
    import numpy as np

    root = memo_root()
    if root is None:
        return np.asarray(compute(), float)
    key, settled = code_key(name, recipe)
    known = lookup(root, VALUES, key)
    if known is not None:
        try:
            return np.frombuffer(bytes.fromhex(known), np.float64).copy()
        except ValueError:                          # a damaged entry: computed again
            pass
    values = np.asarray(compute(), float)
    if settled:
        remember(root, VALUES, key, values.tobytes().hex(), VALUE_ENTRIES)
    return values


def remembered_library(ctrl: Any, form: str, path_search: bool, *, cc: str | None = None, flags=None,
                       build_dir=None) -> Library | None:
    """The library of ``ctrl``'s law when its recipe's key is remembered and the library is in the cache.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The controller.
    form : {"structured", "dense"}
        Law form.
    path_search : bool
        See :func:`coordarm.generated.codegen.structured_law`.
    cc, flags, build_dir : optional
        See :func:`.build.build`.

    Returns
    -------
    Library or None
        A cache hit (its checksum checked), or None: no recipe, not remembered or not in the cache.

    Raises
    ------
    BuildError
        No compiler, bad flags (see :func:`.build.build`).
    """
    found = _remembered(ctrl, form, path_search, cc, flags, build_dir)
    return found[0] if found is not None else None


def _remembered(ctrl: Any, form: str, path_search: bool, cc: str | None, flags: Any,
                build_dir: Any) -> tuple[Library | None, Path, str, bool] | None:
    """``(library or None, cache root, memo key, settled)`` for a controller with a recipe, else None."""
    key = recipe_key(ctrl, form, path_search)
    if key is None:
        return None
    cc_path, flag_list = find_compiler(cc), compile_flags(flags)      # as build() does: no cache made without them,
    compile_timeout()                                                  # and a bad setting refused even on a hit
    root = private_root(build_root(build_dir))
    memo_key = cache_key(Source(key[0], form, ctrl.chain.m), cc_path, flag_list, memo_dir=root)
    known = lookup(root, SOURCES, memo_key)
    hit = known is not None and len(known) == 64 and cached(root / known[:16], known)
    return (Library(root / known[:16] / LIBRARY, known, True, 0.0) if hit else None), root, memo_key, key[1]


def compiled_library(ctrl: Any, form: str, path_search: bool, make_source: Callable[[], Source], *,
                     cc: str | None = None, flags=None, build_dir=None, force: bool = False) -> tuple[Library, float]:
    """The library of ``ctrl``'s law: by its remembered key when its recipe is known, else generated and built.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The controller.
    form : {"structured", "dense"}
        Law form.
    path_search : bool
        See :func:`coordarm.generated.codegen.structured_law`.
    make_source : callable
        ``make_source() -> Source``: generates the C (only when the memo does not know the library).
    cc, flags, build_dir, force : optional
        See :func:`.build.build` (``force`` generates and compiles anew).

    Returns
    -------
    library : Library
        As :func:`.build.build` returns it.
    generate_seconds : float
        Time spent generating the source [s] (0 when the library was found by its recipe).

    Raises
    ------
    BuildError
        See :func:`.build.build`.
    """
    found = None if force else _remembered(ctrl, form, path_search, cc, flags, build_dir)
    if found is not None and found[0] is not None:
        return found[0], 0.0
    start = time.perf_counter()
    source = make_source()
    seconds = time.perf_counter() - start
    library = build(source, cc=cc, flags=flags, build_dir=found[1] if found else build_dir, force=force)
    if found is not None and found[3]:
        remember(found[1], SOURCES, found[2], library.key, SOURCE_ENTRIES)
    return library, seconds
