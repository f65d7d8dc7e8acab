"""The ``/tracking`` record of a planar run: what the Foxglove layout plots, with the logarithms that keep
deviations near rounding readable on a linear plot axis."""
from __future__ import annotations

import numpy as np

from .run import Run

#: Smallest magnitude whose logarithm ``/tracking`` publishes [m]: below it a length is 0 to double
#: precision at the scale of a robot (1e-16 relative), and a plot axis stays readable.
LOG_FLOOR = 1e-18


def log10_floored(x: np.ndarray) -> np.ndarray:
    """``log10(max(|x|, LOG_FLOOR))``: the decimal logarithm of a length, floored at :data:`LOG_FLOOR`.

    Parameters
    ----------
    x : ndarray
        Lengths [m] (any sign; NaN stays NaN).

    Returns
    -------
    ndarray
        The logarithms, of the shape of ``x``.
    """
    return np.log10(np.fmax(np.abs(np.asarray(x, float)), LOG_FLOOR))


def tracking_records(part: Run, ks: np.ndarray, s_target: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """The planar ``/tracking`` records at rows ``ks`` of ``part``, in the order of
    :data:`~.log_schemas.TRACKING_FIELDS`.

    Parameters
    ----------
    part : Run
        The block of steps.
    ks : ndarray of int, shape (k,)
        Its rows.
    s_target : ndarray, shape (k,)
        ``s(0) + integral of v*`` at those rows [m].
    targets : ndarray, shape (k, 2)
        The target points [m].

    Returns
    -------
    ndarray, shape (k, 11)
        ``t, s, s_target, target_x, target_y, max|e|, min link margin, |u|, log10 max|e|, s - s_target,
        log10 |s - s_target|`` (logarithms of values below :data:`LOG_FLOOR` are ``log10(LOG_FLOOR)``).
    """
    max_e = np.max(np.abs(part.e[ks]), axis=1)
    s_error = part.s[ks] - s_target
    logs = log10_floored(max_e), log10_floored(s_error)
    return np.column_stack([part.t[ks], part.s[ks], s_target, targets, max_e, np.min(part.link_margins[ks], axis=1),
                            np.linalg.norm(part.u[ks], axis=1), logs[0], s_error, logs[1]])
