"""What Foxglove draws: the ``/scene`` (``foxglove.SceneUpdate``), ``/tf`` (``foxglove.FrameTransforms``)
and ``/tracking`` messages of a run, built from blocks of its steps.

The scene, in frame ``world``: the chain as solid segments (a line list, 6 px wide at any zoom) coloured
by each link's margin (:func:`margin_colours`: blue at 0.5 or more, violet at 0.375, orange at 0.25, red
at 0; the first link, which has no margin, blue) with a dark sphere at every joint, the whole curve at its
current pose (a solid line, 3 px, a quarter link below the arm's plane), the end point's target (a red
sphere at the point of the curve whose arc length is ``s(0) + integral of v*``), the rail with its end
stops and the carriage (a cube at ``y^1``) on a rail robot, and the obstacles, each drawn from
:func:`obstacle_outlines` (4 px). The frame transforms give, by default (``frames="ends"``), the frames
``base`` (at the pinned first central point ``y^1``, x along the rail on a rail robot) and ``tip`` (at the
free end of the last link, x along it), both parented to ``world``; with ``frames="all"`` a frame
``link1`` .. ``linkm`` per link (origin at the link's central point, x along the link), each parented to
the previous one and ``link1`` to ``world``, so that users can attach their own models to the links. The
messages follow the official Foxglove JSON Schemas shipped in ``foxglove_schemas/`` (see
:mod:`.log_schemas`).
"""
from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from coordarm.symbolic import CoordinatingController
from coordarm.symbolic.curves import Line

from .json_fill import JsonTemplate, digits_kernel
from .log_schemas import CDR_HEADER
from .obstacles import outline
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
    x = np.asarray(margins, float)
    x = np.concatenate([np.full(x.shape[:-1] + (1,), MARGIN_STOPS[-1]), x], axis=-1)
    x = np.where(np.isfinite(x), x, 0.0)
    stops = np.asarray(MARGIN_COLOURS)
    return np.stack([np.interp(x, MARGIN_STOPS, stops[:, c]) for c in range(3)], axis=-1)


def obstacle_outlines(obstacles: Any) -> list[np.ndarray]:
    """Each obstacle as the polyline drawn for it [m], a list of (k, 2) arrays.

    The scene draws what :func:`coordarm.simulation.obstacles.outline` gives (as do the
    figures and the animation): a wall segment is its two ends, a disc and a polygon are
    closed (they repeat their first point).

    Parameters
    ----------
    obstacles : sequence of Obstacle
        The scenario's obstacles.

    Returns
    -------
    list of ndarray, each shape (k, 2)
        The polylines [m].
    """
    return [outline(ob) for ob in obstacles]


def _line_parts(thickness: float, color: tuple[float, ...], kind: int = 0, pixels: bool = False,
                depth: float = 0.0) -> tuple[str, str]:
    """The text of a ``foxglove.LinePrimitive`` before and after its points (``pixels``: thickness in px;
    ``depth`` [m]: the line's pose lies that far below the plane z = 0)."""
    r, g, b, a = color
    pose = _POSE0 if depth == 0 else _POSE0.replace('"z":0}', f'"z":{-depth!r}}}', 1)
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


def _point_slots(template: JsonTemplate, points: int, slot_kind: int) -> None:
    """Append ``points`` comma-separated points whose coordinates [µm] are slots of ``slot_kind``."""
    for i in range(points):
        template.text("," if i else "").text('{"x":').number(slot_kind).text('e-6,"y":').number(slot_kind)
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
                             colour_kind: int) -> None:
    """Append a line list of ``segments`` segments (2 points each, coordinates [µm] of ``point_kind``) whose
    per-point colours [1e-3] are slots of ``colour_kind`` (r, g, b per point; alpha 1), ``thickness`` in px."""
    template.text(f'{{"type":2,"pose":{_POSE0},"thickness":{thickness},"scale_invariant":true,"points":[')
    _point_slots(template, 2 * segments, point_kind)
    template.text('],"color":{"r":0,"g":0,"b":0,"a":1},"colors":[')
    for i in range(2 * segments):
        template.text("," if i else "").text('{"r":').number(colour_kind).text('e-3,"g":').number(colour_kind)
        template.text('e-3,"b":').number(colour_kind).text('e-3,"a":1}')
    template.text('],"indices":[]}')


