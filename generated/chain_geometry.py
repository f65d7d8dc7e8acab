"""The physical checks' geometry in C: a planar chain's joints and its self-distance sweep, a spatial chain's
link frames, many samples per call.

``templates/chain_geometry.c`` repeats :meth:`~coordarm.symbolic.chain.PlanarChain.joints_np` and
:func:`~coordarm.symbolic.geometry.self_distances` operation by operation; compiled as a
:mod:`~coordarm.generated.kernels` library (fixed flags, no contraction), its joints and distances are
the numpy reference's to the last bit (the joints where numpy's ``cos`` and ``sin`` are the C
library's, as on the machine of the tests, numpy 2.4 on x86-64 without AVX-512; elsewhere to an ulp).
Where no C compiler works, :func:`chain_joints` and :func:`self_distances` run the numpy reference
instead (same results, 2.5-6x slower at 64 links). :func:`spatial_frames` repeats
:func:`~coordarm.symbolic.spatial_chain.link_frames` from the cosines and sines numpy computes
(:meth:`~coordarm.symbolic.spatial_chain.SpatialChain.joint_trig`): the same bits wherever it runs.
"""
from __future__ import annotations

import ctypes
import functools
from typing import Any

import numpy as np

from coordarm.symbolic.geometry import self_distances as reference_self_distances

#: Template of the library's source.
TEMPLATE = "chain_geometry.c"

_P, _I, _D = ctypes.c_void_p, ctypes.c_longlong, ctypes.c_double


@functools.cache
def geometry_library() -> ctypes.CDLL | None:
    """The compiled geometry library (:func:`~coordarm.generated.kernels.kernel_library`), its functions typed.

    Returns
    -------
    ctypes.CDLL or None
        None when it cannot be built or loaded (no working C compiler): the callers then run the numpy
        reference.
    """
    from .kernels import kernel_library        # here: the build machinery loads on the first check, not on import
    lib = kernel_library(TEMPLATE)
    if lib is None:
        return None
    lib.coordarm_chain_joints.argtypes = [_P, _P, _I, _I, _D, _P, _P]
    lib.coordarm_chain_joints.restype = None
    lib.coordarm_self_distances.argtypes = [_P, _I, _I, _D, _I, _P, _P, _P, _P, _P, _P]
    lib.coordarm_self_distances.restype = _I
    lib.coordarm_spatial_frames.argtypes = [_P, _P, _P, _P, _I, _I, _P]
    lib.coordarm_spatial_frames.restype = None
    lib.coordarm_close_pairs3d.argtypes = [_P, _P, _I, _I, _D, _I, _P, _P, _P, _P, _P]
    lib.coordarm_close_pairs3d.restype = _I
    lib.coordarm_edge_distances.argtypes = [_P, _I, _I, _P, _I, _P, _I, _P]
    lib.coordarm_edge_distances.restype = None
    return lib


def _c_array(a: Any) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def chain_joints(chain: Any, q: np.ndarray) -> np.ndarray:
    """Link end points of a planar chain's configurations, as :meth:`~coordarm.symbolic.chain.PlanarChain.joints_np`.

    Parameters
    ----------
    chain : PlanarChain
        The chain (``m``, ``xi``, its base point).
    q : (N, dof) ndarray
        Configurations [rad] (``d`` [m] first on a rail).

    Returns
    -------
    (N, m+1, 2) ndarray
        Joint positions [m]; the numpy reference's, bit for bit.
    """
    lib = geometry_library()
    q = np.asarray(q, dtype=float)
    if lib is None or q.ndim != 2 or not len(q):
        return chain.joints_np(q)
    n, m = len(q), chain.m
    angles, base = _c_array(chain.revolute(q)), _c_array(chain.base_point(q))
    joints, scratch = np.empty((n, m + 1, 2)), np.empty((m, 2))
    lib.coordarm_chain_joints(angles.ctypes.data, base.ctypes.data, n, m, float(chain.xi), scratch.ctypes.data,
                              joints.ctypes.data)
    return joints


def spatial_frames(chain: Any, q: np.ndarray) -> np.ndarray:
    """Link frames of a spatial chain's configurations, as :meth:`~coordarm.symbolic.spatial_chain.SpatialChain.frames_np`.

    Parameters
    ----------
    chain : SpatialChain
        The chain.
    q : (N, dof) ndarray
        Configurations [rad] (``d`` [m] first on a rail); any other shape (one pose) gets the numpy frames.

    Returns
    -------
    (N, m, 3, 3) ndarray
        The frames [-] (column 0: each link's direction); the numpy reference's, bit for bit.
    """
    lib = geometry_library()
    q = np.asarray(q, dtype=float)
    if lib is None or q.ndim != 2 or not len(q):
        return chain.frames_np(q)
    trig = [_c_array(x) for x in chain.joint_trig(q)]
    frames = np.empty((len(q), chain.m, 3, 3))
    lib.coordarm_spatial_frames(*(x.ctypes.data for x in trig), len(q), chain.m, frames.ctypes.data)
    return frames


