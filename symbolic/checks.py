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


#: The largest magnitude of a number in a commanded motion (``control.speed`` [m/s], ``control.span`` [m]).
MOST_MOTION_VALUE = 1e6


def bounded_motion(spec: Any, field: str, most: float = MOST_MOTION_VALUE) -> Any:
    """``spec`` (a motion as data), once every real number in it is at most ``most`` in magnitude.

    Parameters
    ----------
    spec : object
        A number, a motion table or a list of them (as read from TOML).
    field : str
        Its name in the error message (e.g. ``"control.speed"``).
    most : float
        The bound.

    Returns
    -------
    object
        ``spec``.

    Raises
    ------
    ConfigError
        A number beyond ``most`` (a commanded speed of 1e300 m/s turns the state into inf and NaN).
    """
    from .errors import ConfigError

    todo = [spec]
    while todo:
        item = todo.pop()
        if isinstance(item, dict):
            todo += list(item.values())
        elif isinstance(item, list):
            todo += item
        elif is_real(item) and abs(item) > most:
            raise ConfigError(f"{field}: {float(item):.4g} is beyond ±{most:g}; no arm moves like that")
    return spec
