"""Planar chain of m equal links with revolute joints (paper eqs. 1-7)."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from .errors import ConfigError


def direction(a):
    """Unit vector ``d(a) = (cos a, sin a)`` (CasADi or numpy)."""
    if isinstance(a, (ca.SX, ca.MX, ca.DM)):
        return ca.vertcat(ca.cos(a), ca.sin(a))
    return np.stack([np.cos(a), np.sin(a)], axis=-1)


def normal(a):
    """Unit normal ``n(a) = (-sin a, cos a) = T(a)^T r`` (CasADi or numpy)."""
    if isinstance(a, (ca.SX, ca.MX, ca.DM)):
        return ca.vertcat(-ca.sin(a), ca.cos(a))
    return np.stack([-np.sin(a), np.cos(a)], axis=-1)


class PlanarChain:
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
    """

    def __init__(self, links: int, link_length: float, B=None) -> None:
        if isinstance(links, bool) or not isinstance(links, (int, np.integer)) or links < 2:
            raise ConfigError(f"links: need an integer of at least 2, got {links!r}")
        if (isinstance(link_length, bool) or not isinstance(link_length, (int, float))
                or not math.isfinite(link_length) or link_length <= 0):
            raise ConfigError(f"link_length: need a finite number > 0, got {link_length!r}")
        self.m, self.xi = int(links), float(link_length)
        if B is None:
            B = np.ones(self.m)
        B = np.asarray(B, dtype=float)
        if B.shape == (self.m,):
            B = np.diag(B)
        if B.shape != (self.m, self.m):
            raise ConfigError(f"B: need shape ({self.m},) or ({self.m}, {self.m}), got {B.shape}")
        if not np.all(np.isfinite(B)):
            raise ConfigError("B: contains NaN or inf")
        if np.linalg.cond(B) > 1e12:
            raise ConfigError("B: matrix is singular (the paper's eq. 2 needs B invertible)")
        self.B = B

    @property
    def links(self) -> int:
        return self.m

    @property
    def link_length(self) -> float:
        return self.xi

    @property
    def b_diagonal(self) -> np.ndarray | None:
        """Diagonal of B if B is diagonal, else None."""
        return np.diag(self.B).copy() if np.count_nonzero(self.B - np.diag(np.diag(self.B))) == 0 else None

    def __repr__(self) -> str:
        return f"PlanarChain(links={self.m}, link_length={self.xi})"

    # ----------------------------------------------------------------- symbolic
    def centres(self, q: ca.SX) -> ca.SX:
        """Central points ``c^j(q)`` (eq. 4) as a 2 x m CasADi expression.

        Parameters
        ----------
        q : casadi.SX or casadi.MX, shape (m,)
            Joint coordinates [rad].

        Returns
        -------
        casadi.SX or casadi.MX, shape (2, m)
            Column j is the centre of link j+1 [m]; the first is the base.
        """
        alpha = ca.cumsum(q)
        cols = [ca.SX.zeros(2, 1) if isinstance(q, ca.SX) else ca.MX.zeros(2, 1)]
        for j in range(1, self.m):
            cols.append(cols[-1] + 0.5 * self.xi * (direction(alpha[j - 1]) + direction(alpha[j])))
        return ca.horzcat(*cols)

    # ------------------------------------------------------------------ numeric
    def check_q(self, q, field: str = "q") -> np.ndarray:
        """Return ``q`` as a float array of shape (m,), or raise a ConfigError naming ``field``.

        Parameters
        ----------
        q : array_like, shape (m,)
            Joint coordinates [rad].
        field : str
            Name used in the error message.

        Returns
        -------
        ndarray, shape (m,)
            ``q`` as floats.

        Raises
        ------
        ConfigError
            Wrong shape, NaN or inf.
        """
        q = np.asarray(q, dtype=float)
        if q.shape != (self.m,):
            raise ConfigError(f"{field}: need shape ({self.m},), got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ConfigError(f"{field}: contains NaN or inf at index {int(np.flatnonzero(~np.isfinite(q))[0])}")
        return q

    def centres_np(self, q) -> np.ndarray:
        """Central points, vectorised over leading axes of ``q``.

        Parameters
        ----------
        q : array_like, shape (..., m)
            Joint coordinates [rad].

        Returns
        -------
        ndarray, shape (..., m, 2)
            Link centres [m].
        """
        alpha = np.cumsum(q, axis=-1)
        d = direction(alpha)
        steps = 0.5 * self.xi * (d[..., :-1, :] + d[..., 1:, :])
        zero = np.zeros(steps.shape[:-2] + (1, 2))
        return np.concatenate([zero, np.cumsum(steps, axis=-2)], axis=-2)

    def joints_np(self, q) -> np.ndarray:
        """Link end points: the chain drawn as a polyline.

        Parameters
        ----------
        q : array_like, shape (..., m)
            Joint coordinates [rad].

        Returns
        -------
        ndarray, shape (..., m+1, 2)
            Joint positions [m], from the first link's free end to the end point.
        """
        alpha = np.cumsum(q, axis=-1)
        d = direction(alpha)
        y = self.centres_np(q)
        first = y[..., :1, :] - 0.5 * self.xi * d[..., :1, :]
        return np.concatenate([first, y + 0.5 * self.xi * d], axis=-2)

    def jacobians_closed_form(self, q) -> np.ndarray:
        """``C^j(q)`` by the closed form of eq. 7; ``C^1 = 0``.

        Parameters
        ----------
        q : array_like, shape (m,)
            Joint coordinates [rad].

        Returns
        -------
        ndarray, shape (m, 2, m)
            ``C[j] = d c^{j+1} / dq`` [m/rad].
        """
        q = self.check_q(q)
        alpha = np.cumsum(q)
        nrm = normal(alpha)
        C = np.zeros((self.m, 2, self.m))
        for j in range(1, self.m):          # 0-based j is the paper's j+1
            C[j] = C[j - 1]
            C[j][:, :j] += 0.5 * self.xi * nrm[j - 1][:, None]
            C[j][:, :j + 1] += 0.5 * self.xi * nrm[j][:, None]
        return C

    def zigzag(self, beta: float, heading: float = 0.0) -> np.ndarray:
        """Uniform zig-zag: links at ``heading +- beta``, centres on a line at ``heading``.

        Centres are spaced ``xi cos(beta)``; the body is ``xi sin(beta)`` wide.

        Parameters
        ----------
        beta : float
            Fold angle [rad], ``0 < |beta| < pi/2``.
        heading : float
            Direction of the line of centres [rad].

        Returns
        -------
        ndarray, shape (m,)
            Joint coordinates [rad].

        Raises
        ------
        ConfigError
            ``beta`` or ``heading`` not finite, or ``beta`` out of range.
        """
        for name, v in (("beta", beta), ("heading", heading)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"{name}: need a finite number, got {v!r}")
        if not 0 < abs(beta) < math.pi / 2:
            raise ConfigError(f"beta: need 0 < |beta| < pi/2 for a zig-zag, got {beta}")
        q = np.empty(self.m)
        q[0] = heading + beta
        q[1:] = 2 * beta * (-1.0) ** np.arange(1, self.m)
        return q
