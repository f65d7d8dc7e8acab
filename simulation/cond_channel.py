"""The rate and the meaning of ``/margins/cond``: the 1-norm condition number (O(m) estimate above 256 joints) by default, the exact 2-norm value on request."""
from __future__ import annotations

from typing import Any

import numpy as np

from coordarm.symbolic.numeric import EXACT_COND_DOF

#: Default rate of ``/margins/cond`` [Hz] up to :data:`~coordarm.symbolic.numeric.EXACT_COND_DOF` joints: one exact
#: 1-norm value costs about 0.2 ms at 64 links on a quiet machine (the curve's geometry at every centre, the
#: decoupling matrix, a dense inverse), about as much as 20 RK4 steps of the compiled law; at 1 Hz that is ~2 %
#: of a run (5 Hz, the former default, made the 100 Hz log cost ~10 % more; benchmarks/RESULTS.md, issue 24).
COND_RATE = 1.0
#: Above this many links the exact ``/margins/cond`` is off unless a rate is given (one SVD of a
#: 4096 x 4096 decoupling matrix takes about a minute; at 16384 links the matrix is 2 GiB).
COND_LINK_LIMIT = 1024
#: What the ``cond`` field holds, by ``cond_exact`` (the ``run`` metadata's ``cond`` entry).
COND_KINDS = {False: "1-norm (exact up to 256 joints, above: an O(m) lower-bound estimate)", True: "2-norm exact"}


#: Default rate of the O(m) estimate above :data:`~coordarm.symbolic.numeric.EXACT_COND_DOF` joints [Hz]:
#: one estimate costs about 25 us per link (a sparse LU and some ten solves), the compiled simulation
#: about 40 us per link per simulated second at a 1 ms step, so at 0.5 Hz the estimate adds about 30 %
#: (benchmarks/RESULTS.md, issue 24); at 5 Hz it would add 300 %.
ESTIMATE_RATE = 0.5


def default_cond_rate(links: int, exact: bool = True) -> float:
    """Default rate of ``/margins/cond`` [Hz].

    The 1-norm value (``exact=False``, the default of a run): :data:`COND_RATE` up to
    :data:`~coordarm.symbolic.numeric.EXACT_COND_DOF` links (computed exactly, cheap there), then
    :data:`ESTIMATE_RATE` (the O(m) estimate, whose share of a run is then the same at every size).
    The exact 2-norm value is an SVD of the m x m decoupling matrix,
    O(m^3): :data:`COND_RATE` up to 64 links, then ``* (64/m)^2``, and 0 (channel off) above
    :data:`COND_LINK_LIMIT` links, which keeps its share of a run's time about what it is at 64 links.

    Parameters
    ----------
    links : int
        Number of links m (> 0).
    exact : bool
        The rate of the exact 2-norm condition number (True) or of the 1-norm one (False).

    Returns
    -------
    float
        The rate [Hz]; for the exact value 0 above :data:`COND_LINK_LIMIT` links.
    """
    if not exact:
        return COND_RATE if links <= EXACT_COND_DOF else ESTIMATE_RATE
    if links > COND_LINK_LIMIT:
        return 0.0
    return COND_RATE * min(1.0, (64.0 / links) ** 2)


def cond_plan(ctrl: Any, cond_rate: float | None, cond_exact: bool, planar: bool) -> tuple[float, bool]:
    """The rate and the kind of ``/margins/cond`` of a run, the one rule the log and the live view share.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The run's controller (its chain's ``m``).
    cond_rate : float or None
        The rate asked for [Hz] (0 = off); None: :func:`default_cond_rate` on a planar chain, off on a spatial one.
    cond_exact : bool
        Whether the exact 2-norm value was asked for (a spatial chain has only that one).
    planar : bool
        Whether the chain is planar.

    Returns
    -------
    rate : float
        Samples per simulated second [Hz]; 0 = off.
    exact : bool
        True: the exact 2-norm value (``ctrl.conds``); False: the 1-norm one (``ctrl.cond_estimates``).
    """
    exact = bool(cond_exact) or not planar
    if cond_rate is None:
        cond_rate = default_cond_rate(ctrl.chain.m, exact) if planar else 0.0
    return cond_rate, exact


def cond_values(ctrl: Any, exact: bool, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The condition numbers of ``/margins/cond`` at the states ``q`` and times ``t``.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The run's controller.
    exact : bool
        The exact 2-norm value (an SVD each) or the 1-norm one (see :func:`cond_plan`).
    q : ndarray, shape (k, n)
        Joint states [rad, m].
    t : ndarray, shape (k,)
        Times [s].

    Returns
    -------
    ndarray, shape (k,)
        The condition numbers [-].
    """
    return np.asarray((ctrl.conds if exact else ctrl.cond_estimates)(q, t))
