"""Sampled-data simulation: the law evaluated every ``period``, held (zero-order hold), delayed.

The controller samples ``q_k = q(t_k)``, ``t_k = t0 + k h``, and the input applied on
``[t_k, t_{k+1})`` is the law evaluated ``delay`` samples earlier,
``u_k = u(q_{k-n}, t_{k-n})`` (before the first ``n`` samples exist, the law at the start).
Because ``u`` is constant on each interval and ``qdot = B u``, the state is integrated
exactly: ``q_{k+1} = q_k + h B u_k``. This simulator is separate from :mod:`simulation.run`
(continuous law, RK4) on purpose: it models the digital controller, not the integrator.
"""
from __future__ import annotations

from collections import deque
from dataclasses import field
from typing import Any

import numpy as np

from coordarm.symbolic import ConfigError, CoordinatingController
from coordarm.symbolic.checks import is_integer
from coordarm.symbolic.outputs import OUTPUTS
from coordarm.symbolic.records import record

from .run import check_number


def check_delay(delay: Any) -> None:
    """Raise ConfigError unless ``delay`` is an integer number of samples >= 0.

    Parameters
    ----------
    delay : int
        Control delay [samples] (a Python or numpy integer).

    Raises
    ------
    ConfigError
        ``delay`` is not an integer or is negative.
    """
    if not is_integer(delay, numpy=True) or delay < 0:
        raise ConfigError(f"delay: need an integer number of samples >= 0, got {delay!r}")


@record
class SampledRun:
    """Samples of a sampled-data run (row k is time ``t[k]``).

    Attributes
    ----------
    t : (N+1,) array
        Sample times [s].
    q : (N+1, dof) array
        Configurations [rad] (on a rail, ``d`` [m] first).
    u : (N+1, dof) array
        Input held on ``[t_k, t_{k+1})`` [rad/s for B = I] (last row: the next input).
    e : (N+1, m-1) array
        Deviations ``e^2..e^m`` [m].
    s : (N+1,) array
        Arc length of the end point [m].
    info : dict
        ``period``, ``delay`` and ``stopped`` (``"completed"`` or ``"diverged"``).
    """

    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    e: np.ndarray
    s: np.ndarray
    info: dict = field(default_factory=dict)

    def error_norm(self) -> np.ndarray:
        """``max_j |e^j|`` at every sample [m].

        Returns
        -------
        (N+1,) ndarray
            The largest deviation of each row [m].
        """
        return np.max(np.abs(self.e), axis=1)


def simulate_sampled(ctrl: CoordinatingController, q0, duration: float, period: float,
                     delay: int = 0, t0: float = 0.0, diverge_at: float = 1.0) -> SampledRun:
    """Simulate the digital coordinating controller with zero-order hold and a delay.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its ``fast_law`` is evaluated once per sample).
    q0 : (dof,) array_like
        Start configuration [rad] (on a rail, ``d`` [m] first).
    duration : float
        Simulated time [s].
    period : float
        Control period ``h`` [s] (also the integration interval, integrated exactly).
    delay : int
        Control delay in samples, ``n >= 0``.
    t0 : float
        Start time [s].
    diverge_at : float
        Stop (``info["stopped"] = "diverged"``) once ``max|e|`` exceeds this [m] or is not finite.

    Returns
    -------
    SampledRun

    Raises
    ------
    ConfigError
        ``duration``, ``period`` or ``diverge_at`` not a finite number > 0, a bad ``delay``, a period
        longer than the duration, or a bad ``q0``.
    """
    for name, v in (("duration", duration), ("period", period), ("diverge_at", diverge_at)):
        check_number(v, name)
    check_delay(delay)
    if period > duration:
        raise ConfigError(f"period: {period} s is longer than the duration {duration} s")
    q = ctrl.chain.check_q(q0, "q0")
    law, chain = ctrl.fast_law(), ctrl.chain
    n_steps = int(round(duration / period))
    rows = {k: [] for k in ("t", "q", "u", "e", "s")}
    first = None
    pending: deque = deque()
    stopped = "completed"
    for k in range(n_steps + 1):
        t = t0 + k * period
        out = dict(zip(OUTPUTS, law(q, t)))
        u_now, e, s = (np.asarray(out[name], dtype=float).ravel() for name in ("u", "e", "s"))
        if first is None:
            first = u_now
            pending.extend([first] * delay)
        pending.append(u_now)
        u = pending.popleft()
        for name, v in (("t", t), ("q", q), ("u", u), ("e", e), ("s", float(s[0]))):
            rows[name].append(v)
        if not np.max(np.abs(e)) <= diverge_at or not np.all(np.isfinite(u)):
            stopped = "diverged"
            break
        if k < n_steps:
            q = q + period * chain.apply_B(u)
    arrays = {k: np.array(v) for k, v in rows.items()}
    return SampledRun(**arrays, info={"period": float(period), "delay": int(delay), "stopped": stopped})