def edge_distances(joints: np.ndarray, edges: np.ndarray, polygon: np.ndarray | None = None) -> np.ndarray | None:
    """Distance from every link to the nearest edge (0 for a link starting inside ``polygon``), in C.

    :func:`coordarm.simulation.obstacles.link_distances` of a segment or polygon obstacle, to the last bit:
    the smallest of the same segment distances (``symbolic.geometry.segment_distance``'s operations).

    Parameters
    ----------
    joints : (N, m+1, 2) array
        Link end points [m].
    edges : (E, 2, 2) array
        The obstacle's edges [m].
    polygon : (k, 2) array, optional
        The corners of a closed polygon [m] (its inside counts as contact).

    Returns
    -------
    (N, m) ndarray or None
        The distances [m]; None without a C compiler or with a point that is not finite (the caller runs numpy).
    """
    lib = geometry_library()
    joints, edges = _c_array(joints), _c_array(edges)
    poly = _c_array(np.zeros((0, 2)) if polygon is None else polygon)
    if lib is None or joints.ndim != 3 or not all(np.isfinite(x).all() for x in (joints, edges, poly)):
        return None
    n, m = joints.shape[0], joints.shape[1] - 1
    out = np.empty((n, m))
    lib.coordarm_edge_distances(joints.ctypes.data, n, m, edges.ctypes.data, len(edges), poly.ctypes.data, len(poly),
                                out.ctypes.data)
    return out


def box_pairs(lo: np.ndarray, hi: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The pairs of non-adjacent links whose boxes come within ``reach`` along all three axes, in C.

    The set :func:`coordarm.simulation.physical3d.close_pairs_numpy` finds, sorted by sample, then by place
    along the sweep (not in its order).

    Parameters
    ----------
    lo, hi : ndarray, each shape (N, m, 3)
        Corners of the links' axis-aligned boxes [m].
    reach : float
        Gap [m] up to which two boxes count as close.

    Returns
    -------
    (sample, link_a, link_b) or None
        0-based int arrays (``link_a < link_b - 1``); None without a C compiler or with a box that is not
        finite (the caller runs the numpy sweep).
    """
    lib = geometry_library()
    lo, hi = _c_array(lo), _c_array(hi)
    if lib is None or lo.ndim != 3 or not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        return None
    n, m = lo.shape[:2]
    scratch, iscratch = np.empty(max(m, 1)), np.empty(2 * max(m, 1), np.int64)
    cap = 8 * n + 1024                      # pairs (a chain along a path: a few a sample; more: a second call)
    while True:
        s, a, b = (np.empty(cap, np.int64) for _ in range(3))
        found = lib.coordarm_close_pairs3d(lo.ctypes.data, hi.ctypes.data, n, m, float(reach), cap, s.ctypes.data,
                                           a.ctypes.data, b.ctypes.data, scratch.ctypes.data, iscratch.ctypes.data)
        if found <= cap:
            return s[:found], a[:found], b[:found]
        cap = found


def self_distances(joints: np.ndarray, clearance: float = 0.0
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pairs of non-adjacent links the sweep compares and their distances, as the numpy reference.

    Same contract as :func:`coordarm.symbolic.geometry.self_distances` (every pair closer than or at
    ``clearance`` is among the pairs, with its exact distance), computed in C; the pairs come sorted
    by sample, then by their place along the sweep, not in the reference's order.

    Parameters
    ----------
    joints : (N, m+1, 2) array
        Link end points [m]; a sample that is not finite makes the whole call run the reference.
    clearance : float
        Distance of interest [m] (>= 0).

    Returns
    -------
    sample, link_a, link_b : int arrays (K,)
        0-based sample and 1-based links (``link_a < link_b - 1``).
    distance : float array (K,)
        Their distance [m] (0 when they cross or touch), the reference's to the last bit.
    """
    lib = geometry_library()
    joints = _c_array(joints)
    if lib is None or joints.ndim != 3 or not np.isfinite(joints).all():
        return reference_self_distances(joints, clearance)
    n, m = joints.shape[0], joints.shape[1] - 1
    scratch, iscratch = np.empty(8 * max(m, 1)), np.empty(2 * max(m, 1), np.int64)
    cap = 16 * n + 1024                     # pairs (a compact chain: ~10 a sample; more: a second call)
    while True:
        s, la, lb = (np.empty(cap, np.int64) for _ in range(3))
        d = np.empty(cap)
        found = lib.coordarm_self_distances(joints.ctypes.data, n, m, float(clearance), cap, s.ctypes.data,
                                            la.ctypes.data, lb.ctypes.data, d.ctypes.data, scratch.ctypes.data,
                                            iscratch.ctypes.data)
        if found <= cap:
            return s[:found], la[:found], lb[:found], d[:found]
        cap = found
