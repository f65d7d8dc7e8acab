"""Generated C for the coordinating law and the simulation loop: emitted, compiled, cached, loaded.

* :mod:`generated.codegen` emits the C source from the symbolic Functions,
* :mod:`generated.templates` holds the hand-written C glue (loops over links and steps),
* :mod:`generated.build` compiles it into a content-addressed cache,
* :mod:`generated.compiled` loads it with ctypes (:class:`CompiledController`),
* :mod:`generated.cli_regen` is ``coordarm regen``.

Use :meth:`symbolic.CoordinatingController.compile` rather than these modules directly.
"""
