"""Plane geometry of segments, vectorised with numpy: intersection, distances, self-contacts.

Used by the start construction (no self-intersection) and by the physical checks of a run
(:mod:`coordarm.simulation.physical`). Every function broadcasts over leading axes.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
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
    return _cross(o[..., 0], o[..., 1], a[..., 0], a[..., 1], b[..., 0], b[..., 1])


def _cross(ox, oy, ax, ay, bx, by):
    return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox)


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
    return _intersect(*_xy(p1, p2, q1, q2))


def _xy(*points: ArrayLike) -> list[np.ndarray]:
    """The x and y components of each point array ``(..., 2)``, in order: ``x1, y1, x2, y2, ...``."""
    out = []
    for p in points:
        p = np.asarray(p, float)
        out += [p[..., 0], p[..., 1]]
    return out


def _intersect(p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y):
    """:func:`segments_intersect` on components (each ``(...)``)."""
    d1, d2 = _cross(q1x, q1y, q2x, q2y, p1x, p1y), _cross(q1x, q1y, q2x, q2y, p2x, p2y)
    d3, d4 = _cross(p1x, p1y, p2x, p2y, q1x, q1y), _cross(p1x, p1y, p2x, p2y, q2x, q2y)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)

    def on(ox, oy, ax, ay, bx, by, d):  # b collinear with o-a and inside its bounding box
        return (d == 0) & (np.minimum(ox, ax) <= bx) & (bx <= np.maximum(ox, ax)) \
            & (np.minimum(oy, ay) <= by) & (by <= np.maximum(oy, ay))
    return proper | on(q1x, q1y, q2x, q2y, p1x, p1y, d1) | on(q1x, q1y, q2x, q2y, p2x, p2y, d2) \
        | on(p1x, p1y, p2x, p2y, q1x, q1y, d3) | on(p1x, p1y, p2x, p2y, q2x, q2y, d4)


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
    return _point_segment(*_xy(p, a, b))


def _point_segment(px, py, ax, ay, bx, by):
    """:func:`point_segment_distance` on components: the same operations in the same order
    (``x*x + y*y`` is what ``np.sum``/``np.linalg.norm`` compute over an axis of two)."""
    abx, aby = bx - ax, by - ay
    den = abx * abx + aby * aby
    tpar = np.clip(((px - ax) * abx + (py - ay) * aby) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    rx, ry = px - (ax + tpar * abx), py - (ay + tpar * aby)
    return np.sqrt(rx * rx + ry * ry)


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
    return _segment(*_xy(p1, p2, q1, q2))


def _segment(p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y):
    """:func:`segment_distance` on components (each ``(...)``)."""
    d = np.minimum(np.minimum(_point_segment(p1x, p1y, q1x, q1y, q2x, q2y), _point_segment(p2x, p2y, q1x, q1y, q2x, q2y)),
                   np.minimum(_point_segment(q1x, q1y, p1x, p1y, p2x, p2y), _point_segment(q2x, q2y, p1x, p1y, p2x, p2y)))
    return np.where(_intersect(p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y), 0.0, d)


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
    n, m = joints.shape[0], joints.shape[1] - 1
    if n == 0 or m < 3:
        empty = np.zeros(0, dtype=int)
        return empty, empty, empty, np.zeros(0)
    jx, jy = joints[..., 0], joints[..., 1]          # components: (n, m+1) each, no (..., 2) reductions
    ax, ay, bx, by = jx[:, :-1], jy[:, :-1], jx[:, 1:], jy[:, 1:]
    dx, dy = bx - ax, by - ay
    reach = float(np.sqrt(np.max(dx * dx + dy * dy))) + clearance
    cx, cy = 0.5 * (ax + bx), 0.5 * (ay + by)
    ux, uy = cx - cx.mean(axis=1, keepdims=True), cy - cy.mean(axis=1, keepdims=True)
    sxx, syy, sxy = (ux * ux).sum(1), (uy * uy).sum(1), (ux * uy).sum(1)
    th = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    x = ux * np.cos(th)[:, None] + uy * np.sin(th)[:, None]
    order = np.argsort(x, axis=1)
    flat = order + (np.arange(n) * m)[:, None]             # sorted order, as flat indices
    xs = x.ravel()[flat]
    lox, hix = np.minimum(ax, bx).ravel()[flat], np.maximum(ax, bx).ravel()[flat]   # bounding boxes, sorted
    loy, hiy = np.minimum(ay, by).ravel()[flat], np.maximum(ay, by).ravel()[flat]
    found: list[tuple[np.ndarray, ...]] = []
    for k in range(1, m):
        near = xs[:, k:] - xs[:, :-k] <= reach
        if not near.any():
            break
        gap = np.maximum(np.maximum(lox[:, k:] - hix[:, :-k], lox[:, :-k] - hix[:, k:]),      # box separation
                         np.maximum(loy[:, k:] - hiy[:, :-k], loy[:, :-k] - hiy[:, k:]))
        near &= (gap <= clearance) & (np.abs(order[:, k:] - order[:, :-k]) >= 2)
        s, i = np.nonzero(near)
        la, lb = order[s, i], order[s, i + k]
        found.append((s, np.minimum(la, lb), np.maximum(la, lb)))
    s, la, lb = (np.concatenate(v) for v in zip(*found)) if found else (np.zeros(0, dtype=int),) * 3
    fa, fb = s * (m + 1) + la, s * (m + 1) + lb             # first end of each link, flat
    x1, y1 = jx.ravel(), jy.ravel()
    dist = _segment(x1[fa], y1[fa], x1[fa + 1], y1[fa + 1], x1[fb], y1[fb], x1[fb + 1], y1[fb + 1])
    return s, la + 1, lb + 1, dist
