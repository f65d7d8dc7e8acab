"""Small hand-written C libraries that speed up the run's own Python work (the physical checks, the log's
JSON), as opposed to the law's generated library.

Each is one template under ``templates/`` (no placeholders), compiled once into the build cache by
:func:`~coordarm.generated.build.build` (keyed like the law's library: source, compiler, flags) with the
fixed :data:`FLAGS`, not ``$COORDARM_CFLAGS``: without contraction, vector maths or ``-ffast-math`` a kernel
computes what its numpy reference computes, to the last bit. Where no C compiler works,
:func:`kernel_library` returns None and the callers run the numpy reference (the same results, slower).
"""
from __future__ import annotations

import contextlib
import ctypes
import functools
import threading
import warnings

from coordarm.symbolic import BuildError

from .build import CacheWarning, build
from .source import Source
from .render import render

#: Compiler flags of the kernels: optimised scalar code, no floating-point contraction, so a kernel
#: computes what numpy computes (``$COORDARM_CFLAGS`` does not apply).
FLAGS = ("-O3", "-ffp-contract=off")


def kernel_source(template: str) -> Source:
    """The C source of a kernel library.

    Parameters
    ----------
    template : str
        Its template under ``templates/`` (e.g. ``"chain_geometry.c"``), without placeholders.

    Returns
    -------
    Source
        Its text, form the template's name without ``.c``, ``m = 0`` (one library serves every chain).
    """
    return Source(render(template), template.removesuffix(".c"), 0)


@functools.cache
def kernel_library(template: str) -> ctypes.CDLL | None:
    """The kernel library of ``template``, built (or taken from the cache) and loaded once per process.

    Parameters
    ----------
    template : str
        See :func:`kernel_source`.

    Returns
    -------
    ctypes.CDLL or None
        The loaded library (the caller types its functions); None when it cannot be built or loaded
        (no working C compiler).

    Notes
    -----
    In the main thread an unsafe cache directory's :class:`~coordarm.generated.build.CacheWarning` is not
    repeated here (the law's build gives it); the warnings filter is the process's, so another thread
    (a log's worker making the first scene) leaves it alone.
    """
    main = threading.current_thread() is threading.main_thread()
    try:
        with warnings.catch_warnings() if main else contextlib.nullcontext():
            if main:
                warnings.simplefilter("ignore", CacheWarning)
            return ctypes.CDLL(str(build(kernel_source(template), flags=FLAGS).path))
    except (BuildError, OSError):
        return None
