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


class RunningIntegral:
    """``integral of v dt`` from a run's first row, on its rows, fed block by block.

    Each interval between consecutive rows is integrated by Simpson's rule where the integrand at its
    middle is given (exact for a cubic ``v``: a smoothstep speed ramp; what RK4's stages give ``s`` when
    the law makes ``s' = v*`` exactly), else by the trapezoidal rule (exact for an affine ``v``, e.g. a
    constant speed). The blocks are summed on in one running order, so they give the bits one call on
    all the rows gives (:meth:`Run.s_reference`, the summary's s tracking :class:`STracking` and the
    scene's target :meth:`~.scene.SceneBuilder.advance` rely on it).
    """

    def __init__(self) -> None:
        self._carry: tuple[float, float, float] | None = None    # (t, v, integral) at the last row seen

    def add(self, t: np.ndarray, v: np.ndarray, middle: np.ndarray | None = None) -> np.ndarray:
        """The integral at each row of the next block.

        Parameters
        ----------
        t : ndarray, shape (N,)
            Times of consecutive rows, following the previous block's [s] (N >= 1).
        v : ndarray, shape (N,)
            The integrand at them.
        middle : ndarray, shape (N,), optional
            The integrand at the middle of the interval that ends at each row (NaN where unknown: the
            trapezoidal rule there; the first row of the first block ends no interval). None: trapezoids.

        Returns
        -------
        ndarray, shape (N,)
            The integral from the first row of the first block [v's unit times s]; a non-finite ``v`` makes
            it non-finite from there on, without a floating-point warning.
        """
        t, v = np.asarray(t, float), np.asarray(v, float)
        first = self._carry is None
        tt = t if first else np.concatenate([[self._carry[0]], t])
        vv = v if first else np.concatenate([[self._carry[1]], v])
        with np.errstate(over="ignore", invalid="ignore"):
            steps = interval_integrals(tt, vv, None if middle is None else np.asarray(middle, float)[1 if first else 0:])
            start = 0.0 if first else self._carry[2]
            integral = np.cumsum(np.concatenate([[start], steps]))
            integral = integral if first else integral[1:]
        self._carry = (float(t[-1]), float(v[-1]), float(integral[-1]))
        return integral


def interval_integrals(t: np.ndarray, v: np.ndarray, middle: np.ndarray | None) -> np.ndarray:
    """``integral of v`` over each interval ``[t_i, t_(i+1)]``: Simpson's rule where ``middle`` (v at its middle)
    is finite, else the trapezoidal rule.

    Parameters
    ----------
    t, v : ndarray, shape (N,)
        Rows [s] and the integrand at them.
    middle : ndarray, shape (N - 1,) or None
        The integrand at each interval's middle (NaN: unknown).

    Returns
    -------
    ndarray, shape (N - 1,)
    """
    dt = np.diff(t)
    trapezoid = 0.5 * dt * (v[1:] + v[:-1])
    if middle is None:
        return trapezoid
    return np.where(np.isfinite(middle), dt / 6.0 * (v[:-1] + 4.0 * middle + v[1:]), trapezoid)


def middle_speeds(t: np.ndarray, scale: np.ndarray, speeds: Callable[[np.ndarray], np.ndarray] | None,
                  before: tuple[float, float] | None = None) -> np.ndarray | None:
    """``v*`` at the middle of the step that ends at each row, where the governor left it whole at both ends.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Rows [s].
    scale : ndarray, shape (N,)
        The governor's factor on ``v*`` at them (:meth:`Run.speed_factor`).
    speeds : callable or None
        ``v*`` at an array of times [m/s] (``ctrl.speeds``); None: no middles (trapezoids).
    before : (float, float), optional
        Time [s] and factor of the row before the first (the previous block's last); None: the first
        row ends no step.

    Returns
    -------
    ndarray, shape (N,) or None
        [m/s]; NaN where the step was governed at either end (the factor inside it is not known) and at
        a first row without ``before``.
    """
    if speeds is None:
        return None
    tt = np.concatenate([[before[0] if before else np.nan], t])
    ss = np.concatenate([[before[1] if before else np.nan], scale])
    whole = (ss[1:] == 1.0) & (ss[:-1] == 1.0)
    mid = 0.5 * (tt[1:] + tt[:-1])
    out = np.full(len(t), np.nan)
    if whole.any():
        out[whole] = np.asarray(speeds(mid[whole]), float).ravel()
    return out


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
    middle where the governor left ``v*`` whole, :class:`RunningIntegral`), continued across chunks in the
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
        self._s0: float | None = None
        self._integral = RunningIntegral()
        self._speeds = speeds
        self._last: tuple[float, float] | None = None       # (t, v_scale) of the last row seen

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
        scale = part.speed_factor()
        middle = middle_speeds(t, scale, self._speeds, self._last)
        self._last = (float(t[-1]), float(scale[-1]))
        integral = self._integral.add(t, scale * np.asarray(part.v_star, float), middle)
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
