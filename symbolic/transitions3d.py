"""Curvature-continuous (G2) transitions of a 3-D path (:class:`~.paths3d.Path3D`), planar clothoid pieces.

In the frame transported without twist along the path, a line has the curvature vector
``(k_1, k_2) = 0`` and an arc of radius ``R`` and bank ``beta`` the constant ``(cos beta, sin beta) / R``
(its components on ``n_1``, ``n_2``); a G1 path jumps between them at every junction. A transition
of length ``L`` changes the curvature vector continuously over ``[S - L/2, S + L/2]`` (``S`` the
junction), each segment giving ``L/2`` of its length as in the plane (:mod:`.transitions`):

* two collinear vectors (a line and an arc, or arcs turning in one plane): the vector ramps linearly
  over ``L``: a planar clothoid (through zero at an inflection);
* two arcs of different planes: the vector ramps to zero over the ``L/2`` before the junction and
  from zero to the next arc's over the ``L/2`` after: two planar clothoids, so the curvature vector,
  and with it the turn's plane wherever the path turns, changes continuously.

Each clothoid piece lies in the plane of its start tangent ``t_0`` and turn direction ``u``; its
point is ``p0 + X t_0 + Y u`` with the planar clothoid's ``(X, Y)`` and its frame turns about
``w = t_0 x u`` by the heading change. The closest point of ``y`` is the planar one of its
in-plane coordinates ``(t_0.(y - p0), u.(y - p0))`` (:func:`~.transitions.spiral_foot`); ``Phi``
adds the out-of-plane part ``w.(y - p0)`` as for an arc.
"""
from __future__ import annotations

import math
from typing import Sequence

import casadi as ca
import numpy as np

from .path_pieces import Piece
from .transitions import DEFAULT_FRACTION, spiral_foot, split_ramp


def curvature_vectors(segments: Sequence[tuple[str, float, float, float]]) -> list[np.ndarray]:
    """Each parsed 3-D segment's curvature vector in the transported frame, ``(k_1, k_2)`` [1/m].

    Parameters
    ----------
    segments : sequence of (str, float, float, float)
        Parsed segments (:func:`~.paths3d.parse_segment3d`).

    Returns
    -------
    list of ndarray, shape (2,)
        0 for a line; ``(cos beta, sin beta) / R`` for an arc.
    """
    return [np.zeros(2) if kind == "line" else np.array([math.cos(b), math.sin(b)]) / r
            for kind, _, r, b in segments]


def segment_lengths3d(segments: Sequence[tuple[str, float, float, float]]) -> list[float]:
    """Length of each parsed 3-D segment [m].

    Parameters
    ----------
    segments : sequence of (str, float, float, float)
        Parsed segments (:func:`~.paths3d.parse_segment3d`).

    Returns
    -------
    list of float
        A line's length, or an arc's ``A R`` [m].
    """
    return [a if kind == "line" else a * r for kind, a, r, _ in segments]


def junction_transitions3d(segments, transition: float | None, own: Sequence[float | None]) -> list[float]:
    """Transition length at every junction of a 3-D path [m] (as :func:`~.transitions.junction_transitions`).

    Parameters
    ----------
    segments : sequence of (str, float, float, float)
        Parsed segments.
    transition : float or None
        The path's ``transition``; None: :data:`~.transitions.DEFAULT_FRACTION` of the smaller radius
        joined, at most the length of either segment.
    own : sequence of float or None
        Each junction's own length (a segment's ``transition``), None where not given.

    Returns
    -------
    list of float
        One per junction; 0 where the curvature vector does not change.
    """
    K, ls = curvature_vectors(segments), segment_lengths3d(segments)
    out = []
    for i in range(len(segments) - 1):
        same = np.array_equal(K[i], K[i + 1])
        k = max(float(np.linalg.norm(K[i])), float(np.linalg.norm(K[i + 1])))
        base = (0.0 if k == 0 else min(DEFAULT_FRACTION / k, ls[i], ls[i + 1])) if transition is None else transition
        L = base if own[i] is None else own[i]
        out.append(0.0 if same else L)
    return out


