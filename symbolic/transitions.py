"""Curvature-continuous (G2) transitions of a composite path: clothoid pieces, exact to rounding.

A path of lines and arcs has a continuous tangent but a jump in curvature at every junction
(G1). A *transition* of length ``L`` at a junction replaces the jump by a clothoid: the
curvature changes linearly with arc length from the segment before to the segment after over
``[S - L/2, S + L/2]``, ``S`` the junction's arc length in the G1 path. Equivalently the G2
curvature is the G1 curvature averaged over a window of length ``L``: the path keeps its start,
start heading, total length and total turning; each segment gives ``L/2`` of its length to each
of its transitions (and must be long enough for it).

Geometry of a clothoid piece (start ``p0``, unit tangent ``d0``, left normal ``n0``, start
curvature ``k0``, curvature rate ``c`` [1/m^2]): at ``sigma`` along it the heading turns by
``theta(sigma) = k0 sigma + c sigma^2 / 2`` and the point is ``p0 + X d0 + Y n0`` with
``(X, Y) = int_0^sigma (cos theta, sin theta)``, computed by Gauss-Legendre quadrature with
:data:`GAUSS_NODES` nodes (exact to rounding for a piece turning at most :data:`MAX_SPIRAL`).

Closest point: Newton's method on ``f(sigma) = t(sigma) . (x(sigma) - p)``, ``f' = 1 - kappa phi``,
a fixed :data:`NEWTON_STEPS` steps started from the projection onto the piece's chord (no branch:
the same operations for every point, so the generated C stays straight-line); then
``phi = n(sigma) . (p - x(sigma))`` and ``psi = s0 + sigma``.
"""
from __future__ import annotations

import functools
import math
from typing import Sequence

import casadi as ca
import numpy as np

from .errors import ConfigError

#: Clothoid pieces turning more than this [rad] are split into equal pieces (and at an inflection).
MAX_SPIRAL = 0.25
#: Gauss-Legendre nodes of the position quadrature on a clothoid piece.
GAUSS_NODES = 7
#: Newton steps of the closest point on a clothoid piece (from the chord projection).
NEWTON_STEPS = 3
#: Default transition length as a fraction of the smaller radius of the two segments it joins.
DEFAULT_FRACTION = 0.25



