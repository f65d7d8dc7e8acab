"""Schemas of the run log: ``ros2msg`` texts for the numeric channels, ``foxglove.SceneUpdate`` JSON.

The numeric channels are CDR-encoded ROS 2 messages made only of ``float64`` fields and
fixed-size ``float64[n]`` arrays, so a message is a 4-byte encapsulation header
(``00 01 00 00``: little-endian CDR) followed by the raw little-endian doubles, with no
padding and no length prefixes. Foxglove plots every field; :mod:`analysis.replay` reads
them back with numpy.

The scene is a ``foxglove.SceneUpdate`` in JSON, whose schema (below) follows the official
Foxglove JSON Schema for the parts we use (entities with line primitives) and declares the
other primitive arrays, which we always leave empty.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

#: CDR encapsulation header: representation identifier CDR_LE (0x0001), options 0.
CDR_HEADER = b"\x00\x01\x00\x00"


@dataclass(frozen=True)
class NumericChannel:
    """A channel whose message is a flat record of ``float64`` fields.

    Attributes
    ----------
    topic : str
        Channel topic, e.g. ``/joint_state``.
    schema_name : str
        ROS 2 type name, e.g. ``coordarm_msgs/msg/JointState``.
    fields : tuple of (str, int)
        Field names with their lengths (0 = a scalar ``float64``).
    """

    topic: str
    schema_name: str
    fields: tuple[tuple[str, int], ...]

    @property
    def width(self) -> int:
        """Number of doubles in one message."""
        return sum(max(n, 1) for _, n in self.fields)

    @property
    def size(self) -> int:
        """Bytes of one encoded message (header included)."""
        return len(CDR_HEADER) + 8 * self.width

    def schema_text(self) -> str:
        """The ``ros2msg`` definition, one field per line."""
        return "".join(f"float64{f'[{n}]' if n else ''} {name}\n" for name, n in self.fields)

    def slices(self) -> dict[str, slice | int]:
        """Column of each field in the decoded ``(N, width)`` array (an int for scalars)."""
        out, col = {}, 0
        for name, n in self.fields:
            out[name] = slice(col, col + n) if n else col
            col += max(n, 1)
        return out


#: The :class:`~simulation.run.Run` array behind each field of the per-step channels.
SOURCES = {"t": "t", "q": "q", "u": "u", "s": "s", "v_star": "v_star", "v_scale": "v_scale", "e": "e",
           "link": "link_margins", "longitudinal": "longitudinal"}


def numeric_channels(links: int) -> dict[str, NumericChannel]:
    """The per-step channels and the condition-number channel for a chain of ``links`` links.

    Keys are short names (``joint_state``, ``task_state``, ``margins``, ``cond``).
    """
    m = links
    return {
        "joint_state": NumericChannel("/joint_state", "coordarm_msgs/msg/JointState",
                                      (("t", 0), ("q", m), ("u", m))),
        "task_state": NumericChannel("/task_state", "coordarm_msgs/msg/TaskState",
                                     (("t", 0), ("s", 0), ("v_star", 0), ("v_scale", 0), ("e", m - 1))),
        "margins": NumericChannel("/margins", "coordarm_msgs/msg/Margins",
                                  (("t", 0), ("link", m - 1), ("longitudinal", 0))),
        "cond": NumericChannel("/margins/cond", "coordarm_msgs/msg/Conditioning",
                               (("t", 0), ("cond", 0))),
    }


#: Channels written at every logged step; a sample is complete when all of them are present.
PER_STEP = ("joint_state", "task_state", "margins")

SCENE_TOPIC = "/scene"
SCENE_SCHEMA_NAME = "foxglove.SceneUpdate"


def _obj(title: str, description: str, props: dict, required: list[str] | None = None) -> dict:
    return {"title": title, "description": description, "type": "object", "properties": props,
            "required": list(props) if required is None else required}


def _num(description: str) -> dict:
    return {"type": "number", "description": description}


def _xyz(title: str, description: str, what: str) -> dict:
    return _obj(title, description, {a: _num(f"{a} coordinate {what}") for a in "xyz"})


def _color(description: str) -> dict:
    names = {"r": "Red", "g": "Green", "b": "Blue", "a": "Alpha"}
    return _obj("foxglove.Color", description,
                {k: _num(f"{v} value between 0 and 1") for k, v in names.items()})


def _pose(description: str) -> dict:
    quat = _obj("foxglove.Quaternion", "Quaternion denoting orientation in 3D space",
                {k: _num(f"{k} value") for k in "xyzw"})
    return _obj("foxglove.Pose", description,
                {"position": _xyz("foxglove.Vector3", "Point denoting position in 3D space", "length"),
                 "orientation": quat})


def _time(title: str, description: str, signed: bool) -> dict:
    sec = {"type": "integer"} if signed else {"type": "integer", "minimum": 0}
    return {"type": "object", "title": title, "description": description,
            "properties": {"sec": sec, "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}}


def _line_primitive() -> dict:
    line_type = {"title": "foxglove.LineType", "description": "Drawing primitive to use for lines",
                 "oneOf": [{"title": "LINE_STRIP", "const": 0, "description": "Connected line segments"},
                           {"title": "LINE_LOOP", "const": 1, "description": "Closed polygon"},
                           {"title": "LINE_LIST", "const": 2, "description": "Individual line segments"}]}
    return _obj("foxglove.LinePrimitive", "A primitive representing a series of points connected by lines", {
        "type": line_type,
        "pose": _pose("Origin of lines relative to reference frame"),
        "thickness": _num("Line thickness"),
        "scale_invariant": {"type": "boolean", "description": "Whether `thickness` is in screen pixels (true) "
                                                              "or world coordinates (false)"},
        "points": {"type": "array", "description": "Points along the line",
                   "items": _xyz("foxglove.Point3", "A point representing a position in 3D space", "position")},
        "color": _color("Solid color to use for the whole line. Ignored if `colors` is non-empty."),
        "colors": {"type": "array", "items": _color("A color in RGBA format"), "description": "Per-point colors"},
        "indices": {"type": "array", "items": {"type": "integer", "minimum": 0},
                    "description": "Indices into the `points` and `colors` attribute arrays"},
    })


def scene_update_schema() -> dict:
    """The ``foxglove.SceneUpdate`` JSON Schema (self-contained, after the official one)."""
    other = {name: {"type": "array", "description": f"{title} primitives (official foxglove.{title}Primitive)",
                    "items": {"type": "object"}}
             for name, title in (("arrows", "Arrow"), ("cubes", "Cube"), ("spheres", "Sphere"),
                                 ("cylinders", "Cylinder"), ("triangles", "TriangleList"),
                                 ("texts", "Text"), ("models", "Model"))}
    kv = _obj("foxglove.KeyValuePair", "A key with its associated value",
              {"key": {"type": "string", "description": "Key"}, "value": {"type": "string", "description": "Value"}})
    entity = _obj("foxglove.SceneEntity", "A visual element in a 3D scene", {
        "timestamp": _time("time", "Timestamp of the entity", signed=False),
        "frame_id": {"type": "string", "description": "Frame of reference"},
        "id": {"type": "string", "description": "Identifier for the entity"},
        "lifetime": _time("duration", "Time after which the entity is removed (0: never)", signed=True),
        "frame_locked": {"type": "boolean", "description": "Whether the entity follows its frame"},
        "metadata": {"type": "array", "items": kv, "description": "Additional user-provided metadata"},
        "lines": {"type": "array", "items": _line_primitive(), "description": "Line primitives"},
        **other,
    })
    deletion = _obj("foxglove.SceneEntityDeletion", "Command to remove previously published entities", {
        "timestamp": _time("time", "Only matching entities earlier than this are deleted", signed=False),
        "type": {"title": "foxglove.SceneEntityDeletionType", "description": "Type of deletion action",
                 "oneOf": [{"title": "MATCHING_ID", "const": 0}, {"title": "ALL", "const": 1}]},
        "id": {"type": "string", "description": "Identifier which must match if `type` is `MATCHING_ID`"},
    })
    return {"title": SCENE_SCHEMA_NAME, "description": "An update to the entities displayed in a 3D scene",
            "type": "object",
            "properties": {"deletions": {"type": "array", "items": deletion, "description": "Scene entities to delete"},
                           "entities": {"type": "array", "items": entity,
                                        "description": "Scene entities to add or replace"}},
            "required": ["deletions", "entities"]}


def scene_update_schema_bytes() -> bytes:
    """:func:`scene_update_schema` as UTF-8 JSON (the bytes stored in the MCAP schema record)."""
    return json.dumps(scene_update_schema(), separators=(",", ":")).encode()
