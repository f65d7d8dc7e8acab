"""Small 3-D vector helpers of the spatial curves: validated parameters, rotations, frames.

A 3-D point parameter is three callables of time (:func:`as_point3`); a direction is a
constant unit 3-vector (:func:`unit_vector`); :func:`rotate` turns a vector about an axis by
Rodrigues' formula, numerically or symbolically in the angle.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import casadi as ca
import numpy as np

from .checks import is_real
from .errors import ConfigError, shown
from .params import as_param

#: A direction shorter than this (before normalising) is refused as zero.
MIN_NORM = 1e-12


def as_point3(value: Any, field: str) -> tuple[Callable, Callable, Callable]:
    """A 3-D point parameter as three callables of time (or one callable returning 3 values).

    Parameters
    ----------
    value : sequence of 3 (float | callable) or callable
        Coordinates [m], each a number or a callable of time, or one callable of time
        returning all three.
    field : str
        Name of the parameter in error messages (``"curve.point"``).

    Returns
    -------
    (callable, callable, callable)
        ``x(t)``, ``y(t)``, ``z(t)`` [m].

    Raises
    ------
    ConfigError
        Not a triple or a callable, or a coordinate that :func:`~.params.as_param` refuses.
    """
    if callable(value):
        return (lambda t: value(t)[0], lambda t: value(t)[1], lambda t: value(t)[2])
    if not isinstance(value, (tuple, list, np.ndarray)) or len(value) != 3:
        raise ConfigError(f"{field}: expected three coordinates [x, y, z], got {shown(value)}")
    return tuple(as_param(v, f"{field}[{i}]") for i, v in enumerate(value))


def finite(value: Any, field: str) -> float:
    """``value`` as a finite float.

    Parameters
    ----------
    value : float
        A number.
    field : str
        Name of the value in error messages.

    Returns
    -------
    float
        The number.

    Raises
    ------
    ConfigError
        Not a finite real number.
    """
    if not is_real(value, numpy=True) or not math.isfinite(value):
        raise ConfigError(f"{field}: need a finite number, got {shown(value)}")
    return float(value)


def finite_vector(value: Any, field: str) -> np.ndarray:
    """A constant 3-vector of finite numbers.

    Parameters
    ----------
    value : sequence of 3 float
        The vector (unit of the parameter).
    field : str
        Name of the parameter in error messages.

    Returns
    -------
    ndarray, shape (3,)
        The vector.

    Raises
    ------
    ConfigError
        Not three finite numbers.
    """
    if not isinstance(value, (tuple, list, np.ndarray)) or len(value) != 3:
        raise ConfigError(f"{field}: expected three numbers [x, y, z], got {shown(value)}")
    for i, v in enumerate(value):
        if not is_real(v, numpy=True) or not math.isfinite(v):
            raise ConfigError(f"{field}[{i}]: expected a finite number, got {shown(v)}")
    return np.array([float(v) for v in value])


def vector_norm(v: np.ndarray) -> tuple[np.ndarray, float]:
    """A finite vector and its Euclidean length, the vector first divided by its largest entry when
    the length of finite entries overflows (so the length is finite and the direction unchanged).

    Parameters
    ----------
    v : ndarray, shape (k,)
        Finite entries.

    Returns
    -------
    v : ndarray, shape (k,)
        ``v``, or ``v / max|v_i|`` when ``|v|`` overflows.
    norm : float
        The length of the returned ``v``.
    """
    with np.errstate(over="ignore"):
        norm = float(np.linalg.norm(v))
    if not math.isfinite(norm):
        v = v / float(np.max(np.abs(v)))
        norm = float(np.linalg.norm(v))
    return v, norm


def unit_vector(value: Any, field: str) -> np.ndarray:
    """A constant direction, normalised.

    Parameters
    ----------
    value : sequence of 3 float
        A non-zero vector (any length).
    field : str
        Name of the parameter in error messages (``"curve.direction"``).

    Returns
    -------
    ndarray, shape (3,)
        The unit vector along ``value``.

    Raises
    ------
    ConfigError
        Not three finite numbers, or the zero vector.
    """
    v, norm = vector_norm(finite_vector(value, field))
    if not norm > MIN_NORM:
        raise ConfigError(f"{field}: must be a non-zero vector, got {v.tolist()}")
    return v / norm


def orthogonal_normal(direction: np.ndarray, normal: Any, field: str) -> np.ndarray:
    """``normal`` orthogonalised against the unit ``direction`` and normalised (Gram-Schmidt).

    Parameters
    ----------
    direction : ndarray, shape (3,)
        A unit vector.
    normal : sequence of 3 float
        A vector not parallel to ``direction``.
    field : str
        Name of ``normal`` in error messages (``"curve.normal"``).

    Returns
    -------
    ndarray, shape (3,)
        The unit vector ``n_1`` perpendicular to ``direction``.

    Raises
    ------
    ConfigError
        ``normal`` is not three finite numbers, is zero, or is parallel to ``direction``.
    """
    n = unit_vector(normal, field)
    n = n - float(n @ direction) * direction
    norm = float(np.linalg.norm(n))
    if not norm > 1e-9:
        raise ConfigError(f"{field}: must not be parallel to the direction {direction.tolist()}")
    return n / norm


def rotate(axis: np.ndarray, angle: Any, v: Any) -> Any:
    """``v`` turned about the unit ``axis`` by ``angle`` (Rodrigues' formula, right-handed).

    Parameters
    ----------
    axis : ndarray, shape (3,)
        Unit axis.
    angle : float or casadi.SX
        Angle [rad].
    v : ndarray or casadi.SX, shape (3,)
        The vector.

    Returns
    -------
    ndarray or casadi.SX, shape (3,)
        ``v cos + (axis x v) sin + axis (axis . v)(1 - cos)``; numeric for a numeric angle and ``v``.
    """
    if isinstance(angle, (int, float)) and isinstance(v, np.ndarray):
        c, s = math.cos(angle), math.sin(angle)
        return v * c + np.cross(axis, v) * s + axis * float(axis @ v) * (1 - c)
    k, vv = ca.DM(axis), ca.vertcat(*[v[i] for i in range(3)])
    c, s = ca.cos(angle), ca.sin(angle)
    return vv * c + ca.cross(k, vv) * s + k * ca.dot(k, vv) * (1 - c)


def any_normal(direction: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to ``direction``: ``e_z x direction`` normalised (else ``e_x x direction``).

    For a direction in the xy plane this is its left normal, so a planar curve gets
    ``n_1`` = the planar left normal and ``n_2 = e_z``.

    Parameters
    ----------
    direction : ndarray, shape (3,)
        A unit vector.

    Returns
    -------
    ndarray, shape (3,)
        A unit vector perpendicular to it.
    """
    n = np.cross([0.0, 0.0, 1.0], direction)
    if np.linalg.norm(n) < 1e-6:
        n = np.cross([1.0, 0.0, 0.0], direction)
    return n / np.linalg.norm(n)
