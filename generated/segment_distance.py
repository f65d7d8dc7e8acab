"""Distances in 3-D from segments to segments, points, boxes and plates with holes in C, many per call (a
spatial chain's capsules against each other and the obstacles).

``templates/segment_distance.c`` repeats :func:`~coordarm.simulation.distance3d.segment_segment_distance_numpy`,
:func:`~coordarm.simulation.distance3d.point_segment_distance3_numpy`,
:func:`~coordarm.simulation.distance3d.segment_box_distance_numpy` and
:func:`~coordarm.simulation.distance3d.plate_search_numpy` operation by operation; compiled as a
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
    lib.coordarm_segment_box.argtypes = [_I, _P, _P, _P, _P]
    lib.coordarm_segment_box.restype = None
    lib.coordarm_segment_plate.argtypes = [_I, _P, _P, ctypes.c_double, ctypes.c_double, _I, _P, _P, _I, _P, _P]
    lib.coordarm_segment_plate.restype = None
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


def _frame_operands(pa: Any, pd: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """``pa`` and ``pd`` as C-contiguous float64 arrays of one shape ``(..., 3)``, or None."""
    pa, pd = np.asarray(pa, dtype=np.float64), np.asarray(pd, dtype=np.float64)
    if pa.shape != pd.shape or not pa.shape or pa.shape[-1] != 3:
        return None
    return np.ascontiguousarray(pa), np.ascontiguousarray(pd)


def segment_box(pa: Any, pd: Any, half: Any) -> np.ndarray | None:
    """Distance [m] from segments to a solid box, in C, the segments given in the box's frame.

    Parameters
    ----------
    pa : array_like, shape (..., 3)
        The first ends minus the box's centre, along the box's axes [m].
    pd : array_like, shape (..., 3)
        The segments (second end minus first), along the box's axes [m].
    half : array_like, shape (3,)
        The box's half edges along its axes [m].

    Returns
    -------
    ndarray, shape (...), or None
        The reference's distances to the last bit (0 when a segment touches or enters the box); None
        without the library or for operands that are not 3-vectors of one shape.
    """
    lib = distance_library()
    operands = _frame_operands(pa, pd) if lib is not None else None
    if operands is None:
        return None
    pa, pd = operands
    h = np.ascontiguousarray(half, dtype=np.float64)
    if h.shape != (3,):
        return None
    out = np.empty(pa.shape[:-1])
    lib.coordarm_segment_box(out.size, pa.ctypes.data, pd.ctypes.data, h.ctypes.data, out.ctypes.data)
    return out


def plate_break_count(extent: float, holes: tuple) -> int:
    """How many parameters a segment is cut at near a plate (faces, square edges, holes' rims and diagonals).

    Parameters
    ----------
    extent : float
        Half-size of the square plate [m] (``inf``: unbounded).
    holes : tuple of (kind, cu, cv, p, q)
        The holes (``"circle"`` or ``"rectangle"``).

    Returns
    -------
    int
        2 (the slab's faces), 4 more for a finite square, 2 per circle, 8 per rectangle.
    """
    return 2 + 4 * math.isfinite(extent) + sum(2 if kind == "circle" else 8 for kind, *_ in holes)


def segment_plate(pa: Any, pd: Any, half_thickness: float, extent: float, holes: tuple,
                  steps: int) -> np.ndarray | None:
    """Distance [m] from segments to a plate with holes, in C, the segments given in the plate's frame.

    Parameters
    ----------
    pa : array_like, shape (..., 3)
        The first ends minus the plate's centre, along its axes ``u, v, n`` [m].
    pd : array_like, shape (..., 3)
        The segments (second end minus first), along the same axes [m].
    half_thickness : float
        Half the plate's thickness [m].
    extent : float
        Half-size of the square plate [m] (``inf``: unbounded).
    holes : tuple of (kind, cu, cv, p, q)
        ``("circle", cu, cv, radius, 0)`` or ``("rectangle", cu, cv, half_width, half_height)`` [m].
    steps : int
        Golden-section iterations on each piece.

    Returns
    -------
    ndarray, shape (...), or None
        The reference's distances to the last bit; None without the library or for operands that are not
        3-vectors of one shape.
    """
    lib = distance_library()
    operands = _frame_operands(pa, pd) if lib is not None else None
    if operands is None:
        return None
    pa, pd = operands
    kinds = np.array([0 if kind == "circle" else 1 for kind, *_ in holes], dtype=np.int64)
    numbers = np.array([x[1:] for x in holes], dtype=np.float64).reshape(-1, 4)
    work = np.empty(2 + plate_break_count(extent, holes))
    out = np.empty(pa.shape[:-1])
    lib.coordarm_segment_plate(out.size, pa.ctypes.data, pd.ctypes.data, float(half_thickness), float(extent),
                               len(holes), kinds.ctypes.data, numbers.ctypes.data, int(steps), work.ctypes.data,
                               out.ctypes.data)
    return out
