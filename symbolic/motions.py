"""Smooth motion primitives: scalar functions of time built from data.

A motion is a callable ``m(t)`` that returns a CasADi expression (or a float for a
float ``t``). Scenario files describe every time-varying parameter with these
primitives, so nothing read from a file is ever evaluated as code.
"""
from __future__ import annotations

import math
from dataclasses import fields
from typing import Any, Callable

import casadi as ca

from .checks import is_real
from .errors import ConfigError, shown
from .records import record


def _finite(value: Any, field: str) -> float:
    """Return ``value`` as a finite float or raise a ConfigError naming ``field``."""
    if not is_real(value):
        raise ConfigError(f"{field}: expected a number, got {shown(value)}")
    if not math.isfinite(value):
        raise ConfigError(f"{field}: must be finite, got {shown(value)}")
    return float(value)


@record(frozen=True)
class Constant:
    """``value``.

    Attributes
    ----------
    value : float
        The constant (unit of the parameter it drives).
    """
    value: float

    def __call__(self, t):
        return self.value + 0 * t


@record(frozen=True)
class Ramp:
    """``start + rate * t``.

    Attributes
    ----------
    start : float
        Value at t = 0.
    rate : float
        Change per second.
    """
    start: float = 0.0
    rate: float = 0.0

    def __call__(self, t):
        return self.start + self.rate * t


@record(frozen=True)
class Sinusoid:
    """``offset + amplitude * sin(omega * t + phase)``.

    Attributes
    ----------
    amplitude : float
        Amplitude.
    omega : float
        Angular frequency [rad/s].
    offset : float
        Mean value.
    phase : float
        Phase at t = 0 [rad].
    """
    amplitude: float
    omega: float
    offset: float = 0.0
    phase: float = 0.0

    def __call__(self, t):
        return self.offset + self.amplitude * ca.sin(self.omega * t + self.phase)


@record(frozen=True)
class Smoothstep:
    """Quintic (C2) transition from ``start`` at ``t0`` to ``end`` at ``t1``.

    Attributes
    ----------
    start, end : float
        Values before ``t0`` and after ``t1``.
    t0, t1 : float
        Start and end of the transition [s], ``t1 > t0``.

    Raises
    ------
    ConfigError
        ``t1 <= t0``.
    """
    start: float
    end: float
    t0: float
    t1: float

    def __post_init__(self):
        if not self.t1 > self.t0:
            raise ConfigError(f"smoothstep: t1 ({self.t1}) must be greater than t0 ({self.t0})")

    def __call__(self, t):
        x = ca.fmin(ca.fmax((t - self.t0) / (self.t1 - self.t0), 0.0), 1.0)
        return self.start + (self.end - self.start) * x**3 * (10 - 15 * x + 6 * x**2)


@record(frozen=True)
class Sum:
    """Sum of several motions.

    Attributes
    ----------
    terms : tuple
        The motions added (callables of time ``t`` [s]).
    """
    terms: tuple

    def __call__(self, t):
        return sum((m(t) for m in self.terms), 0 * t)


KINDS: dict[str, type] = {"constant": Constant, "ramp": Ramp, "sinusoid": Sinusoid,
                          "smoothstep": Smoothstep}

Motion = Callable[[Any], Any]


def motion_from_spec(spec: Any, field: str) -> Motion:
    """Build a motion from data: a number, a table with ``kind``, or a list of those (summed).

    Parameters
    ----------
    spec : float, dict or list
        ``0.3``, ``{"kind": "sinusoid", "amplitude": 0.6, "omega": 0.2}``, or a list.
    field : str
        Name of the field, used in error messages.

    Returns
    -------
    Motion
        A callable of time.

    Raises
    ------
    ConfigError
        A value that is not a finite number, an empty list, an unknown ``kind``, an unknown key
        for that kind, or a missing parameter.
    """
    if is_real(spec):
        return Constant(_finite(spec, field))
    if isinstance(spec, list):
        if not spec:
            raise ConfigError(f"{field}: an empty list is not a motion")
        return Sum(tuple(motion_from_spec(s, f"{field}[{i}]") for i, s in enumerate(spec)))
    if not isinstance(spec, dict):
        raise ConfigError(f"{field}: expected a number, a motion table or a list, got {shown(spec)}")
    kind = spec.get("kind")
    if not isinstance(kind, str) or kind not in KINDS:
        raise ConfigError(f"{field}.kind: expected one of {sorted(KINDS)}, got {shown(kind)}")
    cls = KINDS[kind]
    names = {f.name for f in fields(cls)}
    unknown = set(spec) - names - {"kind"}
    if unknown:
        raise ConfigError(f"{field}: unknown key(s) {sorted(unknown)} for kind {shown(kind)}; "
                          f"allowed: {sorted(names)}")
    args = {k: _finite(v, f"{field}.{k}") for k, v in spec.items() if k != "kind"}
    try:
        return cls(**args)
    except TypeError as exc:
        raise ConfigError(f"{field}: {exc}") from None


def motion_to_spec(motion: Any) -> Any:
    """Inverse of :func:`motion_from_spec` (numbers stay numbers).

    Parameters
    ----------
    motion : float, Constant, Ramp, Sinusoid, Smoothstep or Sum
        A number or motion primitive.

    Returns
    -------
    float, dict or list
        A float for a number or :class:`Constant`, ``{"kind": ..., field: value}`` for another
        primitive, a list of those for a :class:`Sum`.

    Raises
    ------
    ConfigError
        ``motion`` is not a number or motion primitive.
    """
    if isinstance(motion, (int, float)):
        return float(motion)
    if isinstance(motion, Sum):
        return [motion_to_spec(m) for m in motion.terms]
    for kind, cls in KINDS.items():
        if type(motion) is cls:
            if cls is Constant:
                return motion.value
            return {"kind": kind, **{f.name: getattr(motion, f.name) for f in fields(cls)}}
    raise ConfigError(f"cannot describe {shown(motion)} as data (only motion primitives can be)")
