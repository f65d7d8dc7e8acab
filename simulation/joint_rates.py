"""Joint rates and accelerations of a run: their peaks, and the optional ``[chain] rate_limit`` / ``accel_limit``.

The law gives the joint rates ``u`` at every RK4 step; the joint accelerations are their step-to-step
changes, ``du/dt ~ (u_{k+1} - u_k) / h`` (on a rail the first column is the rail's rate ``d'``, so its
change is ``d''``). :class:`JointRates` sees every step (before a log thins the rows), keeps the
peaks and stops the run at the first step beyond a limit (:class:`~coordarm.symbolic.errors.JointRateError`).
"""
from __future__ import annotations

from dataclasses import field

import numpy as np

from coordarm.symbolic.errors import JointRateError
from coordarm.symbolic.records import record


@record
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
    _last = None                 # the previous update's last row (t, u): not a field

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
        acc = np.subtract(rev[1:], rev[:-1])                             # step k ends at row k + 1
        np.divide(np.abs(acc, out=acc), np.diff(tt)[:, None], out=acc)  # (in place: no fresh pages per block)
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
