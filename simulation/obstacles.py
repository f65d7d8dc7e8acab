"""Obstacles: wall segments, circles (solid discs) and closed polygons (solid), with names.

In a scenario file (``[[obstacles]]``, one table each, ``name`` optional: default
``wall 1``, ``wall 2``, ... counted from 1 in file order)::

    [[obstacles]]                      # a wall segment
    a = [1.2, 1.3]
    b = [0.2, 2.3]
    name = "left wall"
    [[obstacles]]                      # a disc
    center = [1.0, -0.5]
    radius = 0.2
    [[obstacles]]                      # a closed polygon (the last point joins the first)
    points = [[2, 0], [2.5, 0], [2.5, 0.5]]

:func:`outline` is the one drawing of an obstacle (figures, animation and the Foxglove
scene use it); :func:`link_distances` is the one distance (the clearance check).
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from coordarm.generated.chain_geometry import edge_distances
from coordarm.symbolic import ConfigError
from coordarm.symbolic.geometry import point_segment_distance, segment_distance
from coordarm.symbolic.records import record

from .run import check_number

#: Obstacle kinds and the keys (besides ``name``) that define them.
KINDS = {"segment": ("a", "b"), "circle": ("center", "radius"), "polygon": ("points",)}


@record(frozen=True, eq=False)
class Obstacle:
    """One obstacle.

    Attributes
    ----------
    kind : str
        ``"segment"``, ``"circle"`` or ``"polygon"``.
    name : str
        Shown in messages, figures and the outcome (``wall 1`` ... by default).
    points : (k, 2) array
        The segment's two ends, the circle's centre (k = 1) or the polygon's corners [m].
    radius : float
        Circle radius [m] (0 for the other kinds).
    """

    kind: str
    name: str
    points: np.ndarray
    radius: float = 0.0

    def to_spec(self) -> dict:
        """The obstacle as scenario data.

        Returns
        -------
        dict
            ``{"name", "a", "b"}`` (segment), ``{"name", "center", "radius"}`` (circle) or
            ``{"name", "points"}`` (polygon); points as ``[x, y]`` lists [m].
        """
        p = self.points.tolist()
        if self.kind == "segment":
            return {"name": self.name, "a": p[0], "b": p[1]}
        if self.kind == "circle":
            return {"name": self.name, "center": p[0], "radius": self.radius}
        return {"name": self.name, "points": p}


def _pair(value: Any, field: str) -> list[float]:
    if not isinstance(value, list) or len(value) != 2:
        raise ConfigError(f"{field}: expected [x, y], got {value!r}")
    return [check_number(v, f"{field}[{i}]", positive=False) for i, v in enumerate(value)]


def obstacle_from_spec(spec: Any, index: int, field: str | None = None) -> Obstacle:
    """Validate one ``[[obstacles]]`` table (``index`` is 0-based; the default name counts from 1).

    Parameters
    ----------
    spec : Any
        The table: ``a``, ``b`` (segment), ``center``, ``radius`` (circle) or ``points`` (polygon),
        points ``[x, y]`` [m], and an optional ``name``.
    index : int
        Its 0-based position in the array.
    field : str or None
        Name of the table in error messages (None: ``obstacles[index]``).

    Returns
    -------
    Obstacle
        The obstacle.

    Raises
    ------
    ConfigError
        Not a table, a bad name, unknown or missing keys, a degenerate segment or polygon, or a
        radius that is not a positive number (the message names the field).
    """
    field = field or f"obstacles[{index}]"
    if not isinstance(spec, dict):
        raise ConfigError(f"{field}: expected a table, got {spec!r}")
    name = spec.get("name", f"wall {index + 1}")
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{field}.name: expected a non-empty string, got {name!r}")
    keys = set(spec) - {"name"}
    kind = next((k for k, ks in KINDS.items() if keys == set(ks)), None)
    if kind is None:
        raise ConfigError(f"{field}: expected a = [x, y], b = [x, y] (segment), center = [x, y], radius = r "
                          f"(circle) or points = [[x, y], ...] (polygon), got keys {sorted(keys)}")
    if kind == "segment":
        pts = np.array([_pair(spec["a"], f"{field}.a"), _pair(spec["b"], f"{field}.b")])
        if not np.any(pts[0] != pts[1]):
            raise ConfigError(f"{field}: a and b are the same point")
        return Obstacle("segment", name, pts)
    if kind == "circle":
        return Obstacle("circle", name, np.array([_pair(spec["center"], f"{field}.center")]),
                        check_number(spec["radius"], f"{field}.radius"))
    pts = spec["points"]
    if not isinstance(pts, list) or len(pts) < 3:
        raise ConfigError(f"{field}.points: need at least 3 points [[x, y], ...], got {pts!r}")
    pts = np.array([_pair(p, f"{field}.points[{i}]") for i, p in enumerate(pts)])
    if abs(_area(pts)) == 0:
        raise ConfigError(f"{field}.points: the polygon has zero area")
    return Obstacle("polygon", name, pts)


def obstacles_from_spec(specs: Any) -> list[Obstacle]:
    """Validate the ``[[obstacles]]`` array; names must be unique.

    Parameters
    ----------
    specs : Any
        The array of tables (see :func:`obstacle_from_spec`).

    Returns
    -------
    list of Obstacle
        The obstacles, in order.

    Raises
    ------
    ConfigError
        Not an array, an invalid table, or repeated names.
    """
    if not isinstance(specs, list):
        raise ConfigError("obstacles: expected an array of tables [[obstacles]]")
    obs = [obstacle_from_spec(s, i) for i, s in enumerate(specs)]
    names = [o.name for o in obs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"obstacles: names must be unique, repeated: {dup}")
    return obs


def _area(pts: np.ndarray) -> float:
    x, y = pts[:, 0], pts[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def outline(obstacle: Obstacle, n: int = 64) -> np.ndarray:
    """The obstacle as a polyline [m], shape (k, 2): a segment's two ends, a closed circle or polygon.

    Parameters
    ----------
    obstacle : Obstacle
        The obstacle.
    n : int
        Segments of a circle's outline.

    Returns
    -------
    ndarray, shape (k, 2)
        The points [m]: 2 for a segment, ``n + 1`` for a circle, corners + 1 for a polygon.
    """
    if obstacle.kind == "segment":
        return obstacle.points.copy()
    if obstacle.kind == "circle":
        a = np.linspace(0.0, 2 * math.pi, n + 1)
        return obstacle.points[0] + obstacle.radius * np.column_stack([np.cos(a), np.sin(a)])
    return np.vstack([obstacle.points, obstacle.points[:1]])


def edges(obstacle: Obstacle) -> np.ndarray:
    """Segments ``(a, b)`` of a segment or polygon obstacle, shape (k, 2, 2).

    Parameters
    ----------
    obstacle : Obstacle
        A segment or polygon.

    Returns
    -------
    ndarray, shape (k, 2, 2)
        End points of each edge [m].
    """
    pts = outline(obstacle)
    return np.stack([pts[:-1], pts[1:]], axis=1)


def inside_polygon(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Whether points ``p`` (..., 2) lie strictly inside the closed polygon ``poly`` (k, 2) (ray casting).

    Parameters
    ----------
    p : ndarray, shape (..., 2)
        Points [m].
    poly : ndarray, shape (k, 2)
        Corners of the polygon [m] (not repeated at the end).

    Returns
    -------
    ndarray of bool, shape (...)
        True inside.
    """
    inside = np.zeros(p.shape[:-1], dtype=bool)
    x, y = p[..., 0], p[..., 1]
    for (x1, y1), (x2, y2) in zip(poly, np.roll(poly, -1, axis=0)):
        if y1 == y2:
            continue
        crosses = (y1 > y) != (y2 > y)
        xint = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (x < xint)
    return inside