@functools.lru_cache(maxsize=None)
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of ``n``-point Gauss-Legendre quadrature on [-1, 1] (:func:`numpy.polynomial.legendre.leggauss`,
    imported at the first need: numpy.polynomial takes 3 ms to import).

    Parameters
    ----------
    n : int
        Number of nodes.

    Returns
    -------
    nodes, weights : ndarray, shape (n,)
    """
    from numpy.polynomial.legendre import leggauss
    return leggauss(n)


def spiral_local(k0: float, c: float, sigma: float) -> tuple[float, float, float]:
    """Local point and heading of a clothoid, ``(X, Y, theta)`` at ``sigma`` (numbers, 24-node quadrature).

    Parameters
    ----------
    k0 : float
        Curvature at the start [1/m].
    c : float
        Curvature rate [1/m^2].
    sigma : float
        Arc length from the start [m] (the piece turns at most :data:`MAX_SPIRAL` over it).

    Returns
    -------
    tuple of float
        ``X`` along ``d0``, ``Y`` along ``n0`` [m], heading change ``theta`` [rad].
    """
    nodes, weights = gauss_legendre(24)
    tau = 0.5 * sigma * (1.0 + nodes)
    th = k0 * tau + 0.5 * c * tau * tau
    w = 0.5 * sigma * weights
    return float(w @ np.cos(th)), float(w @ np.sin(th)), k0 * sigma + 0.5 * c * sigma * sigma


def transition_runs(curvatures: Sequence[float], lengths: Sequence[float], transitions: Sequence[float]
                    ) -> list[list[tuple[float, float, float]]]:
    """The G2 curvature profile: per G1 segment, its constant core and the ramp after it.

    Parameters
    ----------
    curvatures : sequence of float
        Curvature of each G1 segment [1/m] (0 for a line), n values.
    lengths : sequence of float
        Length of each segment [m], n values.
    transitions : sequence of float
        Transition length at each junction [m], n - 1 values (junction i between segments i and i + 1).

    Returns
    -------
    list of list of (float, float, float)
        For segment i: ``(k, 0, core length)`` and, when junction i + 1 has a transition,
        ``(k_i, (k_{i+1} - k_i) / L, L)`` (start curvature [1/m], rate [1/m^2], length [m]).

    Raises
    ------
    ConfigError
        A segment too short for the transitions at its ends (it gives ``L/2`` to each),
        named ``curve.segments[i]``.
    """
    n = len(curvatures)
    runs = []
    for i in range(n):
        before = transitions[i - 1] if i > 0 else 0.0
        after = transitions[i] if i < n - 1 else 0.0
        core = lengths[i] - 0.5 * (before + after)
        if core < -1e-12 * max(1.0, lengths[i]):
            raise ConfigError(f"curve.segments[{i}]: {lengths[i]:.6g} m is too short for its transitions "
                              f"({before:.6g} m before, {after:.6g} m after; each takes half its length "
                              f"from the segment): shorten curve.transition")
        run = [(curvatures[i], 0.0, max(core, 0.0))]
        if after > 0:
            run.append((curvatures[i], (curvatures[i + 1] - curvatures[i]) / after, after))
        runs.append(run)
    return runs


def default_transitions(curvatures: Sequence[float], lengths: Sequence[float]) -> list[float]:
    """Default transition lengths: :data:`DEFAULT_FRACTION` of the smaller radius, at most either neighbour.

    Parameters
    ----------
    curvatures, lengths : sequence of float
        Per G1 segment [1/m], [m].

    Returns
    -------
    list of float
        One length per junction [m]; 0 where the curvature does not change.
    """
    out = []
    for i in range(len(curvatures) - 1):
        k = max(abs(curvatures[i]), abs(curvatures[i + 1]))
        if curvatures[i] == curvatures[i + 1] or k == 0:
            out.append(0.0)
            continue
        out.append(min(DEFAULT_FRACTION / k, lengths[i], lengths[i + 1]))
    return out


def split_ramp(k0: float, c: float, length: float) -> list[tuple[float, float]]:
    """Split a ramp into clothoid pieces: at an inflection, then each turning at most :data:`MAX_SPIRAL`.

    Parameters
    ----------
    k0 : float
        Start curvature [1/m].
    c : float
        Curvature rate [1/m^2] (non-zero).
    length : float
        Ramp length [m].

    Returns
    -------
    list of (float, float)
        ``(start curvature [1/m], length [m])`` of each piece, in order (all share the rate ``c``).
    """
    cuts = [0.0, length]
    zero = -k0 / c
    if 1e-12 * length < zero < length * (1 - 1e-12):
        cuts = [0.0, zero, length]
    pieces = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        peak = max(abs(k0 + c * a), abs(k0 + c * b))
        n = max(1, math.ceil(peak * (b - a) / MAX_SPIRAL - 1e-12))
        h = (b - a) / n
        pieces += [(k0 + c * (a + i * h), h) for i in range(n)]
    return pieces


def _quadrature(k0, c, sigma):
    """``(X, Y)`` of the clothoid at ``sigma`` by :data:`GAUSS_NODES`-node Gauss-Legendre (symbolic)."""
    X, Y = 0, 0
    for x, w in zip(*gauss_legendre(GAUSS_NODES)):
        tau = (0.5 * (1.0 + float(x))) * sigma
        th = (k0 + (0.5 * c) * tau) * tau
        X, Y = X + float(w) * ca.cos(th), Y + float(w) * ca.sin(th)
    return 0.5 * sigma * X, 0.5 * sigma * Y


def spiral_foot(k0, c, sigma, vx, vy):
    """The closest point of a clothoid to ``(vx, vy)`` in its local frame: :data:`NEWTON_STEPS` Newton steps.

    Parameters
    ----------
    k0, c : casadi.SX
        Start curvature [1/m] and curvature rate [1/m^2].
    sigma : casadi.SX
        Start guess of the arc length from the piece's start [m].
    vx, vy : casadi.SX
        The point along ``d0`` and ``n0`` from the piece's start [m].

    Returns
    -------
    tuple of casadi.SX
        ``sigma`` [m], the foot ``(X, Y)`` [m] and the heading change ``theta`` [rad] there.
    """
    for _ in range(NEWTON_STEPS):
        X, Y = _quadrature(k0, c, sigma)
        th = (k0 + 0.5 * c * sigma) * sigma
        ct, st = ca.cos(th), ca.sin(th)
        ex, ey = X - vx, Y - vy
        f = ct * ex + st * ey
        fp = 1 + (k0 + c * sigma) * (ct * ey - st * ex)
        sigma = sigma - f / fp
    X, Y = _quadrature(k0, c, sigma)
    return sigma, X, Y, (k0 + 0.5 * c * sigma) * sigma


def spiral_formulas(sel, p):
    """``(phi, psi)`` at ``p`` (path frame) on the clothoid piece with constants ``sel``.

    Parameters
    ----------
    sel : casadi.SX or DM, shape (>= 10,)
        ``(p0 [m], d0, k0 [1/m], s0 [m], c [1/m^2], length [m], h)``: ``h`` (2,) [1] maps
        ``p - p0`` to the start guess ``sigma = h . (p - p0)`` (the chord projection).
    p : casadi.SX, shape (2,)
        A point in the path's frame [m].

    Returns
    -------
    tuple of casadi.SX
        Signed distance ``phi`` (+ = left) and arc length ``psi`` [m].
    """
    p0, d0, k0, s0, c, h = sel[0:2], sel[2:4], sel[4], sel[5], sel[6], sel[8:10]
    dv = p - p0
    vx, vy = d0[0] * dv[0] + d0[1] * dv[1], d0[0] * dv[1] - d0[1] * dv[0]
    sigma, X, Y, th = spiral_foot(k0, c, h[0] * dv[0] + h[1] * dv[1], vx, vy)
    phi = ca.cos(th) * (vy - Y) - ca.sin(th) * (vx - X)
    return phi, s0 + sigma


def transition_length(value, field: str) -> float:
    """A transition length read from a scenario: a finite number >= 0 [m].

    Parameters
    ----------
    value : object
        The value.
    field : str
        Its name in error messages (``"curve.transition"``).

    Returns
    -------
    float
        The length [m].

    Raises
    ------
    ConfigError
        Not a finite number >= 0.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
            or not math.isfinite(value) or value < 0:
        raise ConfigError(f"{field}: need a length >= 0 [m], got {value!r}")
    return float(value)


