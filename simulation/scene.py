"""What Foxglove draws: the ``/scene`` and ``/scene/fixed`` (``foxglove.SceneUpdate``), ``/tf``
(``foxglove.FrameTransforms``) and ``/tracking`` messages of a run, built from blocks of its steps.

The scene, in frame ``world``: the chain as solid segments (a line list, 6 px wide at any zoom) coloured
by each link's margin (:func:`margin_colours`: blue at 0.5 or more, violet at 0.375, orange at 0.25, red
at 0; the first link, which has no margin, blue) with a dark sphere at every joint, the whole curve at its
current pose (a solid line, 3 px, a quarter link below the arm's plane), the end point's target (a red
sphere at the point of the curve whose arc length is ``s(0) + integral of v*``) and the carriage (a cube
at ``y^1``) on a rail robot. What does not move, the rail with its end stops and the obstacles (each drawn
from :func:`~.scene_fixed.obstacle_outlines`, 4 px), is one ``/scene/fixed`` message before the first scene
(:func:`~.scene_fixed.fixed_update`, entity ``fixed``). The frame transforms (built by :mod:`.frame_transforms`) give, by
default (``frames="ends"``), the frames ``base`` (at the pinned first central point ``y^1``, x along the
rail on a rail robot) and ``tip`` (at the free end of the last link, x along it), both parented to
``world``; with ``frames="all"`` a frame
``link1`` .. ``linkm`` per link (origin at the link's central point, x along the link), each parented to
the previous one and ``link1`` to ``world``, so that users can attach their own models to the links. The
messages follow the official Foxglove JSON Schemas shipped in ``foxglove_schemas/`` (see
:mod:`.log_schemas`).
"""
from __future__ import annotations

import math
from typing import Any, Sequence

import casadi as ca
import numpy as np

from coordarm.symbolic import CoordinatingController
from coordarm.symbolic.curves import Line
from coordarm.symbolic.function_buffer import BufferedFunction

from .s_reference import ArcReference
from .frame_transforms import end_frames_json, frame_transforms_json, stamp_slots, stamps
from .frame_transforms import link_frames  # noqa: F401 (re-exported: coordarm.simulation.scene.link_frames)
from .json_fill import JsonTemplate, digits_kernel
from .log_schemas import CDR_HEADER
from .scene_fixed import fixed_update, length_literal, obstacle_outlines, rail_lines
from .run import Run
from .tracking_record import tracking_records

#: A point in JSON, coordinates as integer micrometres with an exponent (exact to 1e-6 m, and
#: integers format about twice as fast as floats).
_POINT = '{"x":%de-6,"y":%de-6,"z":0}'
_POSE0 = '{"position":{"x":0,"y":0,"z":0},"orientation":{"x":0,"y":0,"z":0,"w":1}}'
ARM_COLOR, CURVE_COLOR, WALL_COLOR, TARGET_COLOR = ((0.15, 0.45, 0.9, 1.0), (0.9, 0.5, 0.1, 1.0),
                                                    (0.2, 0.2, 0.2, 1.0), (0.85, 0.1, 0.1, 1.0))
#: Colours of the joint markers, the rail and its carriage (r, g, b, a).
JOINT_COLOR, RAIL_COLOR, CARRIAGE_COLOR = (0.1, 0.1, 0.1, 1.0), (0.45, 0.45, 0.45, 1.0), (0.3, 0.3, 0.3, 0.9)
#: Widths [px, at any zoom] of the arm, the curve, the obstacles and the rail.
ARM_PX, CURVE_PX, WALL_PX, RAIL_PX = 6.0, 3.0, 4.0, 5.0
#: How far the curve is drawn below the arm's plane [link lengths]: the arm runs along the curve, and a
#: viewer draws the later of two lines at the same depth on top (the curve would hide the links' colours).
CURVE_DEPTH = 0.25
#: The link margin colour scale: margins (stops) and their colours (r, g, b); linear in between. The
#: violet stop keeps the colours saturated between orange and blue (a straight blend passes through grey,
#: which reads as "no colour" in a viewer).
MARGIN_STOPS = (0.0, 0.25, 0.375, 0.5)
MARGIN_COLOURS = ((0.85, 0.1, 0.1), (0.95, 0.6, 0.1), (0.6, 0.3, 0.8), ARM_COLOR[:3])
#: Which frames ``/tf`` carries: ``ends`` (world -> base, world -> tip) or ``all`` (a frame per link).
FRAME_SETS = ("ends", "all")


