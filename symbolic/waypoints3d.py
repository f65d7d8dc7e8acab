"""Waypoints in 3-D: the filleted polyline through points as segments of a :class:`~.paths3d.Path3D`.

Each interior corner's fillet is a circular arc in the plane of its two legs; its bank is the
angle of the turn direction in the frame transported (without twist) to the corner, so a
polyline in the xy plane gives the planar waypoint path (left turns bank 0, right turns bank pi).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import ConfigError, shown
from .vectors3d import any_normal, finite, finite_vector, orthogonal_normal, rotate


def waypoint_points(points: Any) -> np.ndarray:
    """Waypoints validated as an array.

    Parameters
    ----------
    points : sequence of (x, y, z)
        At least two points [m], no two consecutive ones equal.

    Returns
    -------
    ndarray, shape (k, 3)
        The points [m].

    Raises
    ------
    ConfigError
        Fewer than two points, a point that is not three finite numbers, or two consecutive equal points.
    """
    if not isinstance(points, (list, tuple, np.ndarray)) or len(points) < 2:
        raise ConfigError(f"curve.points: need at least two points [x, y, z], got {shown(points)}")
    P = np.array([finite_vector(pt, f"curve.points[{i}]") for i, pt in enumerate(points)])
    for i, L in enumerate(np.linalg.norm(np.diff(P, axis=0), axis=1)):
        if not L > 1e-12:
            raise ConfigError(f"curve.points[{i}] and curve.points[{i + 1}] coincide")
    return P


def waypoint_segments3d(points: Any, radius: float, normal: Any = None
                        ) -> tuple[list[dict], np.ndarray, np.ndarray, np.ndarray]:
    """Segments, start, direction and ``n_1`` of the filleted polyline through 3-D ``points``.

    Each interior corner of turning angle ``a`` (between its two legs) is cut by
    ``radius tan(a/2)`` on both legs and filleted by an arc of angle ``a`` in the plane of the
    two legs; its bank is the angle of the turn direction in the frame transported to it.

    Parameters
    ----------
    points : sequence of (x, y, z)
        At least two waypoints [m].
    radius : float
        Fillet radius [m], > 0.
    normal : sequence of 3 float, optional
        ``n_1`` at the start; default ``e_z x direction`` normalised (``e_x x direction`` for a
        vertical start), so a path in the xy plane gets the planar left normal and ``n_2 = e_z``.

    Returns
    -------
    segments : list of dict
        ``{"line": L}`` and ``{"arc": a, "radius": r, "bank": beta}`` for :class:`Path3D`.
    start : ndarray, shape (3,)
        The first point [m].
    direction : ndarray, shape (3,)
        Unit direction of the first leg.
    normal : ndarray, shape (3,)
        ``n_1`` at the start.

    Raises
    ------
    ConfigError
        Bad points, a radius not > 0, a 180 degree corner, or a fillet that does not fit between
        its neighbours.
    """
    P = waypoint_points(points)
    r = finite(radius, "curve.radius")
    if not r > 0:
        raise ConfigError(f"curve.radius: must be > 0, got {r}")
    legs = np.diff(P, axis=0)
    lengths = np.linalg.norm(legs, axis=1)
    dirs = legs / lengths[:, None]
    turns = np.array([math.atan2(np.linalg.norm(np.cross(a, b)), a @ b) for a, b in zip(dirs[:-1], dirs[1:])])
    for i, a in enumerate(turns):
        if abs(a - math.pi) < 1e-9:
            raise ConfigError(f"curve.points[{i + 1}]: the path turns back on itself (180 degree corner)")
    n1 = any_normal(dirs[0]) if normal is None else orthogonal_normal(dirs[0], normal, "curve.normal")
    trim = r * np.tan(turns / 2)
    before, after = np.r_[0.0, trim], np.r_[trim, 0.0]
    frame, segments = (dirs[0], n1, np.cross(dirs[0], n1)), []
    for i, L in enumerate(lengths):
        rest = L - before[i] - after[i]
        if rest < -1e-12:
            raise ConfigError(f"curve.radius: a fillet of radius {r} does not fit between curve.points[{i}] and "
                              f"curve.points[{i + 1}] (needs {before[i] + after[i]:.4g} m of the {L:.4g} m leg)")
        if rest > 1e-12:
            segments.append({"line": float(rest)})
        if i < len(turns) and turns[i] > 1e-12:
            tan, m1, m2 = frame
            u = dirs[i + 1] - (dirs[i + 1] @ tan) * tan
            u /= np.linalg.norm(u)
            segments.append({"arc": float(turns[i]), "radius": r, "bank": math.atan2(u @ m2, u @ m1)})
            frame = tuple(rotate(np.cross(tan, u), float(turns[i]), v) for v in frame)
    if not segments:
        raise ConfigError("curve.points: the filleted path has no length")
    return segments, P[0], dirs[0], n1
