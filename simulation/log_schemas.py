"""Schemas of the run log: ``ros2msg`` texts for the numeric channels, ``foxglove.SceneUpdate`` JSON.

The numeric channels are CDR-encoded ROS 2 messages made only of ``float64`` fields and
fixed-size ``float64[n]`` arrays, so a message is a 4-byte encapsulation header
(``00 01 00 00``: little-endian CDR) followed by the raw little-endian doubles, with no
padding and no length prefixes. Foxglove plots every field; :mod:`analysis.replay` reads
them back with numpy.

The scene (``foxglove.SceneUpdate``) and the link frames (``foxglove.FrameTransforms``) are
JSON messages under the official Foxglove JSON Schemas, shipped unchanged in
``foxglove_schemas/`` (taken from the published ``@foxglove/schemas`` package, never retyped).
"""
from __future__ import annotations

import json
from typing import Any

from coordarm.symbolic.lazy import package_folder
from coordarm.symbolic.outputs import LAW_OUTPUTS, by_name, outputs_of, spatial_outputs_of
from coordarm.symbolic.records import record

from .log_layout import PLANAR, SPATIAL, ChainLayout

#: CDR encapsulation header: representation identifier CDR_LE (0x0001), options 0.
CDR_HEADER = b"\x00\x01\x00\x00"


@record(frozen=True)
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
    comment : str
        Comment lines heading the ``ros2msg`` definition (e.g. what ``q[0]`` is on a rail).
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

    #: Comment lines heading the ``ros2msg`` definition (e.g. what ``q[0]`` is on a rail).
    comment: str = ""

    def schema_text(self) -> str:
        """The ``ros2msg`` definition, one field per line (after the comment lines, if any).

        Returns
        -------
        str
            The definition text.
        """
        head = "".join(f"# {line}\n" for line in self.comment.splitlines())
        return head + "".join(f"float64{f'[{n}]' if n else ''} {name}\n" for name, n in self.fields)

    def fill(self, out: Any, run: Any, rows: Any) -> None:
        """Write the fields of ``run`` (a :class:`~simulation.run.Run`) at ``rows`` into ``out``, shape (n, width).

        Parameters
        ----------
        out : ndarray, shape (n, width)
            Destination, one message per row.
        run : Run
            A run with an array attribute per field.
        rows : slice or ndarray of int
            The ``n`` rows of the run to write.
        """
        for name, cols in self.slices().items():
            out[:, cols] = getattr(run, name)[rows]

    def slices(self) -> dict[str, slice | int]:
        """Column of each field in the decoded ``(N, width)`` array (an int for scalars).

        Returns
        -------
        dict of str to slice or int
            The columns by field name.
        """
        out, col = {}, 0
        for name, n in self.fields:
            out[name] = slice(col, col + n) if n else col
            col += max(n, 1)
        return out


#: Fields of the per-step channels that are not law outputs (time, state, commanded speed), with their
#: width as ``(per_link, extra)``; channel -> leading fields in order. The law outputs that name a
#: channel in :data:`coordarm.symbolic.outputs.LAW_OUTPUTS` follow, in the table's order, unless
#: listed here (to keep the field order of existing logs). Each field is the Run array of that name.
RUN_FIELDS = {"t": (0, 1), "q": (1, 0), "v_star": (0, 1)}
CHANNEL_LAYOUT = {
    "joint_state": ("/joint_state", "coordarm_msgs/msg/JointState", ("t", "q", "u")),
    "task_state": ("/task_state", "coordarm_msgs/msg/TaskState", ("t", "s", "v_star", "e")),
    "margins": ("/margins", "coordarm_msgs/msg/Margins", ("t", "link_margins", "longitudinal")),
}

#: The comment of ``/margins/cond``: what ``cond`` is (the ``run`` metadata's ``cond`` entry says which).
COND_COMMENT = ("cond: condition number of the decoupling matrix C, as the run metadata's cond entry says:\n"
                "'1-norm (...)': ||C||_1 ||C^-1||_1, exact up to 256 joints, above an O(m) lower-bound estimate\n"
                "(planar default; coordarm.symbolic.cond_estimate); '2-norm exact': sigma_max / sigma_min (an SVD)")
