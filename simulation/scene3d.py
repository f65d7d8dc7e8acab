"""What Foxglove draws of a spatial run (universal joints): ``/scene``, ``/scene/fixed``, ``/tf`` and ``/tracking``.

The scene, in frame ``world``, follows the official ``foxglove.SceneUpdate`` schema as the planar
one (:mod:`.scene`): each link a cylinder (centre ``y^j``, axis along ``d_j``, length ``xi``), each
link end a sphere (the joints), the base a cube (on a rail: at ``d`` along it), the curve at its current
pose a 3-D line strip and the end point's target (the point of the curve at arc length
``s(0) + integral of v*``) a red sphere; ``/scene/fixed``, once, the rail (a grey line between its limits)
and the 3-D obstacles as wireframes (:func:`.obstacles3d.wireframe`). The frame transforms
(``foxglove.FrameTransforms``) give a frame ``link1`` .. ``linkm`` per link, origin at the link's
centre, x along the link and the orientation ``R_j`` of the chain, each parented to the previous one
(``link1`` to ``world``): link j relative to link j-1 is ``Rz(a_j) Ry(b_j)``.
"""
from __future__ import annotations

import json
from typing import Any

import numpy as np

from coordarm.symbolic.spatial_chain import SpatialChain

from .frame_transforms import stamp_slots, stamps
from .json_fill import JsonTemplate
from .log_schemas import CDR_HEADER, SPATIAL_TRACKING_FIELDS
from .obstacles3d import wireframe
from .scene import CURVE_COLOR, CURVE_PX, TARGET_COLOR, WALL_COLOR, WALL_PX, SceneBuilder, margin_colours
from .scene_fixed import length_literal
from .spatial_view import joints_of, link_geometry, rail_ends, roll_command
from .tracking_record import log10_floored

#: Colour of the joint spheres and the base (r, g, b, a).
JOINT_COLOR = (0.1, 0.1, 0.1, 1.0)
#: Colour of the rail (feed axis) (r, g, b, a).
RAIL_COLOR = (0.45, 0.45, 0.45, 0.8)
#: Widths [px, at any zoom] of the links' axis line (drawn over the curve, so the body reads when its
#: cylinders are thinner than a few pixels) and of the obstacles' wireframes (thin: a cage of rods
#: around the body must not hide it).
ARM_AXIS_PX, WIREFRAME_PX = 4.0, 1.5
#: The decimal exponents of the integers a ``/scene`` message writes (:meth:`SpatialSceneBuilder.messages`):
#: positions in micrometres, the end point's target in picometres, orientations (quaternion components) in
#: 1e-9 and colours in 1e-3, as the planar scene (:mod:`.scene`) writes its numbers.
SCENE_EXPONENTS = {"position": 6, "target": 12, "orientation": 9, "colour": 3}
#: The unit (a key of :data:`SCENE_EXPONENTS`) of each quantity a ``/scene`` template's slots show.
_SLOT_UNITS = {"base": "position", "joints": "position", "centres": "position", "axes": "orientation",
               "colours": "colour", "target": "target", "curve": "position"}
#: The quaternion (x, y, z, w) of ``Ry(pi/2)``: it turns a cylinder's axis (z) onto the link's x axis.
_Z_TO_X = np.array([0.0, np.sin(np.pi / 4), 0.0, np.cos(np.pi / 4)])


