"""Generated C for the coordinating law and the simulation loop: emitted, compiled, cached, loaded.

* :mod:`coordarm.generated.codegen` emits the C source from the symbolic Functions (a spatial
  controller's: :mod:`coordarm.generated.spatial_codegen`),
* ``templates/*.c`` hold the hand-written C glue (loops over links and steps), filled by
  :mod:`coordarm.generated.render`,
* :mod:`coordarm.generated.build` compiles it into a content-addressed cache,
* :mod:`coordarm.generated.compiled` loads it with ctypes (:class:`CompiledController`).

:func:`compile` is the entry point; it keeps the compiled controllers it loaded, per controller.
"""
from __future__ import annotations

from collections import OrderedDict
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from coordarm.generated.compiled import CompiledController
    from coordarm.symbolic.controller import CoordinatingController
    from coordarm.symbolic.spatial_controller import SpatialController

#: How many compiled controllers :func:`compile` keeps (the most recently used).
KEEP_COMPILED = 8
# (id(ctrl), form, options) -> (ctrl, compiled); holding ctrl keeps its id from being reused. Not a
# WeakKeyDictionary: a compiled controller refers to its controller, so a weakly keyed entry would
# never be released.
_compiled: "OrderedDict[tuple, tuple[CoordinatingController | SpatialController, CompiledController]]" = OrderedDict()


def compile(ctrl: "CoordinatingController | SpatialController", form: str | None = None,
            **build_options: Any) -> "CompiledController":
    """Generate, compile (or take from the build cache) and load the C code of ``ctrl``'s law.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        Chain (with a diagonal B), curve, gain [1/s] and speed [m/s]; or a spatial chain (universal
        joints, ``B = I``) with its 3-D curve and roll command, whose packed outputs follow
        :func:`coordarm.symbolic.outputs.spatial_offsets`.
    form : {"structured", "dense"}, optional
        Law form (default: the controller's ``law_form``).
    **build_options
        ``cc`` (compiler), ``flags`` (optimisation flags, default ``$COORDARM_CFLAGS`` or ``-O3``),
        ``build_dir`` (cache directory, default :func:`coordarm.generated.build.build_root`), ``force``,
        ``path_search`` (on a path: False compiles the full selection of the closest piece, the slower reference).

    Returns
    -------
    CompiledController
        ``control(q, t)``, ``evaluate(q, t)``, ``step`` and ``chunk`` backed by the library.

    Raises
    ------
    BuildError
        No C compiler, a non-diagonal B, or the generated code did not compile or load.

    Notes
    -----
    The result is kept for the same controller, form and options (the :data:`KEEP_COMPILED` most
    recent): a second call returns the same object, without generating the code again. ``force=True``
    builds anew (and keeps that). Its buffers serve one thread: another thread takes a
    :class:`~coordarm.generated.compiled.CompiledController` of its own.
    """
    from coordarm.generated.compiled import CompiledController
    form = form or ctrl.law_form
    key = _key(ctrl, form, build_options)
    if key is None:                        # an option that cannot be a key: nothing kept
        return CompiledController(ctrl, form, **build_options)
    if key in _compiled and not build_options.get("force"):
        _compiled.move_to_end(key)
        return _compiled[key][1]
    return _keep(key, ctrl, CompiledController(ctrl, form, **build_options))


def compiled_at_hand(ctrl: "CoordinatingController | SpatialController", form: str | None = None,
                     **build_options: Any) -> "CompiledController | None":
    """The compiled law :func:`compile` would return, when it is at hand without generating or compiling C.

    That is: kept from an earlier :func:`compile`, or a library in the cache found by the
    controller's recipe (:func:`coordarm.generated.source_memo.remembered_library`), loaded (and kept).

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The controller.
    form : {"structured", "dense"}, optional
        Law form (default: the controller's).
    **build_options
        As for :func:`compile` (``force`` gives None).

    Returns
    -------
    CompiledController or None
        None when the law would have to be generated or compiled, or its library does not load.
    """
    from coordarm.generated.compiled import CompiledController
    from coordarm.generated.source_memo import remembered_library
    from coordarm.symbolic import BuildError

    form = form or ctrl.law_form
    key = _key(ctrl, form, build_options)
    if key is None or build_options.get("force"):
        return None
    if key in _compiled:
        _compiled.move_to_end(key)
        return _compiled[key][1]
    options = {k: v for k, v in build_options.items() if k != "path_search"}
    try:
        library = remembered_library(ctrl, form, build_options.get("path_search", True), **options)
        return None if library is None else _keep(key, ctrl, CompiledController(ctrl, form, library=library,
                                                                               **build_options))
    except BuildError:                     # compile() meets it again and reports it
        return None


def _key(ctrl: Any, form: str, build_options: dict[str, Any]) -> tuple | None:
    """The key of :data:`_compiled` for ``ctrl``, ``form`` and the options (``force`` aside), or None when an
    option cannot be part of a key."""
    options = {k: v for k, v in build_options.items() if k != "force"}
    try:
        key = (id(ctrl), form, tuple(sorted((k, _frozen(v)) for k, v in options.items())))
        hash(key)
    except TypeError:
        return None
    return key


def _keep(key: tuple, ctrl: Any, compiled: "CompiledController") -> "CompiledController":
    """Keep ``compiled`` under ``key`` (the most recent of :data:`KEEP_COMPILED`) and return it."""
    _compiled[key] = (ctrl, compiled)
    _compiled.move_to_end(key)
    while len(_compiled) > KEEP_COMPILED:
        _compiled.popitem(last=False)
    return compiled


def _frozen(value: Any) -> Any:
    """``value`` as a cache key: lists and tuples as tuples, paths as strings."""
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    return str(value) if hasattr(value, "__fspath__") else value