#: The comment of ``/joint_state`` on a rail: ``q`` and ``u`` hold the rail joint first.
RAIL_COMMENT = ("q[0]: rail position d [m] (introduction axis); q[1..m]: revolute joints q_1..q_m [rad]\n"
                "u[0]: rail rate d_dot [m/s]; u[1..m]: revolute controls")

#: The per-step channels of a spatial chain (universal joints): the same topics and style, fields of
#: their own (``q``, ``u`` 2m wide, ``e`` 2(m-1) wide, the roll and its command, the spatial margins).
SPATIAL_RUN_FIELDS = {"t": (0, 1), "q": (2, 0), "v_star": (0, 1), "roll_star": (0, 1)}
SPATIAL_CHANNEL_LAYOUT = {
    "joint_state": ("/joint_state", "coordarm_msgs/msg/SpatialJointState", ("t", "q", "u")),
    "task_state": ("/task_state", "coordarm_msgs/msg/SpatialTaskState", ("t", "s", "v_star", "e", "roll", "roll_star")),
    "margins": ("/margins", "coordarm_msgs/msg/SpatialMargins", ("t", "link_margins", "end_margin", "joint_margins")),
}
#: The comment of a spatial ``/joint_state`` on a rail: ``q`` and ``u`` hold the rail joint first.
SPATIAL_RAIL_COMMENT = ("q = (d, a_1, b_1, ..., a_m, b_m): rail position d [m] (feed axis), then the joint angles [rad]\n"
                        "u = q' (d_dot [m/s] first) (B = I)")
#: The comments of the spatial channels: what the columns of the vectors are.
SPATIAL_COMMENTS = {
    "joint_state": "q = (a_1, b_1, ..., a_m, b_m) [rad]: R_j = R_{j-1} Rz(a_j) Ry(b_j)\nu = q' [rad/s] (B = I)",
    "task_state": "e = (e^2_1, e^2_2, e^3_1, ..., e^m_2) [m]: normal coordinates of the link centres 2..m\n"
                  "roll = atan2(n_2.d_1, n_1.d_1) [rad], roll_star its command [rad]",
    "margins": "link_margins: links 2..m; end_margin: the 2x2 end solve; joint_margins = |cos b_j|, joints 1..m",
}


def _field(name: str, m: int, rail: bool = False, layout: ChainLayout = PLANAR) -> tuple[str, int]:
    """``(name, length)`` of a channel field for ``m`` links (length 0 = a scalar)."""
    if layout is SPATIAL:
        if name in SPATIAL_RUN_FIELDS:
            per_link, extra = SPATIAL_RUN_FIELDS[name]
            extra += int(rail and name == "q")              # d first on a rail
            return name, 0 if (per_link, extra) == (0, 1) else per_link * m + extra
        out = next(o for o in spatial_outputs_of(rail) if o.name == name)
        return name, 0 if out.scalar else out.width(m)
    if name in RUN_FIELDS:
        per_link, extra = RUN_FIELDS[name]
        extra += int(rail and name == "q")                  # d first on a rail
        return name, 0 if (per_link, extra) == (0, 1) else per_link * m + extra
    out = next(o for o in outputs_of(True) if o.name == name) if rail else by_name(name)
    return name, 0 if out.scalar else out.width(m)


#: The fields of a planar run's ``/tracking`` record (all float64 scalars, in order).
TRACKING_FIELDS = (("t", 0), ("s", 0), ("s_target", 0), ("target_x", 0), ("target_y", 0),
                   ("max_abs_e", 0), ("min_link_margin", 0), ("norm_u", 0),
                   ("log10_max_abs_e", 0), ("s_error", 0), ("log10_abs_s_error", 0))
#: The fields of a spatial run's ``/tracking`` record: the planar ones with the target's ``z`` after its
#: ``y``, then the roll and its command [rad].
SPATIAL_TRACKING_FIELDS = (("t", 0), ("s", 0), ("s_target", 0), ("target_x", 0), ("target_y", 0), ("target_z", 0),
                           ("max_abs_e", 0), ("min_link_margin", 0), ("norm_u", 0), ("roll", 0), ("roll_target", 0),
                           ("log10_max_abs_e", 0), ("s_error", 0), ("log10_abs_s_error", 0))


