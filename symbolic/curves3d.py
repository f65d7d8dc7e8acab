"""Spatial curves: arc length and two normal coordinates in a frame transported without twist (docs/guide/spatial.md).

A :class:`SpatialCurve` gives, at the closest point of ``y`` at time ``t``, the arc length
``psi(y, t)``, the normal coordinates ``Phi(y, t) = (phi_1, phi_2)`` and the frame
``(t, n_1, n_2)`` there (unit tangent and normals, ``t x n_1 = n_2``, transported along the
curve without twist). On the curve the Jacobian of ``(psi, Phi)`` w.r.t. ``y`` is the
orthogonal matrix with rows ``t, n_1, n_2``. Every symbolic member is a closed form in CasADi,
differentiable by AD in ``y`` and ``t``. Composite paths are in :mod:`.paths3d`.
"""
from __future__ import annotations

import math
import weakref
from typing import Any

import casadi as ca
import numpy as np

from .errors import ConfigError, shown
from .lazy import made_once
from .motions import motion_to_spec
from .params import Param, as_param, evaluate, evaluate_many
from .vectors3d import any_normal, as_point3, orthogonal_normal, rotate, unit_vector


def column(values) -> Any:
    """Three scalars (numbers or CasADi expressions) as one CasADi column.

    Parameters
    ----------
    values : sequence of 3 (float or casadi.SX)
        The components.

    Returns
    -------
    casadi.SX or casadi.DM, shape (3, 1)
        The column.
    """
    return ca.vertcat(*values)


def as_column(y) -> Any:
    """A point as a CasADi column: symbols pass through, numbers become a ``DM``.

    Parameters
    ----------
    y : casadi.SX, casadi.MX, casadi.DM or array_like, shape (3,)
        A point [m].

    Returns
    -------
    casadi.SX, casadi.MX or casadi.DM, shape (3, 1)
        The same point.
    """
    if isinstance(y, (ca.SX, ca.MX, ca.DM)):
        return y
    return ca.DM(np.asarray(y, float).reshape(3, 1))


