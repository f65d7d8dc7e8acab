"""Loading on first need, dependency-free: PEP 562 lazy exports (a package's public names load their module on
first use), objects made once per key (:func:`made_once`) and the data folders of coordarm's packages (without
:mod:`importlib.resources`)."""
from __future__ import annotations

import os
import weakref
from importlib import import_module
from typing import Any, Callable


def made_once(cache: weakref.WeakKeyDictionary, key: Any, make: Callable[[], Any]) -> Any:
    """``make()`` the first time for ``key``, then the same object while ``key`` lives.

    For what is built from an object that does not change (a curve's CasADi Functions). A key that
    cannot be weakly referenced or hashed is not remembered (``make()`` each time).

    Parameters
    ----------
    cache : weakref.WeakKeyDictionary
        Where the objects made are kept.
    key : object
        What they are made from.
    make : callable
        ``make()`` -> the object.

    Returns
    -------
    object
        The object made for ``key``.
    """
    try:
        return cache[key]
    except KeyError:
        pass
    except TypeError:                   # not weakly referable or not hashable
        return make()
    made = cache[key] = make()
    return made


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


def package_folder(package: str, *parts: str) -> Any:
    """A data folder of a coordarm package: the plain directory when the package is one, else
    :func:`importlib.resources.files`' (a zipped package). :mod:`importlib.resources` takes 5 ms to import.

    Parameters
    ----------
    package : str
        The package, ``"coordarm.simulation"`` or ``"coordarm"``.
    *parts : str
        The folder inside it, e.g. ``"presets"``.

    Returns
    -------
    Path or importlib.resources.abc.Traversable
        ``/``, ``iterdir``, ``read_text`` and ``read_bytes`` work on either.
    """
    top = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))        # coordarm/ (this is coordarm/symbolic/lazy.py)
    here = os.path.join(top, *package.split(".")[1:], *parts)
    if os.path.isdir(here):
        from pathlib import Path                        # not on the path of ``coordarm --help``
        return Path(here)
    from importlib import resources
    return resources.files(package).joinpath(*parts)
