"""The one fixed-step integrator of coordarm: a classical Runge-Kutta (RK4) step.

Used by the closed-loop step of the coordinating law
(:meth:`~coordarm.symbolic.controller.CoordinatingController.rk4_step`, which the simulation
chunks), by the baselines of :mod:`coordarm.analysis.baselines` and by the numpy benchmark.
Only arithmetic operators are applied, so the same function builds a CasADi graph (``SX``/``MX``
state) or steps numpy arrays; the operation order is fixed here once, and the generated C step
(``ca_rk4`` in :mod:`coordarm.generated.templates`) follows it, so all of them agree to rounding.
Imports nothing (not even CasADi).
"""
from __future__ import annotations

from typing import Any, Callable, TypeVar

#: A state: a CasADi expression (SX, MX, DM) or a numpy array (anything with + and scalar *).
State = TypeVar("State")


def rk4(f: Callable[[State, Any], State], x: State, t: Any, h: float, k1: State | None = None) -> State:
    """One classical RK4 step of ``xdot = f(x, t)`` from ``(x, t)`` to ``t + h``.

    ``x + h / 6 * (k1 + 2 k2 + 2 k3 + k4)`` with ``k1 = f(x, t)``,
    ``k2 = f(x + h / 2 * k1, t + h / 2)``, ``k3 = f(x + h / 2 * k2, t + h / 2)`` and
    ``k4 = f(x + h * k3, t + h)``, evaluated in exactly this order (the simulation's results
    depend on it to the last bit).

    Parameters
    ----------
    f : callable
        ``f(x, t) -> xdot``, the right-hand side; ``xdot`` has the shape of ``x`` [unit of x / s].
    x : casadi SX/MX/DM or ndarray, shape (n,)
        State at the step's start.
    t : float or casadi scalar
        Time at the step's start [s].
    h : float
        Step length [s].
    k1 : same type as x, shape (n,), optional
        ``f(x, t)`` if the caller has it already (e.g. it also keeps other outputs of the law
        at the step's start); computed here otherwise.

    Returns
    -------
    same type as x, shape (n,)
        The state at ``t + h``.
    """
    if k1 is None:
        k1 = f(x, t)
    k2 = f(x + h / 2 * k1, t + h / 2)
    k3 = f(x + h / 2 * k2, t + h / 2)
    k4 = f(x + h * k3, t + h)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