def margin_colours(margins: np.ndarray) -> np.ndarray:
    """The colour of each link from its margin: red at 0, orange at 0.25, violet at 0.375, blue at 0.5 or more.

    Parameters
    ----------
    margins : ndarray, shape (..., m-1)
        The link margins of links 2..m [-] (the first link has none: it is drawn blue).

    Returns
    -------
    ndarray, shape (..., m, 3)
        ``(r, g, b)`` in 0..1 per link.
    """
    x = _padded_margins(margins)
    return np.stack([np.interp(x, MARGIN_STOPS, _STOPS[:, c]) for c in range(3)], axis=-1)


_STOPS = np.array(MARGIN_COLOURS)     # (stop, r/g/b)


def _padded_margins(margins: np.ndarray) -> np.ndarray:
    """The margins (..., m-1) with the first link's (the top stop) first, non-finite ones 0: (..., m)."""
    x = np.asarray(margins, float)
    x = np.concatenate([np.full(x.shape[:-1] + (1,), MARGIN_STOPS[-1]), x], axis=-1)
    return np.where(np.isfinite(x), x, 0.0)


def head_columns(m: int, rail: bool) -> int:
    """How many integers of a ``/scene`` message of m links come before the curve's points.

    Parameters
    ----------
    m : int
        Number of links.
    rail : bool
        The chain is a rail robot (the carriage's centre adds two).

    Returns
    -------
    int
        Stamp (2), target (2), joints (2 (m + 1)), carriage (2 on a rail), the links' colours (3 m).
    """
    return 4 + 2 * (m + 1) + 2 * rail + 3 * m


def scene_numbers(values: np.ndarray, margins: np.ndarray, stamps: np.ndarray, joints: np.ndarray,
                  base: np.ndarray | None, targets: np.ndarray) -> np.ndarray:
    """Write the integers of k ``/scene`` messages before the curve's points into ``values``, in place.

    The columns of :meth:`SceneBuilder._scene_template`'s values: stamp, the target [pm], the joints [µm], the
    carriage (``base``, on a rail) [µm] and each link's colour (r, g, b) [1e-3], each rounded to the nearest
    integer (ties to even); the template shows a link's two ends and its colour at both ends from them.

    Parameters
    ----------
    values : int64 ndarray, shape (k, columns), columns >= :func:`head_columns`
        The destination (its first :func:`head_columns` columns are written).
    margins : ndarray, shape (k, m-1)
        Link margins of links 2..m [-] (colours: :func:`margin_colours`).
    stamps : int ndarray, shape (k, 2)
        ``(sec, nsec)`` of each message.
    joints : ndarray, shape (k, m+1, 2)
        Joint positions [m].
    base : ndarray, shape (k, 2), or None
        The carriage's centre [m] on a rail robot; None on a fixed base.
    targets : ndarray, shape (k, 2)
        The end point's target [m].

    Returns
    -------
    ndarray
        ``values``.
    """
    k, m = joints.shape[0], joints.shape[1] - 1
    values[:, :2] = stamps
    values[:, 2:4] = np.round(targets * 1e12)
    at = 4 + 2 * (m + 1)
    values[:, 4:at] = np.round(joints.reshape(k, -1) * 1e6)
    if base is not None:
        values[:, at:at + 2] = np.round(base * 1e6)
        at += 2
    colours = values[:, at:at + 3 * m].reshape(k, m, 3)      # a view of values' columns
    x = _padded_margins(margins)
    for c in range(3):
        colours[:, :, c] = np.round(np.interp(x, MARGIN_STOPS, _STOPS[:, c]) * 1e3)
    return values


