"""Obstacles of a spatial scenario: plates with holes, spheres, cylinders (capsules) and boxes, with names.

In a scenario file with ``[chain] joints = "universal"`` (one ``[[obstacles]]`` table each;
``name`` optional, default ``"<kind> <i>"`` counted from 1 in file order)::

    [[obstacles]]
    name = "casing"
    kind = "plate"               # a slab about its mid-plane
    point = [1.0, 0.0, 0.0]      # a point of the mid-plane [m]
    normal = [1.0, 0.0, 0.0]
    thickness = 0.02             # [m]
    extent = 1.0                 # optional half-size of a square plate in its plane; default unbounded
    holes = [ { centre = [1.0, 0.0, 0.2], radius = 0.08 } ]   # or { centre, size = [w, h] } (rectangle)
    [[obstacles]]
    kind = "sphere"              # centre, radius
    [[obstacles]]
    kind = "cylinder"            # a, b (axis ends), radius; caps = "round" (a capsule, the only kind)
    [[obstacles]]
    kind = "box"                 # centre, size = [x, y, z] full edges, rotation = { axis, angle } optional

The plate's in-plane axes: ``v`` is ``e_z`` projected onto the plate (``e_y`` for a horizontal
plate), ``u = v x n``; a rectangle's ``size = [w, h]`` and the square's extent are along ``u, v``.
Holes must lie in the slab, inside the square and apart from each other.
:func:`capsule_gaps` is the one distance (links as capsules of a radius).
"""
from __future__ import annotations

import math
from dataclasses import field
from typing import Any

import numpy as np

from coordarm.symbolic import ConfigError
from coordarm.symbolic.errors import shown
from coordarm.symbolic.records import record
from coordarm.symbolic.spatial_chain import rotate_about, unit_vector

from .distance3d import point_segment_distance3, segment_box_distance, segment_plate_distance, segment_segment_distance
from .run import check_number

#: Obstacle kinds, their required and optional keys (besides ``name`` and ``kind``).
KINDS3D = {"plate": (("point", "normal", "thickness"), ("extent", "holes")),
           "sphere": (("centre", "radius"), ()),
           "cylinder": (("a", "b", "radius"), ("caps",)),
           "box": (("centre", "size"), ("rotation",))}


@record(frozen=True, eq=False)
class Obstacle3D:
    """One obstacle in space.

    Attributes
    ----------
    kind : str
        ``"plate"``, ``"sphere"``, ``"cylinder"`` or ``"box"``.
    name : str
        Shown in messages, figures and the outcome.
    spec : dict
        The table as written (with ``name`` and ``kind``).
    centre : ndarray, shape (3,)
        Sphere or box centre, the plate's point, or the cylinder's end ``a`` [m].
    axes : ndarray, shape (3, 3)
        Box edge directions (rows), the plate's ``u, v, n``; identity otherwise.
    half : ndarray, shape (3,)
        Box half edges, the plate's ``(extent, extent, thickness / 2)`` [m].
    radius : float
        Sphere or cylinder radius [m] (0 otherwise).
    end : ndarray, shape (3,)
        The cylinder's end ``b`` [m] (the centre otherwise).
    holes : tuple
        The plate's holes ``(kind, cu, cv, p, q)`` in its frame: circles ``(cu, cv, radius, 0)``,
        rectangles ``(cu, cv, w / 2, h / 2)`` [m].
    """

    kind: str
    name: str
    spec: dict
    centre: np.ndarray
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))
    half: np.ndarray = field(default_factory=lambda: np.zeros(3))
    radius: float = 0.0
    end: np.ndarray | None = None
    holes: tuple = ()

    @property
    def extent(self) -> float:
        """Half-size of a square plate in its plane [m] (``inf``: unbounded)."""
        return float(self.half[0])

    def to_spec(self) -> dict:
        """The obstacle as scenario data (the table as written).

        Returns
        -------
        dict
            A copy of :attr:`spec`.
        """
        return dict(self.spec)


def _point(value: Any, field: str) -> np.ndarray:
    if not isinstance(value, list) or len(value) != 3:
        raise ConfigError(f"{field}: expected [x, y, z], got {shown(value)}")
    return np.array([check_number(v, f"{field}[{i}]", positive=False) for i, v in enumerate(value)])


def plate_axes(normal: np.ndarray) -> np.ndarray:
    """The plate's frame rows ``u, v, n``: ``v`` = ``e_z`` projected onto the plate (``e_y`` if horizontal), ``u = v x n``.

    Parameters
    ----------
    normal : ndarray, shape (3,)
        Unit normal.

    Returns
    -------
    ndarray, shape (3, 3)
        Orthonormal rows ``u, v, n``.
    """
    up = np.array([0.0, 0.0, 1.0]) - normal[2] * normal
    if np.linalg.norm(up) < 1e-9:
        up = np.array([0.0, 1.0, 0.0]) - normal[1] * normal
    v = up / np.linalg.norm(up)
    return np.array([np.cross(v, normal), v, normal])


