"""The ``/tf`` messages of a planar run (``foxglove.FrameTransforms`` JSON): the frames ``base`` and ``tip``
(:func:`end_frames_json`) or a frame per link (:func:`frame_transforms_json`, from :func:`link_frames`),
their numbers written into :class:`~.json_fill.JsonTemplate` slots (see :mod:`.scene`)."""
from __future__ import annotations

import numpy as np

from .json_fill import JsonTemplate


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


def stamp_slots(template: JsonTemplate) -> JsonTemplate:
    """Append a ``foxglove`` time whose ``sec`` and ``nsec`` are slots of kinds 0 and 1.

    Parameters
    ----------
    template : JsonTemplate
        The template to extend (at least two slot kinds).

    Returns
    -------
    JsonTemplate
        ``template``.
    """
    return template.text('{"sec":').number(0).text(',"nsec":').number(1).text("}")


def stamps(ns: list[int] | np.ndarray) -> np.ndarray:
    """``(sec, nsec)`` columns of log times ``ns`` [ns].

    Parameters
    ----------
    ns : list of int or ndarray, shape (k,)
        Log times [ns].

    Returns
    -------
    int64 ndarray, shape (k, 2)
        Whole seconds and the nanoseconds after them.
    """
    ns = np.asarray(ns, np.int64)
    return np.column_stack([ns // 10**9, ns % 10**9])


def frame_values(ns: list[int] | np.ndarray, translations: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """The integers of frame transforms about z, as the ``/tf`` templates take them.

    Parameters
    ----------
    ns : list of int or ndarray, shape (n,)
        Time stamp of each pose [ns].
    translations : ndarray, shape (n, k, 2)
        Origin of each of the k frames of each pose [m].
    angles : ndarray, shape (n, k)
        Rotation of each frame about z [rad].

    Returns
    -------
    int64 ndarray, shape (n, 6 k)
        Per frame: sec, nsec, x, y [nm], the quaternion's z, w [1e-15].
    """
    n, k = np.shape(angles)
    values = np.empty((n, k, 6), np.int64)
    values[..., :2] = stamps(ns)[:, None, :]
    values[..., 2:4] = np.round(translations * 1e9)
    values[..., 4] = np.round(np.sin(0.5 * angles) * 1e15)
    values[..., 5] = np.round(np.cos(0.5 * angles) * 1e15)
    return values.reshape(n, -1)


_TF_TEMPLATES: dict[int, JsonTemplate] = {}


def _tf_template(m: int) -> JsonTemplate:
    """The ``foxglove.FrameTransforms`` of m links, slots (sec, nsec, x, y [nm], z, w [1e-15]) per link."""
    if m not in _TF_TEMPLATES:
        t = JsonTemplate(kinds=4).text('{"transforms":[')
        for j in range(m):
            stamp_slots(t.text("," if j else "").text('{"timestamp":'))
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
    return _tf_template(angle.shape[1]).fill(frame_values(ns, trans, angle))


_END_TEMPLATE = JsonTemplate(kinds=4).text('{"transforms":[')
for _j, _name in enumerate(("base", "tip")):
    stamp_slots(_END_TEMPLATE.text("," if _j else "").text('{"timestamp":'))
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
    d = joints[:, -1] - joints[:, -2]
    angles = np.column_stack([np.full(len(joints), base_angle), np.arctan2(d[:, 1], d[:, 0])])
    return _END_TEMPLATE.fill(frame_values(ns, np.stack([np.asarray(base, float), joints[:, -1]], axis=1), angles))