def _sphere(position: str, diameter: float, color: tuple[float, ...]) -> tuple[str, str]:
    """The text of a ``foxglove.SpherePrimitive`` before and after its position's ``x, y`` text."""
    r, g, b, a = color
    return ('{"pose":{"position":', f',"orientation":{{"x":0,"y":0,"z":0,"w":1}}}},'
            f'"size":{{"x":{diameter},"y":{diameter},"z":{diameter}}},"color":{{"r":{r},"g":{g},"b":{b},"a":{a}}}}}')


def rail_lines(chain: Any, reach: float) -> list[np.ndarray]:
    """The rail of a rail robot as polylines [m]: the rail between its limits (cut to ``reach`` where a
    limit is infinite) and a short stop across it at each finite limit; none on a fixed base.

    Parameters
    ----------
    chain : PlanarChain
        The chain (``rail``, ``rail_angle``, ``rail_limits``, ``xi``).
    reach : float
        Half-length drawn of an unbounded rail [m].

    Returns
    -------
    list of ndarray, each shape (2, 2)
        The rail, then the stops.
    """
    if not getattr(chain, "rail", False) or len(chain.rail_direction) != 2:
        return []    # a fixed base; a spatial chain's rail is drawn by scene3d.SpatialSceneBuilder
    u = chain.rail_direction
    n = np.array([-u[1], u[0]])
    low, high = (max(chain.rail_limits[0], -reach), min(chain.rail_limits[1], reach))
    out = [np.array([low * u, high * u])]
    for d, limit in zip((low, high), chain.rail_limits):
        if np.isfinite(limit):
            out.append(np.array([d * u - 1.5 * chain.xi * n, d * u + 1.5 * chain.xi * n]))
    return out


