"""Type tests shared by every validation: a real number or an integer, never a bool.

Dependency-free (numpy is imported only when a caller asks for its scalar types, and then
it is already loaded), so the command line's small modules may use it.
"""
from __future__ import annotations

from typing import Any


def _numpy_scalars(kind: str) -> tuple[type, ...]:
    import numpy as np

    return (np.integer,) if kind == "integer" else (np.integer, np.floating)


def is_real(value: Any, numpy: bool = False) -> bool:
    """Whether ``value`` is a real number: an ``int`` or ``float``, not a ``bool``.

    Parameters
    ----------
    value : object
        The value to test (not checked for finiteness).
    numpy : bool
        Also accept numpy's integer and floating scalars (``np.int64``, ``np.float32``, ...).

    Returns
    -------
    bool
        True for a real number, False for a bool, a string, None, a list, ...
    """
    kinds = (int, float) + (_numpy_scalars("real") if numpy else ())
    return isinstance(value, kinds) and not isinstance(value, bool)


def is_integer(value: Any, numpy: bool = False) -> bool:
    """Whether ``value`` is an integer: an ``int``, not a ``bool`` (nor an integral float).

    Parameters
    ----------
    value : object
        The value to test.
    numpy : bool
        Also accept numpy's integer scalars (``np.int64``, ...).

    Returns
    -------
    bool
        True for an integer, False for a bool, a float (even ``2.0``), a string, ...
    """
    kinds = (int,) + (_numpy_scalars("integer") if numpy else ())
    return isinstance(value, kinds) and not isinstance(value, bool)
