"""Wall segments and the check that no link crosses one."""
from __future__ import annotations

import numpy as np


def _cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z-component of ``(a - o) x (b - o)``, broadcast over leading axes."""
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (b[..., 0] - o[..., 0])


def segments_intersect(p1, p2, q1, q2) -> np.ndarray:
    """Whether segments ``p1p2`` and ``q1q2`` intersect (touching counts), broadcast."""
    d1, d2 = _cross(q1, q2, p1), _cross(q1, q2, p2)
    d3, d4 = _cross(p1, p2, q1), _cross(p1, p2, q2)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)

    def on(o, a, b, d):  # b collinear with o-a and inside its bounding box
        return (d == 0) & (np.minimum(o[..., 0], a[..., 0]) <= b[..., 0]) & (b[..., 0] <= np.maximum(o[..., 0], a[..., 0])) \
            & (np.minimum(o[..., 1], a[..., 1]) <= b[..., 1]) & (b[..., 1] <= np.maximum(o[..., 1], a[..., 1]))
    return proper | on(q1, q2, p1, d1) | on(q1, q2, p2, d2) | on(p1, p2, q1, d3) | on(p1, p2, q2, d4)


def wall_crossings(joints: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Indices ``(sample, link, wall)`` where a link touches or crosses a wall.

    Parameters
    ----------
    joints : (N, m+1, 2) array
        Link end points over time (``PlanarChain.joints_np``); link j (1-based) joins
        ``joints[:, j-1]`` and ``joints[:, j]``.
    walls : (W, 2, 2) array
        Wall segments ``(a, b)``.

    Returns
    -------
    (K, 3) int array
        One row per contact, with 0-based sample and wall and 1-based link.
    """
    joints = np.asarray(joints, dtype=float)
    walls = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
    if walls.shape[0] == 0:
        return np.zeros((0, 3), dtype=int)
    p1, p2 = joints[:, :-1, None, :], joints[:, 1:, None, :]
    hit = segments_intersect(p1, p2, walls[None, None, :, 0, :], walls[None, None, :, 1, :])
    idx = np.argwhere(hit)
    idx[:, 1] += 1
    return idx


def clearance(joints: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Smallest distance from any link end point to any wall, per sample [m], shape (N,)."""
    walls = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
    if walls.shape[0] == 0:
        return np.full(len(joints), np.inf)
    a, b = walls[:, 0], walls[:, 1]
    ab = b - a
    p = np.asarray(joints, dtype=float)[:, :, None, :]
    tpar = np.clip(np.sum((p - a) * ab, axis=-1) / np.sum(ab * ab, axis=-1), 0.0, 1.0)
    d = np.linalg.norm(p - (a + tpar[..., None] * ab), axis=-1)
    return d.min(axis=(1, 2))