def _hole(spec: Any, field: str, plate: tuple[np.ndarray, np.ndarray, float, float]) -> tuple:
    point, axes, ht, ext = plate
    if not isinstance(spec, dict) or "centre" not in spec or set(spec) not in ({"centre", "radius"}, {"centre", "size"}):
        raise ConfigError(f"{field}: expected {{centre = [x, y, z], radius = r}} or {{centre = [x, y, z], "
                          f"size = [w, h]}}, got {shown(spec)}")
    local = (_point(spec["centre"], f"{field}.centre") - point) @ axes.T
    if abs(local[2]) > ht + 1e-9:
        raise ConfigError(f"{field}.centre: {abs(local[2]):.4g} m off the plate's mid-plane (half thickness {ht:g} m)")
    if "radius" in spec:
        p = q = check_number(spec["radius"], f"{field}.radius")
        hole = ("circle", float(local[0]), float(local[1]), p, 0.0)
    else:
        size = spec["size"]
        if not isinstance(size, list) or len(size) != 2:
            raise ConfigError(f"{field}.size: expected [w, h], got {shown(size)}")
        p, q = (0.5 * check_number(s, f"{field}.size[{i}]") for i, s in enumerate(size))
        hole = ("rectangle", float(local[0]), float(local[1]), p, q)
    if not (abs(hole[1]) + p < ext and abs(hole[2]) + q < ext):
        raise ConfigError(f"{field}: the hole reaches beyond the plate's extent {ext:g} m")
    return hole


def _apart(h1: tuple, h2: tuple) -> bool:
    """Whether two holes (plate frame) are disjoint."""
    if h1[0] == "rectangle" and h2[0] == "rectangle":
        return abs(h1[1] - h2[1]) > h1[3] + h2[3] or abs(h1[2] - h2[2]) > h1[4] + h2[4]
    if h1[0] == "rectangle":
        h1, h2 = h2, h1
    du, dv = abs(h1[1] - h2[1]), abs(h1[2] - h2[2])
    if h2[0] == "circle":
        return math.hypot(du, dv) > h1[3] + h2[3]
    return math.hypot(max(du - h2[3], 0.0), max(dv - h2[4], 0.0)) > h1[3]


def _plate(spec: dict, field: str) -> dict:
    point = _point(spec["point"], f"{field}.point")
    axes = plate_axes(unit_vector(spec["normal"], f"{field}.normal"))
    ht = 0.5 * check_number(spec["thickness"], f"{field}.thickness")
    ext = check_number(spec["extent"], f"{field}.extent") if "extent" in spec else math.inf
    holes = spec.get("holes", [])
    if not isinstance(holes, list):
        raise ConfigError(f"{field}.holes: expected an array of tables, got {shown(holes)}")
    hs = tuple(_hole(h, f"{field}.holes[{i}]", (point, axes, ht, ext)) for i, h in enumerate(holes))
    for i in range(len(hs)):
        for j in range(i):
            if not _apart(hs[i], hs[j]):
                raise ConfigError(f"{field}.holes[{i}]: overlaps holes[{j}]; holes must be apart")
    return dict(centre=point, axes=axes, half=np.array([ext, ext, ht]), holes=hs)


def _shape(kind: str, spec: dict, field: str) -> dict:
    """The geometry of one obstacle (keys of :class:`Obstacle3D`), each value checked."""
    if kind == "plate":
        return _plate(spec, field)
    if kind == "sphere":
        return dict(centre=_point(spec["centre"], f"{field}.centre"), radius=check_number(spec["radius"], f"{field}.radius"))
    if kind == "cylinder":
        if spec.get("caps", "round") != "round":
            raise ConfigError(f"{field}.caps: only \"round\" (a capsule) is available, got {shown(spec['caps'])}")
        a, b = _point(spec["a"], f"{field}.a"), _point(spec["b"], f"{field}.b")
        if not np.any(a != b):
            raise ConfigError(f"{field}: a and b are the same point")
        return dict(centre=a, end=b, radius=check_number(spec["radius"], f"{field}.radius"))
    size = spec["size"]
    if not isinstance(size, list) or len(size) != 3:
        raise ConfigError(f"{field}.size: expected [x, y, z] full edge lengths, got {shown(size)}")
    half = np.array([0.5 * check_number(s, f"{field}.size[{i}]") for i, s in enumerate(size)])
    axes = np.eye(3)
    rot = spec.get("rotation")
    if rot is not None:
        if not isinstance(rot, dict) or set(rot) != {"axis", "angle"}:
            raise ConfigError(f"{field}.rotation: expected {{axis = [x, y, z], angle = a}}, got {shown(rot)}")
        axis = unit_vector(rot["axis"], f"{field}.rotation.axis")
        angle = check_number(rot["angle"], f"{field}.rotation.angle", positive=False)
        axes = np.array([rotate_about(e, axis, angle) for e in np.eye(3)])
    return dict(centre=_point(spec["centre"], f"{field}.centre"), axes=axes, half=half)


