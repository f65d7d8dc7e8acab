"""The base margin of a robot on a rail, planar or spatial: is its base still where the law can drive the body?

Where a path leaves the rail's line the base ``y^1`` (on the rail) leaves the path. Link 1 then
turns towards the path's normal at link 2's centre; as it comes to stand across it, the free
rate of the O(m) solve (link 1's) stops moving the body, and every rate blows up (``|u|`` from 1 to
hundreds of rad/s in 0.2 s) while the link margins, the longitudinal margin (scaled by the same
vanishing factor) and the rail margin stay healthy. The base margin

``|n_1 . grad phi(y^2)| / |n_2 . grad phi(y^2)|``, at most 1,

(``n_j`` link j's normal) is the factor by which link 1's rate moves link 2's centre across
the path, relative to link 2's own: 1 on a zig-zag laid along the path, 0 when link 1 stands
across it. :data:`BASE_THRESHOLD` stops a run before ``|u|`` passes 10 times its value on the
path (evidence: ``tests/test_base_margin.py``).

A spatial chain (two-axis joints) fails otherwise: link 1 turns towards the path's *tangent*, and the
roll of the fold plane, held and measured from link 1 (``atan2(n_2 . d_1, n_1 . d_1)``), spins the
whole body once the base's offset takes the lateral reach link 1 needs to sit in the zig-zag (its
link margins stay above 0.6; the end margin falls late). Its base margin is

``1 - |Phi(y^1)| / (xi/2 |d_2 - (d_2 . t) t|)``, at least 0

(``t`` the path's tangent at link 2's centre): 1 with the base on the path, 0 when the base's offset
equals link 2's half-width across the path. On four bends (up and to the side, ``beta`` 0.3 to 0.9,
links of 0.05 and 0.1 m) it falls below :data:`BASE_THRESHOLD` at 2 to 4.4 times the nominal ``|u|``,
before 10 times (``tests/test_base_margin.py``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from coordarm.symbolic.chain import PlanarChain
from coordarm.symbolic.errors import BaseOffPathError

#: The base margin below which a run on a rail stops (outcome ``base_off_path``).
BASE_THRESHOLD = 0.5
#: The base leaves the path when its distance from it grows faster than this [m/s] (rounding: ~1e-15).
LEAVING_RATE = 1e-6


def base_margins(ctrl: Any, t: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The base margin and the base's distance from the path at each row.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        A chain on a rail and its curve.
    t : (N,) ndarray
        Times [s].
    q : (N, dof) ndarray
        Joint coordinates (``d`` [m] first, then the joint angles [rad]).

    Returns
    -------
    margin : (N,) ndarray
        Planar: ``min(1, |n_1 . grad phi(y^2)| / |n_2 . grad phi(y^2)|)``; spatial:
        ``max(0, 1 - |Phi(y^1)| / (xi/2 |d_2 - (d_2 . t) t|))`` [-].
    offset : (N,) ndarray
        The base's distance from the path, ``|phi(y^1)|`` (spatial: ``|Phi(y^1)|``) [m].
    """
    chain = ctrl.chain
    if not isinstance(chain, PlanarChain):
        return _spatial_base_margins(ctrl, t, q)
    y = chain.centres_np(q)                              # (N, m, 2)
    phi, g = _geometry_at_base(ctrl, y, t)                              # phi(y^1), grad phi at y^2 (2, N)
    offset = np.abs(phi.ravel())
    rail = chain.rail_direction
    a1 = np.arctan2(rail[1], rail[0]) + q[:, 1]
    a2 = a1 + q[:, 2]
    c1 = np.abs(-np.sin(a1) * g[0] + np.cos(a1) * g[1])
    c2 = np.abs(-np.sin(a2) * g[0] + np.cos(a2) * g[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        margin = np.where(c1 < c2, c1 / np.where(c2 > 0, c2, 1.0), 1.0)
    return margin, offset


def _spatial_base_margins(ctrl: Any, t: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`base_margins` of a spatial chain (see the module's docstring)."""
    from .spatial_view import link_geometry          # here: a planar run loads no spatial module

    chain = ctrl.chain
    frames, y = link_geometry(chain, q)                                # (N, m, 3, 3), (N, m, 3)
    d2 = frames[:, 1, :, 0]                                            # (N, 3)
    Phi, grad_psi = _geometry_at_base(ctrl, y, t)
    offset = np.linalg.norm(Phi, axis=0)                               # |Phi(y^1)|
    tangent = grad_psi.T                                               # grad psi at y^2, (N, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        tangent = tangent / np.linalg.norm(tangent, axis=1)[:, None]
        across = np.linalg.norm(d2 - np.sum(d2 * tangent, axis=1)[:, None] * tangent, axis=1)
        margin = 1.0 - offset / (0.5 * chain.xi * across)
    return np.maximum(margin, 0.0), offset          # (NaN stays NaN: a non-finite state stops the run)


def _geometry_at_base(ctrl: Any, y: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The curve's distance output at ``y^1`` and its gradient output at ``y^2`` of each row, in one evaluation.

    The task's ``base_geometry`` (the two outputs of its geometry Function, bit for bit, without the work of
    the others): a new ``map(N)`` of the whole Function at every chunk, twice, took 70-80 ms a chunk of 1000-2000
    rows on thread and pipe3d, 5-10x the law's own time.
    """
    return tuple(ctrl.task.base_geometry()(y[:, 0, :].T, y[:, 1, :].T, t))


def base_stop(ctrl: Any, t: np.ndarray, q: np.ndarray,
              threshold: float = BASE_THRESHOLD) -> tuple[int, BaseOffPathError] | None:
    """The first row whose base margin is below ``threshold`` while the base leaves the path (or not finite).

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The closed loop; a chain without a rail has no base margin (None).
    t : (N,) ndarray
        Times [s].
    q : (N, dof) ndarray
        Joint coordinates.
    threshold : float
        The base margin's threshold [-].

    Returns
    -------
    (int, BaseOffPathError) or None
        The row and the error to stop with, or None.
    """
    chain = ctrl.chain
    if not getattr(chain, "rail", False) or chain.m < 2 or not len(t):
        return None
    margin, offset = base_margins(ctrl, t, q)
    # the base is leaving the path (its offset grows: the path leaves the rail's line); a base kept at a
    # constant distance beside a path (a rail parallel to it) can turn link 1 steeply for a while and the
    # body still follows (tests/test_near_singular.py: margin 0.19, |u| < 1.2), so it is not stopped. A part
    # of one row (the final state, a step after the last chunk's rows, which were judged) has no trend: not
    # leaving (it was taken as leaving, which stopped a run beside the path at its very last row)
    leaving = np.gradient(offset, t) > LEAVING_RATE if len(t) > 1 else np.zeros(len(t), bool)
    low = np.flatnonzero(~(margin >= threshold) & (leaving | ~np.isfinite(margin)))
    if not len(low):
        return None
    row = int(low[0])
    return row, BaseOffPathError(t[row], float(margin[row]), threshold, float(q[row, 0]), float(offset[row]),
                                 spatial=not isinstance(chain, PlanarChain))
