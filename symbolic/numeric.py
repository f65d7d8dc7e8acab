"""The numeric API of the planar coordinating controller: the decoupling matrix at numeric states.

:class:`NumericAPI` is the part of :class:`~coordarm.symbolic.controller.CoordinatingController`
that evaluates the curve's geometry at the link centres, the commanded speed, the decoupling
matrices in closed form (batched over N states) and their condition numbers (the law's outputs
are evaluated by :class:`~.law_face.LawFace`). Its host provides ``chain``, ``task`` and ``gain``.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .chain import PlanarChain, normal
from .params import evaluate as evaluate_param
from .errors import ConfigError
from .law_face import condition_numbers
from .task import Task


#: Up to this many joints :meth:`NumericAPI.cond_estimates` computes ``cond_1`` exactly (a batched dense
#: inverse costs less than the O(m) estimator's Python overhead there: benchmarks/RESULTS.md, issue 24).
EXACT_COND_DOF = 256


def _exact_cond_1(A: np.ndarray) -> float:
    """``||A||_1 ||A^-1||_1`` (inf when ``A`` is singular)."""
    try:
        with np.errstate(all="ignore"):
            return float(np.abs(A).sum(axis=0).max() * np.abs(np.linalg.inv(A)).sum(axis=0).max())
    except np.linalg.LinAlgError:
        return float("inf")


class NumericAPI:
    """Numeric evaluation of a controller's law (a mixin of :class:`~.controller.CoordinatingController`).

    Attributes
    ----------
    chain : PlanarChain
        The manipulator.
    task : Task
        Curve geometry and commands (its mapped Functions are cached there).
    gain : float
        Error gain K [1/s].
    outputs : tuple of str
        Names of the law's outputs, in order.
    """

    chain: PlanarChain
    task: Task
    gain: float
    outputs: Sequence[str]

    def centre_geometry(self, Q, T) -> dict[str, np.ndarray]:
        """The curve's ``phi``, ``psi`` and their derivatives at every link centre of N states.

        Parameters
        ----------
        Q : (N, dof) array_like
            Joint coordinates [rad] (``d`` [m] first on a rail).
        T : (N,) array_like
            Times [s].

        Returns
        -------
        dict
            ``phi``, ``phit``, ``psi``, ``psit`` of shape (N, m) and the gradients ``gphi``,
            ``gpsi`` of shape (N, m, 2), from one mapped call of the geometry Function.

        Raises
        ------
        ConfigError
            ``Q`` and ``T`` not of shapes (N, dof) and (N,).
        """
        Q, T = np.atleast_2d(np.asarray(Q, float)), np.atleast_1d(np.asarray(T, float))
        m, n = self.chain.m, self.chain.dof
        if Q.shape[1:] != (n,) or T.shape != (len(Q),):
            raise ConfigError(f"Q, T: need shapes (N, {n}) and (N,), got {Q.shape} and {T.shape}")
        N = len(Q)
        Y = self.chain.centres_np(Q)                                      # (N, m, 2)
        values = self.task.buffered("geometry", N * m)(Y.reshape(-1, 2).T, np.repeat(T, m)[None])
        out = {}
        for name, v in zip(("phi", "gphi", "phit", "psi", "gpsi", "psit"), values):
            v = np.asarray(v)
            out[name] = v.T.reshape(N, m, 2) if name[0] == "g" else v.reshape(N, m)
        return out

    def speeds(self, T) -> np.ndarray:
        """``v*(t)`` at each of the times ``T``, in one call.

        Parameters
        ----------
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            Commanded speeds [m/s].
        """
        T = np.atleast_1d(np.asarray(T, float))
        return self.task.pointwise("speed")(T)[0].ravel()

    def decoupling_matrices(self, Q, T, geometry: dict[str, np.ndarray] | None = None
                            ) -> tuple[np.ndarray, np.ndarray]:
        """Decoupling matrices (eq. 26) and right-hand sides at N states, in O(N m^2).

        Numeric and batched: the Jacobians ``C^j`` by the closed form of eq. 7 through
        prefix sums of the link normals, the curve gradients from :meth:`centre_geometry`.
        Agrees with the AD ``decoupling_function`` of the controller to rounding, without building its
        O(m^2) symbolic graph (which takes minutes at 1000 links).

        Parameters
        ----------
        Q : (N, m) array_like
            Joint coordinates [rad].
        T : (N,) array_like
            Times [s].
        geometry : dict, optional
            :meth:`centre_geometry` of ``(Q, T)``, when the caller has it already.

        Returns
        -------
        M : (N, m, m) ndarray
            Rows ``(s^m, e^2, ..., e^m)``, columns the controls ``u``; on a rail (N, m+1, m+1),
            rows ``(s, sigma, e^2..e^m)``, columns ``(u_d, u)``.
        rhs : (N, m) ndarray
            ``(v* - dpsi/dt, -K e^j - dphi/dt)`` (on a rail with ``sigma_dot - dpsi/dt(y^m) +
            dpsi/dt(y^1)`` second).
        """
        geo = geometry if geometry is not None else self.centre_geometry(Q, T)
        Q, T = np.atleast_2d(np.asarray(Q, float)), np.atleast_1d(np.asarray(T, float))
        m, xi = self.chain.m, self.chain.xi
        # C^j[:, k] = xi/2 (S_{j-1} + S_j - P_k) for k <= j, with S the prefix sums of the
        # normals n_0..n_{m-1} and P_0 = n_0, P_k = 2 S_{k-1}  (0-based j, k; C^0 = 0).
        S = np.cumsum(normal(np.cumsum(self.chain.revolute(Q), axis=-1)), axis=-2)   # (N, m, 2)
        P = np.concatenate([S[:, :1], 2 * S[:, :-1]], axis=1)
        rows = np.r_[m - 1, 1:m]                                           # target centre of each row
        W = np.concatenate([geo["gpsi"][:, m - 1:], geo["gphi"][:, 1:]], axis=1)  # (N, m, 2) its gradient
        Tj = S[:, rows] + S[:, rows - 1]
        M = 0.5 * xi * (np.einsum("nri,nri->nr", W, Tj)[:, :, None] - W @ np.swapaxes(P, 1, 2))
        M *= np.arange(m)[None, :] <= rows[:, None]
        b = self.chain.b_diagonal
        M = M * b if b is not None else M @ self.chain.B
        rhs = np.concatenate([(self.speeds(T) - geo["psit"][:, m - 1])[:, None],
                              -self.gain * geo["phi"][:, 1:] - geo["phit"][:, 1:]], axis=1)
        if not self.chain.rail:
            return M, rhs
        # the rail: C^j gains the column ``rail`` (every centre slides with the base); the span
        # row sigma = psi(y^m) - psi(y^1) is the s row minus grad psi(y^1)^T C^1 = (h_1 . rail, 0, ...)
        rail = self.chain.rail_direction
        col = W @ rail                                                      # (N, m)
        M = np.concatenate([col[:, :, None], M], axis=2)
        span = M[:, :1].copy()
        span[:, 0, 0] -= geo["gpsi"][:, 0] @ rail
        M = np.concatenate([M[:, :1], span, M[:, 1:]], axis=1)
        sigma = geo["psi"][:, m - 1] - geo["psi"][:, 0]
        rate = self.task.buffered("span_rate", len(T))(sigma[None], T[None])[0].ravel()
        rhs = np.concatenate([rhs[:, :1], (rate - geo["psit"][:, m - 1] + geo["psit"][:, 0])[:, None], rhs[:, 1:]],
                             axis=1)
        return M, rhs

    def decoupling_matrix(self, q, t: float = 0.0) -> np.ndarray:
        """Numeric decoupling matrix (eq. 26); see :meth:`decoupling_matrices`.

        Parameters
        ----------
        q : array_like, shape (m,)
            Joint coordinates [rad].
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (m, m)
            Rows ``(s^m, e^2, ..., e^m)``, columns the controls.
        """
        return self.decoupling_matrices(self.chain.check_q(q)[None], [t])[0][0]

    def cond(self, q, t: float = 0.0) -> float:
        """2-norm condition number of the decoupling matrix.

        Parameters
        ----------
        q : array_like, shape (m,)
            Joint coordinates [rad].
        t : float
            Time [s].

        Returns
        -------
        float
            ``sigma_max / sigma_min`` (inf when singular).
        """
        return float(self.conds(self.chain.check_q(q)[None], [t])[0])

    def conds(self, Q, T) -> np.ndarray:
        """2-norm condition numbers of the decoupling matrices at N states.

        Parameters
        ----------
        Q : array_like, shape (N, m)
            Joint coordinates [rad].
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            ``sigma_max / sigma_min`` of each (inf when singular).
        """
        return condition_numbers(self.decoupling_matrices(Q, T)[0])

    def cond_estimates(self, Q, T) -> np.ndarray:
        """1-norm condition numbers of the decoupling matrices at N states: estimated in O(m) each above
        :data:`EXACT_COND_DOF` joints, exact (a dense inverse, cheaper at that size) up to it.

        The estimate is a lower bound of the exact ``cond_1`` within a factor
        :data:`~.cond_estimate.DOCUMENTED_FACTOR` on the tested chains (see :mod:`.cond_estimate`); the
        exact 2-norm value is :meth:`conds` (an SVD, O(m^3)).

        Parameters
        ----------
        Q : array_like, shape (N, dof)
            Joint coordinates [rad] (``d`` [m] first on a rail).
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            ``est ||C||_1 * est ||C^-1||_1`` of each (inf when singular).
        """
        geo = self.centre_geometry(Q, T)
        Q = np.atleast_2d(np.asarray(Q, float))
        m = self.chain.m
        if self.chain.dof <= EXACT_COND_DOF:     # a dense inverse is cheaper than the estimator here
            M = self.decoupling_matrices(Q, T, geo)[0]
            try:                                 # one batched inverse; a singular matrix: one by one
                with np.errstate(all="ignore"):
                    inverse = np.linalg.inv(M)
            except np.linalg.LinAlgError:
                return np.array([_exact_cond_1(A) for A in M])
            return np.abs(M).sum(axis=1).max(axis=1) * np.abs(inverse).sum(axis=1).max(axis=1)
        from .cond_estimate import DecouplingOperator

        normals = normal(np.cumsum(self.chain.revolute(Q), axis=-1))
        rows = np.concatenate([geo["gpsi"][:, m - 1:], geo["gphi"][:, 1:]], axis=1)
        bd = self.chain.b_diagonal
        dense = {} if bd is not None else {"B": self.chain.B, "B_inverse": np.linalg.inv(self.chain.B)}
        rail = self.chain.rail_direction if self.chain.rail else None
        return np.array([DecouplingOperator(normals[i], rows[i], self.chain.xi, bd, rail=rail,
                                            base_gradient=geo["gpsi"][i, 0] if rail is not None else None,
                                            **dense).cond_estimate() for i in range(len(Q))])

    def base_offset(self, t: float = 0.0) -> float:
        """``|phi(0, t)|``: how far the curve passes from the pinned base.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        float
            Distance [m].
        """
        return abs(float(self.task.geometry([0, 0], t)[0]))

    def base_offsets(self, T: Sequence[float] | np.ndarray) -> np.ndarray:
        """:meth:`base_offset` at each of the times ``T``, in one call (the same values).

        Parameters
        ----------
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            Distances [m].
        """
        T = np.atleast_1d(np.asarray(T, float))
        phi = self.task.mapped("geometry", len(T))(np.zeros((2, len(T))), T[None])[0]
        return np.abs(np.asarray(phi, dtype=float).ravel())

    def speed_at(self, t: float) -> float:
        """The commanded speed at one time.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        float
            ``v*(t)`` [m/s].
        """
        return evaluate_param(self.task.speed, t)
