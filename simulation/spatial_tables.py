"""The keys of a scenario file that belong to one kind of joint: checked once, each error naming its field.

``[chain] joints = "universal"`` makes a spatial chain (:class:`~coordarm.symbolic.SpatialChain`):
its ``[curve]`` is 3-D (:func:`~coordarm.symbolic.curve3d_specs.curve3d_from_spec`), ``[control]``
may command a ``roll`` and ``[start]`` takes ``axis``, ``fold`` and ``roll``; its rail (``[chain] base =
{kind = "rail", direction = [x, y, z], limits = [lo, hi]}``) has a 3-D direction and its ``[control] span``
is the planar one. A planar (``"revolute"``) scenario refuses those keys, and a spatial one the planar
options its law does not have (governor, damping, a projected start); its obstacles are 3-D
(:mod:`coordarm.simulation.obstacles3d`) and its links capsules of ``[chain] radius``.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from coordarm.symbolic import ConfigError, motion_from_spec
from coordarm.symbolic.checks import is_real
from coordarm.symbolic.chain import DEFAULT_JOINT_LIMIT
from coordarm.symbolic.errors import shown

from .run import check_number

if TYPE_CHECKING:   # the 3-D curves load when a universal chain's curve is read
    from coordarm.symbolic.curves3d import SpatialCurve

#: ``[chain] joints``: planar revolute joints, or two-axis (universal) joints of a spatial chain.
JOINTS = ("revolute", "universal")
#: The default bend limit [rad] of a universal joint (the angle between consecutive link directions):
#: the planar chain's default joint limit, so that a planar scenario stated in 3-D (beta = 1.3, bends of
#: 2.6 rad) starts as it does in the plane. The spatial presets set ``joint_limit = 1.4``.
BEND_LIMIT = DEFAULT_JOINT_LIMIT
#: ``[start] kind`` of a spatial chain.
SPATIAL_START_KINDS = ("zigzag", "follow")
#: Keys of a planar ``[curve]`` that a 3-D curve does not have.
PLANAR_CURVE_KEYS = ("angle", "center", "heading", "offset")
#: Keys of a 3-D ``[curve]`` that a planar curve does not have.
SPATIAL_CURVE_KEYS = ("direction", "normal", "centre")
#: Keys a spatial scenario refuses (its law has no such option yet), by section.
PLANAR_ONLY = {"control": ("governor", "damping"), "start": ("heading", "curve")}
#: Keys only a spatial scenario has, by section.
SPATIAL_ONLY = {"chain": ("radius",), "control": ("roll",), "start": ("axis", "fold", "roll")}
CURVE_HINT = ("line: point [x, y, z], direction, normal, rotation = {axis, angle}; arc/circle: centre, radius, "
              "normal; path: start, direction, normal, segments; waypoints: points, radius")


def check_joints(value: Any) -> str:
    """``[chain] joints`` as one of :data:`JOINTS`.

    Parameters
    ----------
    value : Any
        As written.

    Returns
    -------
    str
        ``"revolute"`` or ``"universal"``.

    Raises
    ------
    ConfigError
        Anything else.
    """
    if not isinstance(value, str) or value not in JOINTS:
        raise ConfigError(f"chain.joints: expected one of {list(JOINTS)}, got {shown(value)}")
    return value


def check_kind_keys(data: dict, joints: str) -> None:
    """Refuse the keys that belong to the other kind of joint (see the module docstring).

    Parameters
    ----------
    data : dict
        The scenario as written (before defaults are filled in).
    joints : str
        ``[chain] joints``.

    Raises
    ------
    ConfigError
        ``section.key: ...`` for the first key the chain does not have.
    """
    universal = joints == "universal"
    for sec, keys in (PLANAR_ONLY if universal else SPATIAL_ONLY).items():
        table = data.get(sec)
        for key in keys if isinstance(table, dict) else ():
            if key not in table:
                continue
            if key == "governor" and table[key] is False:
                continue
            if universal:
                raise ConfigError(f"{sec}.{key}: not available for a universal chain (chain.joints = "
                                  f"\"universal\") yet; leave it out")
            raise ConfigError(f"{sec}.{key}: only a universal chain (chain.joints = \"universal\") has it")


def check_curve_kind(spec: dict, joints: str) -> None:
    """Refuse a planar curve for a universal chain and a 3-D curve for a revolute one.

    Parameters
    ----------
    spec : dict
        ``[curve]`` as written.
    joints : str
        ``[chain] joints``.

    Raises
    ------
    ConfigError
        ``curve.key: ...`` naming the first key of the other kind.
    """
    if joints == "universal":
        planar = [k for k in PLANAR_CURVE_KEYS if k in spec]
        if spec.get("kind") in ("path", "waypoints") and "rotation" in spec:
            planar.append("rotation")
        if planar:
            raise ConfigError(f"curve.{planar[0]}: a planar curve key; a universal chain follows a 3-D curve "
                              f"({CURVE_HINT})")
        return
    spatial = [k for k in SPATIAL_CURVE_KEYS if k in spec]
    segments = spec.get("segments")
    if isinstance(segments, list) and any(isinstance(g, dict) and "bank" in g for g in segments):
        spatial.append("segments.bank")
    if spatial:
        raise ConfigError(f"curve.{spatial[0]}: a 3-D curve key; only a universal chain (chain.joints = "
                          f"\"universal\") follows a 3-D curve")


def spatial_curve(spec: dict, curve: Any) -> SpatialCurve | None:
    """``[curve]`` of a universal chain built (None for a user-defined curve, given as ``curve``).

    Parameters
    ----------
    spec : dict
        ``[curve]`` as written.
    curve : SpatialCurve or None
        The user-defined curve of a ``kind = "user-defined"`` table.

    Returns
    -------
    SpatialCurve or None
        The curve.

    Raises
    ------
    ConfigError
        A planar key, or an invalid 3-D curve (named), or a user-defined kind without its curve.
    """
    if spec.get("kind") == "user-defined":
        if not all(callable(getattr(curve, m, None)) for m in ("psi", "Phi", "frame")):
            raise ConfigError(f"curve: the run used a user-defined 3-D curve ({spec.get('class', '?')}), "
                              f"which data cannot describe: pass the curve object in (curve=...)")
        return None
    from coordarm.symbolic.curve3d_specs import curve3d_from_spec

    check_curve_kind(spec, "universal")
    return curve3d_from_spec(spec, "curve")


def spatial_start(st: dict) -> dict:
    """``[start]`` keys of a universal chain checked: ``kind``, ``axis``, ``fold`` (3-vectors), ``roll`` [rad].

    Parameters
    ----------
    st : dict
        ``[start]`` with defaults filled in.

    Returns
    -------
    dict
        ``axis``, ``fold`` and ``roll`` as written (None when left out).

    Raises
    ------
    ConfigError
        A projected start, a vector that is not three finite numbers, or a roll that is not finite.
    """
    if st["kind"] not in SPATIAL_START_KINDS:
        raise ConfigError(f"start.kind: a universal chain starts as one of {SPATIAL_START_KINDS}, "
                          f"got {shown(st['kind'])}")
    from coordarm.symbolic.spatial_chain import unit_vector     # here: a planar scenario does not load it

    for key in ("axis", "fold"):
        if key in st and not abs(np.linalg.norm(unit_vector(st[key], f"start.{key}")) - 1) < 1e-9:
            raise ConfigError(f"start.{key}: too large or too small to normalise, got {shown(st[key])}")
    if "roll" in st:
        check_number(st["roll"], "start.roll", positive=False)
    return {k: st.get(k) for k in ("axis", "fold", "roll")}


def roll_motion(control: dict) -> Any:
    """``[control] roll`` as a motion of time, or None (held at the start's roll).

    Parameters
    ----------
    control : dict
        ``[control]`` as written.

    Returns
    -------
    callable or None
        ``t -> theta*(t)`` [rad].

    Raises
    ------
    ConfigError
        Not a motion.
    """
    return motion_from_spec(control["roll"], "control.roll") if "roll" in control else None


def base_args(spec: Any, universal: bool = False) -> dict:
    """``[chain] base``: ``"fixed"`` or a rail table, as chain keyword arguments.

    A planar chain's rail is ``{kind = "rail", angle = 0.0, limits = [0.0, 5.0]}`` (:class:`PlanarChain`
    arguments ``rail_angle`` [rad], ``rail_limits`` [m]); a universal chain's is ``{kind = "rail",
    direction = [x, y, z], limits = [lo, hi]}`` (:class:`SpatialChain` arguments ``rail_direction``,
    normalised, and ``rail_limits`` [m]).

    Parameters
    ----------
    spec : str or dict
        The ``base`` entry as written.
    universal : bool
        The chain has universal joints (its rail has a 3-D ``direction``, not an ``angle``).

    Returns
    -------
    dict
        ``base`` and, on a rail, the rail's direction (``rail_angle`` or ``rail_direction``) and ``rail_limits``.

    Raises
    ------
    ConfigError
        Neither ``"fixed"`` nor a valid rail table.
    """
    if spec == "fixed":
        return {"base": "fixed"}
    aim = "direction" if universal else "angle"
    if not isinstance(spec, dict) or spec.get("kind") != "rail":
        raise ConfigError(f"chain.base: expected \"fixed\" or a table {{kind = \"rail\", {aim}, limits}}, got {spec!r}")
    unknown = set(spec) - {"kind", aim, "limits"}
    if unknown:
        raise ConfigError(f"chain.base: unknown key(s) {sorted(unknown)}; allowed: ['kind', '{aim}', 'limits']")
    limits = spec.get("limits", [-math.inf, math.inf])
    if (not isinstance(limits, list) or len(limits) != 2
            or not all(is_real(v) for v in limits)
            or not limits[0] < limits[1]):
        raise ConfigError(f"chain.base.limits: need [low, high] with low < high [m], got {limits!r}")
    lim = tuple(float(v) for v in limits)
    if universal:
        from coordarm.symbolic.spatial_chain import unit_vector

        direction = unit_vector(spec.get("direction", [1.0, 0.0, 0.0]), "chain.base.direction")
        return {"base": "rail", "rail_direction": tuple(float(v) for v in direction), "rail_limits": lim}
    angle = check_number(spec.get("angle", 0.0), "chain.base.angle", positive=False)
    return {"base": "rail", "rail_angle": angle, "rail_limits": lim}
