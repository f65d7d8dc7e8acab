"""What a run's summary takes from every step when only some rows are kept in memory.

A logged run keeps a thinned set of rows (:data:`~coordarm.simulation.limits.KEEP_ROWS`, fewer without
figures). Its summary stays exact: the largest ``s`` tracking error is accumulated here over every step
(:class:`STracking`), and each chunk keeps, besides its margins' and ``|u|``'s extremes, the rows of its
largest joint angle against the limit (planar) and its largest roll tracking error (spatial), found by
:func:`summary_rows`.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from .result import Run
from .s_reference import ArcReference


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

    The reference is :meth:`Run.s_reference`'s on the step grid (Simpson's rule with ``v*`` at each step's
    middle where the governor left ``v*`` whole, :class:`~.s_reference.ArcReference`), continued across chunks in the
    same order of summation, so over a run whose every row is kept the two agree to the last bit
    (``tests/test_every_step.py``). The trapezoidal rule alone would report its own error, not the law's:
    3e-8 m on path3d's speed ramp (2 ms steps) against 2e-14 m.

    Parameters
    ----------
    speeds : callable, optional
        ``v*`` at an array of times [m/s] (``ctrl.speeds``); None: the trapezoidal rule.

    Attributes
    ----------
    max : float
        The largest error so far [m] (0 before the first row; NaN from a row where it is not finite on).
    time : float or None
        When it occurred [s].
    """

    def __init__(self, speeds: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        self.max, self.time = 0.0, None
        self._reference = ArcReference(speeds)

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
        reference = self._reference.add(t, part.s[0], part.v_star, part.speed_factor())
        with np.errstate(invalid="ignore"):              # a state turned non-finite: said below
            error = np.abs(np.asarray(part.s, float) - reference)
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
    ratio = np.abs(chain.revolute(part.q)[:, 1:])
    ratio /= np.asarray(limits, float)                  # (in place: one array of the chunk's size, not two)
    return [int(np.argmax(np.max(ratio, axis=1)))]