def segment_transition(seg, field: str):
    """A segment without its ``transition`` key, and that key's length (None when absent).

    Parameters
    ----------
    seg : object
        One entry of a path's ``segments`` (a dict may carry ``transition``).
    field : str
        Its name in error messages.

    Returns
    -------
    tuple
        The segment as :func:`~.path_pieces.parse_segment` takes it, and the length [m] or None.
    """
    if isinstance(seg, dict) and "transition" in seg:
        rest = {k: v for k, v in seg.items() if k != "transition"}
        return rest, transition_length(seg["transition"], f"{field}.transition")
    return seg, None


def junction_transitions(segments, transition: float | None, own: Sequence[float | None]) -> list[float]:
    """Transition length at every junction of parsed segments [m].

    Parameters
    ----------
    segments : sequence of (str, float, float)
        Parsed segments (:func:`~.path_pieces.parse_segment`).
    transition : float or None
        The path's ``transition`` (None: :func:`default_transitions`).
    own : sequence of float or None
        Each junction's own length (a segment's ``transition``), None where not given.

    Returns
    -------
    list of float
        One per junction; 0 where the curvature does not change.
    """
    curv = [0.0 if kind == "line" else math.copysign(1.0 / r, a) for kind, a, r in segments]
    lengths = [a if kind == "line" else abs(a) * r for kind, a, r in segments]
    base = default_transitions(curv, lengths) if transition is None else [transition] * (len(segments) - 1)
    out = [b if L is None else L for b, L in zip(base, own)]
    return [0.0 if curv[i] == curv[i + 1] else L for i, L in enumerate(out)]