#: Unit and meaning of the fields that are not law outputs (those carry their own, in
#: :data:`coordarm.symbolic.outputs.LAW_OUTPUTS` and the spatial layout's outputs).
FIELD_NOTES = {
    "t": ("s", "simulated time"),
    "q": ("rad", "joint angles (d [m] first on a rail)"),
    "v_star": ("m/s", "commanded speed v* of the end point along the curve"),
    "roll_star": ("rad", "commanded roll"),
    "cond": ("-", "2-norm condition number of the decoupling matrix (or the log's estimate of it)"),
    "s_target": ("m", "target arc length s(0) + integral of v*"),
    "target_x": ("m", "target point on the curve, x"),
    "target_y": ("m", "target point on the curve, y"),
    "target_z": ("m", "target point on the curve, z"),
    "max_abs_e": ("m", "largest deviation max_j |e_j|"),
    "min_link_margin": ("-", "smallest link margin (0: singular)"),
    "norm_u": ("rad/s", "Euclidean norm of u"),
    "roll": ("rad", "roll of the first link about the curve"),
    "roll_target": ("rad", "commanded roll"),
    "log10_max_abs_e": ("log10 m", "log10 of max|e| (floored at 1e-18 m): plots read at every scale"),
    "s_error": ("m", "s - s_target"),
    "log10_abs_s_error": ("log10 m", "log10 of |s - s_target| (floored at 1e-18 m)"),
}


def field_notes(fields: tuple[tuple[str, int], ...], rail: bool = False, layout: ChainLayout = PLANAR) -> str:
    """One comment line per field, ``name [unit]: meaning``, for the head of a ``ros2msg`` definition.

    Parameters
    ----------
    fields : tuple of (str, int)
        The channel's fields.
    rail, layout : optional
        The chain's kind (which outputs table describes the law's fields).

    Returns
    -------
    str
        The lines, joined by newlines (fields with no note are left out).
    """
    rows = outputs_of(True) if rail else layout.outputs if layout is SPATIAL else LAW_OUTPUTS
    outputs = {o.name: (o.unit, o.description) for o in rows}
    if "s_target" in dict(fields):   # /tracking: its s is the channels' s
        outputs.setdefault("s", ("m", "arc length of the end point along the curve"))
    lines = []
    for name, _ in fields:
        unit, meaning = FIELD_NOTES.get(name) or outputs.get(name) or (None, None)
        if unit is not None:
            lines.append(f"{name} [{unit}]: {meaning}")
    return "\n".join(lines)


def numeric_channels(links: int, rail: bool = False, layout: ChainLayout = PLANAR) -> dict[str, NumericChannel]:
    """The per-step channels and the condition-number channel for a chain of ``links`` links.

    Keys are short names (``joint_state``, ``task_state``, ``margins``, ``cond``, ``tracking``);
    every per-step field is named after its :class:`~coordarm.simulation.run.Run` array.
    ``/tracking`` (at the scene rate, for the Foxglove layout's plots) holds the end point's arc
    length ``s``, its target ``s_target = s(0) + integral of v*`` [m], the target point on the
    curve [m], ``max|e|`` [m], the smallest link margin and the Euclidean norm of ``u``. On a
    ``rail`` ``q``, ``u`` hold ``d``, ``d_dot`` first (m+1 entries, said in the schema's comment),
    ``/task_state`` adds the span ``sigma`` and ``/margins`` the ``rail_margin``. A spatial chain
    (``layout`` :data:`~.log_layout.SPATIAL`) has the per-step channels of
    :data:`SPATIAL_CHANNEL_LAYOUT` (``q``, ``u`` of 2m, ``e`` of 2(m-1), ``roll``, ``roll_star``,
    ``end_margin``, ``joint_margins``).

    Parameters
    ----------
    links : int
        Number of links m.
    rail : bool
        The chain's base moves on a rail.
    layout : ChainLayout, optional
        The chain kind's layout (default planar).

    Returns
    -------
    dict of str to NumericChannel
        The channels by short name.
    """
    m = links
    out = {}
    spatial = layout is SPATIAL
    for key, (topic, schema, lead) in (SPATIAL_CHANNEL_LAYOUT if spatial else CHANNEL_LAYOUT).items():
        rows = spatial_outputs_of(rail) if spatial else outputs_of(True) if rail else LAW_OUTPUTS
        names = list(lead) + [o.name for o in rows if o.channel == key and o.name not in lead]
        comment = (SPATIAL_RAIL_COMMENT if spatial and rail and key == "joint_state" else SPATIAL_COMMENTS[key]
                   if spatial else RAIL_COMMENT if rail and key == "joint_state" else "")
        fields = tuple(_field(n, m, rail, layout) for n in names)
        out[key] = NumericChannel(topic, schema, fields, _joined(comment, field_notes(fields, rail, layout)))
    cond = (("t", 0), ("cond", 0))
    out["cond"] = NumericChannel("/margins/cond", "coordarm_msgs/msg/Conditioning", cond,
                                 _joined(COND_COMMENT, field_notes(cond)))
    tracking = SPATIAL_TRACKING_FIELDS if spatial else TRACKING_FIELDS
    out["tracking"] = NumericChannel("/tracking", "coordarm_msgs/msg/Tracking", tracking,
                                     field_notes(tracking, rail, layout))
    return out