#: :meth:`SpatialCurve.functions` of each curve alive.
_FUNCTIONS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class SpatialCurve:
    """Base class of the 3-D curves: subclasses define :meth:`coordinates` and :meth:`sample`."""

    kind = "curve3d"

    def coordinates(self, y, t):
        """Arc length, normal coordinates and frame at the closest point of ``y`` (one evaluation for all).

        Parameters
        ----------
        y : casadi.SX or casadi.MX, shape (3, 1)
            A point [m].
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        psi : casadi.SX
            Arc length [m].
        Phi : casadi.SX, shape (2, 1)
            ``(phi_1, phi_2)`` [m].
        frame : tuple of 3 casadi.SX, shape (3, 1)
            ``(t, n_1, n_2)``.
        """
        raise NotImplementedError

    def psi(self, y, t):
        """Arc length of the closest point of ``y``.

        Parameters
        ----------
        y : casadi.SX or casadi.MX, shape (3, 1)
            A point [m].
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        casadi.SX
            ``psi(y, t)`` [m].
        """
        return self.coordinates(y, t)[0]

    def Phi(self, y, t):
        """Normal coordinates ``(phi_1, phi_2)`` of ``y``: its offset from the closest point in ``(n_1, n_2)``.

        Parameters
        ----------
        y : casadi.SX or casadi.MX, shape (3, 1)
            A point [m].
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        casadi.SX, shape (2, 1)
            ``Phi(y, t)`` [m].
        """
        return self.coordinates(y, t)[1]

    def frame(self, y, t):
        """The transported frame ``(t, n_1, n_2)`` at the closest point of ``y``.

        Parameters
        ----------
        y : casadi.SX or casadi.MX, shape (3, 1)
            A point [m].
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        tuple of 3 casadi.SX, shape (3, 1)
            Unit tangent, first and second unit normal (``t x n_1 = n_2``).
        """
        return self.coordinates(y, t)[2]

    def sample(self, t: float, n: int = 200, extent: float | None = None) -> np.ndarray:
        """Points on the curve at time ``t`` (for figures and checks).

        Parameters
        ----------
        t : float
            Time [s].
        n : int
            Number of points.
        extent : float, optional
            Half-length of the drawn piece of a line [m] (default 10), or the rays drawn beyond a
            path's ends [m] (default 0).

        Returns
        -------
        ndarray, shape (n, 3)
            Points [m].
        """
        raise NotImplementedError

    def points_at(self, s: Any, times: Any) -> np.ndarray:
        """The points of arc lengths ``s`` at ``times`` (``point_at`` pair by pair; a line does it at once).

        Parameters
        ----------
        s : array_like, shape (k,) or scalar
            Arc lengths [m].
        times : array_like, shape (k,)
            Times [s].

        Returns
        -------
        ndarray, shape (k, 3)
            The points [m].

        Raises
        ------
        AttributeError
            The curve has no ``point_at`` (it cannot map an arc length to a point).
        """
        t = np.asarray(times, dtype=float).ravel()
        s = np.broadcast_to(np.asarray(s, dtype=float), t.shape)
        point_at = self.point_at
        return np.array([point_at(a, b) for a, b in zip(s.tolist(), t.tolist())], dtype=float).reshape(-1, 3)

    def to_spec(self) -> dict:
        """The curve as data (for parameters built from motion primitives).

        Returns
        -------
        dict
            ``{"kind": ..., <keys>}``, accepted by :func:`~.curve3d_specs.curve3d_from_spec`.

        Raises
        ------
        ConfigError
            A parameter is a Python callable, not a motion primitive.
        """
        raise NotImplementedError

    def period(self, t):
        """Jump of ``psi`` across its branch cut (a closed curve's length), or None.

        Parameters
        ----------
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        expression or None
            ``2 pi R(t)`` for a circle, None for an open curve [m].
        """
        return None

    def functions(self) -> ca.Function:
        """CasADi Function ``(y, t) -> (psi, Phi, tangent, n1, n2)``, built once per curve (it does not change).

        Returns
        -------
        casadi.Function
            Inputs ``y`` (3) [m] and ``t`` [s]; outputs the arc length [m], normal coordinates (2) [m]
            and the frame's three unit vectors (3 each).
        """
        return made_once(_FUNCTIONS, self, self._frame_function)

    def _frame_function(self) -> ca.Function:
        y, t = ca.SX.sym("y", 3), ca.SX.sym("t")
        psi, Phi, (tan, n1, n2) = self.coordinates(y, t)
        return ca.Function(f"{self.kind}_curve3d", [y, t], [psi, Phi, tan, n1, n2],
                           ["y", "t"], ["psi", "Phi", "tangent", "n1", "n2"])


