"""coordarm's version: the one place it is written (``pyproject.toml`` reads it, ``coordarm.__version__``
and the logs' ``build`` record report it), so that nothing at run time needs :mod:`importlib.metadata`
(~20 ms to import)."""

__version__ = "0.1.0"
