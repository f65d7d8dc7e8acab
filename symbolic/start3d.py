"""Start configurations of a spatial chain: a zig-zag along a 3-D curve, uniform or laid link by link.

:func:`zigzag_start` is the uniform zig-zag ``d_j = cos(beta) axis + (-1)^(j+1) sin(beta) fold_rolled``
with the axis and fold taken from the curve's frame at the base by default; :func:`follow_curve3d`
lays a zig-zag link by link with every centre ``y^2..y^m`` on the curve, alternating the fold side,
so that it follows the bends of a 3-D path (the spatial counterpart of :func:`.start.follow_curve`).
:func:`bend_angles` gives the angles between consecutive links, which :func:`check_bends` bounds.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ConfigError
from .spatial_chain import SpatialChain, rotate_about, unit_vector
from .spatial_task import spatial_geometry_function

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: Newton iterations per link of :func:`follow_curve3d`.
MAX_ITER = 60


def base_frame(curve: Any, t0: float, base: ArrayLike = (0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The curve's frame ``(tangent, n_1, n_2)`` at the closest point of the base at ``t0``.

    Parameters
    ----------
    curve : SpatialCurve
        The goal curve.
    t0 : float
        Time [s].
    base : array_like, shape (3,)
        The base ``y^1`` [m] (the origin, or ``d`` along a rail).

    Returns
    -------
    tuple of 3 ndarray, each shape (3,)
        Unit tangent and normals.
    """
    out = curve.functions()(np.asarray(base, float), float(t0))
    return tuple(np.asarray(v, float).ravel() for v in out[2:5])