def _line_parts(thickness: float, color: tuple[float, ...], kind: int = 0, pixels: bool = False,
                depth: float = 0.0) -> tuple[str, str]:
    """The text of a ``foxglove.LinePrimitive`` before and after its points (``pixels``: thickness in px;
    ``depth`` [m]: the line's pose lies that far below the plane z = 0)."""
    r, g, b, a = color
    pose = _POSE0 if depth == 0 else _POSE0.replace('"z":0}', f'"z":{-length_literal(depth)!r}}}', 1)
    return (f'{{"type":{kind},"pose":{pose},"thickness":{thickness},"scale_invariant":{str(pixels).lower()},'
            '"points":[', f'],"color":{{"r":{r},"g":{g},"b":{b},"a":{a}}},"colors":[],"indices":[]}}')


def line_json(points: np.ndarray, thickness: float, color: tuple[float, ...], kind: int = 0,
              pixels: bool = False) -> str:
    """A ``foxglove.LinePrimitive`` in JSON (``kind`` 0 = line strip; points formatted in one pass).

    Parameters
    ----------
    points : ndarray, shape (k, 2)
        The vertices [m] (written to 1e-6 m).
    thickness : float
        Line width [m] (not scale invariant).
    color : tuple of float
        ``(r, g, b, a)``, each in 0..1.
    kind : int
        ``LinePrimitive`` type: 0 line strip, 1 line loop, 2 line list.
    pixels : bool
        ``thickness`` is in pixels, the same at any zoom (``scale_invariant``), instead of metres.

    Returns
    -------
    str
        The JSON object.
    """
    xy = np.round(np.asarray(points, float).reshape(-1, 2) * 1e6).astype(np.int64)
    head, tail = _line_parts(thickness, color, kind, pixels)
    return head + ",".join([_POINT] * len(xy)) % tuple(xy.ravel().tolist()) + tail


def _point_slots(template: JsonTemplate, points: int, slot_kind: int,
                 columns: Sequence[tuple[int, int]] | None = None) -> None:
    """Append ``points`` comma-separated points whose coordinates [µm] are slots of ``slot_kind``: new columns
    of the values, or the ``(x, y)`` columns given for each point."""
    for i in range(points):
        x, y = columns[i] if columns is not None else (None, None)
        template.text("," if i else "").text('{"x":').number(slot_kind, x).text('e-6,"y":').number(slot_kind, y)
        template.text('e-6,"z":0}')


def _line_slots(template: JsonTemplate, points: int, thickness: float, color: tuple[float, ...],
                slot_kind: int, pixels: bool = True, depth: float = 0.0) -> None:
    """Append a line strip of ``points`` points whose coordinates [µm] are slots of ``slot_kind`` (``depth``
    [m] below the plane, as :func:`_line_parts`)."""
    head, tail = _line_parts(thickness, color, 0, pixels, depth)
    template.text(head)
    _point_slots(template, points, slot_kind)
    template.text(tail)


def _coloured_segments_slots(template: JsonTemplate, segments: int, thickness: float, point_kind: int,
                             colour_kind: int, first_point: int) -> None:
    """Append a line list of ``segments`` segments, segment j from point j to point j+1 of the points whose
    coordinates [µm] are the columns ``first_point``, ``first_point + 1``, ... (x, y per point; of
    ``point_kind``), with per-point colours [1e-3] of ``colour_kind``: new columns r, g, b per segment, shown
    at both its ends (alpha 1); ``thickness`` in px."""
    template.text(f'{{"type":2,"pose":{_POSE0},"thickness":{thickness},"scale_invariant":true,"points":[')
    ends = [(first_point + 2 * p, first_point + 2 * p + 1) for j in range(segments) for p in (j, j + 1)]
    _point_slots(template, 2 * segments, point_kind, ends)
    template.text('],"color":{"r":0,"g":0,"b":0,"a":1},"colors":[')
    for i in range(2 * segments):
        r = None if i % 2 == 0 else template.columns - 3      # the second end: the first end's columns
        template.text("," if i else "").text('{"r":').number(colour_kind, r)
        template.text('e-3,"g":').number(colour_kind, None if r is None else r + 1)
        template.text('e-3,"b":').number(colour_kind, None if r is None else r + 2).text('e-3,"a":1}')
    template.text('],"indices":[]}')


