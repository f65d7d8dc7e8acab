"""What Foxglove draws: the ``/scene`` (``foxglove.SceneUpdate``), ``/tf`` (``foxglove.FrameTransforms``)
and ``/tracking`` messages of a run, built from blocks of its steps.

The scene, in frame ``world``: the chain (its joints as a line strip), the whole curve at its
current pose, the end point's target (a sphere at the point of the curve whose arc length is
``s(0) + integral of v*``) and the obstacles, each drawn from :func:`obstacle_outlines`. The
frame transforms give a frame ``link1`` .. ``linkm`` per link (origin at the link's central
point, x along the link), each parented to the previous one and ``link1`` to ``world``, so
that users can attach their own models to the links. The messages follow the official
Foxglove JSON Schemas shipped in ``foxglove_schemas/`` (see :mod:`.log_schemas`).
"""
from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from coordarm.symbolic import CoordinatingController
from coordarm.symbolic.curves import Line

from .json_fill import JsonTemplate
from .log_schemas import CDR_HEADER
from .obstacles import outline
from .run import Run

#: A point in JSON, coordinates as integer micrometres with an exponent (exact to 1e-6 m, and
#: integers format about twice as fast as floats).
_POINT = '{"x":%de-6,"y":%de-6,"z":0}'
_POSE0 = '{"position":{"x":0,"y":0,"z":0},"orientation":{"x":0,"y":0,"z":0,"w":1}}'
ARM_COLOR, CURVE_COLOR, WALL_COLOR, TARGET_COLOR = ((0.15, 0.45, 0.9, 1.0), (0.9, 0.5, 0.1, 0.8),
                                                    (0.2, 0.2, 0.2, 1.0), (0.85, 0.1, 0.1, 1.0))


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


def _line_parts(thickness: float, color: tuple[float, ...], kind: int = 0) -> tuple[str, str]:
    """The text of a ``foxglove.LinePrimitive`` before and after its points."""
    r, g, b, a = color
    return (f'{{"type":{kind},"pose":{_POSE0},"thickness":{thickness},"scale_invariant":false,"points":[',
            f'],"color":{{"r":{r},"g":{g},"b":{b},"a":{a}}},"colors":[],"indices":[]}}')


def line_json(points: np.ndarray, thickness: float, color: tuple[float, ...], kind: int = 0) -> str:
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

    Returns
    -------
    str
        The JSON object.
    """
    xy = np.round(np.asarray(points, float).reshape(-1, 2) * 1e6).astype(np.int64)
    head, tail = _line_parts(thickness, color, kind)
    return head + ",".join([_POINT] * len(xy)) % tuple(xy.ravel().tolist()) + tail


def _line_slots(template: JsonTemplate, points: int, thickness: float, color: tuple[float, ...],
                slot_kind: int) -> None:
    """Append a line strip of ``points`` points whose coordinates [µm] are slots of ``slot_kind``."""
    head, tail = _line_parts(thickness, color)
    template.text(head)
    for i in range(points):
        template.text("," if i else "").text('{"x":').number(slot_kind).text('e-6,"y":').number(slot_kind)
        template.text('e-6,"z":0}')
    template.text(tail)


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
    """

    def __init__(self, ctrl: CoordinatingController, obstacles: Any) -> None:
        self.ctrl = ctrl
        self.reach = 2.2 * ctrl.chain.m * ctrl.chain.xi
        outlines = obstacle_outlines(obstacles)
        self._obstacle_lines = tuple(line_json(p, 0.02, WALL_COLOR) for p in outlines)  # same in every scene
        self._scene_templates: dict[tuple[int, int], JsonTemplate] = {}
        self._line_params: Any = None  # CasADi Function t -> (angle, point) of a straight-line curve
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
            th, px, py = (np.asarray(v, float).ravel() for v in self._line_params(ca.DM(times).T))
            ends = np.array([-self.reach, self.reach])
            return list(np.stack([px[:, None] + ends * np.cos(th)[:, None],
                                  py[:, None] + ends * np.sin(th)[:, None]], -1))
        return [curve.sample(float(t), n=90, extent=self.reach) for t in times]

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
        joints = self.ctrl.chain.joints_np(part.q[ks])
        curves = self.curves(part.t[ks])
        frames = frame_transforms_json(joints, ns)
        ends = 0.5 * (joints[:, -2] + joints[:, -1])  # the central point of the last link
        s, s_target = part.s[ks], self.s_target[ks]
        targets = _targets(curves, ends, s_target - s)
        tracking = np.column_stack([part.t[ks], s, s_target, targets, np.max(np.abs(part.e[ks]), axis=1),
                                    np.min(part.link_margins[ks], axis=1), np.linalg.norm(part.u[ks], axis=1)])
        scenes: list[bytes] = [b""] * len(ks)
        sizes = np.array([len(c) for c in curves])
        for size in np.unique(sizes):        # one template per number of curve points (one for a line)
            rows = np.flatnonzero(sizes == size)
            values = np.concatenate([       # in the template's order: stamp, target, arm, curve
                _stamps(np.asarray(ns)[rows]), np.round(targets[rows] * 1e12),
                np.round(joints[rows].reshape(len(rows), -1) * 1e6),
                np.round(np.array([curves[i] for i in rows]).reshape(len(rows), -1) * 1e6)], axis=1)
            for i, text in zip(rows, self._scene_template(joints.shape[1], int(size)).fill(values)):
                scenes[i] = text
        out = []
        for n, scene, tf, record in zip(np.asarray(ns).tolist(), scenes, frames, tracking.astype("<f8")):
            out.append(("scene", n, scene))
            out.append(("tf", n, tf))
            out.append(("tracking", n, CDR_HEADER + record.tobytes()))
        return out

    def _scene_template(self, joints: int, curve_points: int) -> JsonTemplate:
        """The ``foxglove.SceneUpdate`` with slots: stamp (kinds 0, 1), the arm's ``joints`` points [µm] (2),
        the curve's ``curve_points`` points [µm] (3) and the target sphere's centre [pm] (4); obstacles are
        literal."""
        key = (joints, curve_points)
        if key not in self._scene_templates:
            r, g, b, a = TARGET_COLOR
            d = 0.04
            t = _stamp_slots(JsonTemplate(kinds=5).text('{"deletions":[],"entities":[{"timestamp":'))
            t.text(',"frame_id":"world","id":"coordarm","lifetime":{"sec":0,"nsec":0},"frame_locked":false,'
                   '"metadata":[],"arrows":[],"cubes":[],"spheres":[{"pose":{"position":{"x":').number(4)
            t.text('e-12,"y":').number(4).text('e-12,"z":0},"orientation":{"x":0,"y":0,"z":0,"w":1}},'
                                               f'"size":{{"x":{d},"y":{d},"z":{d}}},'
                                               f'"color":{{"r":{r},"g":{g},"b":{b},"a":{a}}}}}],"cylinders":[],'
                                               '"triangles":[],"texts":[],"models":[],"lines":[')
            _line_slots(t, joints, 0.01, ARM_COLOR, 2)
            t.text(",")
            _line_slots(t, curve_points, 0.005, CURVE_COLOR, 3)
            self._scene_templates[key] = t.text("".join("," + x for x in self._obstacle_lines) + "]}]}")
        return self._scene_templates[key]