def first_direction(curve: Any, beta: float, t0: float, axis: ArrayLike | None = None,
                    fold: ArrayLike | None = None, roll: float = 0.0,
                    base: ArrayLike = (0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Axis and rolled fold direction of a zig-zag (defaults from the curve's frame at the base).

    Parameters
    ----------
    curve : SpatialCurve
        The goal curve.
    beta : float
        Fold angle [rad], ``0 < |beta| < pi/2``.
    t0 : float
        Time [s].
    axis : array_like, shape (3,), optional
        Direction of the zig-zag's line of centres (default: the curve's tangent at the base).
    fold : array_like, shape (3,), optional
        Direction of the fold (default: the curve's ``n_1`` there); orthogonalised against ``axis``.
    roll : float
        Turn of the fold direction about ``axis`` [rad].
    base : array_like, shape (3,)
        The base [m] whose closest point gives the default frame.

    Returns
    -------
    axis, fold : ndarray, each shape (3,)
        Unit axis and unit rolled fold direction, orthogonal.

    Raises
    ------
    ConfigError
        ``beta`` out of range, a vector not finite or zero, or ``fold`` parallel to ``axis``.
    """
    if not 0 < abs(beta) < math.pi / 2:
        raise ConfigError(f"start.beta: need 0 < |beta| < pi/2, got {beta}")
    tangent, n1, _ = base_frame(curve, t0, base)
    ax = tangent if axis is None else unit_vector(axis, "start.axis")
    fo = n1 if fold is None else unit_vector(fold, "start.fold")
    fo = fo - np.dot(fo, ax) * ax
    if np.linalg.norm(fo) < 1e-9:
        raise ConfigError("start.fold: must not be parallel to start.axis")
    return ax, rotate_about(fo / np.linalg.norm(fo), ax, float(roll))


def zigzag_start(chain: SpatialChain, curve: Any, beta: float, t0: float = 0.0, axis: ArrayLike | None = None,
                 fold: ArrayLike | None = None, roll: float = 0.0, d: float = 0.0) -> np.ndarray:
    """The uniform zig-zag ``d_j = cos(beta) axis + (-1)^(j+1) sin(beta) fold_rolled``.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    curve : SpatialCurve
        The goal curve (its frame at the base gives the default axis and fold).
    beta : float
        Fold angle [rad]; consecutive links bend by ``2 |beta|``.
    t0 : float
        Time [s].
    axis, fold : array_like, shape (3,), optional
        See :func:`first_direction`.
    roll : float
        Turn of the fold direction about the axis [rad].
    d : float
        Rail position [m] (a chain on a rail: put first in ``q``; the frame is taken at the base there).

    Returns
    -------
    ndarray, shape (dof,)
        Joint coordinates ``(a_1, b_1, ..., a_m, b_m)`` [rad] (``d`` [m] first on a rail).

    Raises
    ------
    ConfigError
        See :func:`first_direction`.
    """
    base = chain.base_point(chain.with_rail_position(np.zeros(2 * chain.m), d))
    ax, fo = first_direction(curve, beta, t0, axis, fold, roll, base)
    return chain.zigzag(float(beta), ax, fo, 0.0, d=d)


def place_link(geometry: Any, end: np.ndarray, guess: np.ndarray, h: float, t0: float,
               tol: float) -> np.ndarray:
    """The unit direction ``d`` nearest ``guess`` with ``Phi(end + h d) = 0`` (Newton on the sphere).

    Parameters
    ----------
    geometry : casadi.Function
        :func:`~.spatial_task.spatial_geometry_function` of the curve.
    end : ndarray, shape (3,)
        End point of the previous link [m].
    guess : ndarray, shape (3,)
        Unit start guess of the direction.
    h : float
        Half the link length [m].
    t0 : float
        Time [s].
    tol : float
        Stop once the step is below ``tol`` [-].

    Returns
    -------
    ndarray, shape (3,)
        The unit direction (the last iterate if Newton did not converge; the caller checks).
    """
    e1 = np.cross(guess, [1.0, 0.0, 0.0] if abs(guess[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    basis = np.column_stack([e1, np.cross(guess, e1)])
    u = np.zeros(2)
    for _ in range(MAX_ITER):
        v = guess + basis @ u
        d = v / np.linalg.norm(v)
        out = geometry(end + h * d, t0)
        phi, jphi = np.asarray(out[0], float).ravel(), np.asarray(out[1], float)
        jac = h * jphi @ ((np.eye(3) - np.outer(d, d)) / np.linalg.norm(v)) @ basis
        try:
            step = np.linalg.solve(jac, phi)
        except np.linalg.LinAlgError:
            break
        step *= min(1.0, 0.5 / max(np.max(np.abs(step)), 1e-300))
        u -= step
        if np.max(np.abs(step)) < tol:
            break
    v = guess + basis @ u
    return v / np.linalg.norm(v)


def follow_curve3d(chain: SpatialChain, curve: Any, beta: float, t0: float = 0.0, axis: ArrayLike | None = None,
                   fold: ArrayLike | None = None, roll: float = 0.0, tol: float = 1e-13, d: float = 0.0) -> np.ndarray:
    """A spatial zig-zag laid along the curve link by link: every centre ``y^2..y^m`` on it.

    Link 1 leaves the base as the zig-zag of :func:`zigzag_start` (``d_1 = cos(beta) axis +
    sin(beta) fold_rolled``). Each next direction ``d_j`` is the unit vector with
    ``Phi(y^{j-1} + xi/2 (d_{j-1} + d_j)) = 0`` found by Newton's method from the previous
    direction mirrored about the local tangent (which flips the fold side; on a straight line it is
    the uniform zig-zag), with the arc length increasing.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    curve : SpatialCurve
        The goal curve (a 3-D line, arc or path).
    beta : float
        Fold angle [rad], ``0 < |beta| < pi/2``.
    t0 : float
        Time at which to lay the chain on the curve [s].
    axis, fold : array_like, shape (3,), optional
        Of the first link (see :func:`first_direction`).
    roll : float
        Turn of the first link's fold direction about the axis [rad].
    tol : float
        Newton stops once its step is below ``tol`` [-].
    d : float
        Rail position [m] (a chain on a rail: the base is ``d`` along the rail, ``d`` first in ``q``).

    Returns
    -------
    ndarray, shape (dof,)
        Joint coordinates ``(a_1, b_1, ..., a_m, b_m)`` [rad] (``d`` [m] first on a rail).

    Raises
    ------
    ConfigError
        ``beta`` or a vector out of range, or a link that cannot be laid on the curve going forward.
    """
    y = chain.base_point(chain.with_rail_position(np.zeros(2 * chain.m), d))
    ax, fo = first_direction(curve, beta, t0, axis, fold, roll, y)
    geometry, frames, h = spatial_geometry_function(curve), curve.functions(), 0.5 * chain.xi
    directions = [math.cos(beta) * ax + math.sin(beta) * fo]
    s_prev = float(frames(y, t0)[0])
    for j in range(2, chain.m + 1):
        end = y + h * directions[-1]
        tangent = np.asarray(frames(end, t0)[2], float).ravel()
        guess = 2 * np.dot(tangent, directions[-1]) * tangent - directions[-1]
        d_j = place_link(geometry, end, guess, h, t0, tol)
        y_new = end + h * d_j
        out = frames(y_new, t0)
        phi, s = np.asarray(out[1], float).ravel(), float(out[0])
        if not (np.max(np.abs(phi)) < 1e-9 and s > s_prev):
            raise ConfigError(f"start: link {j} cannot be laid on the curve going forward at t0 = {t0} "
                              f"(beta = {beta}); try another beta, axis or fold, or a gentler curve")
        directions.append(d_j)
        y, s_prev = y_new, s
    return chain.joint_angles(np.array(directions), d)


def bend_angles(chain: SpatialChain, q: ArrayLike) -> np.ndarray:
    """Angles between consecutive link directions ``acos(d_{j-1} . d_j)``, j = 2..m, vectorised.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    q : array_like, shape (..., dof)
        Joint coordinates [rad] (``d`` [m] first on a rail).

    Returns
    -------
    ndarray, shape (..., m - 1)
        Bend angles [rad], in [0, pi].
    """
    return bends_between(chain.directions_np(q))


def bends_between(d: np.ndarray) -> np.ndarray:
    """:func:`bend_angles` from the link directions.

    Parameters
    ----------
    d : ndarray, shape (..., m, 3)
        Unit link directions [-].

    Returns
    -------
    ndarray, shape (..., m - 1)
        Bend angles [rad], in [0, pi].
    """
    return np.arccos(np.clip(np.sum(d[..., :-1, :] * d[..., 1:, :], axis=-1), -1.0, 1.0))


def check_bends(chain: SpatialChain, q: ArrayLike, limit: ArrayLike) -> None:
    """Raise a ConfigError naming the joint if a start bends beyond its limit.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    q : array_like, shape (2 m,)
        Joint coordinates [rad].
    limit : float or array_like, shape (m - 1,)
        Bend limit [rad] of joints 2..m.

    Raises
    ------
    ConfigError
        A joint bends beyond its limit.
    """
    bends = bend_angles(chain, chain.check_q(q, "start"))
    lim = np.broadcast_to(np.asarray(limit, float), bends.shape)
    bad = np.flatnonzero(~(bends <= lim))
    if len(bad):
        j = int(bad[0]) + 2
        raise ConfigError(f"start: joint {j} (between links {j - 1} and {j}) bends by {bends[j - 2]:.3f} rad, beyond "
                          f"its limit {lim[j - 2]:.3f} rad; choose a smaller start.beta or another start")
