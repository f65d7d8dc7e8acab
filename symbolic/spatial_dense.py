"""The dense reference of the spatial law: the outputs' Jacobian by AD and a dense solve, and the law Function.

The task outputs are stacked in the row order ``(s, roll, e^2_1, e^2_2, e^3_1, e^3_2, ..., e^m_2)``
(2 m rows for the 2 m joint coordinates ``(a_1, b_1, ..., a_m, b_m)``); the decoupling matrix is
their Jacobian ``M = dY/dq`` (``B = I``) and the right-hand side the commanded rates minus the
outputs' partial time derivatives at fixed ``q``: ``(v* - ds/dt, theta*' - K (theta - theta*) -
dtheta/dt, -K e - de/dt)``; ``u = M^-1 rhs``. On a rail ``q = (d, a_1, b_1, ...)`` and the span
``sigma = psi(y^m) - psi(y^1)`` is a row after ``s``: ``(s, sigma, roll, e^2_1, ...)``, its right-hand
side ``sigma' - dsigma/dt`` (``sigma' = 0`` when held).
"""
from __future__ import annotations

from typing import Any, Sequence

import casadi as ca

from .laws import Law
from .spatial_chain import SpatialChain
from .spatial_recursion import SpatialRecursion
from .spatial_task import SpatialTask


def task_outputs_expr(chain: SpatialChain, task: SpatialTask, q: Any, t: Any) -> Any:
    """The task outputs ``Y = (s, roll, e^2_1, e^2_2, ..., e^m_2)`` of symbolic ``(q, t)`` (on a rail
    ``(s, sigma, roll, e^2_1, ...)``).

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    task : SpatialTask
        Curve geometry.
    q : casadi.SX, shape (dof,)
        Joint coordinates [rad] (``d`` [m] first on a rail).
    t : casadi.SX
        Time [s].

    Returns
    -------
    casadi.SX, shape (dof, 1)
        ``s`` [m], (on a rail ``sigma`` [m],) ``roll`` [rad], then the deviations [m].
    """
    y, d = chain.centres(q), chain.directions(q)
    s = task.geometry(y[:, chain.m - 1], t)[3]
    roll = task.roll_geometry(y[:, 0], d[:, 0], t)[0]
    e = [task.geometry(y[:, j], t)[0] for j in range(1, chain.m)]
    span = [s - task.geometry(y[:, 0], t)[3]] if chain.rail else []
    return ca.vertcat(s, *span, roll, *e)


def spatial_decoupling_expr(chain: SpatialChain, task: SpatialTask, q: Any, t: Any) -> tuple[Any, Any]:
    """Decoupling matrix (rows as :func:`task_outputs_expr`) and right-hand side, by AD.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    task : SpatialTask
        Curve geometry, commands and gain.
    q : casadi.SX, shape (dof,)
        Joint coordinates [rad] (``d`` [m] first on a rail).
    t : casadi.SX
        Time [s].

    Returns
    -------
    M : casadi.SX, shape (dof, dof)
        ``dY/dq`` [m/rad and rad/rad; m/m in the rail column].
    rhs : casadi.SX, shape (dof,)
        ``(v* - ds/dt, [sigma' - dsigma/dt,] theta*' - K (theta - theta*) - dtheta/dt, -K e - de/dt)``.
    """
    Y = task_outputs_expr(chain, task, q, t)
    r = int(chain.rail)
    span = [task.span_rate(Y[1], t)] if chain.rail else []
    target = ca.vertcat(ca.SX(task.speed(t)), *span, task.roll_rate(Y[1 + r], t), -task.gain * Y[2 + r:])
    return ca.jacobian(Y, q), target - ca.jacobian(Y, t)


def spatial_law_function(recursion: SpatialRecursion, form: str, names: Sequence[str]) -> ca.Function:
    """The spatial law ``(q, t) -> outputs`` as an MX Function.

    Parameters
    ----------
    recursion : SpatialRecursion
        The chain's O(m) solve (its ``chain`` and ``task`` serve the dense solve too).
    form : {"structured", "dense"}
        ``"structured"``: ``u`` from the O(m) solve; ``"dense"``: ``u`` from a QR solve of the AD
        decoupling matrix (the margins come from the O(m) solve in both forms).
    names : sequence of str
        The outputs, in order (:data:`~coordarm.symbolic.outputs.SPATIAL_OUTPUTS`).

    Returns
    -------
    casadi.Function
        ``spatial_law_<form>``: inputs ``q`` (dof,) and ``t`` [s], outputs ``names``.
    """
    chain = recursion.chain
    q, t = ca.MX.sym("q", chain.dof), ca.MX.sym("t")
    outs = recursion.outputs(q, t)
    if form == Law.DENSE:
        qs, ts = ca.SX.sym("q", chain.dof), ca.SX.sym("t")
        M, r = spatial_decoupling_expr(chain, recursion.task, qs, ts)
        Mq, rq = ca.Function("spatial_decoupling", [qs, ts], [M, r])(q, t)
        outs["u"] = ca.solve(Mq, rq, "qr")
    return ca.Function(f"spatial_law_{form}", [q, t], [outs[n] for n in names], ["q", "t"], list(names))
