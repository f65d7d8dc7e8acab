"""The 1-norm condition number of the planar decoupling matrix, estimated in O(m) per state.

``cond_1(C) = ||C||_1 ||C^-1||_1``. Both norms are estimated by Hager's method as refined by Higham
(:func:`onenorm_estimate`, the algorithm of LAPACK's ``dlacon``), which needs only products with the
matrix and its transpose. Here those products are O(m) each (:class:`DecouplingOperator`):

* ``C x`` and ``C^T y`` from the chain's structure (docs/model.md, *The O(m) solve*): with ``w = L B x`` (prefix
  sums of the joint rates) the centre velocities are ``ydot^j = ydot^{j-1} + xi/2 (n_{j-1} w_{j-1}
  + n_j w_j)``, and the rows are ``grad psi(y^m) . ydot^m`` and ``grad phi(y^j) . ydot^j``; the
  transpose runs the same prefix sums backwards;
* ``C^-1 b`` and ``C^-T y`` from one sparse QR factorisation (CasADi's ``Linsol`` plugin ``qr``) of the
  same relations written as a sparse square system in ``(u, w, ydot)`` (about 10 m nonzeros; the
  factorisation keeps O(m) fill, as the structured solve shows an O(m) elimination exists); QR needs
  no pivots, so a link across the curve (a small link pivot of the structured solve) is no trouble.
  The symbolic analysis depends only on ``m`` and the rail, and is made once per pattern
  (:func:`system_pattern`). CasADi rather than SciPy's sparse LU: importing ``scipy.sparse.linalg``
  costs about 0.2 s, as much as a whole 1024-link, 1 s run (``benchmarks/RESULTS.md``).

Every estimate is ``||A v||_1 / ||v||_1`` for some ``v``, so the estimated ``cond_1`` is a **lower
bound** of the exact one; Higham reports each norm estimate within a factor 3 in nearly all cases, and on the chains of
``tests/test_cond_estimate.py`` the product is within :data:`DOCUMENTED_FACTOR` (4) of the exact value. Unlike the 2-norm
``cond_2 = sigma_max / sigma_min`` (an SVD, O(m^3)) it measures the same thing up to a factor m:
``cond_2 / m <= cond_1 <= m cond_2``.
"""
from __future__ import annotations

import threading
from functools import lru_cache
from typing import Callable, NamedTuple

import casadi as ca
import numpy as np

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
        Diagonal of ``B`` (``qdot = B u``); None with ``B``.
    B : ndarray, shape (m, m), optional
        A non-diagonal ``B`` (products and solves then cost O(m^2)).
    B_inverse : ndarray, shape (m, m), optional
        Its inverse (with ``B``; computed here when not given: pass it when many states share ``B``).
    rail : ndarray, shape (2,), optional
        Rail direction on a rail (column ``u_d`` first, row ``sigma`` second).
    base_gradient : ndarray, shape (2,), optional
        ``grad psi(y^1)`` on a rail (the span row is the ``s`` row minus it dotted with ``ydot^1``).
    """

    def __init__(self, normals: np.ndarray, row_gradients: np.ndarray, xi: float,
                 b_diagonal: np.ndarray | None = None, B: np.ndarray | None = None,
                 B_inverse: np.ndarray | None = None, rail: np.ndarray | None = None,
                 base_gradient: np.ndarray | None = None) -> None:
        self.n, self.g, self.xi = np.asarray(normals, float), np.asarray(row_gradients, float), float(xi)
        self.m = len(self.n)
        self.bd, self.Bmat = b_diagonal, B
        self.Binv = None if B is None else (np.linalg.inv(B) if B_inverse is None else B_inverse)
        self.rail, self.h1 = rail, base_gradient
        self.dof = self.m + (rail is not None)
        self._matrix = None

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
    def system_values(self) -> np.ndarray:
        """The nonzeros of the square sparse system whose last rows are ``C``, in the order of
        :func:`system_pattern` (``a = (d_dot, v)``, ``v = B u``).

        Unknowns ``(a [dof], w [m], ydot [2 m])``; rows: ``w_j - w_{j-1} - v_j = 0``,
        ``ydot^1 - rail d_dot = 0``, ``ydot^j - ydot^{j-1} - xi/2 (n_{j-1} w_{j-1} + n_j w_j) = 0``,
        then the rows of ``C`` in terms of ``ydot`` (right-hand side ``(0, 0, b)``).

        Returns
        -------
        ndarray, shape (nnz,)
            The entries, one per ``(row, col)`` of the pattern's triplets.
        """
        m, r = self.m, self.rail is not None
        half = 0.5 * self.xi * self.n
        parts = [np.ones(m), -np.ones(m - 1), -np.ones(m), np.ones(2 * m), -np.ones(2 * (m - 1)),
                 -half[:-1].ravel(), -half[1:].ravel()]
        if r:
            parts.append(-np.asarray(self.rail, float))
        parts.append(self.g.ravel())
        if r:
            parts += [self.g[0], -np.asarray(self.h1, float)]
        return np.concatenate(parts)

    def sparse_system(self) -> np.ndarray:
        """The square sparse system of :meth:`system_values` as a dense array (for tests and small chains).

        Returns
        -------
        ndarray, shape (dof + 3 m, dof + 3 m)
            Unknowns ``(a, w, ydot)``, rows as :meth:`system_values`.
        """
        pattern = system_pattern(self.m, self.rail is not None)
        A = np.zeros((pattern.size, pattern.size))
        np.add.at(A, (pattern.rows, pattern.cols), self.system_values())
        return A

    def _factored(self) -> "ca.DM":
        if self._matrix is None:
            pattern = system_pattern(self.m, self.rail is not None)
            nz = np.zeros(pattern.sparsity.nnz())
            np.add.at(nz, pattern.nonzero, self.system_values())
            self._matrix = ca.DM(pattern.sparsity, nz)
        return self._matrix

    def _system_solve(self, rhs: np.ndarray, transposed: bool) -> np.ndarray:
        pattern = system_pattern(self.m, self.rail is not None)
        with pattern.lock:                       # one Linsol memory per pattern: one solve at a time
            x = pattern.solver.solve(self._factored(), ca.DM(rhs), transposed)
        return np.asarray(x, dtype=float).ravel()

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``C^-1 b`` by the sparse QR, O(m) (plus a product with ``B^-1`` when ``B`` is not diagonal).

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
        return self._unscale(self._system_solve(rhs, False)[:self.dof])

    def _unscale(self, a: np.ndarray) -> np.ndarray:
        """``(d_dot, B^-1 v)`` of ``a = (d_dot, v)``."""
        r = self.rail is not None
        v = a[r:]
        u = v / self.bd if self.Bmat is None else self.Binv @ v
        return np.concatenate([a[:r], u])

    def solve_transposed(self, y: np.ndarray) -> np.ndarray:
        """``C^-T y`` by the transposed sparse QR, O(m).

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
        v = u / self.bd if self.Bmat is None else self.Binv.T @ u
        rhs = np.zeros(self.dof + 3 * self.m)
        rhs[:r], rhs[r:self.dof] = y[:r], v
        return self._system_solve(rhs, True)[3 * self.m:]

    def cond_estimate(self) -> float:
        """Estimated ``cond_1(C) = ||C||_1 ||C^-1||_1``, a lower bound (see the module notes).

        Returns
        -------
        float
            The estimate (inf when the sparse QR finds ``C`` singular).
        """
        try:
            inverse = onenorm_estimate(self.solve, self.solve_transposed, self.dof)
        except RuntimeError as exc:             # Linsol: "'nfact' failed" on an exactly singular C
            if "nfact" not in str(exc):
                raise
            return float("inf")
        if not np.isfinite(inverse):
            return float("inf")
        return onenorm_estimate(self.matvec, self.rmatvec, self.dof) * inverse


