"""The dense reference of the spatial law: the outputs' Jacobian by AD and a dense solve, and the law Function.

The task outputs are stacked in the row order ``(s, roll, e^2_1, e^2_2, e^3_1, e^3_2, ..., e^m_2)``
(2 m rows for the 2 m joint coordinates ``(a_1, b_1, ..., a_m, b_m)``); the decoupling matrix is
their Jacobian ``M = dY/dq`` (``B = I``) and the right-hand side the commanded rates minus the
outputs' partial time derivatives at fixed ``q``: ``(v* - ds/dt, theta*' - K (theta - theta*) -
dtheta/dt, -K e - de/dt)``; ``u = M^-1 rhs``.
"""
from __future__ import annotations

from typing import Any, Sequence

import casadi as ca

from .laws import Law
from .spatial_chain import SpatialChain
from .spatial_recursion import SpatialRecursion
from .spatial_task import SpatialTask


def task_outputs_expr(chain: SpatialChain, task: SpatialTask, q: Any, t: Any) -> Any:
    """The task outputs ``Y = (s, roll, e^2_1, e^2_2, ..., e^m_2)`` of symbolic ``(q, t)``.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    task : SpatialTask
        Curve geometry.
    q : casadi.SX, shape (2 m,)
        Joint coordinates [rad].
    t : casadi.SX
        Time [s].

    Returns
    -------
    casadi.SX, shape (2 m, 1)
        ``s`` [m], ``roll`` [rad], then the deviations [m].
    """
    y, d = chain.centres(q), chain.directions(q)
    s = task.geometry(y[:, chain.m - 1], t)[3]
    roll = task.roll_geometry(y[:, 0], d[:, 0], t)[0]
    e = [task.geometry(y[:, j], t)[0] for j in range(1, chain.m)]
    return ca.vertcat(s, roll, *e)


def spatial_decoupling_expr(chain: SpatialChain, task: SpatialTask, q: Any, t: Any) -> tuple[Any, Any]:
    """Decoupling matrix (rows as :func:`task_outputs_expr`) and right-hand side, by AD.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    task : SpatialTask
        Curve geometry, commands and gain.
    q : casadi.SX, shape (2 m,)
        Joint coordinates [rad].
    t : casadi.SX
        Time [s].

    Returns
    -------
    M : casadi.SX, shape (2 m, 2 m)
        ``dY/dq`` [m/rad and rad/rad].
    rhs : casadi.SX, shape (2 m,)
        ``(v* - ds/dt, theta*' - K (theta - theta*) - dtheta/dt, -K e - de/dt)``.
    """
    Y = task_outputs_expr(chain, task, q, t)
    target = ca.vertcat(ca.SX(task.speed(t)), task.roll_rate(Y[1], t), -task.gain * Y[2:])
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
        ``spatial_law_<form>``: inputs ``q`` (2 m,) and ``t`` [s], outputs ``names``.
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
