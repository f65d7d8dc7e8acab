"""Linearised closed-loop error dynamics in task coordinates, by CasADi AD.

The closed loop is ``qdot = f(q, t) = B u(q, t)``; the task map is
``z = h(q, t) = (s^m, e^2, ..., e^m)``. A perturbation ``dq`` of a trajectory ``q*(t)``
obeys ``d(dq)/dt = F dq`` with ``F = df/dq``, and ``dz = H dq`` with ``H = dh/dq``, so

    d(dz)/dt = (H F + Hdot) H^{-1} dz,   Hdot = dH/dq [f] + dH/dt

(``Hdot`` is the change of the task map along the trajectory). The frozen Jacobian
``H F H^{-1}`` alone is *not* the error dynamics while the chain moves. By design the task
dynamics are ``sdot = v*(t)`` and ``edot = -K e``, so the task matrix must be
``diag(0, -K, ..., -K)``: eigenvalue ``-K`` (m-1 times) and 0 in the ``s`` direction, whose
input is ``v*`` alone.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import casadi as ca
import numpy as np

from coordarm.simulation.run import even_indices
from coordarm.symbolic import CoordinatingController
from coordarm.symbolic.laws import Law



@dataclass
class Linearisation:
    """The closed loop linearised at one point ``(q, t)``.

    Attributes
    ----------
    t : float
        Time [s].
    q : (m,) array
        Configuration [rad].
    task_matrix : (m, m) array
        ``(H F + Hdot) H^{-1}``: the error dynamics in task coordinates ``(s, e^2..e^m)`` [1/s].
    frozen_task_matrix : (m, m) array
        ``H F H^{-1}``, the frozen-Jacobian approximation (wrong while the chain moves) [1/s].
    joint_matrix : (m, m) array
        ``F = df/dq`` in joint coordinates [1/s].
    task_rate : (m,) array
        ``H f + dh/dt``: the task velocity ``(sdot, edot)`` at the point.
    free : int
        Leading task coordinates with eigenvalue 0 by design: 1 (``s``), 2 on a rail with a
        held span (``s``, ``sigma``; a commanded span decays like ``-K``).

    On a rail the task coordinates are ``(s, sigma, e^2..e^m)`` and ``q`` has m+1 entries.
    """

    t: float
    q: np.ndarray
    task_matrix: np.ndarray
    frozen_task_matrix: np.ndarray
    joint_matrix: np.ndarray
    task_rate: np.ndarray
    free: int = 1

    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of :attr:`task_matrix`, sorted by real part (descending).

        Returns
        -------
        (m,) complex ndarray
            The eigenvalues [1/s], largest real part first (ties keep numpy's order).
        """
        ev = np.linalg.eigvals(self.task_matrix)
        return ev[np.argsort(-ev.real, kind="stable")]

    def deviation_from_design(self, gain: float, frozen: bool = False) -> float:
        """``max |A - diag(0, -K, ..., -K)|`` of :attr:`task_matrix` (or :attr:`frozen_task_matrix`).

        The design matrix has :attr:`free` leading zeros on its diagonal and ``-K`` on the rest.

        Parameters
        ----------
        gain : float
            The design gain ``K`` [1/s].
        frozen : bool
            Compare :attr:`frozen_task_matrix` instead of :attr:`task_matrix`.

        Returns
        -------
        float
            Largest entry-wise deviation from the design matrix [1/s].
        """
        target = np.diag([0.0] * self.free + [-gain] * (len(self.q) - self.free))
        return float(np.max(np.abs((self.frozen_task_matrix if frozen else self.task_matrix) - target)))


#: The Functions of :func:`linearisation_function`, per controller and form.
_linearisations: "weakref.WeakKeyDictionary[CoordinatingController, dict[str, ca.Function]]" = \
    weakref.WeakKeyDictionary()