def _sphere(position: str, diameter: float, color: tuple[float, ...]) -> tuple[str, str]:
    """The text of a ``foxglove.SpherePrimitive`` before and after its position's ``x, y`` text."""
    r, g, b, a = color
    d = length_literal(diameter)
    return ('{"pose":{"position":', f',"orientation":{{"x":0,"y":0,"z":0,"w":1}}}},'
            f'"size":{{"x":{d},"y":{d},"z":{d}}},"color":{{"r":{r},"g":{g},"b":{b},"a":{a}}}}}')


def point_along(polyline: np.ndarray, start: np.ndarray, distance: float) -> np.ndarray:
    """The point ``distance`` [m] along ``polyline`` from the foot of ``start`` on it.

    Positive distances go towards the polyline's last point; a closed polyline (last point
    equal to the first) wraps around, an open one stops at its ends.

    Parameters
    ----------
    polyline : ndarray, shape (k, 2)
        The polyline [m], k >= 2.
    start : ndarray, shape (2,)
        A point [m]; the walk starts at its nearest point on the polyline.
    distance : float
        Signed distance along the polyline [m].

    Returns
    -------
    ndarray, shape (2,)
        The point [m].
    """
    p = np.asarray(polyline, float)
    a, b = p[:-1], p[1:]
    ab = b - a
    length = np.hypot(ab[:, 0], ab[:, 1])
    tpar = np.clip(np.einsum("ij,ij->i", start - a, ab) / np.maximum(length ** 2, 1e-300), 0.0, 1.0)
    foot = a + tpar[:, None] * ab
    k = int(np.argmin(np.hypot(*(foot - start).T)))
    cum = np.concatenate([[0.0], np.cumsum(length)])
    pos = cum[k] + tpar[k] * length[k] + distance
    if abs(p[0, 0] - p[-1, 0]) <= 1e-9 and abs(p[0, 1] - p[-1, 1]) <= 1e-9 and cum[-1] > 0:
        pos %= cum[-1]
    pos = min(max(pos, 0.0), cum[-1])
    i = int(min(np.searchsorted(cum, pos, side="right") - 1, len(length) - 1))
    return a[i] + (pos - cum[i]) / max(length[i], 1e-300) * ab[i]


def _targets(curves: np.ndarray | list[np.ndarray], starts: np.ndarray, distances: np.ndarray) -> np.ndarray:
    """:func:`point_along` for each polyline, in one pass when all are straight segments (a line; ``curves``
    then may be the (k, 2, 2) array of :meth:`SceneBuilder.line_ends`)."""
    if isinstance(curves, np.ndarray) and curves.shape[1] == 2:
        a, b = curves[:, 0].copy(), curves[:, 1].copy()
    elif all(len(c) == 2 for c in curves):
        a, b = np.array([c[0] for c in curves]), np.array([c[1] for c in curves])
    else:
        return np.array([point_along(c, p, x) for c, p, x in zip(curves, starts, distances)])
    length = np.hypot(*(b - a).T)
    d = (b - a) / length[:, None]
    pos = np.clip(np.clip(np.einsum("ij,ij->i", starts - a, d), 0.0, length) + distances, 0.0, length)
    return a + pos[:, None] * d


