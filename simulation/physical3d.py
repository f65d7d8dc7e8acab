"""Physical validity of a spatial chain: bend limits, capsules apart, capsules clear of obstacles.

:class:`Physical3D` is what a run of a universal chain checks (the interface of
:class:`~coordarm.simulation.physical.Physical`: ``check(t, q)`` and ``clearances(q, t)``):
link j is a capsule about the segment ``y^j -+ xi/2 d_j`` of ``radius``; two non-adjacent
capsules closer than ``2 radius + clearance`` are a ``self`` contact, a capsule closer than
``clearance`` to an obstacle a ``wall`` contact, a bend ``acos(d_{j-1} . d_j)`` beyond the
limit a ``joint_limit`` contact; on a rail, ``d`` outside the rail's limits a ``rail_limit`` contact. :func:`close_pairs` is the broad phase (sort and sweep on the
links' bounding boxes), so a check costs O(m log m) per sample on a chain that is not piled
onto itself.
"""
from __future__ import annotations

import math
from dataclasses import field
from typing import Any, Callable

import numpy as np

from coordarm.generated.chain_geometry import box_pairs, spatial_frames
from coordarm.symbolic import SpatialChain
from coordarm.symbolic.geometry import touching
from coordarm.symbolic.records import record
from coordarm.symbolic.start3d import bends_between

from .distance3d import plate_point_distance, point_segment_distance3, segment_segment_distance
from .obstacles3d import Obstacle3D, bounding_box, capsule_gaps
from .physical import Contact


