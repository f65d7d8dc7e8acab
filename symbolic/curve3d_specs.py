"""Spatial curves from data: the ``kind`` tables of a 3-D ``[curve]`` and :func:`curve3d_from_spec`.

``{"kind": "line", "point": [0, 0, 0], "direction": [1, 0, 0], "normal": [0, 1, 0],
"rotation": {"axis": [0, 0, 1], "angle": MOTION}}``, ``{"kind": "arc" | "circle", "centre": [...],
"radius": R, "normal": [...]}``, ``{"kind": "path", "start", "direction", "normal", "segments"}``
and ``{"kind": "waypoints", "points", "radius"}`` map to the curves of :mod:`.curves3d` and
:mod:`.paths3d`. Every point coordinate, radius and angle is a motion (:func:`~.motions.motion_from_spec`).
"""
from __future__ import annotations

from typing import Any

from .curves3d import Arc3D, Circle3D, Line3D, SpatialCurve
from .errors import ConfigError, shown
from .motions import motion_from_spec
from .paths3d import Path3D

#: 3-D curve kind -> (required keys, optional keys).
CURVE3D_KINDS = {
    "line": (("point", "direction", "normal"), ("rotation",)),
    "circle": (("centre", "radius", "normal"), ("reference",)),
    "arc": (("centre", "radius", "normal"), ("reference",)),
    "path": (("start", "direction", "normal", "segments"), ("transition",)),
    "waypoints": (("points", "radius"), ("normal", "transition")),
}


def check_keys(spec: dict, kind: str, field: str) -> None:
    """Refuse unknown and missing keys of a ``kind`` table.

    Parameters
    ----------
    spec : dict
        The table.
    kind : str
        A key of :data:`CURVE3D_KINDS`.
    field : str
        Name of the table in error messages.

    Raises
    ------
    ConfigError
        An unknown or a missing key.
    """
    required, optional = CURVE3D_KINDS[kind]
    unknown = set(spec) - set(required) - set(optional) - {"kind"}
    if unknown:
        raise ConfigError(f"{field}: unknown key(s) {sorted(unknown)} for kind {kind!r}; "
                          f"allowed: {list(required + optional)}")
    for key in required:
        if key not in spec:
            raise ConfigError(f"{field}.{key}: missing (kind {kind!r} needs {list(required)})")


def motion_point(value: Any, field: str) -> tuple:
    """Three motions from a ``[x, y, z]`` list.

    Parameters
    ----------
    value : list
        Three motion specs (numbers or motion tables) [m].
    field : str
        Name of the point in error messages.

    Returns
    -------
    tuple of 3 motions
        ``x(t)``, ``y(t)``, ``z(t)``.

    Raises
    ------
    ConfigError
        Not a list of three motions.
    """
    if not isinstance(value, list) or len(value) != 3:
        raise ConfigError(f"{field}: expected three coordinates [x, y, z], got {shown(value)}")
    return tuple(motion_from_spec(c, f"{field}[{i}]") for i, c in enumerate(value))


def line_rotation(value: Any, field: str) -> tuple:
    """``{axis = [x, y, z], angle = MOTION}`` as ``(axis, angle motion)``.

    Parameters
    ----------
    value : dict
        The rotation table: a constant axis and an angle motion [rad].
    field : str
        Name of the table in error messages.

    Returns
    -------
    tuple
        ``(axis, angle)`` for :class:`~.curves3d.Line3D`.

    Raises
    ------
    ConfigError
        Not a table with exactly ``axis`` and ``angle``.
    """
    if not isinstance(value, dict) or set(value) != {"axis", "angle"}:
        raise ConfigError(f"{field}: expected {{axis = [x, y, z], angle = MOTION}}, got {shown(value)}")
    return value["axis"], motion_from_spec(value["angle"], f"{field}.angle")


def build(kind: str, spec: dict, field: str) -> SpatialCurve:
    """The curve of a checked ``kind`` table (see :func:`curve3d_from_spec`).

    Parameters
    ----------
    kind : str
        A key of :data:`CURVE3D_KINDS`.
    spec : dict
        The table, keys checked.
    field : str
        Name of the table in error messages.

    Returns
    -------
    SpatialCurve
        The curve.
    """
    if kind == "line":
        rotation = line_rotation(spec["rotation"], f"{field}.rotation") if "rotation" in spec else None
        return Line3D(motion_point(spec["point"], f"{field}.point"), spec["direction"], spec["normal"], rotation)
    if kind in ("circle", "arc"):
        cls = Circle3D if kind == "circle" else Arc3D
        return cls(motion_point(spec["centre"], f"{field}.centre"),
                   motion_from_spec(spec["radius"], f"{field}.radius"), spec["normal"], spec.get("reference"))
    if kind == "path":
        return Path3D(spec["start"], spec["direction"], spec["normal"], spec["segments"], spec.get("transition"))
    return Path3D.from_waypoints(spec["points"], spec["radius"], spec.get("normal"), spec.get("transition"))


def curve3d_from_spec(spec: Any, field: str = "curve") -> SpatialCurve:
    """Build a 3-D curve from data, e.g. ``{"kind": "line", "point": [0, 0, 0], "direction": [1, 0, 0], ...}``.

    Parameters
    ----------
    spec : dict
        ``kind`` (``line``, ``circle``, ``arc``, ``path``, ``waypoints``) and that kind's keys
        (:data:`CURVE3D_KINDS`): ``point``/``centre``/``start``/``points`` [m] (points and centres
        as three motions each), ``direction``, ``normal``, ``rotation = {axis, angle}``, ``radius``
        [m] (a motion for circles and arcs), ``segments`` (``{line = L}``,
        ``{arc = A, radius = R, bank = beta}``), ``transition`` [m] (paths and waypoints: the clothoid
        transitions' length, :mod:`.transitions3d`).
    field : str
        Name of the table in error messages.

    Returns
    -------
    SpatialCurve
        A :class:`~.curves3d.Line3D`, :class:`~.curves3d.Circle3D`, :class:`~.curves3d.Arc3D` or
        :class:`~.paths3d.Path3D`.

    Raises
    ------
    ConfigError
        Not a table, an unknown kind or key, a missing or bad value (named with ``field``).
    """
    if not isinstance(spec, dict):
        raise ConfigError(f"{field}: expected a table, got {shown(spec)}")
    kind = spec.get("kind")
    if not isinstance(kind, str) or kind not in CURVE3D_KINDS:
        raise ConfigError(f"{field}.kind: expected one of {list(CURVE3D_KINDS)}, got {shown(kind)}")
    check_keys(spec, kind, field)
    try:
        return build(kind, spec, field)
    except ConfigError as exc:
        msg = str(exc)
        raise ConfigError(msg.replace("curve.", f"{field}.", 1) if field != "curve" else msg) from None