class SceneBuilder:
    """Builds the ``/scene``, ``/tf`` and ``/tracking`` messages of a run, block by block.

    Feed every block of steps to :meth:`advance` (it keeps the running integral of ``v*``),
    then ask :meth:`messages` for the rows to draw.

    Parameters
    ----------
    ctrl : CoordinatingController
        The run's controller (chain and curve).
    obstacles : array_like
        The scenario's obstacles (drawn through :func:`~.scene_fixed.obstacle_outlines`).
    frames : {"ends", "all"}
        ``/tf``: the frames ``base`` and ``tip`` (default), or a frame per link.

    Attributes
    ----------
    views : bool
        Give the ``/scene`` messages of a planar run as read-only memoryviews of one array per block
        instead of ``bytes`` (:meth:`~.json_fill.JsonTemplate.fill`): no copy of each 26 kB message, for a
        writer that copies them into its records anyway (the log does); default False.
    """

    #: The ``/scene`` messages as memoryviews (see the class's attributes).
    views: bool = False

    def __init__(self, ctrl: CoordinatingController, obstacles: Any, frames: str = "ends") -> None:
        if frames not in FRAME_SETS:
            raise ValueError(f"frames: need one of {', '.join(FRAME_SETS)}, got {frames!r}")
        self.ctrl = ctrl
        self.frames = frames
        digits_kernel()           # the JSON digits' C kernel loaded now, not by a log's worker thread
        self.reach = 2.2 * ctrl.chain.m * ctrl.chain.xi
        # what does not move, the lines of /scene/fixed: the rail, then the obstacles
        self._fixed_lines = (*(line_json(p, RAIL_PX, RAIL_COLOR, pixels=True) for p in rail_lines(ctrl.chain, self.reach)),
                             *(line_json(p, WALL_PX, WALL_COLOR, pixels=True) for p in obstacle_outlines(obstacles)))
        self._fixed_sent = False      # /scene/fixed goes out once, before the first scene
        self._scene_templates: dict[tuple[int, int], JsonTemplate] = {}
        self._line_params: Any = None  # CasADi Function t -> (angle, point) of a straight-line curve (False: none)
        self._line_maps: dict[int, BufferedFunction] = {}   # it mapped over k times, by k
        self._reference: ArcReference = ArcReference(ctrl.speeds)     # of v* over the steps seen
        self.s_target = np.empty(0)

    def advance(self, part: Run) -> np.ndarray:
        """Take the next block of steps; returns (and keeps in :attr:`s_target`) ``s(0) + integral of v*``.

        The integral is Simpson's rule on the step grid with ``v*`` at each step's middle, summed in
        the same order as :meth:`~.result.Run.s_reference` given ``ctrl.speeds``
        (:class:`~.s_reference.ArcReference`), so the two agree to the last bit on an ungoverned run
        (the target is of the commanded ``v*``, not the governed one).

        Parameters
        ----------
        part : Run
            The next block of consecutive steps (``t`` [s], ``s`` [m], ``v_star`` [m/s]).

        Returns
        -------
        ndarray, shape (N,)
            The target arc length at each row of ``part`` [m].
        """
        self.s_target = self._reference.add(part.t, part.s[0], part.v_star)
        return self.s_target

    def curves(self, times: np.ndarray) -> list[np.ndarray]:
        """The curve at each of ``times`` as a polyline (a straight line: one CasADi evaluation for all times).

        Parameters
        ----------
        times : ndarray, shape (k,)
            Times [s].

        Returns
        -------
        list of ndarray
            One polyline [m] per time: its two ends for a straight line, else the curve's
            ``sample(t, n=90, extent=reach)``.
        """
        lines = self.line_ends(times)
        if lines is not None:
            return list(lines)
        return [self.ctrl.curve.sample(float(t), n=90, extent=self.reach) for t in times]

    def line_ends(self, times: np.ndarray) -> np.ndarray | None:
        """The two drawn ends of a straight-line curve at each of ``times`` (None for another curve).

        The line's angle and point come from its CasADi Function mapped over the times (called through
        :class:`~coordarm.symbolic.function_buffer.BufferedFunction`), trusted once it reproduces the curve's
        own sampling.

        Parameters
        ----------
        times : ndarray, shape (k,)
            Times [s].

        Returns
        -------
        ndarray, shape (k, 2, 2), or None
            Per time, the points ``point -+ reach (cos, sin)(angle)`` [m]; None when the curve is not a
            :class:`~coordarm.symbolic.curves.Line` (or its Function does not match its sampling) or no times.
        """
        curve = self.ctrl.curve
        if self._line_params is None and isinstance(curve, Line) and len(times):
            t = ca.SX.sym("t")
            f = ca.Function("line_params", [t], [curve.angle(t), curve.point[0](t), curve.point[1](t)])
            # Trusted only if it reproduces the curve's own sampling.
            th, px, py = (float(v) for v in f(float(times[0])))
            ends = np.array([-self.reach, self.reach])
            first = np.column_stack([px + ends * np.cos(th), py + ends * np.sin(th)])
            ok = np.allclose(first, curve.sample(float(times[0]), n=2, extent=self.reach), rtol=0, atol=1e-12)
            self._line_params = f if ok else False
        if not self._line_params or not len(times):
            return None
        mapped = self._line_maps.get(len(times))
        if mapped is None:
            if len(self._line_maps) > 8:      # block sizes vary little; keep a few
                self._line_maps.clear()
            mapped = self._line_maps[len(times)] = BufferedFunction(self._line_params.map(len(times)))
        th, px, py = (v.ravel() for v in mapped(np.asarray(times, float)[None, :]))
        ends = np.array([-self.reach, self.reach])
        return np.stack([px[:, None] + ends * np.cos(th)[:, None], py[:, None] + ends * np.sin(th)[:, None]], -1)

    def messages(self, part: Run, ks: np.ndarray, ns: np.ndarray) -> list[tuple[str, int, bytes]]:
        """``(channel key, log time, data)`` of the scene, frame transforms and tracking at rows ``ks``.

        ``part`` must be the block last given to :meth:`advance`; ``ns`` are the log times of
        the rows [ns].

        Parameters
        ----------
        part : Run
            The block last given to :meth:`advance`.
        ks : ndarray of int, shape (k,)
            Its rows to draw.
        ns : ndarray of int, shape (k,)
            Log time of each row [ns].

        Returns
        -------
        list of (str, int, bytes)
            ``("scene" | "tf" | "tracking", log time [ns], message)``, three per row, in row order (the
            scenes as memoryviews when :attr:`views`), after ``("fixed", ...)`` the first time
            (:meth:`fixed_first`).
        """
        if not len(ks):
            return []
        chain = self.ctrl.chain
        q = part.q[ks]
        joints, base = chain.joints_np(q), chain.base_point(q)      # base: y^1, the first central point
        lines = self.line_ends(part.t[ks])
        curves = lines if lines is not None else self.curves(part.t[ks])
        if self.frames == "all":
            frames = frame_transforms_json(joints, ns)
        else:
            frames = end_frames_json(base, chain.rail_angle if chain.rail else 0.0, joints, ns)
        ends = 0.5 * (joints[:, -2] + joints[:, -1])  # the central point of the last link
        s, s_target = part.s[ks], self.s_target[ks]
        targets = _targets(curves, ends, s_target - s)
        tracking = tracking_records(part, ks, s_target, targets)
        scenes = self._scenes(part.link_margins[ks], stamps(ns), joints, base if chain.rail else None, targets,
                              curves)
        records = [CDR_HEADER + record.tobytes() for record in tracking.astype("<f8")]
        return self.fixed_first([x for n, scene, tf, record in zip(np.asarray(ns).tolist(), scenes, frames, records)
                                 for x in (("scene", n, scene), ("tf", n, tf), ("tracking", n, record))], ns)

    def fixed_message(self, ns: int) -> bytes:
        """The ``/scene/fixed`` message (:func:`~.scene_fixed.fixed_update`): the rail and the obstacles (their
        outlines; a spatial scene's wireframes).

        Parameters
        ----------
        ns : int
            Its time stamp [ns].

        Returns
        -------
        bytes
            The message.
        """
        return fixed_update(ns, self._fixed_lines)

    def fixed_first(self, out: list[tuple[str, int, Any]], ns: np.ndarray) -> list[tuple[str, int, Any]]:
        """``out`` (the messages of rows logged at ``ns``), after :meth:`fixed_message` the first time only.

        Parameters
        ----------
        out : list of (str, int, bytes)
            Messages of :meth:`messages`.
        ns : ndarray of int
            Their rows' log times [ns] (the first one stamps the fixed message).

        Returns
        -------
        list of (str, int, bytes)
            ``[("fixed", ns[0], message), *out]`` the first time there is a row, else ``out``.
        """
        if self._fixed_sent or not len(ns):
            return out
        self._fixed_sent = True
        first = int(np.asarray(ns)[0])
        return [("fixed", first, self.fixed_message(first)), *out]

    def _scenes(self, margins: np.ndarray, stamps: np.ndarray, joints: np.ndarray, base: np.ndarray | None,
                targets: np.ndarray, curves: np.ndarray | list[np.ndarray]) -> list[bytes] | list[memoryview]:
        """The ``/scene`` messages of k poses: :func:`scene_numbers` then the curve's points [µm], filled into the
        template of each number of curve points (one for a straight line)."""
        k, m = joints.shape[0], joints.shape[1] - 1
        head = head_columns(m, base is not None)
        sizes = [len(c) for c in curves]
        groups = sorted(set(sizes))
        if len(groups) == 1:                    # the slots written in place, the curve's after them
            values = np.empty((k, head + 2 * groups[0]), np.int64)
            scene_numbers(values, margins, stamps, joints, base, targets)
        else:
            values = scene_numbers(np.empty((k, head), np.int64), margins, stamps, joints, base, targets)
        scenes: list[Any] = [b""] * k
        for size in groups:
            rows = np.flatnonzero(np.array(sizes) == size)
            template = self._scene_template(m + 1, size)
            points = curves if len(groups) == 1 else np.array([curves[i] for i in rows])
            if len(groups) == 1:
                group = values
            else:
                group = np.empty((len(rows), template.columns), np.int64)
                group[:, :head] = values[rows]
            assert template.columns == head + 2 * size, (template.columns, head, size)
            group[:, head:] = np.round(np.asarray(points, float).reshape(len(rows), -1) * 1e6)
            for i, text in zip(rows.tolist(), template.fill(group, self.views)):
                scenes[i] = text
        return scenes

    def _scene_template(self, joints: int, curve_points: int) -> JsonTemplate:
        """The ``foxglove.SceneUpdate`` with slots: stamp (kinds 0, 1), the target sphere's centre [pm] (4),
        the joint spheres' centres, the carriage's centre (rail robots) and the links' ends [µm] (2), the
        links' colours [1e-3] (5) and the curve's ``curve_points`` points [µm] (3); the rail and the
        obstacles are literal. A link's ends show its joints' columns, its second end's colour its first's
        (the columns of :func:`scene_numbers`, then the curve's)."""
        key = (joints, curve_points)
        if key not in self._scene_templates:
            chain = self.ctrl.chain
            xi = chain.xi
            t = stamp_slots(JsonTemplate(kinds=6).text('{"deletions":[],"entities":[{"timestamp":'))
            t.text(',"frame_id":"world","id":"coordarm","lifetime":{"sec":0,"nsec":0},"frame_locked":false,'
                   '"metadata":[],"arrows":[],"spheres":[')
            head, tail = _sphere("", max(1.2 * xi, 0.05), TARGET_COLOR)
            t.text(head + '{"x":').number(4).text('e-12,"y":').number(4).text('e-12,"z":0}' + tail)
            head, tail = _sphere("", 0.45 * xi, JOINT_COLOR)
            assert t.columns == 4                   # the joints from column 4 (as scene_numbers writes them)
            for _ in range(joints):
                t.text("," + head + '{"x":').number(2).text('e-6,"y":').number(2).text('e-6,"z":0}' + tail)
            t.text('],"cubes":[')
            if chain.rail:
                r, g, b, a = CARRIAGE_COLOR
                c, s_ = math.cos(0.5 * chain.rail_angle), math.sin(0.5 * chain.rail_angle)
                t.text('{"pose":{"position":{"x":').number(2).text('e-6,"y":').number(2)
                t.text(f'e-6,"z":0}},"orientation":{{"x":0,"y":0,"z":{s_!r},"w":{c!r}}}}},'
                       f'"size":{{"x":{length_literal(1.5 * xi)},"y":{length_literal(xi)},'
                       f'"z":{length_literal(0.5 * xi)}}},'
                       f'"color":{{"r":{r},"g":{g},"b":{b},"a":{a}}}}}')
            t.text('],"cylinders":[],"triangles":[],"texts":[],"models":[],"lines":[')
            _coloured_segments_slots(t, joints - 1, ARM_PX, 2, 5, first_point=4)
            t.text(",")
            _line_slots(t, curve_points, CURVE_PX, CURVE_COLOR, 3, depth=CURVE_DEPTH * xi)
            self._scene_templates[key] = t.text("]}]}")
        return self._scene_templates[key]
