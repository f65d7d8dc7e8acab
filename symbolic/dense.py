"""The dense reference of the coordinating law (paper eqs. 26-27), with damped least squares.

The decoupling matrix comes from AD Jacobians ``C^j = dc^j/dq`` of the chain's centres (an
O(m^2) graph) and is solved densely (O(m^3)); near a singularity (see :mod:`.near_singular`) the
damped least-squares solution replaces it inside a band of small margins.
"""
from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from .chain_model import ChainModel
from .near_singular import damping_factor
from .task import Task


def decoupling_matrix_expr(chain: ChainModel, task: Task, q: Any, t: Any, v_scale: Any = 1) -> tuple[Any, Any]:
    """Decoupling matrix (eq. 26, rows ``s^m, e^2..e^m``) and right-hand side, by AD.

    Parameters
    ----------
    chain : ChainModel
        The manipulator.
    task : Task
        Curve geometry, commanded speed and span, gain K [1/s].
    q : casadi.SX or casadi.MX, shape (dof,)
        Symbolic joint coordinates [rad] (``d`` [m] first on a rail).
    t : casadi.SX or casadi.MX
        Symbolic time [s].
    v_scale : float or casadi expression
        Factor on ``v*`` in the ``s`` row (the governor's; default 1).

    Returns
    -------
    M : casadi expression, shape (dof, dof)
        Rows ``(s^m, e^2, ..., e^m)`` (on a rail ``(s, sigma, e^2..e^m)``), columns the controls ``u``.
    rhs : casadi expression, shape (dof,)
        ``(v_scale v* - dpsi/dt, -K e^j - dphi/dt)`` (on a rail the span row's ``sigma_dot`` is
        scaled by ``v_scale`` too).
    """
    y = chain.centres(q)
    rows, rhs = [], []
    for j in [chain.m - 1] + list(range(1, chain.m)):
        phi, g, phit, psi, h, psit = task.geometry(y[:, j], t)
        Cj = ca.jacobian(y[:, j], q)
        if j == chain.m - 1 and not rows:
            rows.append(ca.mtimes(h.T, Cj))
            rhs.append(v_scale * task.speed(t) - psit)
            if chain.rail:        # the span row: sigma = psi(y^m) - psi(y^1)
                _, _, _, psi1, h1, psit1 = task.geometry(y[:, 0], t)
                rows.append(rows[0] - ca.mtimes(h1.T, ca.jacobian(y[:, 0], q)))
                rhs.append(v_scale * task.span_rate(psi - psi1, t) - psit + psit1)
            continue
        rows.append(ca.mtimes(g.T, Cj))
        rhs.append(-task.gain * phi - phit)
    M = ca.vertcat(*rows)
    bd = chain.b_diagonal
    if bd is not None and chain.rail:
        bd = np.r_[1.0, bd]                           # qdot_d = u_d on a rail
    M = M * ca.repmat(ca.DM(bd).T, M.size1(), 1) if bd is not None else ca.mtimes(M, ca.DM(chain.B_joints))
    return M, ca.vertcat(*rhs)


def dense_controls(chain: ChainModel, task: Task, outs: dict[str, Any], q: ca.MX, t: ca.MX,
                   dense: bool, damping: dict | None) -> ca.MX:
    """The controls ``u`` of the dense solve (eq. 27) and/or of damped least squares.

    Parameters
    ----------
    chain : ChainModel
        The manipulator.
    task : Task
        Curve geometry and commands.
    outs : dict
        The structured law's outputs at ``(q, t)`` (:meth:`.StructuredRecursion.outputs`): its
        ``v_scale`` scales the commands, its margins set the damping, its ``u`` is kept where
        the damping is off and ``dense`` is False.
    q : casadi.MX, shape (dof,)
        Joint coordinates [rad].
    t : casadi.MX
        Time [s].
    dense : bool
        Solve the dense decoupling matrix by QR (the ``"dense"`` form).
    damping : dict or None
        ``{"kind": "dls", "lambda": [m/rad], "band": (0, 1]}``: inside the band of the smallest
        margin, ``u = M^T (M M^T + lambda_v^2 I)^-1 r``.

    Returns
    -------
    casadi.MX, shape (dof,)
        ``u`` [rad/s for B = I] (``d_dot`` [m/s] first on a rail).
    """
    qs, ts, vs = ca.SX.sym("q", chain.dof), ca.SX.sym("t"), ca.SX.sym("v_scale")
    M, r = decoupling_matrix_expr(chain, task, qs, ts, vs)
    Mq, rq = ca.Function("decoupling", [qs, ts, vs], [M, r])(q, t, outs["v_scale"])
    u = ca.solve(Mq, rq, "qr") if dense else outs["u"]
    if damping:
        smallest = ca.fmin(ca.mmin(outs["link_margins"]), outs["longitudinal"])
        lam2 = damping_factor(smallest, damping["lambda"], damping["band"])
        damped = ca.mtimes(Mq.T, ca.solve(ca.mtimes(Mq, Mq.T) + lam2 * ca.MX.eye(chain.dof), rq, "qr"))
        u = ca.if_else(lam2 > 0, damped, u)
    return u