def ramps(ka: np.ndarray, kb: np.ndarray, L: float) -> list[tuple[float, float, float, float]]:
    """The planar clothoid pieces of one transition: ``(bank [rad], k0 [1/m], c [1/m^2], length [m])``.

    Parameters
    ----------
    ka, kb : ndarray, shape (2,)
        Curvature vectors before and after the junction [1/m].
    L : float
        Transition length [m] (> 0).

    Returns
    -------
    list of tuple
        Pieces in order, each turning towards ``cos(bank) n_1 + sin(bank) n_2`` with signed curvature
        ``k0 + c sigma`` (split at an inflection and into turns of at most :data:`~.transitions.MAX_SPIRAL`).
    """
    d = kb - ka
    scale = max(float(ka @ ka), float(kb @ kb))
    if abs(ka[0] * kb[1] - ka[1] * kb[0]) <= 1e-12 * scale:            # one plane: one linear ramp
        runs = [(d / np.linalg.norm(d), ka, np.linalg.norm(d) / L, L)]
    else:                                                                # down to 0, then up in the new plane
        runs = [(ka / np.linalg.norm(ka), ka, -np.linalg.norm(ka) / (L / 2), L / 2),
                (kb / np.linalg.norm(kb), np.zeros(2), np.linalg.norm(kb) / (L / 2), L / 2)]
    out = []
    for u, k_start, c, length in runs:
        bank = math.atan2(u[1], u[0])
        out += [(bank, k0, c, h) for k0, h in split_ramp(float(k_start @ u), c, length)]
    return out


def local_piece(k0: float, c: float, length: float) -> Piece:
    """The planar clothoid of a 3-D piece in its own plane coordinates (start at 0, heading along x).

    Parameters
    ----------
    k0, c, length : float
        Start curvature [1/m], curvature rate [1/m^2] and length [m].

    Returns
    -------
    Piece
        The clothoid in the plane of ``t_0`` (x) and ``u`` (y).
    """
    return Piece(np.zeros(2), np.array([1.0, 0.0]), k0, 0.0, length, c=c)


def spiral_constants(p0, tangent, n1, n2, s0, bank, k0, c, length) -> np.ndarray:
    """The 28 constants of a 3-D clothoid piece (the layout of :func:`~.paths3d.piece_constants`, flag 2).

    Parameters
    ----------
    p0, tangent, n1, n2 : ndarray, shape (3,)
        Start point [m] and the transported frame there.
    s0 : float
        Arc length at the start [m].
    bank, k0, c, length : float
        Turn direction [rad], start curvature [1/m], curvature rate [1/m^2], length [m].

    Returns
    -------
    ndarray, shape (28,)
        ``p0, t, n1, n2``, ``s0``, 2 (the flag), ``k0``, ``c``, the chord guess ``h`` (2,), plane normal
        ``w``, turn direction ``u`` and ``(n1.u, n1.w, n2.u, n2.w)``.
    """
    u = math.cos(bank) * n1 + math.sin(bank) * n2
    w = np.cross(tangent, u)
    end = local_piece(k0, c, length).end()[0]
    h = length * end / float(end @ end)
    return np.r_[p0, tangent, n1, n2, s0, 2.0, k0, c, h, w, u, n1 @ u, n1 @ w, n2 @ u, n2 @ w]


def spiral_formulas3d(sel, y):
    """``(psi, Phi, frame)`` at ``y`` on the 3-D clothoid piece with constants ``sel`` (:func:`spiral_constants`).

    Parameters
    ----------
    sel : casadi.SX or DM, shape (28,)
        The piece's constants.
    y : casadi.SX, shape (3, 1)
        A point [m].

    Returns
    -------
    tuple
        Arc length [m], ``Phi`` (2, 1) [m] and the frame (tangent, ``n_1``, ``n_2``) at the closest point.
    """
    p0, t0, s0, k0, c, h = sel[0:3], sel[3:6], sel[12], sel[14], sel[15], sel[16:18]
    w, u = sel[18:21], sel[21:24]
    c11, c12, c21, c22 = sel[24], sel[25], sel[26], sel[27]
    v = y - p0
    a, b, z = ca.dot(t0, v), ca.dot(u, v), ca.dot(w, v)
    sigma, X, Y, th = spiral_foot(k0, c, h[0] * a + h[1] * b, a, b)
    ct, st = ca.cos(th), ca.sin(th)
    d = ct * (b - Y) - st * (a - X)
    normal = -st * t0 + ct * u
    frame = (ct * t0 + st * u, c11 * normal + c12 * w, c21 * normal + c22 * w)
    return s0 + sigma, ca.vertcat(c11 * d + c12 * z, c21 * d + c22 * z), frame
