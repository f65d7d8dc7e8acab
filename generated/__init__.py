"""Generated C for the coordinating law and the simulation loop: emitted, compiled, cached, loaded.

* :mod:`coordarm.generated.codegen` emits the C source from the symbolic Functions,
* :mod:`coordarm.generated.templates` holds the hand-written C glue (loops over links and steps),
* :mod:`coordarm.generated.build` compiles it into a content-addressed cache,
* :mod:`coordarm.generated.compiled` loads it with ctypes (:class:`CompiledController`),
* :mod:`coordarm.generated.commands.regen` is ``coordarm regen``.

Use :meth:`symbolic.CoordinatingController.compile` rather than these modules directly.
"""