def link_distances(joints: np.ndarray, obstacle: Obstacle) -> np.ndarray:
    """Distance [m] from every link to ``obstacle`` (0 when it touches, crosses or lies inside).

    Parameters
    ----------
    joints : (N, m+1, 2) array
        Link end points (``PlanarChain.joints_np``) [m].
    obstacle : Obstacle
        A segment, circle or polygon.

    Returns
    -------
    (N, m) array
        Column j-1 is link j.
    """
    joints = np.asarray(joints, dtype=float)
    a, b = joints[:, :-1], joints[:, 1:]
    if obstacle.kind == "circle":
        return np.maximum(point_segment_distance(obstacle.points[0], a, b) - obstacle.radius, 0.0)
    found = edge_distances(joints, edges(obstacle), obstacle.points if obstacle.kind == "polygon" else None)
    if found is not None:                        # in C, the same numbers
        return found
    d = nearest_edge_distances(a, b, edges(obstacle))
    if obstacle.kind == "polygon":
        d = np.where(inside_polygon(a, obstacle.points), 0.0, d)
    return d


def nearest_edge_distances(a: np.ndarray, b: np.ndarray, edge: np.ndarray) -> np.ndarray:
    """Distance [m] from every segment ``ab`` to the nearest of the segments ``edge``.

    The same numbers as the minimum of :func:`segment_distance` over every edge, computed for
    few pairs: a link's distance to an edge is at least the gap between their bounding boxes,
    so each link first takes the edge whose box is nearest (an exact distance ``d0``), then
    only the edges whose boxes are nearer than ``d0`` are measured.

    Parameters
    ----------
    a, b : (..., 2) arrays
        Segment ends [m].
    edge : (E, 2, 2) array
        The edges' ends [m].

    Returns
    -------
    (...) array
        The distances [m] (0 where a segment touches or crosses an edge).
    """
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    elo, ehi = np.minimum(edge[:, 0], edge[:, 1]), np.maximum(edge[:, 0], edge[:, 1])
    shape = (len(edge),) + (1,) * (a.ndim - 1)
    bound = 0.0                                  # squared gaps between the boxes, (E, ...)
    for k in (0, 1):
        g = np.maximum(np.maximum(elo[:, k].reshape(shape) - hi[..., k], lo[..., k] - ehi[:, k].reshape(shape)), 0.0)
        bound = bound + g * g
    first = np.argmin(bound, axis=0)
    d = segment_distance(a, b, edge[first, 0], edge[first, 1])
    # an edge is skipped only when its box is farther than d by a margin far above rounding
    e, *rest = np.nonzero(bound <= (d * d)[None] * (1 + 1e-9))
    if len(e):
        idx = tuple(rest)
        np.minimum.at(d, idx, segment_distance(a[idx], b[idx], edge[e, 0], edge[e, 1]))
    return d