def link_frames(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each link's frame relative to its parent (link j-1; ``world`` for link 1).

    Parameters
    ----------
    joints : (..., m+1, 2) array
        Link end points [m] (``PlanarChain.joints_np``).

    Returns
    -------
    translation : (..., m, 2) array
        Origin of frame j (link j's central point) in frame j-1 [m].
    angle : (..., m) array
        Rotation of frame j relative to frame j-1 about z [rad] (``q_j`` for a fixed base).
    """
    joints = np.asarray(joints, float)
    centre = 0.5 * (joints[..., :-1, :] + joints[..., 1:, :])
    d = joints[..., 1:, :] - joints[..., :-1, :]
    alpha = np.arctan2(d[..., 1], d[..., 0])
    parent_c = np.concatenate([np.zeros_like(centre[..., :1, :]), centre[..., :-1, :]], axis=-2)
    parent_a = np.concatenate([np.zeros_like(alpha[..., :1]), alpha[..., :-1]], axis=-1)
    rel = centre - parent_c
    c, s = np.cos(parent_a), np.sin(parent_a)
    trans = np.stack([c * rel[..., 0] + s * rel[..., 1], -s * rel[..., 0] + c * rel[..., 1]], axis=-1)
    angle = np.angle(np.exp(1j * (alpha - parent_a)))  # wrapped to (-pi, pi]
    return trans, angle


def _stamp_slots(template: JsonTemplate) -> JsonTemplate:
    """Append a ``foxglove`` time whose ``sec`` and ``nsec`` are slots of kinds 0 and 1."""
    return template.text('{"sec":').number(0).text(',"nsec":').number(1).text("}")


def _stamps(ns: list[int] | np.ndarray) -> np.ndarray:
    """``(sec, nsec)`` columns of log times ``ns`` [ns]."""
    ns = np.asarray(ns, np.int64)
    return np.column_stack([ns // 10**9, ns % 10**9])


_TF_TEMPLATES: dict[int, JsonTemplate] = {}


def _tf_template(m: int) -> JsonTemplate:
    """The ``foxglove.FrameTransforms`` of m links, slots (sec, nsec, x, y [nm], z, w [1e-15]) per link."""
    if m not in _TF_TEMPLATES:
        t = JsonTemplate(kinds=4).text('{"transforms":[')
        for j in range(m):
            _stamp_slots(t.text("," if j else "").text('{"timestamp":'))
            t.text(f',"parent_frame_id":"{"world" if j == 0 else f"link{j}"}","child_frame_id":"link{j + 1}",'
                   '"translation":{"x":').number(2).text('e-9,"y":').number(2)
            t.text('e-9,"z":0},"rotation":{"x":0,"y":0,"z":').number(3).text('e-15,"w":').number(3).text("e-15}}")
        _TF_TEMPLATES[m] = t.text("]}")
    return _TF_TEMPLATES[m]


def frame_transforms_json(joints: np.ndarray, ns: list[int] | np.ndarray) -> list[bytes]:
    """The ``foxglove.FrameTransforms`` of poses ``joints`` (n, m+1, 2) stamped ``ns`` [ns], one JSON each.

    Translations are exact to 1 nm, rotations (quaternions about z) to 1e-15; the numbers are
    written by :class:`~.json_fill.JsonTemplate` (space-padded, fixed width per batch).

    Parameters
    ----------
    joints : ndarray, shape (n, m+1, 2)
        Joint positions of each pose [m].
    ns : list of int or ndarray, shape (n,)
        Time stamp of each pose [ns].

    Returns
    -------
    list of bytes
        One JSON message per pose.
    """
    trans, angle = link_frames(joints)
    n, m = angle.shape
    values = np.empty((n, m, 6), np.int64)
    values[..., :2] = _stamps(ns)[:, None, :]
    values[..., 2:4] = np.round(trans * 1e9)
    values[..., 4] = np.round(np.sin(0.5 * angle) * 1e15)
    values[..., 5] = np.round(np.cos(0.5 * angle) * 1e15)
    return _tf_template(m).fill(values.reshape(n, -1))


_END_TEMPLATE = JsonTemplate(kinds=4).text('{"transforms":[')
for _j, _name in enumerate(("base", "tip")):
    _stamp_slots(_END_TEMPLATE.text("," if _j else "").text('{"timestamp":'))
    _END_TEMPLATE.text(f',"parent_frame_id":"world","child_frame_id":"{_name}","translation":{{"x":').number(2)
    _END_TEMPLATE.text('e-9,"y":').number(2).text('e-9,"z":0},"rotation":{"x":0,"y":0,"z":').number(3)
    _END_TEMPLATE.text('e-15,"w":').number(3).text("e-15}}")
_END_TEMPLATE.text("]}")


def end_frames_json(base: np.ndarray, base_angle: float, joints: np.ndarray, ns: list[int] | np.ndarray) -> list[bytes]:
    """The ``foxglove.FrameTransforms`` ``world -> base`` and ``world -> tip`` of poses ``joints``, one JSON each.

    ``base`` sits at the first central point ``y^1`` turned by ``base_angle`` (the rail's direction, 0 on
    a fixed base); ``tip`` at the last joint (the free end of link m), x along link m.

    Parameters
    ----------
    base : ndarray, shape (n, 2)
        The first central point of each pose [m].
    base_angle : float
        Rotation of the base frame about z [rad].
    joints : ndarray, shape (n, m+1, 2)
        Joint positions of each pose [m].
    ns : list of int or ndarray, shape (n,)
        Time stamp of each pose [ns].

    Returns
    -------
    list of bytes
        One JSON message per pose (translations to 1 nm, quaternions to 1e-15).
    """
    joints = np.asarray(joints, float)
    n = len(joints)
    d = joints[:, -1] - joints[:, -2]
    angles = np.column_stack([np.full(n, base_angle), np.arctan2(d[:, 1], d[:, 0])])
    values = np.empty((n, 2, 6), np.int64)
    values[..., :2] = _stamps(ns)[:, None, :]
    values[:, 0, 2:4] = np.round(np.asarray(base, float) * 1e9)
    values[:, 1, 2:4] = np.round(joints[:, -1] * 1e9)
    values[..., 4] = np.round(np.sin(0.5 * angles) * 1e15)
    values[..., 5] = np.round(np.cos(0.5 * angles) * 1e15)
    return _END_TEMPLATE.fill(values.reshape(n, -1))


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


def _targets(curves: list[np.ndarray], starts: np.ndarray, distances: np.ndarray) -> np.ndarray:
    """:func:`point_along` for each polyline, in one pass when all are straight segments (a line)."""
    if all(len(c) == 2 for c in curves):
        a, b = np.array([c[0] for c in curves]), np.array([c[1] for c in curves])
        length = np.hypot(*(b - a).T)
        d = (b - a) / length[:, None]
        pos = np.clip(np.clip(np.einsum("ij,ij->i", starts - a, d), 0.0, length) + distances, 0.0, length)
        return a + pos[:, None] * d
    return np.array([point_along(c, p, x) for c, p, x in zip(curves, starts, distances)])


class SceneBuilder:
    """Builds the ``/scene``, ``/tf`` and ``/tracking`` messages of a run, block by block.

    Feed every block of steps to :meth:`advance` (it keeps the running integral of ``v*``),
    then ask :meth:`messages` for the rows to draw.

    Parameters
    ----------
    ctrl : CoordinatingController
        The run's controller (chain and curve).
    obstacles : array_like
        The scenario's obstacles (drawn through :func:`obstacle_outlines`).
    frames : {"ends", "all"}
        ``/tf``: the frames ``base`` and ``tip`` (default), or a frame per link.
    """

    def __init__(self, ctrl: CoordinatingController, obstacles: Any, frames: str = "ends") -> None:
        if frames not in FRAME_SETS:
            raise ValueError(f"frames: need one of {', '.join(FRAME_SETS)}, got {frames!r}")
        self.ctrl = ctrl
        self.frames = frames
        digits_kernel()           # the JSON digits' C kernel loaded now, not by a log's worker thread
        self.reach = 2.2 * ctrl.chain.m * ctrl.chain.xi
        outlines = obstacle_outlines(obstacles)
        # the same in every scene: obstacles and the rail
        self._obstacle_lines = tuple(line_json(p, WALL_PX, WALL_COLOR, pixels=True) for p in outlines)
        self._rail_lines = tuple(line_json(p, RAIL_PX, RAIL_COLOR, pixels=True)
                                 for p in rail_lines(ctrl.chain, self.reach))
        self._scene_templates: dict[tuple[int, int], JsonTemplate] = {}
        self._line_params: Any = None  # CasADi Function t -> (angle, point) of a straight-line curve
        self._line_maps: dict[int, Any] = {}   # it mapped over k times, by k
        self._s0: float | None = None
        self._carry = (0.0, 0.0, 0.0)  # (t, v*, integral of v*) at the last step seen
        self.s_target = np.empty(0)

    def advance(self, part: Run) -> np.ndarray:
        """Take the next block of steps; returns (and keeps in :attr:`s_target`) ``s(0) + integral of v*``.

        The integral is the trapezoidal rule on the step grid, summed in the same order as
        :meth:`simulation.run.Run.s_reference`, so the two agree to the last bit.

        Parameters
        ----------
        part : Run
            The next block of consecutive steps (``t`` [s], ``s`` [m], ``v_star`` [m/s]).

        Returns
        -------
        ndarray, shape (N,)
            The target arc length at each row of ``part`` [m].
        """
        t, v = np.asarray(part.t, float), np.asarray(part.v_star, float)
        if self._s0 is None:
            self._s0 = float(part.s[0])
            t_prev, v_prev, acc = t[0], v[0], 0.0
            inc = 0.5 * np.diff(t) * (v[1:] + v[:-1])
            integral = np.cumsum(np.concatenate([[acc], inc]))
        else:
            t_prev, v_prev, acc = self._carry
            tt, vv = np.concatenate([[t_prev], t]), np.concatenate([[v_prev], v])
            inc = 0.5 * np.diff(tt) * (vv[1:] + vv[:-1])
            integral = np.cumsum(np.concatenate([[acc], inc]))[1:]
        self._carry = (float(t[-1]), float(v[-1]), float(integral[-1]))
        self.s_target = self._s0 + integral
        return self.s_target

    def curves(self, times: np.ndarray) -> list[np.ndarray]:
        """The curve at each of ``times`` as a polyline (a straight line: one CasADi call for all times).

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
        if self._line_params and len(times):
            th, px, py = self._line_values(np.asarray(times, float))
            ends = np.array([-self.reach, self.reach])
            return list(np.stack([px[:, None] + ends * np.cos(th)[:, None],
                                  py[:, None] + ends * np.sin(th)[:, None]], -1))
        return [curve.sample(float(t), n=90, extent=self.reach) for t in times]

    def _line_values(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The straight line's angle and point at ``times``: its CasADi Function mapped over them (one
        evaluation per time, as the call on a row of times does, ~7x cheaper than that call)."""
        mapped = self._line_maps.get(len(times))
        if mapped is None:
            if len(self._line_maps) > 8:      # block sizes vary little; keep a few
                self._line_maps.clear()
            mapped = self._line_maps[len(times)] = self._line_params.map(len(times))
        return tuple(v.full().ravel() for v in mapped(ca.DM(times[None, :])))

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
            ``("scene" | "tf" | "tracking", log time [ns], message)``, three per row, in row order.
        """
        if not len(ks):
            return []
        chain = self.ctrl.chain
        joints = chain.joints_np(part.q[ks])
        base = chain.base_point(part.q[ks])               # y^1, the first central point
        curves = self.curves(part.t[ks])
        if self.frames == "all":
            frames = frame_transforms_json(joints, ns)
        else:
            frames = end_frames_json(base, chain.rail_angle if chain.rail else 0.0, joints, ns)
        ends = 0.5 * (joints[:, -2] + joints[:, -1])  # the central point of the last link
        s, s_target = part.s[ks], self.s_target[ks]
        targets = _targets(curves, ends, s_target - s)
        tracking = tracking_records(part, ks, s_target, targets)
        m = joints.shape[1] - 1
        # The integers of the scene template, rounded once: a segment's ends are joints, a link's colour is
        # each of its two points' (the same integers as rounding the repeated values).
        joint_um = np.round(joints * 1e6).astype(np.int64)
        segment_um = np.stack([joint_um[:, :-1], joint_um[:, 1:]], axis=2).reshape(len(ks), -1)  # link j: ends j, j+1
        colours = np.repeat(np.round(margin_colours(part.link_margins[ks]) * 1e3).astype(np.int64), 2, axis=1)
        columns = [_stamps(ns), np.round(targets * 1e12), joint_um.reshape(len(ks), -1),
                   np.round(base * 1e6) if chain.rail else None, segment_um, colours.reshape(len(ks), -1)]
        columns = [c for c in columns if c is not None]
        scenes: list[bytes] = [b""] * len(ks)
        sizes = np.array([len(c) for c in curves])
        for size in sorted(set(sizes.tolist())):  # one template per number of curve points (one for a line)
            rows = np.flatnonzero(sizes == size)
            template = self._scene_template(m + 1, int(size))
            curve_um = np.round(np.array([curves[i] for i in rows]).reshape(len(rows), -1) * 1e6)
            values, at = np.empty((len(rows), template.slots), np.int64), 0
            for c in [*(c if len(rows) == len(ks) else c[rows] for c in columns), curve_um]:
                values[:, at:at + c.shape[1]] = c      # (floats hold integers here: cast exactly)
                at += c.shape[1]
            assert at == template.slots, (at, template.slots)
            for i, text in zip(rows, template.fill(values)):
                scenes[i] = text
        out = []
        for n, scene, tf, record in zip(np.asarray(ns).tolist(), scenes, frames, tracking.astype("<f8")):
            out.append(("scene", n, scene))
            out.append(("tf", n, tf))
            out.append(("tracking", n, CDR_HEADER + record.tobytes()))
        return out

    def _scene_template(self, joints: int, curve_points: int) -> JsonTemplate:
        """The ``foxglove.SceneUpdate`` with slots: stamp (kinds 0, 1), the target sphere's centre [pm] (4),
        the joint spheres' centres, the carriage's centre (rail robots) and the links' ends [µm] (2), the
        links' colours [1e-3] (5) and the curve's ``curve_points`` points [µm] (3); the rail and the
        obstacles are literal."""
        key = (joints, curve_points)
        if key not in self._scene_templates:
            chain = self.ctrl.chain
            xi = chain.xi
            t = _stamp_slots(JsonTemplate(kinds=6).text('{"deletions":[],"entities":[{"timestamp":'))
            t.text(',"frame_id":"world","id":"coordarm","lifetime":{"sec":0,"nsec":0},"frame_locked":false,'
                   '"metadata":[],"arrows":[],"spheres":[')
            head, tail = _sphere("", max(1.2 * xi, 0.05), TARGET_COLOR)
            t.text(head + '{"x":').number(4).text('e-12,"y":').number(4).text('e-12,"z":0}' + tail)
            head, tail = _sphere("", 0.45 * xi, JOINT_COLOR)
            for _ in range(joints):
                t.text("," + head + '{"x":').number(2).text('e-6,"y":').number(2).text('e-6,"z":0}' + tail)
            t.text('],"cubes":[')
            if chain.rail:
                r, g, b, a = CARRIAGE_COLOR
                c, s_ = math.cos(0.5 * chain.rail_angle), math.sin(0.5 * chain.rail_angle)
                t.text('{"pose":{"position":{"x":').number(2).text('e-6,"y":').number(2)
                t.text(f'e-6,"z":0}},"orientation":{{"x":0,"y":0,"z":{s_!r},"w":{c!r}}}}},'
                       f'"size":{{"x":{1.5 * xi},"y":{xi},"z":{0.5 * xi}}},'
                       f'"color":{{"r":{r},"g":{g},"b":{b},"a":{a}}}}}')
            t.text('],"cylinders":[],"triangles":[],"texts":[],"models":[],"lines":[')
            _coloured_segments_slots(t, joints - 1, ARM_PX, 2, 5)
            t.text(",")
            _line_slots(t, curve_points, CURVE_PX, CURVE_COLOR, 3, depth=CURVE_DEPTH * xi)
            extra = "".join("," + x for x in (*self._rail_lines, *self._obstacle_lines))
            self._scene_templates[key] = t.text(extra + "]}]}")
        return self._scene_templates[key]
