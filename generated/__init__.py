"""Generated C for the coordinating law and the simulation loop: emitted, compiled, cached, loaded.

* :mod:`coordarm.generated.codegen` emits the C source from the symbolic Functions,
* ``templates/*.c`` hold the hand-written C glue (loops over links and steps), filled by
  :mod:`coordarm.generated.render`,
* :mod:`coordarm.generated.build` compiles it into a content-addressed cache,
* :mod:`coordarm.generated.compiled` loads it with ctypes (:class:`CompiledController`).

:func:`compile` is the entry point (``CoordinatingController.compile()`` calls it).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from coordarm.generated.compiled import CompiledController
    from coordarm.symbolic.controller import CoordinatingController


def compile(ctrl: "CoordinatingController", form: str | None = None, **build_options: Any) -> "CompiledController":
    """Generate, compile (or take from the build cache) and load the C code of ``ctrl``'s law.

    Parameters
    ----------
    ctrl : CoordinatingController
        Chain (with a diagonal B), curve, gain [1/s] and speed [m/s].
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
    """
    from coordarm.generated.compiled import CompiledController

    return CompiledController(ctrl, form or ctrl.law_form, **build_options)