def link_ends(chain: SpatialChain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ends of every link's axis, ``y^j - xi/2 d_j`` and ``y^j + xi/2 d_j``, and the directions ``d_j``.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    q : ndarray, shape (N, dof)
        Configurations [rad] (``d`` [m] first on a rail).

    Returns
    -------
    a, b, d : ndarray, each shape (N, m, 3)
        The ends [m] and the unit directions.
    """
    d = spatial_frames(chain, q)[..., 0]          # in C, numpy's bits
    half = 0.5 * chain.xi * d
    a = np.concatenate([-half[:, :1], np.cumsum(2 * half[:, :-1], axis=1) - half[:, :1]], axis=1)
    a = a + chain.base_point(q)[:, None, :]
    return a, a + 2 * half, d


def all3(x: np.ndarray) -> np.ndarray:
    """``np.all(x, axis=-1)`` for a last axis of 3 (x, y, z), as two ``&``: numpy's reduction over so short
    an axis costs several times as much.

    Parameters
    ----------
    x : ndarray of bool, shape (..., 3)
        Per axis.

    Returns
    -------
    ndarray of bool, shape (...)
        True where all three are.
    """
    return x[..., 0] & x[..., 1] & x[..., 2]


def body_box(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each sample's box around the boxes of all its links (a link's box lies inside it).

    ``fmin``/``fmax`` pass over a link whose box is NaN (a sample is NaN from a joint on). The links are
    reduced as rows of a contiguous copy: numpy's reduction over the middle axis of ``(N, m, 3)`` costs 5x
    as much.

    Parameters
    ----------
    lo, hi : ndarray, each shape (N, m, 3)
        Corners of the links' axis-aligned boxes [m].

    Returns
    -------
    lo, hi : ndarray, each shape (N, 3)
        Corners of each sample's box [m].
    """
    n, m = lo.shape[:2]
    lows = np.ascontiguousarray(lo.transpose(1, 0, 2)).reshape(m, -1)
    highs = np.ascontiguousarray(hi.transpose(1, 0, 2)).reshape(m, -1)
    return np.fmin.reduce(lows, axis=0).reshape(n, 3), np.fmax.reduce(highs, axis=0).reshape(n, 3)


#: Rows per block of :func:`block_spheres` (the summary's clearances).
CLEARANCE_BLOCK = 32


def block_spheres(a: np.ndarray, b: np.ndarray, block: int = CLEARANCE_BLOCK) -> tuple[np.ndarray, np.ndarray]:
    """A sphere around each link's axis over each block of ``block`` rows (around the box of its ends there).

    Parameters
    ----------
    a, b : ndarray, each shape (N, m, 3)
        Link axis ends [m], finite.
    block : int
        Rows per block.

    Returns
    -------
    centre : ndarray, shape (ceil(N / block), m, 3)
        Centres [m].
    radius : ndarray, shape (ceil(N / block), m)
        Radii [m].
    """
    starts = np.arange(0, len(a), block)
    lo = np.minimum.reduceat(np.minimum(a, b), starts, axis=0)
    hi = np.maximum.reduceat(np.maximum(a, b), starts, axis=0)
    return 0.5 * (lo + hi), 0.5 * np.linalg.norm(hi - lo, axis=-1)


def sphere_bound(obstacle: Obstacle3D, centre: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """A lower bound of the distance from any point of each sphere to an obstacle [m] (may be negative).

    The distance from the centre to the sphere's centre or the cylinder's axis less the obstacle's radius,
    or to a box's or plate's bounding box (:func:`~.obstacles3d.bounding_box`), less the sphere's radius.

    Parameters
    ----------
    obstacle : Obstacle3D
        The obstacle.
    centre : ndarray, shape (..., 3)
        Sphere centres [m].
    radius : ndarray, shape (...)
        Sphere radii [m].

    Returns
    -------
    ndarray, shape (...)
        The bounds [m].
    """
    if obstacle.kind == "sphere":
        d = np.linalg.norm(centre - obstacle.centre, axis=-1) - obstacle.radius
    elif obstacle.kind == "cylinder":
        d = point_segment_distance3(centre, obstacle.centre, obstacle.end) - obstacle.radius
    else:
        lo, hi = bounding_box(obstacle)
        d = np.linalg.norm(np.maximum(np.maximum(lo - centre, centre - hi), 0.0), axis=-1)
    return d - radius


def nearest_candidates(bound: np.ndarray, n: int, gaps: Callable[[np.ndarray, np.ndarray], np.ndarray],
                       within: float = math.inf, block: int = CLEARANCE_BLOCK) -> tuple[np.ndarray, np.ndarray]:
    """The (row, link) pairs, row-major, among which the smallest gap lies and every pair that ties it.

    The block and link of the smallest bound is measured; the blocks and links whose bound exceeds the
    smallest gap found there, or ``within`` (by more than rounding), cannot hold the smallest gap, and are
    left out. So ``argmin`` over the candidates' gaps finds the pair ``argmin`` over all pairs finds, with its gap.

    Parameters
    ----------
    bound : ndarray, shape (blocks, m)
        A lower bound of every gap in each block and link [m] (:func:`sphere_bound` of :func:`block_spheres`
        less the capsule radius).
    n : int
        Rows.
    gaps : callable
        ``gaps(rows, links)`` -> the gaps of those pairs [m] (above ``within`` a gap may be a lower bound).
    within : float
        An upper bound of the smallest gap [m] (a plate's: its nearest link end's distance), else inf.
    block : int
        Rows per block, as :func:`block_spheres` made them (the last block may be shorter).

    Returns
    -------
    rows, links : int ndarray, each shape (K,)
        The candidates, sorted by row, then link.
    """
    m = bound.shape[1]

    def pairs(kb: np.ndarray, kj: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rows = (kb[:, None] * block + np.arange(block)).ravel()
        links = np.repeat(kj, block)
        inside = rows < n
        order = np.argsort(rows[inside] * m + links[inside], kind="stable")
        return rows[inside][order], links[inside][order]
    first = np.array(np.unravel_index(int(np.argmin(bound)), bound.shape))[:, None]
    best = min(float(np.min(gaps(*pairs(*first)))), within)      # either is at least the smallest gap
    kb, kj = np.nonzero(~(bound > best + 1e-9 * (1.0 + abs(best))))             # (a NaN bound is kept)
    return pairs(kb, kj)


def close_pairs(lo: np.ndarray, hi: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pairs of non-adjacent links whose bounding boxes come within ``reach`` of each other along all three axes.

    In C (:func:`~coordarm.generated.chain_geometry.box_pairs`), else :func:`close_pairs_numpy`: the same
    pairs, in another order.

    Parameters
    ----------
    lo, hi : ndarray, each shape (N, m, 3)
        Corners of the links' axis-aligned bounding boxes [m].
    reach : float
        Gap [m] up to which two boxes count as close.

    Returns
    -------
    sample, link_a, link_b : int ndarray, each shape (K,)
        0-based sample and 0-based links, ``link_a < link_b - 1``.
    """
    found = box_pairs(lo, hi, reach)
    return found if found is not None else close_pairs_numpy(lo, hi, reach)


def close_pairs_numpy(lo: np.ndarray, hi: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`close_pairs` in numpy (sort and sweep).

    Per sample the boxes are sorted by their low end along the axis of the body's largest
    extent; the box k places further on is compared while any still overlaps along that axis
    (none further can then), and kept when the boxes overlap along all three axes.

    Parameters
    ----------
    lo, hi : ndarray, each shape (N, m, 3)
        Corners of the links' axis-aligned bounding boxes [m].
    reach : float
        Gap [m] up to which two boxes count as close.

    Returns
    -------
    sample, link_a, link_b : int ndarray, each shape (K,)
        0-based sample and 0-based links, ``link_a < link_b - 1``.
    """
    n, m = lo.shape[:2]
    ax = np.argmax(hi.max(axis=1) - lo.min(axis=1), axis=-1)                     # (N,)
    key = np.take_along_axis(lo, ax[:, None, None], axis=2)[..., 0]
    order = np.argsort(key, axis=1)
    los = np.take_along_axis(lo, order[..., None], axis=1)
    his = np.take_along_axis(hi, order[..., None], axis=1)
    klo = np.take_along_axis(key, order, axis=1)
    khi = np.take_along_axis(np.take_along_axis(hi, ax[:, None, None], axis=2)[..., 0], order, axis=1)
    found = []
    for k in range(1, m):
        if not np.any(klo[:, k:] <= khi[:, :-k] + reach):
            break
        near = all3((los[:, k:] <= his[:, :-k] + reach) & (los[:, :-k] <= his[:, k:] + reach))
        s, i = np.nonzero(near)
        la, lb = order[s, i], order[s, i + k]
        keep = np.abs(la - lb) > 1
        found.append((s[keep], np.minimum(la, lb)[keep], np.maximum(la, lb)[keep]))
    if not found:
        empty = np.zeros(0, dtype=int)
        return empty, empty, empty
    return tuple(np.concatenate(x) for x in zip(*found))


def self_gaps(a: np.ndarray, b: np.ndarray, radius: float, clearance: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gaps between the capsules of non-adjacent links that may be within ``clearance`` of each other.

    Parameters
    ----------
    a, b : ndarray, each shape (N, m, 3)
        Link axis ends [m].
    radius : float
        Capsule radius [m].
    clearance : float
        Gap of interest [m] (>= 0).

    Returns
    -------
    sample, link_a, link_b : int ndarray, each shape (K,)
        0-based sample and 0-based links of each compared pair; every pair within ``clearance``
        is among them.
    gap : ndarray, shape (K,)
        Axis distance minus ``2 radius`` [m].
    """
    reach = (2 * radius + clearance) * (1 + 1e-9) + 1e-12
    s, i, j = close_pairs(np.minimum(a, b), np.maximum(a, b), reach)
    gap = segment_segment_distance(a[s, i], b[s, i], a[s, j], b[s, j]) - 2 * radius
    return s, i, j, gap


@record
class Physical3D:
    """What a run of a universal chain checks at every checked sample.

    Attributes
    ----------
    chain : SpatialChain
        The manipulator.
    limit : float or list of float
        Bend limit [rad] of joints 2..m (one, or one per joint).
    radius : float
        Capsule radius of every link [m].
    clearance : float
        Extra distance kept between capsules and from obstacles [m] (0: touching is contact).
    obstacles : list of Obstacle3D
        Plates, spheres, cylinders and boxes.
    rate_limits : (float or None, float or None)
        ``[chain] rate_limit`` [rad/s] and ``accel_limit`` [rad/s^2] (:mod:`.joint_rates`); None: unchecked.
    """

    chain: SpatialChain
    limit: Any
    radius: float
    clearance: float = 0.0
    obstacles: list[Obstacle3D] = field(default_factory=list)
    rate_limits: tuple = (None, None)

    def check(self, t: np.ndarray, q: np.ndarray) -> list[Contact]:
        """Every contact at the samples ``(t[k], q[k])``, sorted by time (then kind, links).

        Parameters
        ----------
        t : ndarray, shape (N,)
            Times of the samples [s].
        q : ndarray, shape (N, dof)
            Configurations [rad] (``d`` [m] first on a rail).

        Returns
        -------
        list of Contact
            ``joint_limit`` (value: the bend [rad]), ``self`` (value: the gap between the two
            capsules [m]), ``wall`` contacts (value: the gap to the obstacle [m]) and on a rail
            ``rail_limit`` (value: ``d`` [m], link 1).
        """
        t = np.atleast_1d(np.asarray(t, float))
        q = np.asarray(q, float).reshape(len(t), -1)
        c, found = float(self.clearance), []
        if self.chain.rail:
            lo, hi = self.chain.rail_limits
            for k in np.flatnonzero(~((q[:, 0] >= lo) & (q[:, 0] <= hi))):
                found.append((k, 0, Contact("rail_limit", float(t[k]), (1,), float(q[k, 0]),
                                            hi if q[k, 0] > hi else lo)))
        a, b, d = link_ends(self.chain, q)
        bends = bends_between(d)
        lim = np.broadcast_to(np.asarray(self.limit, float), bends.shape[-1:])
        for k, j in zip(*np.nonzero(~(bends <= lim))):
            found.append((k, 0, Contact("joint_limit", float(t[k]), (int(j) + 1, int(j) + 2), float(bends[k, j]),
                                        float(lim[j]))))
        s, i, j, gap = self_gaps(a, b, self.radius, c)
        hit = touching(gap, c)
        for k, la, lb, g in zip(s[hit], i[hit], j[hit], gap[hit]):
            found.append((k, 1, Contact("self", float(t[k]), (int(la) + 1, int(lb) + 1), float(g), c)))
        if self.obstacles:      # each link's box, widened by what still counts as touching (a broad phase)
            reach = (self.radius + c) * (1 + 1e-9) + 1e-12
            lo, hi = np.minimum(a, b) - reach, np.maximum(a, b) + reach
            body_lo, body_hi = body_box(lo, hi)
        for ob in self.obstacles:
            ob_lo, ob_hi = bounding_box(ob)
            rows = np.flatnonzero(all3((body_lo <= ob_hi) & (body_hi >= ob_lo)))   # the body's box meets it
            k, j = np.nonzero(all3((lo[rows] <= ob_hi) & (hi[rows] >= ob_lo)))   # the links' boxes meet it
            k = rows[k]
            g = capsule_gaps(a[k, j], b[k, j], self.radius, ob, within=c)
            hit = touching(g, c)
            for k_, j_, g_ in zip(k[hit], j[hit], g[hit]):
                found.append((k_, 2, Contact("wall", float(t[k_]), (int(j_) + 1,), float(g_), c, ob.name)))
        found.sort(key=lambda x: (int(x[0]), x[1], x[2].links))
        return [x[2] for x in found]

    def clearances(self, q: np.ndarray, t: np.ndarray) -> dict[str, tuple[float, float, int]]:
        """Per obstacle: (smallest gap [m], its time [s], its 1-based link) over the samples.

        Parameters
        ----------
        q : ndarray, shape (N, dof)
            Configurations [rad] (``d`` [m] first on a rail).
        t : ndarray, shape (N,)
            Times of the samples [s].

        Returns
        -------
        dict of str to (float, float, int)
            By obstacle name; the gap is between the link's capsule and the obstacle.
        """
        t = np.atleast_1d(np.asarray(t, float))
        a, b, _ = link_ends(self.chain, np.asarray(q, float).reshape(len(t), -1))
        spheres = block_spheres(a, b) if np.isfinite(a).all() and np.isfinite(b).all() else None
        out = {}
        for ob in self.obstacles:
            within = math.inf
            if ob.kind == "plate":          # an upper bound: the nearest link end's distance
                ends = plate_point_distance((a - ob.centre) @ ob.axes.T, ob.half[2], ob.extent, ob.holes)
                within = float(np.min(ends)) - self.radius
            def gaps(k: np.ndarray, j: np.ndarray) -> np.ndarray:
                return capsule_gaps(a[k, j], b[k, j], self.radius, ob, within=within)
            if spheres is None:             # a NaN: every pair (argmin finds the first NaN, as before)
                k, j = (x.ravel() for x in np.indices(a.shape[:2]))
            else:
                k, j = nearest_candidates(sphere_bound(ob, *spheres) - self.radius, len(a), gaps, within)
            g = gaps(k, j)
            i = int(np.argmin(g))
            out[ob.name] = (float(g[i]), float(t[k[i]]), int(j[i]) + 1)
        return out
