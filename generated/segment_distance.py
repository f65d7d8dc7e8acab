"""Distances between 3-D segments and from points to segments in C, many per call (a spatial chain's capsules).

``templates/segment_distance.c`` repeats :func:`~coordarm.simulation.distance3d.segment_segment_distance_numpy`
and :func:`~coordarm.simulation.distance3d.point_segment_distance3_numpy` operation by operation; compiled as a
:mod:`~coordarm.generated.kernels` library (fixed flags, no contraction), its distances are the numpy
reference's to the last bit. Each function returns None where no C compiler works (the caller then runs
the reference) or where the operands are not 3-vectors.
"""
from __future__ import annotations

import ctypes
import functools
import math
from typing import Any

import numpy as np

#: Template of the library's source.
TEMPLATE = "segment_distance.c"

_P, _I = ctypes.c_void_p, ctypes.c_longlong


@functools.cache
def distance_library() -> ctypes.CDLL | None:
    """The compiled distance library (:func:`~coordarm.generated.kernels.kernel_library`), its functions typed.

    Returns
    -------
    ctypes.CDLL or None
        None when it cannot be built or loaded (no working C compiler).
    """
    from .kernels import kernel_library        # here: the build machinery loads on the first check, not on import
    lib = kernel_library(TEMPLATE)
    if lib is None:
        return None
    lib.coordarm_segment_segment.argtypes = [_I] + [_P, _I] * 4 + [_P]
    lib.coordarm_segment_segment.restype = None
    lib.coordarm_point_segment.argtypes = [_I] + [_P, _I] * 3 + [_P]
    lib.coordarm_point_segment.restype = None
    return lib


def _operands(points: tuple[Any, ...]) -> tuple[tuple[int, ...], list[tuple[np.ndarray, int]]] | None:
    """The broadcast shape of 3-vectors and each operand as (C-contiguous float64 array, stride in doubles):
    a single point keeps stride 0, any other is broadcast to the whole shape (stride 3). None if the
    operands do not broadcast to (..., 3)."""
    arrays = [np.asarray(v, dtype=np.float64) for v in points]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays))
    except ValueError:
        return None
    if not shape or shape[-1] != 3:
        return None
    out = [(np.ascontiguousarray(a), 0) if a.shape == (3,) else
           (np.ascontiguousarray(np.broadcast_to(a, shape)), 3) for a in arrays]
    return shape[:-1], out


def _call(function: str, points: tuple[Any, ...]) -> np.ndarray | None:
    lib = distance_library()
    operands = _operands(points) if lib is not None else None
    if operands is None:
        return None
    shape, arrays = operands
    out = np.empty(shape)
    args = [x for a, stride in arrays for x in (a.ctypes.data, stride)]
    getattr(lib, function)(math.prod(shape), *args, out.ctypes.data)
    return out


def segment_segment(p1: Any, p2: Any, q1: Any, q2: Any) -> np.ndarray | None:
    """Distance [m] between segments ``p1p2`` and ``q1q2`` in 3-D, in C.

    Parameters
    ----------
    p1, p2, q1, q2 : array_like, shape (..., 3)
        Ends of the first and second segments [m] (broadcast together).

    Returns
    -------
    ndarray, shape (...), or None
        The reference's distances to the last bit; None without the library or for operands that are not
        3-vectors.
    """
    return _call("coordarm_segment_segment", (p1, p2, q1, q2))


def point_segment(p: Any, a: Any, b: Any) -> np.ndarray | None:
    """Distance [m] from points ``p`` to segments ``ab`` in 3-D, in C.

    Parameters
    ----------
    p, a, b : array_like, shape (..., 3)
        Points and the segments' ends [m] (broadcast together).

    Returns
    -------
    ndarray, shape (...), or None
        As :func:`segment_segment`.
    """
    return _call("coordarm_point_segment", (p, a, b))
