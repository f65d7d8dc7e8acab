"""What a run's summary takes from every step when only some rows are kept in memory.

A logged run keeps a thinned set of rows (:data:`~coordarm.simulation.limits.KEEP_ROWS`, fewer without
figures). Its summary stays exact: the largest ``s`` tracking error is accumulated here over every step
(:class:`STracking`), and each chunk keeps, besides its margins' and ``|u|``'s extremes, the rows of its
largest joint angle against the limit (planar) and its largest roll tracking error (spatial), found by
:func:`summary_rows`.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .result import Run


class RunningIntegral:
    """``integral of v dt`` from a run's first row, by the trapezoidal rule on its rows, fed block by block.

    The blocks are summed on in one running order, :meth:`Run.s_reference`'s, so they give the bits one
    call on all the rows gives (what both the summary's s tracking, :class:`STracking`, and the scene's
    target, :meth:`~.scene.SceneBuilder.advance`, rely on).
    """

    def __init__(self) -> None:
        self._carry: tuple[float, float, float] | None = None    # (t, v, integral) at the last row seen

    def add(self, t: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The integral at each row of the next block.

        Parameters
        ----------
        t : ndarray, shape (N,)
            Times of consecutive rows, following the previous block's [s] (N >= 1).
        v : ndarray, shape (N,)
            The integrand at them.

        Returns
        -------
        ndarray, shape (N,)
            The integral from the first row of the first block [v's unit times s]; a non-finite ``v`` makes
            it non-finite from there on, without a floating-point warning.
        """
        t, v = np.asarray(t, float), np.asarray(v, float)
        with np.errstate(over="ignore", invalid="ignore"):
            if self._carry is None:
                integral = np.cumsum(np.concatenate([[0.0], 0.5 * np.diff(t) * (v[1:] + v[:-1])]))
            else:
                t_prev, v_prev, acc = self._carry
                tt, vv = np.concatenate([[t_prev], t]), np.concatenate([[v_prev], v])
                integral = np.cumsum(np.concatenate([[acc], 0.5 * np.diff(tt) * (vv[1:] + vv[:-1])]))[1:]
        self._carry = (float(t[-1]), float(v[-1]), float(integral[-1]))
        return integral


def governed_steps(part: Run) -> int:
    """Rows of ``part`` where the governor slowed ``v*``.

    Parameters
    ----------
    part : Run
        Rows of consecutive steps.

    Returns
    -------
    int
        Rows with ``v_scale < 1`` (each lasts one step, as in :meth:`Run.governed_time`).
    """
    return int(np.count_nonzero(part.speed_factor() < 1))


class STracking:
    """The largest ``|s - (s(0) + integral of v_scale v*)|`` over every step of a run, fed chunk by chunk.

    The reference is :meth:`Run.s_reference`'s trapezoidal rule on the step grid, continued across
    chunks in the same order of summation, so over a run whose every row is kept the two agree to the
    last bit (``tests/test_every_step.py``).

    Attributes
    ----------
    max : float
        The largest error so far [m] (0 before the first row; NaN from a row where it is not finite on).
    time : float or None
        When it occurred [s].
    """

    def __init__(self) -> None:
        self.max, self.time = 0.0, None
        self._s0: float | None = None
        self._integral = RunningIntegral()

    def add(self, part: Run) -> None:
        """Take the next rows of the run (consecutive steps, following the previous ones).

        Parameters
        ----------
        part : Run
            Rows ``t`` [s], ``s`` [m], ``v_star`` [m/s] (and ``v_scale``) of consecutive steps.
        """
        t = np.asarray(part.t, float)
        if not len(t):
            return
        if self._s0 is None:
            self._s0 = float(part.s[0])
        integral = self._integral.add(t, part.speed_factor() * np.asarray(part.v_star, float))
        with np.errstate(invalid="ignore"):              # a state turned non-finite: said below
            error = np.abs(np.asarray(part.s, float) - (self._s0 + integral))
        bad = ~np.isfinite(error)
        if bad.any() and not math.isnan(self.max):   # the first non-finite error is the run's (and stays)
            self.max, self.time = float("nan"), float(t[np.argmax(bad)])
            return
        k = int(np.argmax(error))
        if self.time is None or error[k] > self.max:
            self.max, self.time = float(error[k]), float(t[k])

    def info(self) -> dict[str, float]:
        """The entries for ``Run.info``.

        Returns
        -------
        dict
            ``max_s_tracking_error`` [m] and ``max_s_tracking_error_time`` [s] (empty before the first row).
        """
        return {} if self.time is None else {"max_s_tracking_error": self.max, "max_s_tracking_error_time": self.time}


def summary_rows(part: Run, chain: Any) -> list[int]:
    """Rows of a chunk the summary's maxima come from, beyond the margins' and ``|u|``'s extremes.

    Parameters
    ----------
    part : Run
        One chunk's rows (at least one).
    chain : Chain or SpatialChain
        The run's chain: a planar one's ``joint_limits`` [rad] (the row of the largest ``|q_j|/limit``,
        ``j >= 2``, as the summary's joints line), a spatial one's roll (the row of the largest
        ``|roll - roll*|``, wrapped).

    Returns
    -------
    list of int
        Row indices into ``part`` (possibly none).
    """
    if "roll" in part.extra and "roll_star" in part.extra:
        error = np.abs(np.angle(np.exp(1j * (np.asarray(part.extra["roll"]) - np.asarray(part.extra["roll_star"])))))
        return [int(np.argmax(error))]
    limits = getattr(chain, "joint_limits", None)
    if limits is None or part.q.shape[1] != chain.dof or chain.m < 2:
        return []
    ratio = np.abs(chain.revolute(part.q)[:, 1:]) / np.asarray(limits, float)
    return [int(np.argmax(np.max(ratio, axis=1)))]
