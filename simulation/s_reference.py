"""The end point's commanded arc length ``s(0) + integral of v_scale v*`` on a run's rows, one rule for all.

The summary's s tracking (:class:`~.every_step.STracking`), :meth:`~.result.Run.s_reference` (figures,
replays), the scene's ``/tracking`` target (:meth:`~.scene.SceneBuilder.advance`) and the comparisons'
reference integrate ``v*`` here: Simpson's rule on each interval whose middle ``v*`` is known (exact for a
cubic ``v*``, a smoothstep ramp; what RK4's stages give ``s`` when the law makes ``s' = v*`` exactly), the
trapezoidal rule elsewhere (exact for an affine ``v*``; on a ramp off by O(step^2): 3e-8 m on path3d's at
2 ms steps, which the summary used to report as the law's error).
"""
from __future__ import annotations

from typing import Callable

import numpy as np


class RunningIntegral:
    """``integral of v dt`` from a run's first row, on its rows, fed block by block.

    Each interval between consecutive rows is integrated by Simpson's rule where the integrand at its
    middle is given (exact for a cubic ``v``: a smoothstep speed ramp; what RK4's stages give ``s`` when
    the law makes ``s' = v*`` exactly), else by the trapezoidal rule (exact for an affine ``v``, e.g. a
    constant speed). The blocks are summed on in one running order, so they give the bits one call on
    all the rows gives (:meth:`~.result.Run.s_reference`, the summary's s tracking
    :class:`~.every_step.STracking` and the scene's target :meth:`~.scene.SceneBuilder.advance` rely on it).
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
        The governor's factor on ``v*`` at them (:meth:`~.result.Run.speed_factor`).
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


class ArcReference:
    """``s(0) + integral of scale v*`` on a run's rows, fed block by block: the one reference of the summary's s
    tracking, :meth:`~.result.Run.s_reference`, the scene's target and the figures.

    Simpson's rule with ``v*`` at the middle of each step where ``scale`` (the governor's factor) is 1 at both
    ends (``speeds`` given), else the trapezoidal rule (:class:`RunningIntegral`, :func:`middle_speeds`).

    Parameters
    ----------
    speeds : callable, optional
        ``v*`` at an array of times [m/s] (``ctrl.speeds``); None: the trapezoidal rule.
    """

    def __init__(self, speeds: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        self.s0: float | None = None
        self._speeds = speeds
        self._integral = RunningIntegral()
        self._last: tuple[float, float] | None = None       # (t, scale) of the last row seen

    def add(self, t: np.ndarray, s0: float, v_star: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
        """The reference at each row of the next block (consecutive rows, following the previous block's).

        Parameters
        ----------
        t : ndarray, shape (N,)
            Times [s] (N >= 1).
        s0 : float
            ``s`` at the first row of the run [m] (read from the first block only).
        v_star : ndarray, shape (N,)
            Commanded speed at the rows [m/s].
        scale : ndarray, shape (N,), optional
            The governor's factor on ``v*`` at the rows (default 1: the commanded ``v*``).

        Returns
        -------
        ndarray, shape (N,)
            ``s(0) + integral of scale v*`` [m].
        """
        t = np.asarray(t, float)
        scale = np.ones(len(t)) if scale is None else np.asarray(scale, float)
        if self.s0 is None:
            self.s0 = float(s0)
        middle = middle_speeds(t, scale, self._speeds, self._last)
        self._last = (float(t[-1]), float(scale[-1]))
        return self.s0 + self._integral.add(t, scale * np.asarray(v_star, float), middle)
