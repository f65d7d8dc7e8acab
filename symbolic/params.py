"""Parameters of curves and paths: a number or a callable of time, as a callable of time.

Every parameter of :mod:`.curves` and :mod:`.paths` (a point, an angle, a radius, an offset)
may be a number or a callable ``p(t)`` returning a CasADi expression (the motion primitives of
:mod:`.motions` are such callables); these helpers validate it once and return callables.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import casadi as ca
import numpy as np

from .checks import is_real
from .errors import ConfigError, shown
from .motions import Constant

Param = Any  # float | Callable[[t], expression]


def as_param(value: Param, field: str) -> Callable:
    """A scalar parameter as a callable of time, validated.

    Parameters
    ----------
    value : float or callable
        A finite number (unit of the parameter), or a callable of time ``t`` [s] returned as is.
    field : str
        Name of the parameter in error messages (``"curve.angle"``).

    Returns
    -------
    callable
        ``p(t)``: ``value`` itself, or a :class:`~.motions.Constant` of the number.

    Raises
    ------
    ConfigError
        ``value`` is neither a number nor a callable, or not finite.
    """
    if callable(value):
        return value
    if not is_real(value, numpy=True):
        raise ConfigError(f"{field}: expected a number or a callable of t, got {shown(value)}")
    if not math.isfinite(value):
        raise ConfigError(f"{field}: must be finite, got {shown(value)}")
    return Constant(float(value))


def as_point(value: Any, field: str) -> tuple[Callable, Callable]:
    """A 2-D point parameter as two callables of time (or one callable returning 2 values).

    Parameters
    ----------
    value : (float | callable, float | callable) or callable
        A pair of coordinates [m] (each a number or a callable of time), or one callable of
        time returning both.
    field : str
        Name of the parameter in error messages (``"curve.point"``).

    Returns
    -------
    (callable, callable)
        ``x(t)`` and ``y(t)`` [m].

    Raises
    ------
    ConfigError
        Not a pair or a callable, or a coordinate that :func:`as_param` refuses.
    """
    if callable(value):
        return (lambda t: value(t)[0], lambda t: value(t)[1])
    if not isinstance(value, (tuple, list, np.ndarray)) or len(value) != 2:
        raise ConfigError(f"{field}: expected a pair (x, y), got {shown(value)}")
    return as_param(value[0], f"{field}[0]"), as_param(value[1], f"{field}[1]")


def evaluate(param: Callable, t: float) -> float:
    """Numeric value of a parameter callable at time ``t``.

    Parameters
    ----------
    param : callable
        ``p(t)``, as returned by :func:`as_param`.
    t : float
        Time [s].

    Returns
    -------
    float
        ``p(t)`` (unit of the parameter).
    """
    v = param(ca.DM(t))
    return float(ca.DM(v)) if not isinstance(v, (int, float)) else float(v)


def evaluate_many(param: Callable, times: Any) -> np.ndarray:
    """Numeric values of a parameter callable at many times, in one call on a row of times.

    The motions (:mod:`.motions`) are elementwise, so the values are :func:`evaluate`'s, bit for bit; a
    callable that does not take a row (it fails, or gives one value for several times) is evaluated
    time by time.

    Parameters
    ----------
    param : callable
        ``p(t)``, as returned by :func:`as_param`.
    times : array_like, shape (k,)
        Times [s].

    Returns
    -------
    ndarray, shape (k,)
        ``p(t)`` at each time (unit of the parameter).
    """
    t = np.asarray(times, dtype=float).ravel()
    try:
        v = param(ca.DM(t).T)
        out = np.full(t.shape, float(v)) if isinstance(v, (int, float)) else np.asarray(ca.DM(v), dtype=float).ravel()
    except Exception:   # noqa: BLE001 - a user's callable of one time: the loop below
        out = None
    if out is None or out.shape != t.shape:
        out = np.array([evaluate(param, x) for x in t.tolist()], dtype=float)
    return out