def linearisation_function(ctrl: CoordinatingController, form: str | None = None) -> ca.Function:
    """``(q, t) -> (H, F, Hdot, task_rate)`` as a CasADi Function, by AD of the law.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller; its law (``form``) is the one differentiated.
    form : {"structured", "dense"}, optional
        Form of the law (default: the controller's).

    Returns
    -------
    casadi.Function
        ``(q (dof,), t) -> (H (dof, dof), F (dof, dof) [1/s], Hdot (dof, dof) [1/s], task_rate (dof,))``,
        built once per controller and form and cached while the controller lives.
    """
    form = form or ctrl.law_form
    per_ctrl = _linearisations.setdefault(ctrl, {})
    if form not in per_ctrl:
        per_ctrl[form] = _linearisation_function(ctrl, form)
    return per_ctrl[form]


def _linearisation_function(ctrl: CoordinatingController, form: str) -> ca.Function:
    """The uncached body of :func:`linearisation_function` (on a rail: tasks ``(s, sigma, e)``; spatial:
    ``(s, roll, e)``; spatial on a rail: ``(s, sigma, roll, e)``)."""
    m = ctrl.chain.dof
    sym = ca.SX if form == Law.STRUCTURED else ca.MX      # the dense law's linear solve is MX only
    q, t = sym.sym("q", m), sym.sym("t")
    out = dict(zip(ctrl.outputs, ctrl.fast_law(form)(q, t)))
    u, e, s = out["u"], out["e"], out["s"]
    if "roll" in out:                    # a spatial chain: B = I, tasks (s, [sigma,] roll, e^2_1, e^2_2, ...)
        f, z = u, ca.vertcat(s, *([out["sigma"]] if ctrl.chain.rail else []), out["roll"], e)
    else:
        f = ca.mtimes(ca.DM(ctrl.B_joints), u)
        z = ca.vertcat(s, out["sigma"], e) if ctrl.chain.rail else ca.vertcat(s, e)
    H = ca.jacobian(z, q)
    F = ca.jacobian(f, q)
    # Hdot: one forward directional derivative of H along the flow (f, 1) in (q, t)
    Hdot = ca.reshape(ca.jtimes(ca.vec(H), ca.vertcat(q, t), ca.vertcat(f, 1)), m, m)
    rate = ca.mtimes(H, f) + ca.jacobian(z, t)
    return ca.Function("linearised_loop", [q, t], [H, F, Hdot, rate], ["q", "t"], ["H", "F", "Hdot", "task_rate"])


def linearise(ctrl: CoordinatingController, q, t: float = 0.0, form: str | None = None) -> Linearisation:
    """Linearise the closed loop of ``ctrl`` at ``(q, t)`` and map it to task coordinates.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller.
    q : (m,) array_like
        Configuration [rad] (typically a point of a simulated trajectory).
    t : float
        Time [s].
    form : {"structured", "dense"}, optional
        Form of the law to differentiate.

    Returns
    -------
    Linearisation
        The matrices at ``(q, t)``.

    Raises
    ------
    ConfigError
        ``q`` has the wrong shape or is not finite.
    numpy.linalg.LinAlgError
        The task map's Jacobian ``H`` is singular at ``q``.
    """
    q = ctrl.chain.check_q(q)
    H, F, Hdot, rate = (np.asarray(x) for x in linearisation_function(ctrl, form)(q, float(t)))
    Hinv = np.linalg.inv(H)
    free = 2 if ctrl.chain.rail and ctrl.span is None else 1
    return Linearisation(float(t), q, (H @ F + Hdot) @ Hinv, H @ F @ Hinv, F, rate.ravel(), free)


def linearise_run(ctrl: CoordinatingController, t, q, points: int = 5,
                  form: str | None = None) -> list[Linearisation]:
    """Linearise at ``points`` samples spread evenly over a trajectory ``(t, q)``.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller that produced the trajectory.
    t : (N,) array_like
        Sample times [s].
    q : (N, dof) array
        Configurations [rad] (``d`` [m] first on a rail), row k at ``t[k]``.
    points : int
        How many samples, evenly spread with the first and last included (fewer if ``N < points``).
    form : {"structured", "dense"}, optional
        Form of the law to differentiate (default: the controller's).

    Returns
    -------
    list of Linearisation
        One per sample, in time order.
    """
    t = np.asarray(t, dtype=float)
    idx = even_indices(len(t), points)
    return [linearise(ctrl, q[k], float(t[k]), form) for k in idx]
