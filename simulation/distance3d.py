"""Distances in 3-D from segments (capsule axes) to points, segments, boxes and plates with holes, vectorised.

Every function broadcasts over leading axes. Segment-segment, point-segment and segment-box
distances are closed form (the box: the squared distance along the segment is a convex
piecewise quadratic with at most six breakpoints, minimised piece by piece). A plate is the
product of its in-plane region (a square or the whole plane, minus the holes) and the slab
``|w| <= T/2``, so the distance of a point is ``sqrt(delta_Q^2 + (|w| - T/2)_+^2)``; along a
segment it is minimised on every piece between the parameters where the segment enters or
leaves the slab, the square or a hole (and crosses a rectangular hole's diagonals): the pieces'
ends exactly, and inside each piece a golden-section search. On every piece the distance is
linear, concave (inside a hole, within the slab) or convex, except above or below a circular
hole, where the nearest point is on the rim and the search assumes one minimum per piece
(the exact line-circle distance would need a quartic).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from coordarm.generated.segment_distance import point_segment, segment_box, segment_plate, segment_segment

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: Golden-section iterations on a piece of a segment near a plate (interval shrinks by 0.618 each).
GOLDEN_STEPS = 50


def point_segment_distance3(p: ArrayLike, a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Distance [m] from points ``p`` to segments ``ab`` in 3-D: :func:`point_segment_distance3_numpy`, computed
    in C where a compiler works (:mod:`coordarm.generated.segment_distance`: the same values to the last bit).

    Parameters
    ----------
    p, a, b : array_like, shape (..., 3)
        Points and the segments' ends [m].

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    out = point_segment(p, a, b)
    return point_segment_distance3_numpy(p, a, b) if out is None else out


def point_segment_distance3_numpy(p: ArrayLike, a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Distance [m] from points ``p`` to segments ``ab`` in 3-D (the reference of the C kernel).

    Parameters
    ----------
    p, a, b : array_like, shape (..., 3)
        Points and the segments' ends [m].

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    p, a, b = np.asarray(p, float), np.asarray(a, float), np.asarray(b, float)
    ab = b - a
    den = np.sum(ab * ab, axis=-1)
    s = np.clip(np.sum((p - a) * ab, axis=-1) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    return np.linalg.norm(p - (a + s[..., None] * ab), axis=-1)


def segment_segment_distance(p1: ArrayLike, p2: ArrayLike, q1: ArrayLike, q2: ArrayLike) -> np.ndarray:
    """Distance [m] between segments ``p1p2`` and ``q1q2`` in 3-D: :func:`segment_segment_distance_numpy`,
    computed in C where a compiler works (:mod:`coordarm.generated.segment_distance`: the same values to the
    last bit, ~20x faster).

    Parameters
    ----------
    p1, p2, q1, q2 : array_like, shape (..., 3)
        Ends of the first and second segments [m].

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    out = segment_segment(p1, p2, q1, q2)
    return segment_segment_distance_numpy(p1, p2, q1, q2) if out is None else out


