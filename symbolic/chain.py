"""Planar chain of m equal links with revolute joints (paper eqs. 1-7): a :class:`.ChainModel`."""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

import casadi as ca
import numpy as np

from .carry import CARRY, Carry
from .chain_model import ChainModel, check_joint_vector
from .checks import is_integer, is_real
from .errors import ConfigError

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: Kinds of base: pinned at the origin, or on a rail (introduction axis).
BASES = ("fixed", "rail")
#: Default limit of every relative joint angle [rad].
DEFAULT_JOINT_LIMIT = 2.8


def _joint_limits(links: int, joint_limit) -> np.ndarray:
    """Limits of joints 2..m as an (m-1,) array in (0, pi], from one number or a list of m-1."""
    if isinstance(joint_limit, (list, tuple, np.ndarray)):
        lim = np.asarray(joint_limit, dtype=float) if all(
            is_real(v, numpy=True)
            for v in np.ravel(joint_limit)) else None
        if lim is None or lim.shape != (links - 1,):
            raise ConfigError(f"joint_limit: need one number or a list of {links - 1} numbers "
                              f"(joints 2..{links}), got {joint_limit!r}")
    elif not is_real(joint_limit, numpy=True):
        raise ConfigError(f"joint_limit: need a number [rad] or a list of them, got {joint_limit!r}")
    else:
        lim = np.full(links - 1, float(joint_limit))
    bad = np.flatnonzero(~((lim > 0) & (lim <= math.pi)))
    if len(bad):
        raise ConfigError(f"joint_limit: need 0 < limit <= pi [rad], joint {int(bad[0]) + 2} has {lim[bad[0]]!r}")
    return lim


def direction(a: ca.SX | ca.MX | ca.DM | ArrayLike) -> ca.SX | ca.MX | ca.DM | np.ndarray:
    """Unit vector ``d(a) = (cos a, sin a)`` (CasADi or numpy).

    Parameters
    ----------
    a : casadi.SX, casadi.MX, casadi.DM, float or array_like
        Angle(s) [rad], any shape for numpy.

    Returns
    -------
    casadi column (2, 1) or ndarray, shape a.shape + (2,)
        The unit vector(s) [-].
    """
    if isinstance(a, (ca.SX, ca.MX, ca.DM)):
        return ca.vertcat(ca.cos(a), ca.sin(a))
    return np.stack([np.cos(a), np.sin(a)], axis=-1)


def normal(a: ca.SX | ca.MX | ca.DM | ArrayLike) -> ca.SX | ca.MX | ca.DM | np.ndarray:
    """Unit normal ``n(a) = (-sin a, cos a) = T(a)^T r`` (CasADi or numpy).

    Parameters
    ----------
    a : casadi.SX, casadi.MX, casadi.DM, float or array_like
        Angle(s) [rad], any shape for numpy.

    Returns
    -------
    casadi column (2, 1) or ndarray, shape a.shape + (2,)
        The unit normal(s) [-].
    """
    if isinstance(a, (ca.SX, ca.MX, ca.DM)):
        return ca.vertcat(-ca.sin(a), ca.cos(a))
    return np.stack([-np.sin(a), np.cos(a)], axis=-1)


