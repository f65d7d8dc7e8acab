"""What the figures and the Foxglove scene draw of a spatial chain: its joints, a view box, the clipped curve, the roll command."""
from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from coordarm.generated.chain_geometry import spatial_frames
from coordarm.symbolic.spatial_chain import SpatialChain


def link_geometry(chain: SpatialChain, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """The link frames and centres of a spatial chain, the frames computed once (in C for a stack of poses).

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    q : array_like, shape (..., dof)
        Joint coordinates [rad] (``d`` [m] first on a rail).

    Returns
    -------
    frames : ndarray, shape (..., m, 3, 3)
        :meth:`~coordarm.symbolic.spatial_chain.SpatialChain.frames_np`, bit for bit (column 0: the directions).
    centres : ndarray, shape (..., m, 3)
        :meth:`~coordarm.symbolic.spatial_chain.SpatialChain.centres_np` [m], bit for bit.
    """
    frames = spatial_frames(chain, q)               # (the numpy frames for one pose)
    return frames, chain.centres_of(frames[..., 0], q)


def spatial_joints(chain: SpatialChain, q: Any) -> np.ndarray:
    """Link end points of a spatial chain: the chain drawn as a polyline.

    Link j spans ``y^j -+ xi/2 d_j``; the polyline starts at the first link's free end
    ``y^1 - xi/2 d_1`` and then runs through ``y^j + xi/2 d_j`` (j = 1..m), the last the end point.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    q : array_like, shape (..., 2 m)
        Joint coordinates ``(a_1, b_1, ...)`` [rad].

    Returns
    -------
    ndarray, shape (..., m+1, 3)
        Joint positions [m].
    """
    frames, y = link_geometry(chain, q)
    return joints_of(chain, frames[..., 0], y)


def joints_of(chain: SpatialChain, d: np.ndarray, y: np.ndarray) -> np.ndarray:
    """:func:`spatial_joints` from the link directions and centres (:func:`link_geometry`'s).

    Parameters
    ----------
    chain : SpatialChain
        The manipulator (its link length).
    d, y : ndarray, each shape (..., m, 3)
        Unit link directions [-] and link centres [m].

    Returns
    -------
    ndarray, shape (..., m+1, 3)
        Joint positions [m].
    """
    first = y[..., :1, :] - 0.5 * chain.xi * d[..., :1, :]
    return np.concatenate([first, y + 0.5 * chain.xi * d], axis=-2)


def view_box(points: np.ndarray, margin: float, flat: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box around ``points`` for an equal-scale 3-D view.

    The box holds every point with ``10 %`` of the largest extent plus ``margin`` on each side; an
    axis whose extent is below ``flat`` times the largest one is widened about its middle to that
    (a planar run gets a readable flat box, not a sheet).

    Parameters
    ----------
    points : ndarray, shape (k, 3)
        Points to hold [m] (non-finite rows are ignored).
    margin : float
        Extra room on each side [m] (e.g. a link length).
    flat : float
        Smallest extent of an axis relative to the largest [-].

    Returns
    -------
    lo, hi : ndarray, shape (3,)
        Corners of the box [m].
    """
    pts = np.asarray(points, float).reshape(-1, 3)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.1 * float(np.max(hi - lo)) + margin
    lo, hi = lo - pad, hi + pad
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    half = np.maximum(half, flat * float(np.max(half)))
    return mid - half, mid + half


def clip_to_box(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``points`` with every point outside the box ``[lo, hi]`` replaced by NaN (a break in a drawn line).

    Parameters
    ----------
    points : ndarray, shape (k, 3)
        Polyline vertices [m].
    lo, hi : ndarray, shape (3,)
        Corners of the box [m].

    Returns
    -------
    ndarray, shape (k, 3)
        The clipped polyline [m].
    """
    pts = np.array(points, float)
    outside = np.any((pts < lo) | (pts > hi), axis=1)
    pts[outside] = np.nan
    return pts


def roll_command(ctrl: Any, times: np.ndarray) -> np.ndarray:
    """The commanded roll ``theta*(t)`` of a spatial controller at ``times`` (one mapped CasADi call).

    Parameters
    ----------
    ctrl : SpatialController
        The controller (its ``roll_target``, a callable of ``t``).
    times : ndarray, shape (k,)
        Times [s].

    Returns
    -------
    ndarray, shape (k,)
        ``theta*`` [rad].
    """
    times = np.asarray(times, float).ravel()
    t = ca.SX.sym("t")
    f = ca.Function("roll_command", [t], [0 * t + ctrl.roll_target(t)])
    return np.asarray(f.map(len(times))(ca.DM(times).T), float).ravel() if len(times) else np.empty(0)


def rail_ends(chain: SpatialChain, reach: float) -> np.ndarray | None:
    """The two ends of a spatial chain's rail, ``low r`` and ``high r`` (an infinite limit cut to ``reach``).

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    reach : float
        Distance from the origin at which an unbounded rail is cut [m].

    Returns
    -------
    ndarray, shape (2, 3), or None
        The ends [m]; None for a fixed base.
    """
    if not chain.rail:
        return None
    lo, hi = (float(np.clip(v, -reach, reach)) for v in chain.rail_limits)
    return np.array([lo, hi])[:, None] * chain.rail_direction


def span_command(ctrl: Any, times: np.ndarray) -> np.ndarray | None:
    """The commanded span ``sigma*(t)`` of a spatial controller on a rail at ``times``, or None when it is held.

    Parameters
    ----------
    ctrl : SpatialController
        The controller (its ``span``, a callable of ``t``, or None).
    times : ndarray, shape (k,)
        Times [s].

    Returns
    -------
    ndarray, shape (k,), or None
        ``sigma*`` [m].
    """
    if getattr(ctrl, "span", None) is None:
        return None
    times = np.asarray(times, float).ravel()
    t = ca.SX.sym("t")
    f = ca.Function("span_command", [t], [0 * t + ctrl.span(t)])
    return np.asarray(f.map(len(times))(ca.DM(times).T), float).ravel() if len(times) else np.empty(0)