class Line3D(SpatialCurve):
    """Straight line through ``point`` along ``direction``, optionally turning rigidly about ``point``.

    ``psi = t.(y - p)``, ``Phi = (n_1.(y - p), n_2.(y - p))`` with ``n_1`` = ``normal``
    orthogonalised against the direction and ``n_2 = t x n_1``. A rotation ``(axis, angle(t))``
    turns ``t, n_1, n_2`` about ``axis`` by ``angle(t)`` (Rodrigues), the line about ``point``.

    Parameters
    ----------
    point : sequence of 3 (float | callable) or callable
        A point of the line [m], each coordinate a number or a motion (callable of time).
    direction : sequence of 3 float
        Direction of the line (any non-zero length); ``psi`` grows along it.
    normal : sequence of 3 float
        The first normal ``n_1`` (any length, not parallel to ``direction``).
    rotation : (sequence of 3 float, float | callable), optional
        ``(axis, angle)``: the axis (any non-zero length) and the angle [rad], a number or a motion.

    Raises
    ------
    ConfigError
        A bad point, a zero direction, a normal parallel to it, or a malformed rotation.
    """

    kind = "line"

    def __init__(self, point: Any = (0.0, 0.0, 0.0), direction: Any = (1.0, 0.0, 0.0),
                 normal: Any = (0.0, 1.0, 0.0), rotation: Any = None) -> None:
        self.point = as_point3(point, "curve.point")
        self.direction = unit_vector(direction, "curve.direction")
        self.normal = orthogonal_normal(self.direction, normal, "curve.normal")
        self.binormal = np.cross(self.direction, self.normal)
        self.axis, self.angle = None, None
        if rotation is not None:
            if not isinstance(rotation, (tuple, list)) or len(rotation) != 2:
                raise ConfigError(f"curve.rotation: expected (axis, angle), got {shown(rotation)}")
            self.axis = unit_vector(rotation[0], "curve.rotation.axis")
            self.angle = as_param(rotation[1], "curve.rotation.angle")

    def basis(self, t):
        """The line's frame ``(t, n_1, n_2)`` at time ``t`` (the same at every point).

        Parameters
        ----------
        t : casadi.SX or float
            Time [s].

        Returns
        -------
        tuple of 3 casadi.SX or casadi.DM, shape (3, 1)
            Tangent and normals.
        """
        vectors = (self.direction, self.normal, self.binormal)
        if self.axis is None:
            return tuple(ca.DM(v) for v in vectors)
        angle = self.angle(t)
        return tuple(rotate(self.axis, angle, ca.DM(v)) for v in vectors)

    def coordinates(self, y, t):
        v = as_column(y) - column([c(t) for c in self.point])
        tan, n1, n2 = self.basis(t)
        return ca.dot(tan, v), ca.vertcat(ca.dot(n1, v), ca.dot(n2, v)), (tan, n1, n2)

    def numeric_basis(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The frame :meth:`basis` as numbers at time ``t``.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        tuple of 3 ndarray, shape (3,)
            Tangent and normals.
        """
        vectors = (self.direction, self.normal, self.binormal)
        if self.axis is None:
            return vectors
        angle = evaluate(self.angle, t)
        return tuple(rotate(self.axis, angle, v) for v in vectors)

    def point_at(self, s: float, t: float = 0.0) -> np.ndarray:
        """The point of arc length ``s`` at time ``t``.

        Parameters
        ----------
        s : float
            Arc length [m].
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (3,)
            The point [m].
        """
        p = np.array([evaluate(c, t) for c in self.point])
        return p + s * self.numeric_basis(t)[0]

    def points_at(self, s: Any, times: Any) -> np.ndarray:
        # at once (the docstring is SpatialCurve's): each motion evaluated on a row of all the times
        # (params.evaluate_many), the tangent turned by rotate as numeric_basis does: point_at's values, bit for bit
        t = np.asarray(times, dtype=float).ravel()
        s = np.broadcast_to(np.asarray(s, dtype=float), t.shape)
        p = np.stack([evaluate_many(c, t) for c in self.point], axis=-1)
        if self.axis is None:
            return p + s[:, None] * self.direction
        tangents = [rotate(self.axis, a, self.direction) for a in evaluate_many(self.angle, t).tolist()]
        return p + s[:, None] * np.array(tangents).reshape(-1, 3)

    def to_spec(self) -> dict:
        spec = {"kind": "line", "point": [motion_to_spec(c) for c in self.point],
                "direction": self.direction.tolist(), "normal": self.normal.tolist()}
        if self.axis is not None:
            spec["rotation"] = {"axis": self.axis.tolist(), "angle": motion_to_spec(self.angle)}
        return spec

    def sample(self, t: float, n: int = 200, extent: float | None = None) -> np.ndarray:
        half = 10.0 if extent is None else float(extent)
        return np.array([self.point_at(s, t) for s in np.linspace(-half, half, n)])


class Circle3D(SpatialCurve):
    """Circle of centre ``centre`` and radius ``radius`` in the plane of normal ``normal``, travelled
    counter-clockwise about it.

    With ``w`` the unit normal, ``r = y - C - ((y - C).w) w`` the in-plane part and ``rho = |r|``:
    the frame at the closest point is ``t = w x r/rho``, ``n_1 = w x t = -r/rho`` (towards the
    centre), ``n_2 = w``; ``Phi = (R - rho, (y - C).w)`` (the deviation vector
    ``(rho - R) r/rho + ((y - C).w) w`` in that frame; ``phi_1`` as the planar circle's ``phi``),
    and ``psi = R a`` with ``a`` the angle of ``r`` about ``w`` from ``reference``, in
    ``(-pi, pi]`` (the branch cut lies opposite the reference; :meth:`period` unwraps it).

    Parameters
    ----------
    centre : sequence of 3 (float | callable) or callable
        Centre [m], each coordinate a number or a motion.
    radius : float or callable
        Radius [m], > 0.
    normal : sequence of 3 float
        Normal ``w`` of the circle's plane (any non-zero length).
    reference : sequence of 3 float, optional
        Direction from the centre where ``psi = 0`` (orthogonalised against ``w``); default: towards
        the origin (the base) from the centre at t = 0, or any in-plane direction when the base lies
        on the axis.

    Raises
    ------
    ConfigError
        A bad centre, a radius not > 0 at t = 0, a zero normal, or a reference along it.
    """

    kind = "circle"

    def __init__(self, centre: Any, radius: Param, normal: Any = (0.0, 0.0, 1.0), reference: Any = None) -> None:
        self.centre = as_point3(centre, "curve.centre")
        self.radius = as_param(radius, "curve.radius")
        r0 = evaluate(self.radius, 0.0)
        if not r0 > 0:
            raise ConfigError(f"curve.radius: must be > 0, got {r0}")
        self.normal = unit_vector(normal, "curve.normal")
        if reference is None:
            towards = -np.array([evaluate(c, 0.0) for c in self.centre])
            towards = towards - float(towards @ self.normal) * self.normal
            reference = towards if np.linalg.norm(towards) > 1e-9 else any_normal(self.normal)
        self.reference = orthogonal_normal(self.normal, reference, "curve.reference")

    def coordinates(self, y, t):
        w, ref, R = ca.DM(self.normal), ca.DM(self.reference), self.radius(t)
        full = as_column(y) - column([c(t) for c in self.centre])
        z = ca.dot(full, w)
        r = full - z * w
        rho = ca.norm_2(r)
        u = r / rho
        a = ca.atan2(ca.dot(ca.cross(ref, r), w), ca.dot(ref, r))
        tan = ca.cross(w, u)
        return R * a, ca.vertcat(R - rho, z), (tan, -u, w)

    def period(self, t):
        return 2 * math.pi * self.radius(t)

    def point_at(self, s: float, t: float = 0.0) -> np.ndarray:
        """The point of arc length ``s`` at time ``t`` (``psi = s`` there, modulo the period).

        Parameters
        ----------
        s : float
            Arc length [m].
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (3,)
            The point [m].
        """
        R = evaluate(self.radius, t)
        c = np.array([evaluate(v, t) for v in self.centre])
        return c + R * rotate(self.normal, s / R, self.reference)

    def to_spec(self) -> dict:
        return {"kind": self.kind, "centre": [motion_to_spec(c) for c in self.centre],
                "radius": motion_to_spec(self.radius), "normal": self.normal.tolist(),
                "reference": self.reference.tolist()}

    def sample(self, t: float, n: int = 200, extent: float | None = None) -> np.ndarray:
        R = evaluate(self.radius, t)
        return np.array([self.point_at(s, t) for s in np.linspace(-math.pi * R, math.pi * R, n)])


class Arc3D(Circle3D):
    """A circular arc in space: the circle of :class:`Circle3D` (scenario ``kind = "arc"``).

    Parameters
    ----------
    centre : sequence of 3 (float | callable) or callable
        Centre [m].
    radius : float or callable
        Radius [m], > 0.
    normal : sequence of 3 float
        Normal of the arc's plane; the arc turns counter-clockwise about it.
    reference : sequence of 3 float, optional
        Direction from the centre where ``psi = 0`` (see :class:`Circle3D`).
    """

    kind = "arc"


for _cls in (Line3D, Circle3D):     # the subclasses' implementations carry the base class's documentation
    for _name in ("coordinates", "sample", "period", "to_spec", "points_at"):
        _own = vars(_cls).get(_name)
        if _own is not None and not _own.__doc__:
            _own.__doc__ = getattr(SpatialCurve, _name).__doc__
