"""Plane geometry of segments, vectorised with numpy: intersection, distances, self-contacts.

Used by the start construction (no self-intersection) and by the physical checks of a run
(:mod:`coordarm.simulation.physical`). Every function broadcasts over leading axes.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z-component of ``(a - o) x (b - o)``, broadcast over leading axes.

    Parameters
    ----------
    o, a, b : ndarray, shape (..., 2)
        Points [m].

    Returns
    -------
    ndarray, shape (...)
        The cross products [m^2]; positive when ``o, a, b`` turn counter-clockwise.
    """
    return (a[..., 0] - o[..., 0]) * (b[..., 1] - o[..., 1]) - (a[..., 1] - o[..., 1]) * (b[..., 0] - o[..., 0])


def segments_intersect(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Whether segments ``p1p2`` and ``q1q2`` intersect (touching counts), broadcast.

    Parameters
    ----------
    p1, p2 : ndarray, shape (..., 2)
        End points of the first segments [m].
    q1, q2 : ndarray, shape (..., 2)
        End points of the second segments [m].

    Returns
    -------
    ndarray of bool, shape (...)
        True where the segments cross or touch.
    """
    d1, d2 = cross(q1, q2, p1), cross(q1, q2, p2)
    d3, d4 = cross(p1, p2, q1), cross(p1, p2, q2)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)

    def on(o, a, b, d):  # b collinear with o-a and inside its bounding box
        return (d == 0) & (np.minimum(o[..., 0], a[..., 0]) <= b[..., 0]) & (b[..., 0] <= np.maximum(o[..., 0], a[..., 0])) \
            & (np.minimum(o[..., 1], a[..., 1]) <= b[..., 1]) & (b[..., 1] <= np.maximum(o[..., 1], a[..., 1]))
    return proper | on(q1, q2, p1, d1) | on(q1, q2, p2, d2) | on(p1, p2, q1, d3) | on(p1, p2, q2, d4)


def point_segment_distance(p: ArrayLike, a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Distance [m] from points ``p`` to segments ``ab``, broadcast over leading axes.

    Parameters
    ----------
    p : array_like, shape (..., 2)
        Points [m].
    a, b : array_like, shape (..., 2)
        End points of the segments [m].

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    p, a, b = np.asarray(p, float), np.asarray(a, float), np.asarray(b, float)
    ab = b - a
    den = np.sum(ab * ab, axis=-1)
    tpar = np.clip(np.sum((p - a) * ab, axis=-1) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    return np.linalg.norm(p - (a + tpar[..., None] * ab), axis=-1)


def segment_distance(p1: ArrayLike, p2: ArrayLike, q1: ArrayLike, q2: ArrayLike) -> np.ndarray:
    """Distance [m] between segments ``p1p2`` and ``q1q2`` (exactly 0 when they intersect), broadcast.

    Parameters
    ----------
    p1, p2 : array_like, shape (..., 2)
        End points of the first segments [m].
    q1, q2 : array_like, shape (..., 2)
        End points of the second segments [m].

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    d = np.minimum(np.minimum(point_segment_distance(p1, q1, q2), point_segment_distance(p2, q1, q2)),
                   np.minimum(point_segment_distance(q1, p1, p2), point_segment_distance(q2, p1, p2)))
    return np.where(segments_intersect(p1, p2, q1, q2), 0.0, d)


def touching(distance: np.ndarray, clearance: float) -> np.ndarray:
    """Contact: the distance is 0 (touching or crossing) or below ``clearance`` [m].

    Parameters
    ----------
    distance : ndarray
        Distances [m], any shape.
    clearance : float
        Smallest allowed distance [m].

    Returns
    -------
    ndarray of bool, same shape as ``distance``
        True where in contact.
    """
    return (distance <= 0.0) | (distance < clearance)


def self_distances(joints: np.ndarray, clearance: float = 0.0
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Distances of the pairs of non-adjacent links that may be within ``clearance`` of each other.

    Sort and sweep: per sample the link centres are sorted along the principal axis of the
    body and only links whose centres are within ``xi + clearance`` along that axis are
    compared (two links of length ``xi`` closer than ``clearance`` have centres that close);
    of those, pairs whose bounding boxes are more than ``clearance`` apart are dropped
    before the exact distance. A compact or stretched chain costs O(m log m) per sample
    (a chain piled onto itself up to O(m^2)).

    Parameters
    ----------
    joints : (N, m+1, 2) array
        Link end points (``PlanarChain.joints_np``); link j (1-based) joins rows j-1 and j.
    clearance : float
        Distance of interest [m] (>= 0).

    Returns
    -------
    sample, link_a, link_b : int arrays (K,)
        0-based sample and 1-based links (``link_a < link_b - 1``) of each compared pair;
        every pair closer than or at ``clearance`` is among them.
    distance : float array (K,)
        Their distance [m] (0 when they cross or touch).
    """
    joints = np.asarray(joints, dtype=float)
    a, b = joints[:, :-1], joints[:, 1:]
    c = 0.5 * (a + b)
    n, m = c.shape[:2]
    if n == 0 or m < 3:
        empty = np.zeros(0, dtype=int)
        return empty, empty, empty, np.zeros(0)
    reach = float(np.max(np.linalg.norm(b - a, axis=-1))) + clearance
    d = c - c.mean(axis=1, keepdims=True)
    sxx, syy, sxy = (d[..., 0] ** 2).sum(1), (d[..., 1] ** 2).sum(1), (d[..., 0] * d[..., 1]).sum(1)
    th = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    x = d[..., 0] * np.cos(th)[:, None] + d[..., 1] * np.sin(th)[:, None]
    order = np.argsort(x, axis=1)
    xs = np.take_along_axis(x, order, axis=1)
    lo = np.take_along_axis(np.minimum(a, b), order[..., None], axis=1)   # bounding boxes, in sorted order
    hi = np.take_along_axis(np.maximum(a, b), order[..., None], axis=1)
    found: list[tuple[np.ndarray, ...]] = []
    for k in range(1, m):
        near = xs[:, k:] - xs[:, :-k] <= reach
        if not near.any():
            break
        gap = np.maximum(lo[:, k:] - hi[:, :-k], lo[:, :-k] - hi[:, k:]).max(axis=-1)   # box separation
        near &= (gap <= clearance) & (np.abs(order[:, k:] - order[:, :-k]) >= 2)
        s, i = np.nonzero(near)
        la, lb = order[s, i], order[s, i + k]
        found.append((s, np.minimum(la, lb), np.maximum(la, lb)))
    s, la, lb = (np.concatenate(v) for v in zip(*found)) if found else (np.zeros(0, dtype=int),) * 3
    dist = segment_distance(a[s, la], b[s, la], a[s, lb], b[s, lb])
    return s, la + 1, lb + 1, dist
