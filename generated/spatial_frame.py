"""The coordinates the compiled spatial law works in: a line's own frame, else the base frame.

A line's frame ``F(t) = [t, n_1, n_2]`` (columns) is the same at every point, so in the coordinates
``y^c = F^T (y - p)`` (``p`` the line's point) the normal coordinates are ``Phi = (y^c_2, y^c_3)``,
their Jacobian is ``[[0, 1, 0], [0, 0, 1]]`` and ``psi = y^c_1``: the per-link geometry, the link
pivot ``dPhi/dy E_j`` and ``dPhi/dy y'`` cost nothing. Rates stay the base frame's velocities, only
written in the basis ``F``; the time derivatives at a fixed point are
``(psi_t, Phi_t) = F'^T F y^c - F^T p'`` (time-only matrices, computed once per law call). Any
other curve keeps the base frame (``F = I``, ``p = 0``) and its own geometry.
"""
from __future__ import annotations

from typing import Any

import casadi as ca

from coordarm.symbolic import SpatialController
from coordarm.symbolic.curves3d import Line3D, column


def line_frame(curve: Line3D, t: Any) -> tuple[Any, Any]:
    """``(F, p)``: a line's frame (columns ``t, n_1, n_2``) and point at time ``t``.

    Parameters
    ----------
    curve : Line3D
        The line.
    t : casadi.SX
        Time [s].

    Returns
    -------
    (casadi.SX, casadi.SX)
        ``F`` (3, 3) [-] and ``p`` (3,) [m].
    """
    return ca.SX(ca.horzcat(*curve.basis(t))), ca.SX(column([c(t) for c in curve.point]))


def frame_of(ctrl: SpatialController, t: Any) -> tuple[Any, Any] | None:
    """The compiled law's frame ``(F, p)`` at ``t``: the curve's own for a line, ``None`` (the base frame) else.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.
    t : casadi.SX
        Time [s].

    Returns
    -------
    (casadi.SX, casadi.SX) or None
        ``F`` (3, 3), ``p`` (3,) [m], as :func:`line_frame`.
    """
    return line_frame(ctrl.task.curve, t) if isinstance(ctrl.task.curve, Line3D) else None


def frame_geometry(ctrl: SpatialController) -> ca.Function:
    """``(y, t) -> (Phi, dPhi/dy, dPhi/dt, psi, grad psi, dpsi/dt)`` in the compiled law's coordinates.

    As :func:`~coordarm.symbolic.spatial_task.spatial_geometry_function`; for a line ``y`` is
    ``y^c = F^T (y - p)`` and the gradients are those with respect to ``y^c`` (the time derivatives
    are at a fixed point of the base frame); for any other curve the task's own geometry.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Inputs ``y`` (3,) [m], ``t`` [s]; outputs ``Phi`` (2,) [m], ``JPhi`` (2, 3) [-], ``Phit`` (2,)
        [m/s], ``psi`` [m], ``gpsi`` (3,) [-], ``psit`` [m/s].
    """
    if not isinstance(ctrl.task.curve, Line3D):
        return ctrl.task.geometry
    y, t = ca.SX.sym("y", 3), ca.SX.sym("t")
    F, p = line_frame(ctrl.task.curve, t)
    Fdot = ca.reshape(ca.jacobian(ca.vec(F), t), 3, 3)
    rates = ca.mtimes(ca.mtimes(Fdot.T, F), y) - ca.mtimes(F.T, ca.jacobian(p, t))   # (psi_t, Phi_t)
    J = ca.SX(ca.DM.eye(3)[1:3, :])                                                   # structural 0 and 1
    return ca.Function("spatial_frame_geometry", [y, t],
                       [y[1:3], J, rates[1:3], y[0], ca.SX(ca.DM.eye(3)[:, 0]), rates[0]],
                       ["y", "t"], ["Phi", "JPhi", "Phit", "psi", "gpsi", "psit"])
