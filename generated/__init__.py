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
    options = {k: v for k, v in build_options.items() if k != "force"}
    try:
        key = (id(ctrl), form, tuple(sorted((k, _frozen(v)) for k, v in options.items())))
        hash(key)
    except TypeError:                      # an option that cannot be a key: nothing kept
        return CompiledController(ctrl, form, **build_options)
    if key in _compiled and not build_options.get("force"):
        _compiled.move_to_end(key)
        return _compiled[key][1]
    compiled = CompiledController(ctrl, form, **build_options)
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