def _joined(*parts: str) -> str:
    """The non-empty ``parts`` joined by newlines."""
    return "\n".join(p for p in parts if p)


#: Former field names, as found in older logs (old name -> name).
LEGACY_FIELDS = {"link": "link_margins"}


def fields_from_schema(text: str) -> tuple[tuple[str, int], ...]:
    """The fields of a stored ``ros2msg`` schema of a numeric channel, former names renamed.

    Parameters
    ----------
    text : str
        The schema as :meth:`NumericChannel.schema_text` writes it (``float64[n] name`` lines,
        ``#`` comment lines skipped).

    Returns
    -------
    tuple of (str, int)
        ``(name, length)`` per field, 0 for a scalar (see :class:`NumericChannel`).

    Raises
    ------
    ValueError
        A line that is not a ``float64`` field.
    """
    out = []
    for line in text.splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        kind, _, name = line.strip().partition(" ")
        if kind == "float64":
            n = 0
        elif kind.startswith("float64[") and kind.endswith("]") and kind[8:-1].isdigit():
            n = int(kind[8:-1])
        else:
            raise ValueError(f"not a float64 field: {line!r}")
        out.append((LEGACY_FIELDS.get(name.strip(), name.strip()), n))
    return tuple(out)


#: Channels written at every logged step; a sample is complete when all of them are present.
PER_STEP = ("joint_state", "task_state", "margins")

#: Foxglove channels: topic, official schema name (JSON Schema shipped in ``foxglove_schemas/``).
SCENE_TOPIC, SCENE_SCHEMA_NAME = "/scene", "foxglove.SceneUpdate"
#: What does not move (the obstacles, the rail): one ``foxglove.SceneUpdate`` at the first scene's time (a
#: viewer shows the latest message of each topic after a seek; the live view sends it again to a new subscriber).
FIXED_TOPIC = "/scene/fixed"
TF_TOPIC, TF_SCHEMA_NAME = "/tf", "foxglove.FrameTransforms"
FOXGLOVE_CHANNELS = {"scene": (SCENE_TOPIC, SCENE_SCHEMA_NAME), "fixed": (FIXED_TOPIC, SCENE_SCHEMA_NAME),
                     "tf": (TF_TOPIC, TF_SCHEMA_NAME)}


def foxglove_schema_bytes(name: str) -> bytes:
    """The official JSON Schema of the Foxglove message ``name`` (e.g. ``foxglove.SceneUpdate``), as stored.

    The files are the ones the published ``@foxglove/schemas`` package defines (version in
    ``foxglove_schemas/VERSION``), extracted verbatim by ``foxglove_schemas/update.sh``.

    Parameters
    ----------
    name : str
        The message type, e.g. ``foxglove.SceneUpdate``.

    Returns
    -------
    bytes
        The schema file's content.

    Raises
    ------
    FileNotFoundError
        No schema of that name ships with coordarm.
    """
    return (package_folder(__package__, "foxglove_schemas") / f"{name}.json").read_bytes()


def foxglove_schema(name: str) -> dict:
    """:func:`foxglove_schema_bytes` parsed.

    Parameters
    ----------
    name : str
        The message type, e.g. ``foxglove.SceneUpdate``.

    Returns
    -------
    dict
        The JSON Schema.

    Raises
    ------
    FileNotFoundError
        No schema of that name ships with coordarm.
    """
    return json.loads(foxglove_schema_bytes(name))