def obstacle3d_from_spec(spec: Any, index: int) -> Obstacle3D:
    """Validate one ``[[obstacles]]`` table of a spatial scenario (``index`` 0-based).

    Parameters
    ----------
    spec : Any
        The table (keys: module docstring).
    index : int
        Its position in the array.

    Returns
    -------
    Obstacle3D
        The obstacle.

    Raises
    ------
    ConfigError
        ``obstacles[i].field: ...``: not a table, unknown kind, missing or unknown keys, a bad value.
    """
    field = f"obstacles[{index}]"
    if not isinstance(spec, dict):
        raise ConfigError(f"{field}: expected a table, got {shown(spec)}")
    kind = spec.get("kind")
    if kind not in KINDS3D:
        raise ConfigError(f"{field}.kind: expected one of {list(KINDS3D)}, got {shown(kind)}")
    name = spec.get("name", f"{kind} {index + 1}")
    if not isinstance(name, str) or not name:
        raise ConfigError(f"{field}.name: expected a non-empty string, got {shown(name)}")
    need, optional = KINDS3D[kind]
    missing = [k for k in need if k not in spec]
    if missing:
        raise ConfigError(f"{field}.{missing[0]}: missing (a {kind} has {list(need)}, optional {list(optional)})")
    unknown = sorted(set(spec) - set(need) - set(optional) - {"name", "kind"})
    if unknown:
        raise ConfigError(f"{field}.{unknown[0]}: unknown key for a {kind} (keys {list(need)}, optional {list(optional)})")
    return Obstacle3D(kind, name, dict(spec, name=name), **_shape(kind, spec, field))


def obstacles3d_from_spec(specs: Any) -> list[Obstacle3D]:
    """Validate the ``[[obstacles]]`` array of a spatial scenario; names must be unique.

    Parameters
    ----------
    specs : Any
        The array of tables.

    Returns
    -------
    list of Obstacle3D
        In order.

    Raises
    ------
    ConfigError
        Not an array, an invalid table (named), or repeated names.
    """
    if not isinstance(specs, list):
        raise ConfigError("obstacles: expected an array of tables [[obstacles]]")
    obs = [obstacle3d_from_spec(s, i) for i, s in enumerate(specs)]
    names = [o.name for o in obs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"obstacles: names must be unique, repeated: {dup}")
    return obs


def bounding_box(obstacle: Obstacle3D) -> tuple[np.ndarray, np.ndarray]:
    """The obstacle's axis-aligned bounding box: its lowest and highest corner [m].

    A sphere's centre -+ radius; a cylinder's ends -+ radius; a box's centre -+ the sum of its half edges
    along each axis; a square plate's centre -+ its half-size along ``u, v`` and half thickness along ``n``;
    an unbounded plate's box is infinite across its plane (an axis-aligned plate's thickness still bounds it).

    Parameters
    ----------
    obstacle : Obstacle3D
        The obstacle.

    Returns
    -------
    lo, hi : ndarray, shape (3,)
        The corners [m] (``-inf``/``inf`` where unbounded).
    """
    if obstacle.kind == "sphere":
        return obstacle.centre - obstacle.radius, obstacle.centre + obstacle.radius
    if obstacle.kind == "cylinder":
        ends = np.array([obstacle.centre, obstacle.end])
        return ends.min(axis=0) - obstacle.radius, ends.max(axis=0) + obstacle.radius
    with np.errstate(invalid="ignore"):      # an unbounded plate: inf * 0 along an axis it is flat on
        reach = np.nan_to_num(np.abs(obstacle.axes).T * obstacle.half, nan=0.0, posinf=np.inf).sum(axis=1)
    return obstacle.centre - reach, obstacle.centre + reach


