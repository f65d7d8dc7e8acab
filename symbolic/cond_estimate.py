"""The 1-norm condition number of the planar decoupling matrix, estimated in O(m) per state.

``cond_1(C) = ||C||_1 ||C^-1||_1``. Both norms are estimated by Hager's method as refined by Higham
(:func:`onenorm_estimate`, the algorithm of LAPACK's ``dlacon``), which needs only products with the
matrix and its transpose. Here those products are O(m) each (:class:`DecouplingOperator`):

* ``C x`` and ``C^T y`` from the chain's structure (DESIGN.md section 3): with ``w = L B x`` (prefix
  sums of the joint rates) the centre velocities are ``ydot^j = ydot^{j-1} + xi/2 (n_{j-1} w_{j-1}
  + n_j w_j)``, and the rows are ``grad psi(y^m) . ydot^m`` and ``grad phi(y^j) . ydot^j``; the
  transpose runs the same prefix sums backwards;
* ``C^-1 b`` and ``C^-T y`` from one sparse LU of the same relations written as a sparse square
  system in ``(u, w, ydot)`` (about 10 m nonzeros; the LU keeps O(m) fill, as the structured solve
  shows an O(m) elimination exists); the LU pivots by itself, so a link across the curve (a small
  link pivot of the structured solve) is no trouble.

Every estimate is ``||A v||_1 / ||v||_1`` for some ``v``, so the estimated ``cond_1`` is a **lower
bound** of the exact one; Higham reports each norm estimate within a factor 3 in nearly all cases, and on the chains of
``tests/test_cond_estimate.py`` the product is within :data:`DOCUMENTED_FACTOR` (4) of the exact value. Unlike the 2-norm
``cond_2 = sigma_max / sigma_min`` (an SVD, O(m^3)) it measures the same thing up to a factor m:
``cond_2 / m <= cond_1 <= m cond_2``.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

#: The estimated ``cond_1`` is at least the exact one divided by this on every tested chain
#: (tests/test_cond_estimate.py: the worst of 800 random states of 3 to 30 links of the line, arc, thread
#: and pipe presets was 1/3.09, the product of two estimates each "rarely more than 3 off" (Higham)).
DOCUMENTED_FACTOR = 4.0
#: Most iterations of the estimator (LAPACK's ``ITMAX``).
MAX_ITERATIONS = 5


def onenorm_estimate(apply: Callable[[np.ndarray], np.ndarray], apply_t: Callable[[np.ndarray], np.ndarray],
                     n: int) -> float:
    """A lower bound of ``||A||_1`` from products with ``A`` and ``A^T`` (Hager 1984, Higham 1988).

    Deterministic: it starts from ``(1/n, ..., 1/n)``, moves to the unit vector of the largest
    ``|A^T sign(A x)|`` until that stops growing, and finally tries Higham's alternating vector
    ``(-1)^i (1 + i/(n-1))``. At most ``2 MAX_ITERATIONS + 1`` products.

    Parameters
    ----------
    apply, apply_t : callable
        ``x -> A x`` and ``y -> A^T y`` on arrays of shape (n,).
    n : int
        Order of ``A``.

    Returns
    -------
    float
        ``max ||A v||_1 / ||v||_1`` over the vectors tried (<= ``||A||_1``, exact for n = 1).
    """
    x = np.full(n, 1.0 / n)
    est, signs = 0.0, None
    for k in range(MAX_ITERATIONS):
        y = apply(x)
        new = float(np.abs(y).sum())
        s = np.where(y >= 0, 1.0, -1.0)
        if k and (new <= est or np.array_equal(s, signs)):
            est = max(est, new)
            break
        est, signs = new, s
        z = apply_t(s)
        j = int(np.argmax(np.abs(z)))
        if k and abs(z[j]) <= z @ x:
            break
        x = np.zeros(n)
        x[j] = 1.0
    if n > 1:
        alt = (-1.0) ** np.arange(n) * (1 + np.arange(n) / (n - 1))
        est = max(est, float(np.abs(apply(alt)).sum()) / float(np.abs(alt).sum()))
    return est


class DecouplingOperator:
    """The planar decoupling matrix of one state as O(m) products and solves (rows and columns as
    :meth:`~.numeric.NumericAPI.decoupling_matrices`).

    Parameters
    ----------
    normals : ndarray, shape (m, 2)
        Link normals ``n(alpha_j)``.
    row_gradients : ndarray, shape (m, 2)
        ``grad psi(y^m)`` then ``grad phi(y^j)``, j = 2..m (the rows of the fixed-base matrix).
    xi : float
        Link length [m].
    b_diagonal : ndarray, shape (m,), optional
        Diagonal of ``B`` (``qdot = B u``); None with ``B_lu``.
    B_lu : tuple, optional
        ``scipy.linalg.lu_factor(B)`` of a non-diagonal ``B`` (products then cost O(m^2)).
    B : ndarray, shape (m, m), optional
        The non-diagonal ``B`` itself (with ``B_lu``).
    rail : ndarray, shape (2,), optional
        Rail direction on a rail (column ``u_d`` first, row ``sigma`` second).
    base_gradient : ndarray, shape (2,), optional
        ``grad psi(y^1)`` on a rail (the span row is the ``s`` row minus it dotted with ``ydot^1``).
    """

    def __init__(self, normals: np.ndarray, row_gradients: np.ndarray, xi: float,
                 b_diagonal: np.ndarray | None = None, B_lu: tuple | None = None, B: np.ndarray | None = None,
                 rail: np.ndarray | None = None, base_gradient: np.ndarray | None = None) -> None:
        self.n, self.g, self.xi = np.asarray(normals, float), np.asarray(row_gradients, float), float(xi)
        self.m = len(self.n)
        self.bd, self.B_lu, self.Bmat = b_diagonal, B_lu, B
        self.rail, self.h1 = rail, base_gradient
        self.dof = self.m + (rail is not None)
        self._lu = None

    # ------------------------------------------------------------------ products
    def _velocities(self, v: np.ndarray, d_dot: float) -> np.ndarray:
        """Centre velocities ``ydot^j`` (m, 2) of joint rates ``v = B u`` and rail rate ``d_dot``."""
        w = np.cumsum(v)
        half = 0.5 * self.xi * self.n * w[:, None]                   # xi/2 n_j w_j
        V = np.zeros((self.m, 2))
        V[1:] = np.cumsum(half[:-1] + half[1:], axis=0)
        return V + (0.0 if self.rail is None else d_dot * self.rail)

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """``C x`` in O(m) (O(m^2) with a non-diagonal ``B``).

        Parameters
        ----------
        x : ndarray, shape (dof,)
            Controls (``u_d`` first on a rail).

        Returns
        -------
        ndarray, shape (dof,)
            The rows' rates ``(s, [sigma,] e^2..e^m)``.
        """
        d_dot, u = (x[0], x[1:]) if self.rail is not None else (0.0, x)
        v = self.bd * u if self.Bmat is None else self.Bmat @ u
        V = self._velocities(v, d_dot)
        rows = np.einsum("ji,ji->j", self.g, np.concatenate([V[-1:], V[1:]]))
        if self.rail is None:
            return rows
        return np.concatenate([rows[:1], [rows[0] - self.h1 @ V[0]], rows[1:]])

    def rmatvec(self, y: np.ndarray) -> np.ndarray:
        """``C^T y`` in O(m) (the adjoint of :meth:`matvec`).

        Parameters
        ----------
        y : ndarray, shape (dof,)
            Weights of the rows ``(s, [sigma,] e^2..e^m)``.

        Returns
        -------
        ndarray, shape (dof,)
            Weights of the controls.
        """
        ys, ysig, ye = (y[0], y[1], y[2:]) if self.rail is not None else (y[0], 0.0, y[1:])
        Vb = np.zeros((self.m, 2))
        Vb[1:] = self.g[1:] * ye[:, None]
        Vb[-1] += self.g[0] * (ys + ysig)
        if self.rail is not None:
            Vb[0] -= self.h1 * ysig
        tail = np.cumsum(Vb[::-1], axis=0)[::-1]                     # sum over k >= j of Vb_k
        steps = 0.5 * self.xi * np.einsum("ji,ji->j", self.n, np.concatenate([tail[1:], np.zeros((1, 2))]))
        wb = steps.copy()
        wb[1:] += 0.5 * self.xi * np.einsum("ji,ji->j", self.n[1:], tail[1:])
        vb = np.cumsum(wb[::-1])[::-1]
        ub = self.bd * vb if self.Bmat is None else self.Bmat.T @ vb
        return ub if self.rail is None else np.concatenate([[self.rail @ tail[0]], ub])

    # ------------------------------------------------------------------ solves
    def sparse_system(self) -> scipy.sparse.csc_matrix:
        """The square sparse system in ``(a, w, ydot)`` whose last rows are ``C`` (``a = (d_dot, v)``, ``v = B u``).

        Returns
        -------
        scipy.sparse.csc_matrix, shape (dof + m + 2 m,) * 2
            Unknowns ``(a [dof], w [m], ydot [2 m])``; rows: ``w_j - w_{j-1} - v_j = 0``,
            ``ydot^1 - rail d_dot = 0``, ``ydot^j - ydot^{j-1} - xi/2 (n_{j-1} w_{j-1} + n_j w_j) = 0``,
            then the rows of ``C`` in terms of ``ydot`` (right-hand side ``(0, 0, b)``).
        """
        m, dof, r = self.m, self.dof, self.rail is not None
        W, Y = dof, dof + m                     # first columns of w and of ydot
        I, J, X = [], [], []

        def put(i, j, x):
            I.append(np.broadcast_to(i, np.shape(x)).ravel() if np.ndim(x) else [i])
            J.append(np.broadcast_to(j, np.shape(x)).ravel() if np.ndim(x) else [j])
            X.append(np.ravel(x))

        k = np.arange(m)
        put(k, W + k, np.ones(m))                                    # w_j
        put(k[1:], W + k[:-1], -np.ones(m - 1))                      # - w_{j-1}
        put(k, r + k, -np.ones(m))                                   # - v_j
        rows = m + 2 * k[:, None] + np.arange(2)                     # (m, 2) rows of ydot^j
        put(rows, Y + 2 * k[:, None] + np.arange(2), np.ones((m, 2)))
        put(rows[1:], Y + 2 * k[:-1, None] + np.arange(2), -np.ones((m - 1, 2)))
        half = 0.5 * self.xi * self.n
        put(rows[1:], np.broadcast_to(W + k[:-1, None], (m - 1, 2)), -half[:-1])
        put(rows[1:], np.broadcast_to(W + k[1:, None], (m - 1, 2)), -half[1:])
        if r:
            put(rows[0], np.zeros(2, int), -self.rail)
        out = 3 * m                                                  # first row of C
        targets = np.r_[m - 1, 1:m]
        crow = out + np.r_[0, 1 + r:m + r] if r else out + np.arange(m)
        put(np.broadcast_to(crow[:, None], (m, 2)), Y + 2 * targets[:, None] + np.arange(2), self.g)
        if r:
            put(np.full(2, out + 1), Y + 2 * (m - 1) + np.arange(2), self.g[0])
            put(np.full(2, out + 1), Y + np.arange(2), -self.h1)
        size = dof + 3 * m
        return scipy.sparse.csc_matrix((np.concatenate(X), (np.concatenate(I), np.concatenate(J))), (size, size))

    def _factor(self):
        if self._lu is None:
            self._lu = scipy.sparse.linalg.splu(self.sparse_system())
        return self._lu

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``C^-1 b`` by the sparse LU, O(m) (plus a solve with ``B`` when it is not diagonal).

        Parameters
        ----------
        b : ndarray, shape (dof,)
            Right-hand side (rows as :meth:`matvec`).

        Returns
        -------
        ndarray, shape (dof,)
            Controls ``u`` (``u_d`` first on a rail).
        """
        rhs = np.zeros(self.dof + 3 * self.m)
        rhs[3 * self.m:] = b
        a = self._factor().solve(rhs)[:self.dof]
        return self._unscale(a)

    def _unscale(self, a: np.ndarray) -> np.ndarray:
        """``(d_dot, B^-1 v)`` of ``a = (d_dot, v)``."""
        r = self.rail is not None
        v = a[r:]
        u = v / self.bd if self.Bmat is None else scipy.linalg.lu_solve(self.B_lu, v)
        return np.concatenate([a[:r], u])

    def solve_transposed(self, y: np.ndarray) -> np.ndarray:
        """``C^-T y`` by the transposed sparse LU, O(m).

        Parameters
        ----------
        y : ndarray, shape (dof,)
            Weights of the controls.

        Returns
        -------
        ndarray, shape (dof,)
            Weights of the rows.
        """
        r = self.rail is not None
        u = y[r:]
        v = u / self.bd if self.Bmat is None else scipy.linalg.lu_solve(self.B_lu, u, trans=1)
        rhs = np.zeros(self.dof + 3 * self.m)
        rhs[:r], rhs[r:self.dof] = y[:r], v
        return self._factor().solve(rhs, trans="T")[3 * self.m:]

    def cond_estimate(self) -> float:
        """Estimated ``cond_1(C) = ||C||_1 ||C^-1||_1``, a lower bound (see the module notes).

        Returns
        -------
        float
            The estimate (inf when the sparse LU finds ``C`` singular).
        """
        try:
            inverse = onenorm_estimate(self.solve, self.solve_transposed, self.dof)
        except RuntimeError:                    # splu: "Factor is exactly singular"
            return float("inf")
        if not np.isfinite(inverse):
            return float("inf")
        return onenorm_estimate(self.matvec, self.rmatvec, self.dof) * inverse
