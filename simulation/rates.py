"""Rates of a log: how many simulation steps lie between two samples of a channel."""
from __future__ import annotations

from typing import Any

import numpy as np

from coordarm.symbolic import ConfigError
from coordarm.symbolic.checks import is_real

#: The most steps between two samples (more than any run has: ``run.duration / run.step`` <= 1e12);
#: a lower rate is this, so that step counters stay within int64.
MOST_STEPS_BETWEEN = 2 ** 52


def steps_between(rate: Any, step: float, name: str) -> int:
    """Steps between two samples at ``rate`` samples per simulated second (at least 1).

    Parameters
    ----------
    rate : float
        Samples per simulated second [Hz]; anything else (not a real number, not positive, not
        finite) is refused.
    step : float
        The simulation step [s].
    name : str
        The rate's name in the error message.

    Returns
    -------
    int
        ``round(1 / (rate * step))``, at least 1 and at most :data:`MOST_STEPS_BETWEEN` (a rate
        so low that no run reaches its second sample: only the first and last are written).

    Raises
    ------
    ConfigError
        ``rate`` (named ``name`` in the message) is not a positive number.
    """
    if not is_real(rate) or not rate > 0 or not np.isfinite(rate):
        raise ConfigError(f"{name}: need a positive number of samples per second, got {rate!r}")
    between = 1.0 / (float(rate) * step)
    return MOST_STEPS_BETWEEN if not between < MOST_STEPS_BETWEEN else max(1, int(round(between)))
