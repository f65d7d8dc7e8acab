"""Spatial chain of m equal links with universal (two-axis) joints (docs/guide/spatial.md): a :class:`.KinematicChain`.

Joint j has the angles ``(a_j, b_j)``; ``q = (a_1, b_1, ..., a_m, b_m)``. Link frames ``R_0 = I``,
``R_j = R_{j-1} Rz(a_j) Ry(b_j)``, link directions ``d_j = R_j e_x``, centres ``y^1 = 0`` (the base,
pinned at the origin) and ``y^j = y^{j-1} + xi/2 (d_{j-1} + d_j)``. With every ``b_j = 0`` it is the
planar chain with ``q_j = a_j``.

On a rail (``base="rail"``, the feed axis) a prismatic joint ``d`` [m] comes first in ``q``:
``q = (d, a_1, b_1, ..., a_m, b_m)`` (``dof = 2 m + 1``) and the base is ``y^1 = d r`` with ``r`` the
unit rail direction; the link frames do not depend on ``d`` (``R_0 = I``). :meth:`SpatialChain.angles`
drops ``d``, :meth:`SpatialChain.rail_position` reads it, :attr:`SpatialChain.rail_direction` and
:attr:`SpatialChain.rail_limits` describe the rail.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

import casadi as ca
import numpy as np

from .chain_model import KinematicChain, check_joint_vector
from .checks import is_integer, is_real
from .errors import ConfigError, shown
from .vectors3d import vector_norm

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def rot_z(a: Any) -> Any:
    """``Rz(a) = [[c, -s, 0], [s, c, 0], [0, 0, 1]]`` (CasADi).

    Parameters
    ----------
    a : casadi.SX or casadi.MX
        Angle [rad].

    Returns
    -------
    casadi expression, shape (3, 3)
    """
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def rot_y(b: Any) -> Any:
    """``Ry(b) = [[c, 0, s], [0, 1, 0], [-s, 0, c]]`` (CasADi).

    Parameters
    ----------
    b : casadi.SX or casadi.MX
        Angle [rad].

    Returns
    -------
    casadi expression, shape (3, 3)
    """
    c, s = ca.cos(b), ca.sin(b)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def joint_rotation_np(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """``Rz(a) Ry(b)``, vectorised over the shape of ``a`` and ``b``.

    Parameters
    ----------
    a, b : array_like, same shape
        Joint angles [rad].

    Returns
    -------
    ndarray, shape a.shape + (3, 3)
    """
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    return joint_matrices(np.cos(a), np.sin(a), np.cos(b), np.sin(b))


def joint_matrices(ca: np.ndarray, sa: np.ndarray, cb: np.ndarray, sb: np.ndarray) -> np.ndarray:
    """``Rz(a) Ry(b) = [[ca cb, -sa, ca sb], [sa cb, ca, sa sb], [-sb, 0, cb]]`` from the cosines and sines.

    Parameters
    ----------
    ca, sa, cb, sb : ndarray, same shape
        ``cos a, sin a, cos b, sin b`` [-].

    Returns
    -------
    ndarray, shape ca.shape + (3, 3)
    """
    rows = [[ca * cb, -sa, ca * sb], [sa * cb, ca, sa * sb], [-sb, np.zeros_like(ca), cb]]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def link_frames(ca: np.ndarray, sa: np.ndarray, cb: np.ndarray, sb: np.ndarray) -> np.ndarray:
    """The link frames ``R_j = R_{j-1} Rz(a_j) Ry(b_j)`` (``R_0 = I``) from the joints' cosines and sines.

    Each entry of a product is ``p_0 q_0 + p_1 q_1 + p_2 q_2``, summed left to right, one rounding per
    operation (never a fused multiply-add): the same bits on every machine, which the C kernel
    (:func:`coordarm.generated.chain_geometry.spatial_frames`) repeats. (A BLAS product, as ``@``
    makes it, rounds as the CPU's kernel does.)

    Parameters
    ----------
    ca, sa, cb, sb : ndarray, each shape (..., m)
        ``cos a_j, sin a_j, cos b_j, sin b_j`` [-].

    Returns
    -------
    ndarray, shape (..., m, 3, 3)
        The frames [-] (column 0: the link's direction).
    """
    J = joint_matrices(ca, sa, cb, sb)
    R = np.empty_like(J)
    R[..., 0, :, :] = J[..., 0, :, :]
    for j in range(1, J.shape[-3]):
        P, Q = R[..., j - 1, :, :], J[..., j, :, :]
        R[..., j, :, :] = (P[..., :, 0, None] * Q[..., None, 0, :] + P[..., :, 1, None] * Q[..., None, 1, :]
                           + P[..., :, 2, None] * Q[..., None, 2, :])
    return R


def joint_angles_of_direction(R_prev: np.ndarray, d: np.ndarray) -> tuple[float, float]:
    """The joint angles ``(a, b)`` that turn the frame ``R_prev`` so that its x axis becomes ``d``.

    In the frame of the previous link ``l = R_prev^T d = (cos a cos b, sin a cos b, -sin b)``:
    ``a = atan2(l_y, l_x)``, ``b = atan2(-l_z, |(l_x, l_y)|)`` (so ``|b| <= pi/2``).

    Parameters
    ----------
    R_prev : ndarray, shape (3, 3)
        Frame of the previous link.
    d : ndarray, shape (3,)
        Unit direction of the link.

    Returns
    -------
    (float, float)
        ``(a, b)`` [rad].
    """
    lx, ly, lz = R_prev.T @ d
    return math.atan2(ly, lx), math.atan2(-lz, math.hypot(lx, ly))


def rotate_about(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """``v`` turned by ``angle`` about the unit ``axis`` (Rodrigues).

    Parameters
    ----------
    v, axis : ndarray, shape (3,)
        Vector, unit axis.
    angle : float
        Angle [rad], right-handed about ``axis``.

    Returns
    -------
    ndarray, shape (3,)
    """
    c, s = math.cos(angle), math.sin(angle)
    return c * v + s * np.cross(axis, v) + (1 - c) * np.dot(axis, v) * axis


def unit_vector(v: Any, name: str) -> np.ndarray:
    """``v`` as a unit 3-vector, or a ConfigError naming ``name``.

    Parameters
    ----------
    v : array_like, shape (3,)
        A non-zero finite vector.
    name : str
        Name used in the error message.

    Returns
    -------
    ndarray, shape (3,)

    Raises
    ------
    ConfigError
        Not three finite numbers, or zero.
    """
    three = (isinstance(v, (list, tuple)) or isinstance(v, np.ndarray) and v.ndim == 1) and len(v) == 3
    arr = np.asarray(v, dtype=float) if three and all(is_real(x, numpy=True) for x in v) else None
    norm = 0.0
    if arr is not None and np.all(np.isfinite(arr)):
        arr, norm = vector_norm(arr)
    if norm == 0:
        raise ConfigError(f"{name}: need three finite numbers, not all zero, got {shown(v)}")
    return arr / norm


class SpatialChain(KinematicChain):
    """A spatial chain of ``links`` links of length ``link_length`` with universal joints.

    Parameters
    ----------
    links : int
        Number of links m >= 2.
    link_length : float
        Link length xi > 0 [m].
    base : {"fixed", "rail"}
        ``"fixed"``: the base ``y^1`` is pinned at the origin. ``"rail"``: a feed axis, a prismatic
        joint ``d`` [m] first in ``q`` slides the base to ``y^1 = d rail_direction``.
    rail_direction : array_like, shape (3,)
        Direction of the rail (normalised here; a rail only).
    rail_limits : (float, float)
        Allowed range ``[low, high]`` of ``d`` [m] (a run leaving it stops with a ``rail_limit`` contact).

    Attributes
    ----------
    m : int
        Number of links.
    xi : float
        Link length [m].
    dof : int
        ``2 m`` joint angles ``(a_1, b_1, ..., a_m, b_m)``, plus ``d`` first on a rail (``2 m + 1``).
    rail : bool
        Whether the base slides on a rail.
    rail_direction : ndarray, shape (3,)
        Unit direction of the rail (``(1, 0, 0)`` for a fixed base, unused there).
    rail_limits : (float, float)
        Range of ``d`` [m] (``(-inf, inf)`` for a fixed base).

    Raises
    ------
    ConfigError
        ``links`` or ``link_length`` of the wrong type or out of range, an unknown base, a rail
        direction that is not three finite numbers (not all zero), or rail limits that are not
        ``[low, high]`` with ``low < high``.
    """

    kind = "universal"

    def __init__(self, links: int, link_length: float, base: str = "fixed",
                 rail_direction: ArrayLike = (1.0, 0.0, 0.0),
                 rail_limits: Sequence[float] = (-math.inf, math.inf)) -> None:
        if not is_integer(links) or links < 2:
            raise ConfigError(f"links: need an integer >= 2, got {links!r}")
        if not is_real(link_length) or not math.isfinite(link_length) or link_length <= 0:
            raise ConfigError(f"link_length: need a finite number > 0 [m], got {link_length!r}")
        if base not in ("fixed", "rail"):
            raise ConfigError(f"base: expected one of ('fixed', 'rail'), got {base!r}")
        self.m, self.xi = int(links), float(link_length)
        self.rail = base == "rail"
        self.rail_direction = unit_vector(rail_direction, "rail_direction")
        lim = tuple(rail_limits) if isinstance(rail_limits, (list, tuple)) else ()
        if len(lim) != 2 or any(not is_real(v) or math.isnan(v) for v in lim) or not lim[0] < lim[1]:
            raise ConfigError(f"rail_limits: need [low, high] with low < high [m], got {rail_limits!r}")
        self.rail_limits = (float(lim[0]), float(lim[1]))
        self.dof = 2 * self.m + int(self.rail)

    @property
    def links(self) -> int:
        """Number of links m."""
        return self.m

    @property
    def link_length(self) -> float:
        """Link length xi [m]."""
        return self.xi

    def __repr__(self) -> str:
        rail = f", base='rail', rail_direction={self.rail_direction.tolist()}" if self.rail else ""
        return f"SpatialChain(links={self.m}, link_length={self.xi}{rail})"

    # ------------------------------------------------------------------------------ rail
    def angles(self, q: Any) -> Any:
        """The ``2 m`` joint angles ``(a_1, b_1, ..., a_m, b_m)`` of ``q`` (``d`` dropped on a rail).

        Parameters
        ----------
        q : ndarray, shape (..., dof), or casadi expression, shape (dof,)
            Joint coordinates.

        Returns
        -------
        same type, shape (..., 2 m)
            The joint angles [rad].
        """
        if not self.rail:
            return q
        return q[..., 1:] if isinstance(q, np.ndarray) else q[1:]

    def rail_position(self, q: ArrayLike) -> np.ndarray:
        """The rail position ``d`` of ``q`` (0 for a fixed base), vectorised over leading axes.

        Parameters
        ----------
        q : array_like, shape (..., dof)
            Joint coordinates.

        Returns
        -------
        ndarray, shape (...)
            ``d`` [m].
        """
        q = np.asarray(q, float)
        return q[..., 0] if self.rail else np.zeros(q.shape[:-1])

    def base_point(self, q: ArrayLike) -> np.ndarray:
        """The base ``y^1 = d rail_direction`` (the origin for a fixed base), vectorised.

        Parameters
        ----------
        q : array_like, shape (..., dof)
            Joint coordinates.

        Returns
        -------
        ndarray, shape (..., 3)
            The base [m].
        """
        return self.rail_position(q)[..., None] * self.rail_direction

    def with_rail_position(self, angles: ArrayLike, d: float = 0.0) -> np.ndarray:
        """``q`` from the joint angles: ``(d, angles)`` on a rail, the angles alone for a fixed base.

        Parameters
        ----------
        angles : array_like, shape (2 m,)
            ``(a_1, b_1, ..., a_m, b_m)`` [rad].
        d : float
            Rail position [m] (ignored for a fixed base).

        Returns
        -------
        ndarray, shape (dof,)
        """
        angles = np.asarray(angles, float)
        return np.r_[float(d), angles] if self.rail else angles

    # ---------------------------------------------------------------------------- CasADi
    def frames(self, q: Any) -> list[Any]:
        """The link frames ``R_1..R_m`` of symbolic joint coordinates.

        Parameters
        ----------
        q : casadi.SX or casadi.MX, shape (2 m,)
            Joint coordinates ``(a_1, b_1, ...)`` [rad].

        Returns
        -------
        list of casadi expression, each (3, 3)
        """
        R, out, q = None, [], self.angles(q)
        for j in range(self.m):
            J = ca.mtimes(rot_z(q[2 * j]), rot_y(q[2 * j + 1]))
            R = J if R is None else ca.mtimes(R, J)
            out.append(R)
        return out

    def directions(self, q: Any) -> Any:
        """Link directions ``d_j = R_j e_x`` of symbolic joint coordinates.

        Parameters
        ----------
        q : casadi.SX or casadi.MX, shape (2 m,)
            Joint coordinates [rad].

        Returns
        -------
        casadi expression, shape (3, m)
            Column j is the unit direction of link j+1.
        """
        return ca.horzcat(*[R[:, 0] for R in self.frames(q)])

    def centres(self, q: Any) -> Any:
        """Link centres of symbolic joint coordinates.

        Parameters
        ----------
        q : casadi.SX or casadi.MX, shape (2 m,)
            Joint coordinates [rad].

        Returns
        -------
        casadi expression, shape (3, m)
            Column j is the centre of link j+1 [m] (column 0 the base: the origin, or ``d`` along the rail).
        """
        d = self.directions(q)
        cols = [q[0] * ca.DM(self.rail_direction) if self.rail else ca.DM.zeros(3, 1) + 0 * q[0]]
        for j in range(1, self.m):
            cols.append(cols[-1] + 0.5 * self.xi * (d[:, j - 1] + d[:, j]))
        return ca.horzcat(*cols)

    # ----------------------------------------------------------------------------- numpy
    def check_q(self, q: ArrayLike, field: str = "q") -> np.ndarray:
        """Return ``q`` as a float array of shape (2 m,), or raise a ConfigError naming ``field``.

        Parameters
        ----------
        q : array_like, shape (dof,)
            Joint coordinates ``(a_1, b_1, ..., a_m, b_m)`` [rad] (``d`` [m] first on a rail).
        field : str
            Name used in the error message.

        Returns
        -------
        ndarray, shape (dof,)
            ``q`` as floats.

        Raises
        ------
        ConfigError
            Wrong shape, NaN or inf.
        """
        return check_joint_vector(q, self.dof, field, " (d, a_1, b_1, ..., a_m, b_m)" if self.rail
                                  else " (a_1, b_1, ..., a_m, b_m)")

    def frames_np(self, q: ArrayLike) -> np.ndarray:
        """Link frames ``R_j``, vectorised over leading axes of ``q`` (:func:`link_frames` of :meth:`joint_trig`).

        Parameters
        ----------
        q : array_like, shape (..., 2 m)
            Joint coordinates [rad].

        Returns
        -------
        ndarray, shape (..., m, 3, 3)
        """
        return link_frames(*self.joint_trig(q))

    def joint_trig(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``cos a_j, sin a_j, cos b_j, sin b_j`` of ``q``'s joint angles, as numpy computes them for the frames.

        Parameters
        ----------
        q : array_like, shape (..., dof)
            Joint coordinates [rad] (``d`` [m] first on a rail).

        Returns
        -------
        ca, sa, cb, sb : ndarray, each shape (..., m)
            [-].
        """
        angles = self.angles(np.asarray(q, float))
        a, b = angles[..., 0::2], angles[..., 1::2]
        return np.cos(a), np.sin(a), np.cos(b), np.sin(b)

    def directions_np(self, q: ArrayLike) -> np.ndarray:
        """Link directions ``d_j``, vectorised over leading axes of ``q``.

        Parameters
        ----------
        q : array_like, shape (..., 2 m)
            Joint coordinates [rad].

        Returns
        -------
        ndarray, shape (..., m, 3)
        """
        return self.frames_np(q)[..., :, 0]

    def centres_np(self, q: ArrayLike) -> np.ndarray:
        """Link centres, vectorised over leading axes of ``q``.

        Parameters
        ----------
        q : array_like, shape (..., 2 m)
            Joint coordinates [rad].

        Returns
        -------
        ndarray, shape (..., m, 3)
            Link centres [m], the first at the base (the origin, or ``d`` along the rail).
        """
        return self.centres_of(self.directions_np(q), q)

    def centres_of(self, d: np.ndarray, q: ArrayLike) -> np.ndarray:
        """Link centres from the link directions ``d`` of ``q`` (:meth:`centres_np` without the frames).

        Parameters
        ----------
        d : ndarray, shape (..., m, 3)
            Unit link directions of ``q`` [-].
        q : array_like, shape (..., dof)
            Joint coordinates (the rail position ``d`` [m] places the base).

        Returns
        -------
        ndarray, shape (..., m, 3)
            Link centres [m], the first at the base.
        """
        steps = 0.5 * self.xi * (d[..., :-1, :] + d[..., 1:, :])
        base = self.base_point(q)[..., None, :]
        return np.concatenate([base, base + np.cumsum(steps, axis=-2)], axis=-2)

    def joint_angles(self, directions: ArrayLike, d: float = 0.0) -> np.ndarray:
        """The joint coordinates of given link directions (each joint with ``|b_j| <= pi/2``).

        Parameters
        ----------
        directions : array_like, shape (m, 3)
            Unit link directions ``d_1..d_m`` (normalised here).
        d : float
            Rail position [m] (a chain on a rail only; put first in ``q``).

        Returns
        -------
        ndarray, shape (dof,)
            ``(a_1, b_1, ..., a_m, b_m)`` [rad] (``d`` [m] first on a rail).
        """
        dirs = np.asarray(directions, float)
        dirs = dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)
        q, R = np.empty(2 * self.m), np.eye(3)
        for j in range(self.m):
            a, b = joint_angles_of_direction(R, dirs[j])
            q[2 * j:2 * j + 2] = a, b
            R = R @ joint_rotation_np(a, b)
        return self.with_rail_position(q, d)

    def zigzag(self, beta: float, axis: ArrayLike = (1.0, 0.0, 0.0), fold: ArrayLike = (0.0, 1.0, 0.0),
               roll: float = 0.0, d: float = 0.0) -> np.ndarray:
        """Uniform spatial zig-zag ``d_j = cos(beta) axis + (-1)^(j+1) sin(beta) fold_rolled``.

        ``fold`` is orthogonalised against ``axis`` and turned by ``roll`` about it; the centres lie
        on the line through the origin along ``axis``, spaced ``xi cos(beta)``.

        Parameters
        ----------
        beta : float
            Fold angle [rad], ``0 < |beta| < pi/2``.
        axis : array_like, shape (3,)
            Direction of the line of centres.
        fold : array_like, shape (3,)
            Direction of the fold (not parallel to ``axis``).
        roll : float
            Turn of the fold direction about ``axis`` [rad].
        d : float
            Rail position [m] (a chain on a rail only; the centres then lie on the line through the base).

        Returns
        -------
        ndarray, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).

        Raises
        ------
        ConfigError
            A value not finite, ``beta`` out of range, or ``fold`` parallel to ``axis``.
        """
        for name, v in (("beta", beta), ("roll", roll)):
            if not is_real(v) or not math.isfinite(v):
                raise ConfigError(f"{name}: need a finite number, got {v!r}")
        if not 0 < abs(beta) < math.pi / 2:
            raise ConfigError(f"beta: need 0 < |beta| < pi/2 for a zig-zag, got {beta}")
        ax, fo = unit_vector(axis, "axis"), unit_vector(fold, "fold")
        fo = fo - np.dot(fo, ax) * ax
        if np.linalg.norm(fo) < 1e-9:
            raise ConfigError("fold: must not be parallel to axis")
        fo = rotate_about(fo / np.linalg.norm(fo), ax, float(roll))
        signs = (-1.0) ** np.arange(self.m)                  # (-1)^(j+1) for j = 1..m
        dirs = math.cos(beta) * ax + math.sin(beta) * signs[:, None] * fo
        return self.joint_angles(dirs, d)
