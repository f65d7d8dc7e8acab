"""The end-point task of a spatial chain for the resolved-rate baselines (``pinv``, ``dls``), in CasADi.

The spatial counterpart of the planar task of :mod:`.baselines`: the central point ``y^m`` of the
last link is driven along the 3-D curve at ``v*`` and its two normal coordinates decay like
``exp(-K t)``, i.e. ``A qdot = r`` with the 3 x dof task Jacobian ``A = [grad psi^T; dPhi/dy] dy^m/dq``
and ``r = (v* - psi_t, -K Phi - Phi_t)``. ``dy^m/dq`` is the reverse-mode gradient of each coordinate
of ``y^m`` (three O(m) sweeps). The 3 x 3 Gram matrix ``G = A A^T`` is inverted in closed form
(:func:`inverse3`) and the ``dls`` damping reads the ratio of ``A``'s extreme singular values from
``G``'s eigenvalues (:func:`singular_value_ratio3`, the trigonometric closed form of a symmetric 3 x 3
matrix), so the whole law compiles to straight-line C.
"""
from __future__ import annotations

import math
from typing import Any

import casadi as ca


def inverse3(G: Any) -> Any:
    """The inverse of a 3 x 3 CasADi matrix by its adjugate over its determinant (not finite when singular).

    Parameters
    ----------
    G : casadi.SX, shape (3, 3)
        The matrix.

    Returns
    -------
    casadi.SX, shape (3, 3)
        ``G^-1``.
    """
    def cof(i: int, j: int) -> Any:
        r, c = [k for k in range(3) if k != i], [k for k in range(3) if k != j]
        return (-1) ** (i + j) * (G[r[0], c[0]] * G[r[1], c[1]] - G[r[0], c[1]] * G[r[1], c[0]])

    C = ca.vertcat(*[ca.horzcat(*[cof(i, j) for j in range(3)]) for i in range(3)])
    det = G[0, 0] * C[0, 0] + G[0, 1] * C[0, 1] + G[0, 2] * C[0, 2]
    return C.T / det


def singular_value_ratio3(G: Any) -> Any:
    """``sigma_min / sigma_max`` of ``A`` from the symmetric positive semidefinite ``G = A A^T`` (3 x 3).

    The eigenvalues of a symmetric 3 x 3 matrix in closed form (Smith 1961): with ``q = tr G / 3``,
    ``p = sqrt(|G - q I|_F^2 / 6)`` and ``phi = acos(det((G - q I) / p) / 2) / 3``, the largest is
    ``q + 2 p cos(phi)`` and the smallest ``q + 2 p cos(phi + 2 pi / 3)``; the ratio is the square root
    of theirs (1 where ``G`` is a multiple of ``I``, 0 where ``G = 0``).

    Parameters
    ----------
    G : casadi.SX, shape (3, 3)
        ``A A^T``.

    Returns
    -------
    casadi.SX
        The ratio in [0, 1] [-].
    """
    q = (G[0, 0] + G[1, 1] + G[2, 2]) / 3
    off = G[0, 1] ** 2 + G[0, 2] ** 2 + G[1, 2] ** 2
    p = ca.sqrt(((G[0, 0] - q) ** 2 + (G[1, 1] - q) ** 2 + (G[2, 2] - q) ** 2 + 2 * off) / 6)
    safe = ca.fmax(p, 1e-300)
    B = (G - q * ca.SX.eye(3)) / safe
    det = (B[0, 0] * (B[1, 1] * B[2, 2] - B[1, 2] * B[2, 1]) - B[0, 1] * (B[1, 0] * B[2, 2] - B[1, 2] * B[2, 0])
           + B[0, 2] * (B[1, 0] * B[2, 1] - B[1, 1] * B[2, 0]))
    phi = ca.acos(ca.fmin(ca.fmax(det / 2, -1), 1)) / 3
    big = q + 2 * p * ca.cos(phi)
    small = ca.fmax(q + 2 * p * ca.cos(phi + 2 * math.pi / 3), 0)
    return ca.if_else(big > 0, ca.sqrt(small / ca.fmax(big, 1e-300)), 0)


def spatial_end_point_task(ctrl: Any, q: Any, t: Any) -> tuple[Any, Any, Any]:
    """``y^m`` (3,), the task Jacobian ``A`` (3, dof) and the commanded rates ``r`` (3,) of a spatial chain.

    Rows of ``A`` and ``r``: along the curve (``psi``), then across it (``phi_1``, ``phi_2``).

    Parameters
    ----------
    ctrl : SpatialController
        The chain (``centres``), the curve's geometry (``task.geometry``), ``K`` [1/s] and ``v*(t)`` [m/s].
    q : casadi.SX, shape (dof,)
        Joint coordinates [rad] (on a rail, ``d`` [m] first).
    t : casadi.SX
        Time [s].

    Returns
    -------
    y : casadi.SX, shape (3, 1)
        Central point of the last link [m].
    A : casadi.SX, shape (3, dof)
        ``d(psi, Phi)(y^m)/dq`` [m/rad].
    r : casadi.SX, shape (3, 1)
        ``(v* - psi_t, -K Phi - Phi_t)`` [m/s].
    """
    y = ctrl.chain.centres(q)[:, -1]
    J = ca.vertcat(*[ca.gradient(y[i], q).T for i in range(3)])      # three reverse sweeps: O(m)
    Phi, JPhi, Phit, _, gpsi, psit = ctrl.task.geometry(y, t)
    A = ca.vertcat(ca.mtimes(gpsi.T, J), ca.mtimes(JPhi, J))
    r = ca.vertcat(ctrl.speed(t) - psit, -ctrl.gain * Phi - Phit)
    return y, A, r