def segment_segment_distance_numpy(p1: ArrayLike, p2: ArrayLike, q1: ArrayLike, q2: ArrayLike) -> np.ndarray:
    """Distance [m] between segments ``p1p2`` and ``q1q2`` in 3-D, closest points in closed form (the
    reference of the C kernel).

    The parameter on the first segment is that of the infinite lines' closest points, clamped to
    [0, 1]; the second's follows and is clamped, then the first is recomputed; the result is the
    smaller of that pair's distance and the four end-to-segment distances (which hold the minimum
    whenever it is not inside both segments, so nearly parallel segments stay exact).

    Parameters
    ----------
    p1, p2, q1, q2 : array_like, shape (..., 3)
        Ends of the first and second segments [m].

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    p1, p2, q1, q2 = (np.asarray(v, float) for v in (p1, p2, q1, q2))
    d1, d2, r = p2 - p1, q2 - q1, p1 - q1
    a, e = np.sum(d1 * d1, -1), np.sum(d2 * d2, -1)
    b, c, f = np.sum(d1 * d2, -1), np.sum(d1 * r, -1), np.sum(d2 * r, -1)
    a1, e1 = np.where(a > 0, a, 1.0), np.where(e > 0, e, 1.0)
    den = a * e - b * b
    ok = den > 1e-14 * a * e
    s = np.where(ok, np.clip((b * f - c * e) / np.where(ok, den, 1.0), 0.0, 1.0), 0.0)
    t = (b * s + f) / e1
    s = np.where(t < 0, np.clip(-c / a1, 0.0, 1.0), np.where(t > 1, np.clip((b - c) / a1, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    inner = np.linalg.norm(r + s[..., None] * d1 - t[..., None] * d2, axis=-1)
    ends = np.minimum(np.minimum(point_segment_distance3_numpy(p1, q1, q2), point_segment_distance3_numpy(p2, q1, q2)),
                      np.minimum(point_segment_distance3_numpy(q1, p1, p2), point_segment_distance3_numpy(q2, p1, p2)))
    return np.minimum(inner, ends)


def segment_box_distance(a: ArrayLike, b: ArrayLike, centre: ArrayLike, axes: ArrayLike, half: ArrayLike) -> np.ndarray:
    """Distance [m] from segments ``ab`` to a solid box (0 when they touch or enter it), in closed form:
    :func:`segment_box_distance_numpy`, computed in C where a compiler works (the same values to the last bit).

    Parameters
    ----------
    a, b : array_like, shape (..., 3)
        Segment ends [m].
    centre : array_like, shape (3,)
        The box's centre [m].
    axes : array_like, shape (3, 3)
        Its unit edge directions, one per row.
    half : array_like, shape (3,)
        Its half edge lengths [m] along those rows.

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    pa, pd = box_frame(a, b, centre, axes)
    out = segment_box(pa, pd, half)
    return _box_distance_numpy(pa, pd, half) if out is None else out


