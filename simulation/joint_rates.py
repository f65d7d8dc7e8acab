"""Joint rates and accelerations of a run: their peaks, and the optional ``[chain] rate_limit`` / ``accel_limit``.

The law gives the joint rates ``u`` at every RK4 step; the joint accelerations are their step-to-step
changes, ``du/dt ~ (u_{k+1} - u_k) / h`` (on a rail the first column is the rail's rate ``d'``, so its
change is ``d''``). :class:`JointRates` sees every step (before a log thins the rows), keeps the
peaks and stops the run at the first step beyond a limit (:class:`JointRateError`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from coordarm.symbolic.errors import ConfigError, CoordarmError


class JointRateError(CoordarmError):
    """A joint moved faster (``kind = "rate"``) or turned its rate faster (``"accel"``) than its limit.

    Parameters
    ----------
    time : float
        Simulated time [s].
    joint : int
        1-based joint index (``q_j``; on a rail joint 0 is the rail).
    value : float
        ``|u_j|`` [rad/s] or ``|du_j/dt|`` [rad/s^2].
    limit : float
        The limit it exceeded.
    kind : {"rate", "accel"}
        Which limit.
    run : object, optional
        The run up to that state.
    """

    def __init__(self, time: float, joint: int, value: float, limit: float, kind: str,
                 run: object | None = None) -> None:
        self.time, self.joint, self.value, self.limit, self.kind, self.run = time, joint, value, limit, kind, run
        what = (f"moves at |u| = {value:.4g} rad/s, above chain.rate_limit = {limit:.4g} rad/s" if kind == "rate" else
                f"accelerates at |du/dt| = {value:.4g} rad/s^2, above chain.accel_limit = {limit:.4g} rad/s^2")
        super().__init__(f"joint {kind} limit at t = {time:.4f} s: joint {joint} {what}; run stopped")

    def __reduce__(self):
        return (JointRateError, (self.time, self.joint, self.value, self.limit, self.kind, None))


def check_limit(value: Any, field_name: str) -> float | None:
    """A ``rate_limit`` or ``accel_limit`` read from a scenario: None, or a finite number > 0.

    Parameters
    ----------
    value : object
        The value (None when the key is left out).
    field_name : str
        Its name in error messages (``"chain.rate_limit"``).

    Returns
    -------
    float or None
        The limit.

    Raises
    ------
    ConfigError
        Not a finite number > 0.
    """
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{field_name}: need a number > 0, got {value!r}")
    return float(value)


@dataclass
class JointRates:
    """The peaks of ``|u|`` and ``|du/dt|`` over a run, and its optional limits.

    Attributes
    ----------
    rail : bool
        The first column of ``u`` is the rail's rate ``d'`` [m/s] (its change is ``d''``, kept apart).
    rate_limit, accel_limit : float or None
        Limits of ``|u_j|`` [rad/s] and ``|du_j/dt|`` [rad/s^2] of the joints' angles (None: unchecked).
    per_joint : int
        Columns of ``u`` per joint: 1 (revolute), 2 (a universal joint's two angles); joints are
        named ``column // per_joint + 1``.
    peaks : dict
        ``du_dt`` [rad/s^2] with its ``du_dt_joint`` and ``du_dt_time`` [s] (the end of the step), and on a
        rail ``rail_accel`` [m/s^2] with ``rail_accel_time``.
    """

    rail: bool = False
    rate_limit: float | None = None
    accel_limit: float | None = None
    per_joint: int = 1
    peaks: dict = field(default_factory=dict)
    _last: tuple | None = field(default=None, repr=False)

    def update(self, t: np.ndarray, u: np.ndarray) -> tuple[int, JointRateError] | None:
        """Take the next rows ``(t, u)`` of the run; the first row beyond a limit, and its error.

        Parameters
        ----------
        t : ndarray, shape (n,)
            Times [s], every step.
        u : ndarray, shape (n, dof)
            Rates at those times (on a rail ``d'`` [m/s] first).

        Returns
        -------
        tuple of (int, JointRateError) or None
            Row of ``t`` and the error, or None within the limits.
        """
        if len(t) == 0:
            return None
        tt, uu = (np.r_[self._last[0], t], np.vstack([self._last[1], u])) if self._last else (t, u)
        shift = 1 if self._last else 0
        self._last = (t[-1:], u[-1:])
        r = int(self.rail)
        rev = uu[:, r:]
        stop = None
        if self.rate_limit is not None:
            bad = np.argwhere(np.abs(rev) > self.rate_limit)
            if len(bad):
                k, j = bad[0]
                stop = (int(k), JointRateError(float(tt[k]), int(j) // self.per_joint + 1, float(abs(rev[k, j])),
                                               self.rate_limit, "rate"))
        acc = np.abs(np.diff(rev, axis=0)) / np.diff(tt)[:, None]       # step k ends at row k + 1
        if self.accel_limit is not None:
            bad = np.argwhere(acc > self.accel_limit)
            if len(bad) and (stop is None or bad[0][0] + 1 < stop[0]):
                k, j = bad[0]
                stop = (int(k) + 1, JointRateError(float(tt[k + 1]), int(j) // self.per_joint + 1, float(acc[k, j]),
                                                   self.accel_limit, "accel"))
        end = len(tt) if stop is None else stop[0] + 1                   # the peaks up to the stop only
        self._peaks(tt[:end], uu[:end], acc[:end - 1])
        return None if stop is None else (stop[0] - shift, stop[1])

    def _peaks(self, tt: np.ndarray, uu: np.ndarray, acc: np.ndarray) -> None:
        """Raise the peaks with the steps between the rows ``tt`` (``acc`` their revolute accelerations)."""
        if len(acc) == 0:
            return
        k, j = np.unravel_index(np.argmax(acc), acc.shape)
        if acc[k, j] > self.peaks.get("du_dt", -1.0):
            self.peaks.update(du_dt=float(acc[k, j]), du_dt_joint=int(j) // self.per_joint + 1,
                              du_dt_time=float(tt[k + 1]))
        if self.rail:
            dd = np.abs(np.diff(uu[:, 0])) / np.diff(tt)
            i = int(np.argmax(dd))
            if dd[i] > self.peaks.get("rail_accel", -1.0):
                self.peaks.update(rail_accel=float(dd[i]), rail_accel_time=float(tt[i + 1]))
