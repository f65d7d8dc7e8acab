"""Smooth time-varying curves with an orthonormalised description (paper eqs. 8-11).

A curve gives ``phi(y, t)`` (signed distance, zero on the curve) and ``psi(y, t)``
(arc length) whose Jacobian w.r.t. ``y`` is the rotation ``T(alpha*)`` on the curve.
Every parameter is a number, a tuple of numbers, or a callable of time returning a
CasADi expression (the motion primitives of :mod:`symbolic.motions` are such callables).
"""
from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from .errors import ConfigError
from .motions import motion_to_spec
from .params import Param, as_param, as_point, evaluate


class Curve:
    """Base class: subclasses define :meth:`phi`, :meth:`psi`, :meth:`sample`, :meth:`to_spec`."""

    kind = "curve"

    def phi(self, y, t):
        """Signed distance from the curve (zero on it).

        Parameters
        ----------
        y : casadi.SX, shape (2,)
            A point [m].
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        casadi.SX
            ``phi(y, t)`` [m].
        """
        raise NotImplementedError

    def psi(self, y, t):
        """Arc-length coordinate of the point ``y`` along the curve.

        Parameters
        ----------
        y : casadi.SX, shape (2,)
            A point [m].
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        casadi.SX
            ``psi(y, t)`` [m].
        """
        raise NotImplementedError

    def sample(self, t: float, n: int = 400, extent: float = 10.0) -> np.ndarray:
        """Points on the curve at time ``t``, for plotting.

        Parameters
        ----------
        t : float
            Time [s].
        n : int
            Number of points.
        extent : float
            Half-length of the drawn piece of an unbounded curve [m].

        Returns
        -------
        ndarray, shape (n, 2)
            Points [m].
        """
        raise NotImplementedError

    def point_at(self, s: float, t: float = 0.0) -> np.ndarray:
        """The point of arc length ``s`` at time ``t`` (for drawing the target ``s*(t)``).

        Parameters
        ----------
        s : float
            Arc length [m].
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (2,)
            The point [m].

        Raises
        ------
        NotImplementedError
            The curve cannot map an arc length to a point (a user-defined curve without it).
        """
        raise NotImplementedError

    def to_spec(self) -> dict:
        """The curve as data (only for parameters built from motion primitives).

        Returns
        -------
        dict
            ``{"kind": ..., <parameters>}``, accepted by :func:`curve_from_spec`.

        Raises
        ------
        ConfigError
            A parameter is a Python callable, not a motion primitive.
        """
        raise NotImplementedError

    def period(self, t):
        """Jump of ``psi`` across its branch cut at time ``t`` (a closed curve's length), or None.

        A run unwraps ``s`` by it (:func:`unwrap_s`) so that ``s`` stays continuous.

        Parameters
        ----------
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        expression or None
            The period [m] (``2 pi R(t)`` for a circle), None for an open curve.
        """
        return None

    def functions(self) -> ca.Function:
        """CasADi Function ``(y, t) -> (phi, psi)``.

        Returns
        -------
        casadi.Function
            Inputs ``y`` [m] and ``t`` [s], outputs ``phi`` and ``psi`` [m].
        """
        y, t = ca.SX.sym("y", 2), ca.SX.sym("t")
        return ca.Function(f"{self.kind}_curve", [y, t], [self.phi(y, t), self.psi(y, t)],
                           ["y", "t"], ["phi", "psi"])


class Line(Curve):
    """Straight line through ``point`` at ``angle`` [rad]; ``psi`` grows along ``(cos, sin)(angle)``.

    Parameters
    ----------
    point : (float | callable, float | callable) or callable
        A point of the line [m].
    angle : float or callable
        Direction of the line [rad].
    """

    kind = "line"

    def __init__(self, point: Any = (0.0, 0.0), angle: Param = 0.0) -> None:
        self.point, self.angle = as_point(point, "curve.point"), as_param(angle, "curve.angle")

    def phi(self, y, t):
        th = self.angle(t)
        return -ca.sin(th) * (y[0] - self.point[0](t)) + ca.cos(th) * (y[1] - self.point[1](t))

    def psi(self, y, t):
        th = self.angle(t)
        return ca.cos(th) * (y[0] - self.point[0](t)) + ca.sin(th) * (y[1] - self.point[1](t))

    def sample(self, t: float, n: int = 400, extent: float = 10.0) -> np.ndarray:
        p = np.array([evaluate(c, t) for c in self.point])
        th = evaluate(self.angle, t)
        s = np.linspace(-extent, extent, n)
        return p + s[:, None] * np.array([math.cos(th), math.sin(th)])

    def point_at(self, s: float, t: float = 0.0) -> np.ndarray:
        th = evaluate(self.angle, t)
        return np.array([evaluate(c, t) for c in self.point]) + s * np.array([math.cos(th), math.sin(th)])

    def to_spec(self) -> dict:
        return {"kind": "line", "point": [motion_to_spec(c) for c in self.point],
                "angle": motion_to_spec(self.angle)}