class PlanarChain(ChainModel):
    """A planar chain of ``links`` links of length ``link_length``.

    Link 1 turns about its own centre, pinned at the origin (``y^1 = 0``); joint j
    joins links j-1 and j; ``alpha_j = q_1 + ... + q_j`` (eq. 5); the plant is
    ``qdot = B u`` (eq. 2).

    Parameters
    ----------
    links : int
        Number of links m (at least 2).
    link_length : float
        Link length xi [m].
    B : array_like, optional
        Input matrix, (m, m) or its diagonal (m,). Defaults to the identity.
    joint_limit : float or sequence of float
        Largest ``|q_j|`` of the relative joints j = 2..m [rad], one number for all or a list
        of m-1 (default :data:`DEFAULT_JOINT_LIMIT`; the compact zig-zag at beta uses 2 beta).
    clearance : float
        Smallest allowed distance between non-adjacent links and from a link to an obstacle
        [m] (default 0: touching counts as a collision).
    base : {"fixed", "rail"}
        ``"fixed"``: the first central point is pinned at the origin. ``"rail"``: an
        introduction axis, a prismatic joint ``d`` [m] before the first revolute joint slides
        it to ``y^1 = d (cos, sin)(rail_angle)``; ``q`` then holds ``d`` first (m+1 joints)
        and ``qdot_d = u_d`` (``B`` acts on the revolute joints).
    rail_angle : float
        Direction of the rail [rad].
    rail_limits : (float, float)
        Allowed range of ``d`` [m] (a run leaving it stops like a collision).

    Raises
    ------
    ConfigError
        Fewer than 2 links, a link length that is not a finite number > 0, a ``B`` of the wrong
        shape, not finite or singular, joint limits outside ``(0, pi]`` or of the wrong count, a
        negative or non-finite clearance, an unknown base, a non-finite rail angle, or rail
        limits that are not ``[low, high]`` with ``low < high``.
    """

    def __init__(self, links: int, link_length: float, B: ArrayLike | None = None,
                 joint_limit: float | Sequence[float] | None = None, clearance: float = 0.0,
                 base: str = "fixed", rail_angle: float = 0.0,
                 rail_limits: Sequence[float] = (-math.inf, math.inf)) -> None:
        if not is_integer(links, numpy=True) or links < 2:
            raise ConfigError(f"links: need an integer of at least 2, got {links!r}")
        if (not is_real(link_length)
                or not math.isfinite(link_length) or link_length <= 0):
            raise ConfigError(f"link_length: need a finite number > 0, got {link_length!r}")
        self.m, self.xi = int(links), float(link_length)
        self._bd, self._B = _input_matrix(B, self.m)
        self.joint_limits = _joint_limits(self.m, DEFAULT_JOINT_LIMIT if joint_limit is None else joint_limit)
        if (not is_real(clearance)
                or not math.isfinite(clearance) or clearance < 0):
            raise ConfigError(f"clearance: need a finite number >= 0, got {clearance!r}")
        self.clearance = float(clearance)
        if base not in BASES:
            raise ConfigError(f"base: expected one of {BASES}, got {base!r}")
        self.rail = base == "rail"
        if not is_real(rail_angle) or not math.isfinite(rail_angle):
            raise ConfigError(f"rail_angle: need a finite number [rad], got {rail_angle!r}")
        self.rail_angle = float(rail_angle)
        lim = tuple(rail_limits) if isinstance(rail_limits, (list, tuple)) else ()
        if (len(lim) != 2 or any(not is_real(v) or math.isnan(v) for v in lim)
                or not lim[0] < lim[1]):
            raise ConfigError(f"rail_limits: need [low, high] with low < high [m], got {rail_limits!r}")
        self.rail_limits = (float(lim[0]), float(lim[1]))
        #: Number of joints: m revolute joints, plus the rail's prismatic joint first.
        self.dof = self.m + int(self.rail)

    @property
    def links(self) -> int:
        return self.m

    @property
    def link_length(self) -> float:
        return self.xi

    @property
    def B(self) -> np.ndarray:
        """The input matrix as a dense (m, m) array (built on each access when B is diagonal: O(m^2))."""
        return self._B if self._B is not None else np.diag(self._bd)

    @property
    def b_diagonal(self) -> np.ndarray | None:
        """Diagonal of B if B is diagonal, else None (O(m): a diagonal B is stored as a vector)."""
        return None if self._bd is None else self._bd.copy()

    def apply_B(self, u: ArrayLike) -> np.ndarray:
        """``B u``: a product by the diagonal when B is diagonal, O(m) per row.

        Parameters
        ----------
        u : array_like, shape (..., m)
            Controls (one per row).

        Returns
        -------
        ndarray, shape (..., m)
            Joint rates ``qdot = B u`` [rad/s].
        """
        u = np.asarray(u, dtype=float)
        return self._bd * u if self._bd is not None else u @ self._B.T

    def __repr__(self) -> str:
        rail = f", base='rail', rail_angle={self.rail_angle}" if self.rail else ""
        return f"PlanarChain(links={self.m}, link_length={self.xi}{rail})"

    @property
    def rail_direction(self) -> np.ndarray:
        """Unit vector of the rail (the direction in which ``d`` slides the base)."""
        return np.array([math.cos(self.rail_angle), math.sin(self.rail_angle)])

    def revolute(self, q: np.ndarray | ca.SX | ca.MX) -> np.ndarray | ca.SX | ca.MX:
        """The revolute joint angles ``q_1..q_m`` of ``q`` (drops ``d`` on a rail), any leading axes.

        Parameters
        ----------
        q : ndarray or casadi expression, shape (..., dof)
            Joint coordinates.

        Returns
        -------
        same type, shape (..., m)
            The revolute joint angles [rad].
        """
        return q[..., 1:] if self.rail and isinstance(q, np.ndarray) else (q[1:] if self.rail else q)

    def base_point(self, q: ArrayLike) -> np.ndarray:
        """The first central point ``y^1``: the origin, or ``d`` along the rail.

        Parameters
        ----------
        q : array_like, shape (..., dof) (or (..., 1): ``d`` alone)
            Joint coordinates.

        Returns
        -------
        ndarray, shape (..., 2)
            The base [m].
        """
        q = np.asarray(q, float)
        if not self.rail:
            return np.zeros(q.shape[:-1] + (2,))
        return q[..., :1] * self.rail_direction

    # ----------------------------------------------------------------- symbolic
    def centres(self, q: ca.SX) -> ca.SX:
        """Central points ``c^j(q)`` (eq. 4) as a 2 x m CasADi expression.

        Parameters
        ----------
        q : casadi.SX or casadi.MX, shape (dof,)
            Joint coordinates [rad] (on a rail ``d`` [m] first).

        Returns
        -------
        casadi.SX or casadi.MX, shape (2, m)
            Column j is the centre of link j+1 [m]; the first is the base.
        """
        zero = ca.SX.zeros(2, 1) if isinstance(q, ca.SX) else ca.MX.zeros(2, 1)
        if self.rail:
            zero = q[0] * ca.DM(self.rail_direction)
            q = q[1:]
        alpha = ca.cumsum(q)
        cols = [zero]
        for j in range(1, self.m):
            cols.append(cols[-1] + 0.5 * self.xi * (direction(alpha[j - 1]) + direction(alpha[j])))
        return ca.horzcat(*cols)

    @property
    def B_joints(self) -> np.ndarray:
        """``B`` over all joints: ``diag(1, B)`` on a rail (``qdot_d = u_d``), else ``B``; shape (dof, dof)."""
        if not self.rail:
            return self.B
        out = np.eye(self.dof)
        out[1:, 1:] = self.B
        return out

    # ----------------------------------------------------- pieces of the law (ChainModel)
    def link_direction(self, alpha: ca.SX) -> ca.SX:
        """The direction ``d(alpha) = (cos, sin)(alpha)`` of a link at absolute angle ``alpha`` [rad].

        Parameters
        ----------
        alpha : casadi.SX
            Absolute angle ``alpha_j = q_1 + ... + q_j`` [rad].

        Returns
        -------
        casadi.SX, shape (2, 1)
            The unit direction.
        """
        return direction(alpha)

    @staticmethod
    def link_normal(d: ca.SX) -> ca.SX:
        """The normal ``n = (-d_2, d_1)`` of a link of direction ``d``.

        Parameters
        ----------
        d : casadi.SX, shape (2, 1)
            Link direction.

        Returns
        -------
        casadi.SX, shape (2, 1)
            ``d`` turned by +90 degrees.
        """
        return ca.vertcat(-d[1], d[0])

    def centre_step(self, d_prev: ca.SX, d_j: ca.SX) -> ca.SX:
        """``y^j - y^{j-1} = xi/2 (d_{j-1} + d_j)`` [m] (eq. 4).

        Parameters
        ----------
        d_prev, d_j : casadi.SX, shape (2, 1)
            Directions of links ``j-1`` and ``j``.

        Returns
        -------
        casadi.SX, shape (2, 1)
            The step from the centre of link ``j-1`` to that of link ``j`` [m].
        """
        return 0.5 * self.xi * (d_prev + d_j)

    def first_carry(self, q1: ca.SX) -> ca.SX:
        """The carry of link 1: centre at the base (the origin), ``w_1 = p``, ``ydot^1 + xi/2 n_1 w_1 = xi/2 n_1 p``.

        Parameters
        ----------
        q1 : casadi.SX
            Joint angle ``q_1`` [rad].

        Returns
        -------
        casadi.SX, shape (CARRY.size, 1)
            Layout :data:`~coordarm.symbolic.carry.CARRY`.
        """
        c, s = ca.cos(q1), ca.sin(q1)
        h = 0.5 * self.xi
        return CARRY.pack(Carry(y=(0, 0), alpha=q1, direction=(c, s), P=(0, 0), Q=(-h * s, h * c), a=0, b=1,
                                sum_abs_b=1))

    def controls_from_link_rates(self, w: ca.MX) -> ca.MX:
        """The controls ``u = B^-1 qdot`` of the revolute joints from the link rates ``w_j = alpha_j'``.

        Parameters
        ----------
        w : casadi.MX, shape (m, 1)
            Link rates ``w_1..w_m`` [rad/s].

        Returns
        -------
        casadi.MX, shape (m, 1)
            ``u`` [rad/s for B = I]; ``qdot_j = w_j - w_{j-1}`` (a division when B is diagonal).
        """
        qdot = w - ca.vertcat(0, w[:-1])
        bd = self.b_diagonal
        if bd is not None:
            return qdot / ca.DM(bd) if not np.all(bd == 1) else qdot
        return ca.mtimes(ca.DM(np.linalg.inv(self.B)), qdot)

    # ------------------------------------------------------------------ numeric
    def check_q(self, q: ArrayLike, field: str = "q") -> np.ndarray:
        """Return ``q`` as a float array of shape (dof,), or raise a ConfigError naming ``field``.

        Parameters
        ----------
        q : array_like, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).
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
        return check_joint_vector(q, self.dof, field, " (d, then the m revolute joints)" if self.rail else "")

    def centres_np(self, q: ArrayLike) -> np.ndarray:
        """Central points, vectorised over leading axes of ``q``.

        Parameters
        ----------
        q : array_like, shape (..., dof)
            Joint coordinates [rad] (``d`` [m] first on a rail).

        Returns
        -------
        ndarray, shape (..., m, 2)
            Link centres [m].
        """
        return self._centres_directions(q)[0]

    def _centres_directions(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Link centres ``(..., m, 2)`` [m] and link directions ``(..., m, 2)`` [-] of ``q``."""
        q = np.asarray(q, float)
        alpha = np.cumsum(self.revolute(q), axis=-1)
        d = direction(alpha)
        steps = 0.5 * self.xi * (d[..., :-1, :] + d[..., 1:, :])
        base = self.base_point(q)[..., None, :]
        return np.concatenate([base, base + np.cumsum(steps, axis=-2)], axis=-2), d

    def joints_np(self, q: ArrayLike) -> np.ndarray:
        """Link end points: the chain drawn as a polyline.

        Parameters
        ----------
        q : array_like, shape (..., dof)
            Joint coordinates [rad] (``d`` [m] first on a rail).

        Returns
        -------
        ndarray, shape (..., m+1, 2)
            Joint positions [m], from the first link's free end to the end point.
        """
        y, d = self._centres_directions(q)                 # the directions computed once
        half = 0.5 * self.xi * d
        return np.concatenate([y[..., :1, :] - half[..., :1, :], y + half], axis=-2)

    def jacobians_closed_form(self, q: ArrayLike) -> np.ndarray:
        """``C^j(q)`` by the closed form of eq. 7; ``C^1 = 0`` (on a rail: the rail column).

        Parameters
        ----------
        q : array_like, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).

        Returns
        -------
        ndarray, shape (m, 2, dof)
            ``C[j] = d c^{j+1} / dq`` [m/rad].
        """
        q = self.check_q(q)
        alpha = np.cumsum(self.revolute(q))
        nrm = normal(alpha)
        r = int(self.rail)
        C = np.zeros((self.m, 2, self.dof))
        if self.rail:
            C[:, :, 0] = self.rail_direction
        for j in range(1, self.m):          # 0-based j is the paper's j+1
            C[j, :, r:] = C[j - 1, :, r:]
            C[j][:, r:r + j] += 0.5 * self.xi * nrm[j - 1][:, None]
            C[j][:, r:r + j + 1] += 0.5 * self.xi * nrm[j][:, None]
        return C

    def zigzag(self, beta: float, heading: float = 0.0, d: float = 0.0) -> np.ndarray:
        """Uniform zig-zag: links at ``heading +- beta``, centres on a line at ``heading``.

        Centres are spaced ``xi cos(beta)``; the body is ``xi sin(beta)`` wide.

        Parameters
        ----------
        beta : float
            Fold angle [rad], ``0 < |beta| < pi/2``.
        heading : float
            Direction of the line of centres [rad].
        d : float
            Rail position [m] (a chain on a rail only; prepended to ``q``).

        Returns
        -------
        ndarray, shape (dof,)
            Joint coordinates [rad].

        Raises
        ------
        ConfigError
            ``beta`` or ``heading`` not finite, or ``beta`` out of range.
        """
        for name, v in (("beta", beta), ("heading", heading)):
            if not is_real(v) or not math.isfinite(v):
                raise ConfigError(f"{name}: need a finite number, got {v!r}")
        if not 0 < abs(beta) < math.pi / 2:
            raise ConfigError(f"beta: need 0 < |beta| < pi/2 for a zig-zag, got {beta}")
        q = np.empty(self.m)
        q[0] = heading + beta
        q[1:] = 2 * beta * (-1.0) ** np.arange(1, self.m)
        return np.r_[float(d), q] if self.rail else q


def _input_matrix(B, m: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(diagonal, None)`` for a diagonal B (given as (m,) or (m, m)), ``(None, B)`` for a full one.

    The checks cost O(m) for a diagonal; only a full B pays for its O(m^3) condition number.

    Raises
    ------
    ConfigError
        Wrong shape, NaN or inf, or (numerically) singular.
    """
    if B is None:
        return np.ones(m), None
    B = np.asarray(B, dtype=float)
    if B.shape not in ((m,), (m, m)):
        raise ConfigError(f"B: need shape ({m},) or ({m}, {m}), got {B.shape}")
    if not np.all(np.isfinite(B)):
        raise ConfigError("B: contains NaN or inf")
    if B.ndim == 2 and np.count_nonzero(B - np.diag(np.diag(B))) == 0:
        B = np.diag(B).copy()
    if B.ndim == 1:
        size = np.abs(B)
        if size.min() == 0 or size.max() / size.min() > 1e12:
            raise ConfigError("B: matrix is singular (the paper's eq. 2 needs B invertible)")
        return B, None
    if np.linalg.cond(B) > 1e12:
        raise ConfigError("B: matrix is singular (the paper's eq. 2 needs B invertible)")
    return None, B