def capsule_gaps(a: np.ndarray, b: np.ndarray, radius: float, obstacle: Obstacle3D,
                 within: float = math.inf) -> np.ndarray:
    """Gap [m] between capsules (axis ``ab``, ``radius``) and an obstacle: axis distance minus ``radius``.

    Parameters
    ----------
    a, b : ndarray, shape (..., 3)
        Capsule axis ends [m].
    radius : float
        Capsule radius [m].
    obstacle : Obstacle3D
        The obstacle.
    within : float
        Gaps above this need not be exact [m] (plates only: a lower bound above it is returned).

    Returns
    -------
    ndarray, shape (...)
        Gaps [m]; ``<= 0`` when the capsule touches or enters the obstacle.
    """
    if obstacle.kind == "sphere":
        d = point_segment_distance3(obstacle.centre, a, b) - obstacle.radius
    elif obstacle.kind == "cylinder":
        d = segment_segment_distance(a, b, obstacle.centre, obstacle.end) - obstacle.radius
    elif obstacle.kind == "box":
        d = segment_box_distance(a, b, obstacle.centre, obstacle.axes, obstacle.half)
    else:
        d = segment_plate_distance(a, b, obstacle, within + radius)
    return d - radius


#: Half-size [m] at which an unbounded plate is drawn (at least; or twice its holes' reach).
DRAWN_EXTENT = 0.5


def _circle(centre: np.ndarray, e1: np.ndarray, e2: np.ndarray, radius: float, n: int = 48) -> np.ndarray:
    a = np.linspace(0.0, 2 * math.pi, n + 1)[:, None]
    return centre + radius * (np.cos(a) * e1 + np.sin(a) * e2)


def _loop(centre: np.ndarray, e1: np.ndarray, e2: np.ndarray, h1: float, h2: float) -> np.ndarray:
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]], float)
    return centre + corners[:, :1] * h1 * e1 + corners[:, 1:] * h2 * e2


def wireframe(obstacle: Obstacle3D) -> list[np.ndarray]:
    """The obstacle drawn as 3-D polylines [m] (figures and the Foxglove scene).

    A sphere: three great circles; a cylinder: its end circles and four lines along it; a box:
    its twelve edges; a plate: its outline (an unbounded plate at :data:`DRAWN_EXTENT` or twice its
    holes' reach) and every hole's rim, on both faces.

    Parameters
    ----------
    obstacle : Obstacle3D
        The obstacle.

    Returns
    -------
    list of ndarray, each shape (k, 3)
        The polylines [m].
    """
    c, (e1, e2, e3) = obstacle.centre, obstacle.axes
    if obstacle.kind == "sphere":
        r = obstacle.radius
        return [_circle(c, e1, e2, r), _circle(c, e2, e3, r), _circle(c, e3, e1, r)]
    if obstacle.kind == "cylinder":
        axis = obstacle.end - c
        t = axis / np.linalg.norm(axis)
        u = np.cross(t, e1 if abs(t[0]) < 0.9 else e2)
        u /= np.linalg.norm(u)
        v, r = np.cross(t, u), obstacle.radius
        sides = [np.array([c + r * w, obstacle.end + r * w]) for w in (u, -u, v, -v)]
        return [_circle(c, u, v, r), _circle(obstacle.end, u, v, r)] + sides
    h = obstacle.half
    if obstacle.kind == "box":
        faces = [_loop(c + s * h[2] * e3, e1, e2, h[0], h[1]) for s in (-1, 1)]
        edges = [np.array([c + a * h[0] * e1 + b * h[1] * e2 - h[2] * e3, c + a * h[0] * e1 + b * h[1] * e2 + h[2] * e3])
                 for a in (-1, 1) for b in (-1, 1)]
        return faces + edges
    reach = max([abs(x[1]) + x[3] for x in obstacle.holes] + [abs(x[2]) + max(x[3], x[4]) for x in obstacle.holes]
                + [0.5 * DRAWN_EXTENT])
    ext = obstacle.extent if math.isfinite(obstacle.extent) else max(DRAWN_EXTENT, 2 * reach)
    out = []
    for s in (-1, 1):
        face = c + s * h[2] * e3
        out.append(_loop(face, e1, e2, ext, ext))
        for kind, cu, cv, p, q in obstacle.holes:
            centre = face + cu * e1 + cv * e2
            out.append(_circle(centre, e1, e2, p) if kind == "circle" else _loop(centre, e1, e2, p, q))
    return out


def densified(points: np.ndarray, n: int = 16) -> np.ndarray:
    """A polyline with ``n`` equal steps per segment (so that clipping to a box keeps what is inside).

    Parameters
    ----------
    points : ndarray, shape (k, 3)
        Vertices [m].
    n : int
        Steps per segment.

    Returns
    -------
    ndarray, shape ((k - 1) n + 1, 3)
        The same polyline [m].
    """
    s = np.linspace(0.0, 1.0, n + 1)[:-1, None]
    parts = [a + s * (b - a) for a, b in zip(points[:-1], points[1:])]
    return np.vstack(parts + [points[-1:]])