def quaternions(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(x, y, z, w)`` of rotation matrices (Shepperd's method, ``w >= 0``).

    Parameters
    ----------
    R : ndarray, shape (..., 3, 3)
        Rotation matrices.

    Returns
    -------
    ndarray, shape (..., 4)
        The quaternions.
    """
    R = np.asarray(R, float)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    cand = np.stack([  # 4 * (x^2, y^2, z^2, w^2) candidates: the largest gives the best-conditioned row
        1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22, 1 + m00 + m11 + m22], axis=-1)
    k = np.argmax(cand, axis=-1)
    r = np.sqrt(np.maximum(np.take_along_axis(cand, k[..., None], -1)[..., 0], 1e-300)) * 0.5
    a, b, c = R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]
    s01, s02, s12 = R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0], R[..., 1, 2] + R[..., 2, 1]
    rows = np.stack([np.stack([r, s01 / (4 * r), s02 / (4 * r), a / (4 * r)], -1),
                     np.stack([s01 / (4 * r), r, s12 / (4 * r), b / (4 * r)], -1),
                     np.stack([s02 / (4 * r), s12 / (4 * r), r, c / (4 * r)], -1),
                     np.stack([a / (4 * r), b / (4 * r), c / (4 * r), r], -1)], axis=-2)
    q = np.take_along_axis(rows, k[..., None, None], -2)[..., 0, :]
    return q * np.where(q[..., 3:] < 0, -1.0, 1.0)


def quaternion_product(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p q`` of quaternions ``(x, y, z, w)`` (the rotation ``q`` first, then ``p``).

    Parameters
    ----------
    p, q : ndarray, shape (..., 4)
        Quaternions.

    Returns
    -------
    ndarray, shape (..., 4)
        The product.
    """
    px, py, pz, pw = np.moveaxis(np.asarray(p, float), -1, 0)
    qx, qy, qz, qw = np.moveaxis(np.asarray(q, float), -1, 0)
    return np.stack([pw * qx + px * qw + py * qz - pz * qy, pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw, pw * qw - px * qx - py * qy - pz * qz], axis=-1)


def spatial_link_frames(chain: SpatialChain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each link's frame relative to its parent (link j-1; ``world`` for link 1).

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    q : ndarray, shape (n, 2 m)
        Joint coordinates [rad].

    Returns
    -------
    translation : ndarray, shape (n, m, 3)
        Origin of frame j (link j's centre) in frame j-1 [m].
    rotation : ndarray, shape (n, m, 4)
        Quaternion ``(x, y, z, w)`` of frame j in frame j-1 (``Rz(a_j) Ry(b_j)``).
    """
    R, c = link_geometry(chain, q)
    parent_R = np.concatenate([np.broadcast_to(np.eye(3), R[:, :1].shape), R[:, :-1]], axis=1)
    parent_c = np.concatenate([np.zeros_like(c[:, :1]), c[:, :-1]], axis=1)
    trans = np.einsum("nkji,nkj->nki", parent_R, c - parent_c)
    return trans, quaternions(np.swapaxes(parent_R, -1, -2) @ R)


def _vec(v: Any, literal: bool = False) -> dict[str, float]:
    number = length_literal if literal else float
    return {"x": number(v[0]), "y": number(v[1]), "z": number(v[2])}


def _pose(p: Any, quat: Any = (0.0, 0.0, 0.0, 1.0)) -> dict[str, Any]:
    return {"position": _vec(p), "orientation": dict(zip("xyzw", (float(x) for x in quat)))}


def _colour(c: tuple[float, ...]) -> dict[str, float]:
    return dict(zip("rgba", c))


def _line(points: np.ndarray, thickness: float, colour: tuple[float, ...], pixels: bool = False,
          literal: bool = False) -> dict[str, Any]:
    """A ``foxglove.LinePrimitive`` line strip through ``points`` (k, 3) [m] (non-finite points dropped; with
    ``literal``, written as :func:`~.scene_fixed.length_literal` writes lengths), ``thickness`` in px if
    ``pixels`` (the same at any zoom), else in metres."""
    pts = np.asarray(points, float)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    return {"type": 0, "pose": _pose((0, 0, 0)), "thickness": thickness, "scale_invariant": pixels,
            "points": [_vec(p, literal) for p in pts], "color": _colour(colour), "colors": [], "indices": []}


def _axis_line(pose: dict[str, np.ndarray]) -> dict[str, Any]:
    """The links' axes as a ``foxglove.LinePrimitive`` line list (one segment per link, joint to joint,
    coloured as its cylinder), :data:`ARM_AXIS_PX` wide at any zoom; drawn after the curve, which runs
    along the same axes."""
    joints = np.asarray(pose["joints"], float)
    colours = np.repeat(np.asarray(pose["colours"], float), 2, axis=0)
    ends = np.stack([joints[:-1], joints[1:]], axis=1).reshape(-1, 3)
    return {"type": 2, "pose": _pose((0, 0, 0)), "thickness": ARM_AXIS_PX, "scale_invariant": True,
            "points": [_vec(p) for p in ends], "color": _colour((0.0, 0.0, 0.0, 1.0)),
            "colors": [_colour((*c, 1.0)) for c in colours.tolist()], "indices": []}


def _dumps(value: Any) -> str:
    return json.dumps(value, separators=(",", ":"))


def _numbers(t: JsonTemplate, names: str, kind: int, exponent: int, shown: list[int] | None = None,
             end: str = "}") -> list[int]:
    """Append ``{"x":<slot>e-<exponent>,...`` and ``end`` for each of ``names`` (slots of ``kind``: new columns,
    or the ``shown`` ones); returns their columns."""
    out = []
    for i, name in enumerate(names):
        t.text(("{" if i == 0 else ",") + f'"{name}":')
        t.number(kind, None if shown is None else shown[i])
        out.append(t.columns - 1 if shown is None else shown[i])
        t.text(f"e-{exponent}")
    t.text(end)
    return out


def _sphere_slots(t: JsonTemplate, size: float, colour: tuple[float, ...], kind: int, exponent: int) -> list[int]:
    """Append a sphere (or a cube: the same fields) whose position is three slots of ``kind``; returns their
    columns. The rest is :func:`_pose`'s, :func:`_colour`'s text."""
    t.text('{"pose":{"position":')
    cols = _numbers(t, "xyz", kind, exponent)
    t.text(',"orientation":' + _dumps(dict(zip("xyzw", (0.0, 0.0, 0.0, 1.0)))) + '},"size":' +
           _dumps({"x": size, "y": size, "z": size}) + ',"color":' + _dumps(_colour(colour)) + "}")
    return cols


class SpatialSceneBuilder(SceneBuilder):
    """Builds the ``/scene``, ``/tf`` and ``/tracking`` messages of a spatial run, block by block.

    The same interface as :class:`~.scene.SceneBuilder`: feed every block of steps to :meth:`advance`,
    then ask :meth:`messages` for the rows to draw.

    Parameters
    ----------
    ctrl : SpatialController
        The run's controller (chain and 3-D curve).
    obstacles : array_like
        The scenario's 3-D obstacles (drawn as wireframes, :func:`~.obstacles3d.wireframe`).
    radius : float, optional
        The links' capsule radius [m] (``[chain] radius``): each link is drawn as the capsule the physical
        checks use, a cylinder of that radius with a sphere of that radius at each end. None: thin
        cylinders (``0.12 xi``) with larger joint spheres.
    frames : {"ends", "all"}
        ``/tf``: the frames ``base`` (at the origin) and ``tip`` (the free end of link m, oriented as
        ``R_m``), or a frame per link.

    Attributes
    ----------
    TRACKING_FIELDS : tuple of (str, int)
        The fields of the ``/tracking`` record (all scalars, float64, in order): the planar first eight
        with the target's ``z`` after its ``y``, the roll and its command [rad], then ``log10 max|e|``,
        ``s - s_target`` [m] and ``log10 |s - s_target|``.
    """

    TRACKING_FIELDS = SPATIAL_TRACKING_FIELDS

    def __init__(self, ctrl: Any, obstacles: Any, radius: float | None = None, frames: str = "ends") -> None:
        super().__init__(ctrl, [], frames)
        xi = ctrl.chain.xi
        self.radius = 0.12 * xi if radius is None else float(radius)     # of the link cylinders [m]
        d = 2.6 * self.radius if radius is None else 2 * self.radius  # capsules: caps of the radius
        self._sizes = {"joint": length_literal(d), "base": length_literal(2 * d),      # as the scene writes them
                       "target": length_literal(max(1.2 * xi, 0.05)),
                       "cylinder": {"x": length_literal(2 * self.radius), "y": length_literal(2 * self.radius),
                                    "z": length_literal(xi)}}
        self._path_points: np.ndarray | None = None     # a path's polyline (it does not move)
        ends = rail_ends(ctrl.chain, self.reach)         # the rail between its limits, under the walls
        rail = [] if ends is None else [_line(ends, length_literal(0.02 * xi + 0.004), RAIL_COLOR, literal=True)]
        walls = [_line(p, WIREFRAME_PX, WALL_COLOR, pixels=True, literal=True)
                 for ob in obstacles for p in wireframe(ob)]
        self._fixed_lines = tuple(_dumps(line) for line in rail + walls)        # /scene/fixed's
        self._templates3d: dict[tuple[int, int], tuple[JsonTemplate, dict[str, list[int]]]] = {}

    def curves(self, times: np.ndarray) -> list[np.ndarray]:
        """The curve at each of ``times`` as a 3-D polyline (a line: its two ends; a path, which does not
        move, sampled once).

        Parameters
        ----------
        times : ndarray, shape (k,)
            Times [s].

        Returns
        -------
        list of ndarray, each shape (n, 3)
            One polyline [m] per time.
        """
        curve = self.ctrl.curve
        if getattr(curve, "kind", "") == "line":         # its two ends, as sample(t, n=2, extent=reach) draws them
            ends = curve.points_at(np.tile([-self.reach, self.reach], len(times)), np.repeat(times, 2))
            return list(ends.reshape(-1, 2, 3))
        if getattr(curve, "kind", "") in ("path", "waypoints"):
            if self._path_points is None:
                self._path_points = curve.sample(0.0, n=300, extent=0.25 * self.reach)
            return [self._path_points] * len(times)
        return [curve.sample(float(t), n=300, extent=0.25 * self.reach) for t in times]

    def targets(self, part: Any, ks: np.ndarray) -> np.ndarray:
        """The end point's target on the curve at rows ``ks`` of ``part`` (its end point's centre if the
        curve cannot map an arc length to a point).

        Parameters
        ----------
        part : Run
            The block last given to :meth:`advance`.
        ks : ndarray of int, shape (k,)
            Its rows.

        Returns
        -------
        ndarray, shape (k, 3)
            The target points [m].
        """
        try:
            return self.ctrl.curve.points_at(self.s_target[ks], part.t[ks])
        except (AttributeError, TypeError, NotImplementedError):
            return link_geometry(self.ctrl.chain, part.q[ks])[1][:, -1]

    def scene_entity(self, pose: dict[str, np.ndarray], curve: np.ndarray, target: np.ndarray,
                     ns: int) -> dict[str, Any]:
        """The ``foxglove.SceneEntity`` of one pose.

        Parameters
        ----------
        pose : dict of str to ndarray
            ``centres`` (m, 3) [m], ``axes`` (m, 4) (quaternions turning z onto ``d_j``), ``joints``
            (m+1, 3) [m] and ``base`` (3,) [m] of the chain (see :meth:`poses`).
        curve : ndarray, shape (n, 3)
            The curve's polyline [m].
        target : ndarray, shape (3,)
            The end point's target [m].
        ns : int
            Time stamp [ns].

        Returns
        -------
        dict
            The entity (id ``"coordarm"``, frame ``world``).
        """
        sizes = self._sizes
        cylinders = [{"pose": _pose(c, a), "size": dict(sizes["cylinder"]), "bottom_scale": 1,
                      "top_scale": 1, "color": _colour((*rgb, 1.0))}
                     for c, a, rgb in zip(pose["centres"], pose["axes"], pose["colours"].tolist())]
        d, big, b = sizes["joint"], sizes["target"], sizes["base"]
        spheres = [{"pose": _pose(p), "size": {"x": d, "y": d, "z": d}, "color": _colour(JOINT_COLOR)}
                   for p in pose["joints"]]
        spheres.append({"pose": _pose(target), "size": {"x": big, "y": big, "z": big}, "color": _colour(TARGET_COLOR)})
        base = {"pose": _pose(pose["base"]), "size": {"x": b, "y": b, "z": b}, "color": _colour(JOINT_COLOR)}
        return {"timestamp": {"sec": int(ns // 10**9), "nsec": int(ns % 10**9)}, "frame_id": "world",
                "id": "coordarm", "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False, "metadata": [],
                "arrows": [], "cubes": [base], "spheres": spheres, "cylinders": cylinders,
                "lines": [_line(curve, CURVE_PX, CURVE_COLOR, pixels=True), _axis_line(pose)],
                "triangles": [], "texts": [],
                "models": []}

    def _scenes(self, drawn: dict[str, np.ndarray], colours: np.ndarray, curves: list[np.ndarray],
                targets: np.ndarray, ns: np.ndarray) -> list[bytes]:
        """The ``/scene`` messages of k poses (``drawn``: :meth:`pose_arrays`): the integers of each
        (:data:`SCENE_EXPONENTS`) filled into one template (:class:`~.json_fill.JsonTemplate`). Poses whose curves differ in length, or with a number that is not finite, are encoded from
        :meth:`scene_entity` instead."""
        k, sizes = len(colours), {len(c) for c in curves}
        data = {**drawn, "colours": colours, "target": targets, "curve": curves}
        blocks = {key: np.asarray(v, float).reshape(k, -1) for key, v in data.items()} if len(sizes) == 1 else {}
        if not blocks or not all(np.isfinite(b).all() for b in blocks.values()):
            poses = [{**dict(zip(drawn, row)), "colours": rgb} for *row, rgb in zip(*drawn.values(), colours)]
            return [json.dumps({"deletions": [], "entities": [self.scene_entity(p, c, x, n)]},
                               separators=(",", ":")).encode() for p, c, x, n in zip(poses, curves, targets, np.asarray(ns).tolist())]
        template, columns = self._scene_template(self.ctrl.chain.m, sizes.pop())
        values = np.empty((k, template.columns), np.int64)
        values[:, columns["stamp"]] = stamps(ns)
        for key, block in blocks.items():
            values[:, columns[key]] = np.round(block * 10.0 ** SCENE_EXPONENTS[_SLOT_UNITS[key]])
        return template.fill(values)

    def _scene_template(self, m: int, curve_points: int) -> tuple[JsonTemplate, dict[str, list[int]]]:
        """The ``foxglove.SceneUpdate`` of :meth:`scene_entity` with integer slots (:data:`SCENE_EXPONENTS`) and
        the columns of each quantity: ``stamp`` (sec, nsec), ``base``, ``joints``, ``centres`` (x, y, z each),
        ``axes`` (x, y, z, w each), ``colours`` (r, g, b each), ``target``, ``curve`` (x, y, z each); the axis line
        shows the joints' and the colours' columns again."""
        key = (m, curve_points)
        if key in self._templates3d:
            return self._templates3d[key]
        sizes = self._sizes
        exp = SCENE_EXPONENTS
        t = stamp_slots(JsonTemplate(kinds=6).text('{"deletions":[],"entities":[{"timestamp":'))
        columns: dict[str, list[int]] = {"stamp": [0, 1]}

        t.text(',"frame_id":"world","id":"coordarm","lifetime":{"sec":0,"nsec":0},"frame_locked":false,'
               '"metadata":[],"arrows":[],"cubes":[')
        columns["base"] = _sphere_slots(t, sizes["base"], JOINT_COLOR, 2, exp["position"])
        t.text('],"spheres":[')
        columns["joints"] = []
        for j in range(m + 1):
            columns["joints"] += _sphere_slots(t, sizes["joint"], JOINT_COLOR, 2, exp["position"])
            t.text(",")
        columns["target"] = _sphere_slots(t, sizes["target"], TARGET_COLOR, 4, exp["target"])
        t.text('],"cylinders":[')
        columns["centres"], columns["axes"], columns["colours"] = [], [], []
        for j in range(m):
            t.text(("," if j else "") + '{"pose":{"position":')
            columns["centres"] += _numbers(t, "xyz", 2, exp["position"])
            t.text(',"orientation":')
            columns["axes"] += _numbers(t, "xyzw", 3, exp["orientation"])
            t.text('},"size":' + _dumps(sizes["cylinder"]) + ',"bottom_scale":1,"top_scale":1,"color":')
            columns["colours"] += _numbers(t, "rgb", 5, exp["colour"], end=',"a":1.0}}')
        t.text('],"lines":[')
        curve = _line(np.zeros((0, 3)), CURVE_PX, CURVE_COLOR, pixels=True)
        head, tail = _dumps(curve).split('"points":[]')
        t.text(head + '"points":[')
        columns["curve"] = []
        for i in range(curve_points):
            t.text("," if i else "")
            columns["curve"] += _numbers(t, "xyz", 2, exp["position"])
        t.text("]" + tail)
        t.text(",")
        axis = _axis_line({"joints": np.zeros((1, 3)), "colours": np.zeros((0, 3))})
        head, tail = _dumps(axis).split('"points":[]')
        middle, tail = tail.split('"colors":[]')
        t.text(head + '"points":[')
        joints = columns["joints"]
        for j in range(m):
            for end in (j, j + 1):
                t.text("," if (j or end) else "")
                _numbers(t, "xyz", 2, exp["position"], joints[3 * end:3 * end + 3])
        t.text("]" + middle + '"colors":[')
        rgb = columns["colours"]
        for j in range(2 * m):                  # both ends of link j in its cylinder's colour
            t.text("," if j else "")
            _numbers(t, "rgb", 5, exp["colour"], rgb[3 * (j // 2):3 * (j // 2) + 3], end=',"a":1.0}')
        t.text("]" + tail + '],"triangles":[],"texts":[],"models":[]}]}')
        self._templates3d[key] = t, columns
        return t, columns

    def poses(self, q: np.ndarray) -> list[dict[str, np.ndarray]]:
        """The chain's drawn geometry at each row of ``q`` (computed for all rows at once).

        Parameters
        ----------
        q : ndarray, shape (k, dof)
            Joint coordinates [rad] (``d`` [m] first on a rail).

        Returns
        -------
        list of dict
            Per row: ``centres`` (m, 3) [m] (the cylinders' centres ``y^j``), ``axes`` (m, 4) (quaternions
            ``(x, y, z, w)`` of ``R_j Ry(pi/2)``: the cylinder's z axis along ``d_j``), ``joints`` (m+1, 3) [m]
            and ``base`` (3,) [m] (the origin, or ``d`` along the rail); the caller adds ``colours`` (m, 3)
            (:func:`~.scene.margin_colours`) before :meth:`scene_entity`.
        """
        drawn = self.pose_arrays(q)
        return [dict(zip(drawn, row)) for row in zip(*drawn.values())]

    def pose_arrays(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """:meth:`poses` as arrays over the rows: ``base`` (k, 3), ``joints`` (k, m+1, 3), ``centres`` (k, m, 3)
        [m] and ``axes`` (k, m, 4).

        Parameters
        ----------
        q : ndarray, shape (k, dof)
            Joint coordinates [rad] (``d`` [m] first on a rail).

        Returns
        -------
        dict of str to ndarray
            The chain's drawn geometry, the rows first.
        """
        chain = self.ctrl.chain
        frames, centres = link_geometry(chain, q)
        return {"base": chain.base_point(q), "joints": joints_of(chain, frames[..., 0], centres), "centres": centres,
                "axes": quaternion_product(quaternions(frames), _Z_TO_X)}

    def frame_transforms(self, q: np.ndarray, ns: np.ndarray) -> list[bytes]:
        """The ``foxglove.FrameTransforms`` of poses ``q`` (k, 2m) stamped ``ns`` [ns], one JSON each.

        Parameters
        ----------
        q : ndarray, shape (k, 2 m)
            Joint coordinates [rad].
        ns : ndarray of int, shape (k,)
            Time stamps [ns].

        Returns
        -------
        list of bytes
            One message per pose.
        """
        chain = self.ctrl.chain
        if self.frames == "all":
            trans, rot = spatial_link_frames(chain, q)
            parents = ["world"] + [f"link{j}" for j in range(1, chain.m)]
            children = [f"link{j}" for j in range(1, chain.m + 1)]
        else:   # world -> base (the first central point, unturned), world -> tip (last joint, R_m)
            frames, centres = link_geometry(chain, q)
            joints = joints_of(chain, frames[..., 0], centres)
            trans = np.stack([centres[:, 0], joints[:, -1]], axis=1)
            rot = np.stack([np.broadcast_to([0.0, 0.0, 0.0, 1.0], (len(q), 4)),
                            quaternions(frames[:, -1])], axis=1)
            parents, children = ["world", "world"], ["base", "tip"]
        out = []
        for n, tr, ro in zip(np.asarray(ns).tolist(), trans, rot):
            stamp = {"sec": int(n // 10**9), "nsec": int(n % 10**9)}
            out.append(json.dumps({"transforms": [
                {"timestamp": stamp, "parent_frame_id": parent, "child_frame_id": child, "translation": _vec(tr[j]),
                 "rotation": dict(zip("xyzw", ro[j].tolist()))} for j, (parent, child) in enumerate(zip(parents, children))]},
                separators=(",", ":")).encode())
        return out

    def messages(self, part: Any, ks: np.ndarray, ns: np.ndarray) -> list[tuple[str, int, bytes]]:
        """``(channel key, log time, data)`` of the scene, frame transforms and tracking at rows ``ks``.

        Parameters
        ----------
        part : Run
            The block last given to :meth:`advance` (``q`` (N, 2m), ``e``, ``s``, ``roll``, ``link_margins``, ``u``).
        ks : ndarray of int, shape (k,)
            Its rows to draw.
        ns : ndarray of int, shape (k,)
            Log time of each row [ns].

        Returns
        -------
        list of (str, int, bytes)
            ``("scene" | "tf" | "tracking", log time [ns], message)``, three per row, in row order, after
            ``("fixed", ...)`` the first time (:meth:`fixed_first`); the tracking record holds
            :attr:`TRACKING_FIELDS`.
        """
        ks = np.asarray(ks, int)
        if not len(ks):
            return []
        q, t = part.q[ks], np.asarray(part.t, float)[ks]
        curves, targets = self.curves(t), self.targets(part, ks)
        roll_target = roll_command(self.ctrl, t)
        max_e, s_error = np.max(np.abs(part.e[ks]), axis=1), part.s[ks] - self.s_target[ks]
        tracking = np.column_stack([t, part.s[ks], self.s_target[ks], targets, max_e,
                                    np.min(part.link_margins[ks], axis=1), np.linalg.norm(part.u[ks], axis=1),
                                    part.roll[ks], roll_target, log10_floored(max_e), s_error, log10_floored(s_error)])
        colours = margin_colours(part.link_margins[ks])
        scenes = self._scenes(self.pose_arrays(q), colours, curves, targets, ns)
        out = []
        for i, (n, tf) in enumerate(zip(np.asarray(ns).tolist(), self.frame_transforms(q, ns))):
            out.append(("scene", n, scenes[i]))
            out.append(("tf", n, tf))
            out.append(("tracking", n, CDR_HEADER + tracking[i].astype("<f8").tobytes()))
        return self.fixed_first(out, ns)

