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
    _acc = None                  # the accelerations' array, kept from block to block: not a field

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
        last, self._last = self._last, (t[-1:], u[-1:])
        tt = np.r_[last[0], t] if last else t           # the previous block's last row first: its step ends here
        shift = 1 if last else 0
        r = int(self.rail)
        rev = u[:, r:]
        stop = None
        if self.rate_limit is not None:                 # (the previous last row was checked with its block)
            bad = np.argwhere(np.abs(rev) > self.rate_limit)
            if len(bad):
                k, j = bad[0]
                stop = (int(k) + shift, JointRateError(float(t[k]), int(j) // self.per_joint + 1, float(abs(rev[k, j])),
                                                       self.rate_limit, "rate"))
        acc = self._steps(last[1][:, r:] if last else None, rev)        # step k ends at row k + 1 of tt
        np.divide(np.abs(acc, out=acc), np.diff(tt)[:, None], out=acc)
        if self.accel_limit is not None:
            bad = np.argwhere(acc > self.accel_limit)
            if len(bad) and (stop is None or bad[0][0] + 1 < stop[0]):
                k, j = bad[0]
                stop = (int(k) + 1, JointRateError(float(tt[k + 1]), int(j) // self.per_joint + 1, float(acc[k, j]),
                                                   self.accel_limit, "accel"))
        end = len(tt) if stop is None else stop[0] + 1                   # the peaks up to the stop only
        rail = (np.r_[last[1][:, 0], u[:, 0]] if last else u[:, 0])[:end] if self.rail else None
        self._peaks(tt[:end], rail, acc[:end - 1])
        return None if stop is None else (stop[0] - shift, stop[1])

    def _steps(self, before: np.ndarray | None, rows: np.ndarray) -> np.ndarray:
        """``rows[k+1] - rows[k]`` (``before``: the row before ``rows[0]`` first), into an array kept from block to
        block (no fresh pages, no copy of the block with its previous row in front)."""
        n = len(rows) - (before is None)
        if self._acc is None or len(self._acc) < n or self._acc.shape[1] != rows.shape[1]:
            self._acc = np.empty((n, rows.shape[1]))
        acc = self._acc[:n]
        if before is not None:
            np.subtract(rows[:1], before, out=acc[:1])
        np.subtract(rows[1:], rows[:-1], out=acc[n - len(rows) + 1:])
        return acc

    def _peaks(self, tt: np.ndarray, rail: np.ndarray | None, acc: np.ndarray) -> None:
        """Raise the peaks with the steps between the rows ``tt`` (``acc`` their revolute accelerations, ``rail``
        the rail's rates ``d'`` at the rows, None without a rail)."""
        if len(acc) == 0:
            return
        k, j = np.unravel_index(np.argmax(acc), acc.shape)
        if acc[k, j] > self.peaks.get("du_dt", -1.0):
            self.peaks.update(du_dt=float(acc[k, j]), du_dt_joint=int(j) // self.per_joint + 1,
                              du_dt_time=float(tt[k + 1]))
        if self.rail:
            dd = np.abs(np.diff(rail)) / np.diff(tt)
            i = int(np.argmax(dd))
            if dd[i] > self.peaks.get("rail_accel", -1.0):
                self.peaks.update(rail_accel=float(dd[i]), rail_accel_time=float(tt[i + 1]))