def box_frame(a: ArrayLike, b: ArrayLike, centre: ArrayLike, axes: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Segments ``ab`` in a frame (a box's or a plate's): the first end from its centre and the segment, along its axes.

    Parameters
    ----------
    a, b : array_like, shape (..., 3)
        Segment ends [m].
    centre : array_like, shape (3,)
        The frame's origin [m].
    axes : array_like, shape (3, 3)
        Its unit axes, one per row.

    Returns
    -------
    pa, pd : ndarray, shape (..., 3)
        ``(a - centre) R^T`` and ``(b - a) R^T`` [m].
    """
    R = np.asarray(axes, float)
    a = np.asarray(a, float)
    return (a - centre) @ R.T, (np.asarray(b, float) - a) @ R.T


def segment_box_distance_numpy(a: ArrayLike, b: ArrayLike, centre: ArrayLike, axes: ArrayLike,
                               half: ArrayLike) -> np.ndarray:
    """:func:`segment_box_distance` in numpy (the reference of the C kernel).

    Parameters
    ----------
    a, b : array_like, shape (..., 3)
        Segment ends [m].
    centre : array_like, shape (3,)
        The box's centre [m].
    axes : array_like, shape (3, 3)
        Its unit edge directions, one per row.
    half : array_like, shape (3,)
        Its half edge lengths [m] along those rows.

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    pa, pd = box_frame(a, b, centre, axes)
    return _box_distance_numpy(pa, pd, half)


def _box_distance_numpy(pa: np.ndarray, pd: np.ndarray, half: ArrayLike) -> np.ndarray:
    """The box distance from the segments in its frame (:func:`box_frame`)."""
    h = np.asarray(half, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        br = np.concatenate([(h - pa) / pd, (-h - pa) / pd], axis=-1)
    br = np.clip(np.nan_to_num(br, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0)
    ends = np.broadcast_to(np.array([0.0, 1.0]), br.shape[:-1] + (2,))
    S = np.sort(np.concatenate([ends, br], axis=-1), axis=-1)          # (..., 8)
    lo, hi = S[..., :-1], S[..., 1:]
    mid = 0.5 * (lo + hi)
    pm = pa[..., None, :] + mid[..., None] * pd[..., None, :]          # (..., 7, 3)
    out = np.abs(pm) > h
    target = np.sign(pm) * h
    pdx = pd[..., None, :]
    num = np.sum(np.where(out, pdx * (pa[..., None, :] - target), 0.0), -1)
    den = np.sum(np.where(out, pdx * pdx, 0.0), -1)
    vertex = np.clip(-num / np.where(den > 0, den, 1.0), lo, hi)
    cand = np.concatenate([S, np.where(den > 0, vertex, mid)], axis=-1)  # (..., 15)
    pc = pa[..., None, :] + cand[..., None] * pd[..., None, :]
    g = np.sum(np.maximum(np.abs(pc) - h, 0.0) ** 2, -1)
    return np.sqrt(np.min(g, axis=-1))


def plate_point_distance(x: np.ndarray, half_thickness: float, extent: float,
                         holes: tuple[tuple[str, float, float, float, float], ...]) -> np.ndarray:
    """Distance [m] from points in the plate's frame ``(u, v, w)`` to the plate (0 inside its solid part).

    Parameters
    ----------
    x : ndarray, shape (..., 3)
        Points in the plate's frame [m]: in-plane ``u, v``, ``w`` along the normal from the mid-plane.
    half_thickness : float
        Half the thickness [m].
    extent : float
        Half-size of the square plate [m] (``inf``: unbounded).
    holes : tuple of (kind, cu, cv, p, q)
        ``("circle", cu, cv, radius, 0)`` or ``("rectangle", cu, cv, half_width, half_height)`` [m],
        disjoint and inside the square.

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    u, v, w = x[..., 0], x[..., 1], x[..., 2]
    dw = np.maximum(np.abs(w) - half_thickness, 0.0)
    delta = np.zeros_like(u)
    if math.isfinite(extent):
        delta = np.hypot(np.maximum(np.abs(u) - extent, 0.0), np.maximum(np.abs(v) - extent, 0.0))
    for kind, cu, cv, p, q in holes:
        du, dv = u - cu, v - cv
        if kind == "circle":
            delta = delta + np.maximum(p - np.hypot(du, dv), 0.0)
        else:
            delta = delta + np.maximum(np.minimum(p - np.abs(du), q - np.abs(dv)), 0.0)
    return np.hypot(delta, dw)


def _plate_breaks(pa: np.ndarray, pd: np.ndarray, half_thickness: float, extent: float,
                  holes: tuple) -> np.ndarray:
    """Parameters in [0, 1] where segments cross the slab's faces, the square's edges, a hole's rim or a
    rectangle's diagonals (where its nearest edge changes), (..., k)."""
    planes = [(2, half_thickness), (2, -half_thickness)]
    if math.isfinite(extent):
        planes += [(0, extent), (0, -extent), (1, extent), (1, -extent)]
    quad = []
    for kind, cu, cv, p, q in holes:
        if kind == "circle":
            quad.append((cu, cv, p))
        else:
            planes += [(0, cu + p), (0, cu - p), (1, cv + q), (1, cv - q)]
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for k, level in planes:
            out.append((level - pa[..., k]) / pd[..., k])
        for kind, cu, cv, p, q in holes:      # a rectangle's diagonals: where its nearest edge changes
            if kind == "rectangle":
                for sv in (1.0, -1.0):
                    for level in (p - q, q - p):
                        du, dv = pa[..., 0] - cu, pa[..., 1] - cv
                        out.append((level - du + sv * dv) / (pd[..., 0] - sv * pd[..., 1]))
        for cu, cv, rho in quad:           # |(u, v)(s) - c|^2 = rho^2
            ou, ov = pa[..., 0] - cu, pa[..., 1] - cv
            A = pd[..., 0] ** 2 + pd[..., 1] ** 2
            B = 2 * (ou * pd[..., 0] + ov * pd[..., 1])
            C = ou ** 2 + ov ** 2 - rho ** 2
            root = np.sqrt(np.maximum(B * B - 4 * A * C, 0.0))
            out += [(-B - root) / (2 * A), (-B + root) / (2 * A)]
    br = np.stack(out, axis=-1)
    return np.clip(np.nan_to_num(br, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0)


def segment_plate_distance(a: ArrayLike, b: ArrayLike, plate: Any, within: float = math.inf) -> np.ndarray:
    """Distance [m] from segments ``ab`` to a plate with holes (0 when they touch or enter its solid part).

    The segment is cut at every crossing of a face, an edge or a hole's rim; on each piece the
    distance is the smaller of its ends' and, inside, a golden-section minimum (a piece above a
    hole, where the nearest point is on the rim, is unimodal). Segments whose distance to the
    slab alone exceeds ``within`` get that lower bound instead (no search).

    Parameters
    ----------
    a, b : array_like, shape (..., 3)
        Segment ends [m].
    plate : Obstacle3D
        A ``plate`` (its ``centre``, ``axes`` rows ``u, v, n``, ``half``, ``holes``).
    within : float
        Distances above this need not be exact [m] (a lower bound above it is returned).

    Returns
    -------
    ndarray, shape (...)
        Distances [m].
    """
    (_, _, ht), ext = plate.half, plate.extent
    pa, pd = box_frame(a, b, plate.centre, plate.axes)
    wa, wb = pa[..., 2], pa[..., 2] + pd[..., 2]
    across = np.sign(wa - ht) != np.sign(wb - ht)
    bound = np.where(across | (np.sign(wa + ht) != np.sign(wb + ht)), 0.0,
                     np.maximum(np.minimum(np.abs(wa), np.abs(wb)) - ht, 0.0))
    out = bound.copy()
    sel = bound <= within
    if not np.any(sel):
        return out
    pa, pd = pa[sel], pd[sel]
    near = segment_plate(pa, pd, ht, ext, plate.holes, GOLDEN_STEPS)
    out[sel] = plate_search_numpy(pa, pd, ht, ext, plate.holes) if near is None else near
    return out


def plate_search_numpy(pa: np.ndarray, pd: np.ndarray, half_thickness: float, extent: float,
                       holes: tuple) -> np.ndarray:
    """Distance [m] from segments in a plate's frame to the plate: the pieces' ends and a golden-section
    minimum inside each piece (:data:`GOLDEN_STEPS` iterations), in numpy (the reference of the C kernel).

    Parameters
    ----------
    pa : ndarray, shape (n, 3)
        First ends from the plate's centre, along its axes ``u, v, n`` [m] (:func:`box_frame`).
    pd : ndarray, shape (n, 3)
        The segments along the same axes [m].
    half_thickness : float
        Half the thickness [m].
    extent : float
        Half-size of the square plate [m] (``inf``: unbounded).
    holes : tuple of (kind, cu, cv, p, q)
        As :func:`plate_point_distance`.

    Returns
    -------
    ndarray, shape (n,)
        Distances [m].
    """
    def dist(s: np.ndarray) -> np.ndarray:
        return plate_point_distance(pa[:, None, :] + s[..., None] * pd[:, None, :], half_thickness, extent, holes)

    S = np.sort(np.concatenate([np.zeros((len(pa), 1)), np.ones((len(pa), 1)),
                                _plate_breaks(pa, pd, half_thickness, extent, holes)], axis=-1), axis=-1)
    best = np.min(dist(S), axis=-1)
    lo, hi = S[:, :-1].copy(), S[:, 1:].copy()
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = dist(x1), dist(x2)
    for _ in range(GOLDEN_STEPS):
        left = f1 <= f2
        lo, hi = np.where(left, lo, x1), np.where(left, x2, hi)
        x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
        f1, f2 = dist(x1), dist(x2)
    return np.minimum(best, np.min(np.minimum(f1, f2), axis=-1))