class SystemPattern(NamedTuple):
    """The sparsity of :meth:`DecouplingOperator.system_values` and its symbolically analysed QR solver.

    Parameters
    ----------
    size : int
        Order of the system, ``dof + 3 m``.
    rows, cols : ndarray of int, shape (nnz,)
        Row and column of each value, in the order of :meth:`DecouplingOperator.system_values`.
    sparsity : casadi.Sparsity
        The pattern (duplicates merged).
    nonzero : ndarray of int, shape (nnz,)
        Nonzero of ``sparsity`` that each value adds to.
    solver : casadi.Linsol
        CasADi's sparse QR (plugin ``qr``) for this pattern.
    lock : threading.Lock
        Held while the solver runs (its memory is shared by the states of one pattern).
    """

    size: int
    rows: np.ndarray
    cols: np.ndarray
    sparsity: "ca.Sparsity"
    nonzero: np.ndarray
    solver: "ca.Linsol"
    lock: threading.Lock


@lru_cache(maxsize=8)
def system_pattern(m: int, rail: bool) -> SystemPattern:
    """The pattern of the sparse system of an ``m``-link chain (with a rail or not), analysed once.

    Parameters
    ----------
    m : int
        Links.
    rail : bool
        Whether the base slides on a rail (one more unknown and one more row).

    Returns
    -------
    SystemPattern
        Its triplets, sparsity and solver.
    """
    r = int(rail)
    dof = m + r
    W, Y, out = dof, dof + m, 3 * m             # first columns of w and ydot, first row of C
    k = np.arange(m)
    two = np.arange(2)
    yrow = m + 2 * k[:, None] + two             # (m, 2) rows of ydot^j
    ycol = Y + 2 * k[:, None] + two
    targets = np.r_[m - 1, 1:m]
    crow = out + np.r_[0, 1 + r:m + r] if r else out + k
    pairs = [(k, W + k), (k[1:], W + k[:-1]), (k, r + k), (yrow, ycol), (yrow[1:], ycol[:-1]),
             (yrow[1:], np.broadcast_to(W + k[:-1, None], (m - 1, 2))),
             (yrow[1:], np.broadcast_to(W + k[1:, None], (m - 1, 2)))]
    if r:
        pairs.append((yrow[0], np.zeros(2, int)))
    pairs.append((np.broadcast_to(crow[:, None], (m, 2)), Y + 2 * targets[:, None] + two))
    if r:
        pairs += [(np.full(2, out + 1), Y + 2 * (m - 1) + two), (np.full(2, out + 1), Y + two)]
    rows = np.concatenate([np.ravel(i) for i, _ in pairs])
    cols = np.concatenate([np.ravel(j) for _, j in pairs])
    size = dof + 3 * m
    sparsity, nonzero = ca.Sparsity.triplet(size, size, rows.tolist(), cols.tolist(), True)
    return SystemPattern(size, rows, cols, sparsity, np.asarray(nonzero, int),
                         ca.Linsol(f"cond_qr_{m}_{r}", "qr", sparsity), threading.Lock())
