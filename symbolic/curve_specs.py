"""Curves from data: the ``kind`` tables and :func:`curve_from_spec`.

Scenario files describe a curve as a table, ``{"kind": "line", "point": [0, 0], "angle": 0.3}``;
this module maps the kinds to the moving curves of :mod:`.curves` and the composite paths of
:mod:`.paths` (it imports both, :mod:`.paths` when a path is asked for; neither imports it).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .curves import Arc, Circle, Curve, Line
from .errors import ConfigError, shown
from .motions import motion_from_spec

if TYPE_CHECKING:
    from .paths import Path

#: Curve kind -> its class of :mod:`.curves` and that class's keys.
CURVES = {"line": (Line, ("point", "angle")), "circle": (Circle, ("center", "radius", "reference")),
          "arc": (Arc, ("point", "angle", "radius"))}

#: Curve kinds built by :func:`path_from_spec` (composite paths of :mod:`.paths`) and their keys.
PATH_KINDS = {"path": ("start", "heading", "segments", "offset", "rotation", "transition"),
              "waypoints": ("points", "radius", "offset", "rotation", "transition")}


def path_from_spec(spec: dict, field: str = "curve") -> Path:
    """A :class:`Path` from a ``kind = "path"`` or ``kind = "waypoints"`` table (see :func:`curve_from_spec`).

    Parameters
    ----------
    spec : dict
        ``kind`` (a key of :data:`PATH_KINDS`) and that kind's keys: ``start`` [m], ``heading``
        [rad] and ``segments``, or ``points`` [m] and the fillet ``radius`` [m]; optional
        ``offset`` (a pair of motions [m]), ``rotation`` (a motion [rad]) and ``transition``
        (the clothoid transitions' length [m], see :class:`~.paths.Path`).
    field : str
        Name of the table in error messages.

    Returns
    -------
    Path
        A new path.

    Raises
    ------
    ConfigError
        An unknown or missing key, or a bad value (named with ``field``).
    """
    from .paths import Path          # here: a scenario without a path does not load it (nor its pieces)

    kind = spec["kind"]
    keys = PATH_KINDS[kind]
    unknown = set(spec) - set(keys) - {"kind"}
    if unknown:
        raise ConfigError(f"{field}: unknown key(s) {sorted(unknown)} for kind {kind!r}; allowed: {list(keys)}")
    required = keys[:3] if kind == "path" else keys[:2]
    for k in required:
        if k not in spec:
            raise ConfigError(f"{field}.{k}: missing (kind {kind!r} needs {list(required)})")
    motion = {}
    if "offset" in spec:
        v = spec["offset"]
        if not isinstance(v, list) or len(v) != 2:
            raise ConfigError(f"{field}.offset: expected a pair [x, y] of motions, got {v!r}")
        motion["offset"] = tuple(motion_from_spec(c, f"{field}.offset[{i}]") for i, c in enumerate(v))
    if "rotation" in spec:
        motion["rotation"] = motion_from_spec(spec["rotation"], f"{field}.rotation")
    if "transition" in spec:
        motion["transition"] = spec["transition"]
    try:
        if kind == "waypoints":
            return Path.from_waypoints(spec["points"], spec["radius"], **motion)
        return Path(spec["start"], spec["heading"], spec["segments"], **motion)
    except ConfigError as exc:
        msg = str(exc)
        raise ConfigError(msg.replace("curve.", f"{field}.", 1) if field != "curve" else msg) from None


def curve_from_spec(spec: Any, field: str = "curve") -> Curve:
    """Build a curve from data, e.g. ``{"kind": "line", "point": [0, 0], "angle": 0.3}``.

    Kinds: ``line``, ``circle``, ``arc`` (moving curves of :mod:`symbolic.curves`) and
    ``path``, ``waypoints`` (composite paths of :mod:`symbolic.paths`).

    Parameters
    ----------
    spec : dict
        ``kind`` and that curve's parameters (numbers or motions; see the kinds' classes).
    field : str
        Name of the table in error messages.

    Returns
    -------
    Curve
        A new curve of the kind's class.

    Raises
    ------
    ConfigError
        Not a table, an unknown kind or key, a missing or bad parameter.
    """
    if not isinstance(spec, dict):
        raise ConfigError(f"{field}: expected a table, got {shown(spec)}")
    kind = spec.get("kind")
    if isinstance(kind, str) and kind in PATH_KINDS:
        return path_from_spec(spec, field)
    if not isinstance(kind, str) or kind not in CURVES:
        raise ConfigError(f"{field}.kind: expected one of {sorted(CURVES) + list(PATH_KINDS)}, got {shown(kind)}")
    cls, keys = CURVES[kind]
    unknown = set(spec) - set(keys) - {"kind"}
    if unknown:
        raise ConfigError(f"{field}: unknown key(s) {sorted(unknown)} for kind {shown(kind)}; allowed: {list(keys)}")
    args = {}
    for k, v in spec.items():
        if k == "kind":
            continue
        if k in ("point", "center"):
            if not isinstance(v, list) or len(v) != 2:
                raise ConfigError(f"{field}.{k}: expected a pair [x, y], got {shown(v)}")
            args[k] = tuple(motion_from_spec(c, f"{field}.{k}[{i}]") for i, c in enumerate(v))
        else:
            args[k] = motion_from_spec(v, f"{field}.{k}")
    try:
        return cls(**args)
    except TypeError as exc:            # a missing parameter
        raise ConfigError(f"{field}: {exc}".replace("__init__()", kind)) from None