class Circle(Curve):
    """Circle of centre ``center`` and radius ``radius``, travelled counter-clockwise.

    ``phi = R - |y - c|`` (positive inside) and ``psi = R * angle(y - c)``, the angle
    measured from ``reference`` [rad] (default: the direction of the base seen from
    the centre at t = 0), so the branch cut of ``atan2`` lies opposite the reference.

    Parameters
    ----------
    center : (float | callable, float | callable) or callable
        Centre [m].
    radius : float or callable
        Radius [m], > 0.
    reference : float or callable, optional
        Angle [rad] where ``psi = 0``.

    Raises
    ------
    ConfigError
        A radius that is not positive at t = 0, or parameters that are not numbers or callables.
    """

    kind = "circle"

    def __init__(self, center: Any, radius: Param, reference: Param | None = None) -> None:
        self.center, self.radius = as_point(center, "curve.center"), as_param(radius, "curve.radius")
        r0 = evaluate(self.radius, 0.0)
        if not r0 > 0:
            raise ConfigError(f"curve.radius: must be > 0, got {r0}")
        if reference is None:
            c0 = [evaluate(c, 0.0) for c in self.center]
            reference = math.atan2(-c0[1], -c0[0])
        self.reference = as_param(reference, "curve.reference")

    def phi(self, y, t):
        r = ca.vertcat(y[0] - self.center[0](t), y[1] - self.center[1](t))
        return self.radius(t) - ca.norm_2(r)

    def psi(self, y, t):
        r = ca.vertcat(y[0] - self.center[0](t), y[1] - self.center[1](t))
        a0 = self.reference(t)
        cross = ca.cos(a0) * r[1] - ca.sin(a0) * r[0]
        dot = ca.cos(a0) * r[0] + ca.sin(a0) * r[1]
        return self.radius(t) * ca.atan2(cross, dot)

    def period(self, t):  # the docstring is the base class's (set below)
        return 2 * math.pi * self.radius(t)

    def sample(self, t: float, n: int = 400, extent: float = 10.0) -> np.ndarray:
        c = np.array([evaluate(v, t) for v in self.center])
        a = np.linspace(0, 2 * math.pi, n)
        return c + evaluate(self.radius, t) * np.stack([np.cos(a), np.sin(a)], axis=1)

    def point_at(self, s: float, t: float = 0.0) -> np.ndarray:
        R, a = evaluate(self.radius, t), evaluate(self.reference, t)
        ang = a + s / R
        return np.array([evaluate(c, t) for c in self.center]) + R * np.array([math.cos(ang), math.sin(ang)])

    def to_spec(self) -> dict:
        return {"kind": "circle", "center": [motion_to_spec(c) for c in self.center],
                "radius": motion_to_spec(self.radius), "reference": motion_to_spec(self.reference)}


class Arc(Circle):
    """Circle through ``point`` with tangent direction ``angle`` there, radius ``radius``.

    The centre is ``point + R n(angle)`` (to the left of the tangent) and ``psi = 0`` at
    ``point``; ``point``, ``angle`` and ``radius`` may all move.

    Parameters
    ----------
    point : (float | callable, float | callable) or callable
        A point of the arc [m].
    angle : float or callable
        Tangent direction at ``point`` [rad].
    radius : float or callable
        Radius [m], > 0.
    """

    kind = "arc"

    def __init__(self, point: Any = (0.0, 0.0), angle: Param = 0.0, radius: Param = 1.0) -> None:
        self.point, self.angle = as_point(point, "curve.point"), as_param(angle, "curve.angle")
        radius = as_param(radius, "curve.radius")
        center = (lambda t: self.point[0](t) - radius(t) * ca.sin(self.angle(t)),
                  lambda t: self.point[1](t) + radius(t) * ca.cos(self.angle(t)))
        super().__init__(center, radius, reference=lambda t: self.angle(t) - math.pi / 2)

    def to_spec(self) -> dict:
        return {"kind": "arc", "point": [motion_to_spec(c) for c in self.point],
                "angle": motion_to_spec(self.angle), "radius": motion_to_spec(self.radius)}


def unwrap_s(curve: Curve, t: np.ndarray, s: np.ndarray, previous: tuple[float, float] | None = None
             ) -> np.ndarray:
    """``s`` made continuous across the branch cut of a closed curve's ``psi``, keeping the turns.

    Parameters
    ----------
    curve : Curve
        Its :meth:`Curve.period` (None: ``s`` is returned unchanged).
    t, s : (N,) arrays
        Times [s] and ``psi`` as computed (jumping by a period at the cut) [m].
    previous : (t, s), optional
        The last unwrapped sample before these (to continue a run chunk by chunk).

    Returns
    -------
    (N,) array
        ``s`` plus the whole number of periods that keeps it continuous [m].
    """
    s = np.asarray(s, dtype=float)
    if curve.period(ca.SX.sym("t")) is None or not len(s):
        return s
    tt = ca.SX.sym("t")
    f = ca.Function("period", [tt], [curve.period(tt)])
    ts = np.concatenate([[previous[0]], t]) if previous else np.asarray(t, float)
    ss = np.concatenate([[previous[1]], s]) if previous else s
    P = np.asarray(f.map(len(ts))(ts[None])).ravel()
    angle = np.unwrap(2 * math.pi * ss / P)
    out = angle * P / (2 * math.pi)
    return out[1:] if previous else out


for _cls in (Line, Circle, Arc):     # the subclasses' implementations carry the base class's documentation
    for _name in ("phi", "psi", "sample", "point_at", "to_spec", "period"):
        _own = vars(_cls).get(_name)
        if _own is not None and not _own.__doc__:
            _own.__doc__ = getattr(Curve, _name).__doc__

