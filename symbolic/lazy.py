"""PEP 562 lazy exports: a package's public names load their module on first use (dependency-free)."""
from __future__ import annotations

from importlib import import_module
from typing import Any, Callable


def lazy_exports(package: str, exports: dict[str, str],
                 aliases: dict[str, str] | None = None) -> Callable[[str], Any]:
    """The module-level ``__getattr__`` of a package whose names load on first access.

    Parameters
    ----------
    package : str
        The package's ``__name__`` (the loaded values are cached in its namespace).
    exports : dict
        Public name -> module defining it: absolute (``"coordarm.symbolic.errors"``) or a
        submodule of ``package`` (``"errors"``).
    aliases : dict, optional
        Public name -> name in that module, when they differ.

    Returns
    -------
    callable
        ``__getattr__(name)``, raising AttributeError for names not in ``exports``.
    """
    import sys

    aliases = aliases or {}

    def __getattr__(name: str) -> Any:
        try:
            module = exports[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(import_module(module if "." in module else f"{package}.{module}"), aliases.get(name, name))
        setattr(sys.modules[package], name, value)
        return value

    return __getattr__
