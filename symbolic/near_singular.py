"""Keeping the law usable near a singularity: the speed governor and variable damping.

Both are smooth functions of a dimensionless margin (0 at the singularity) that work on
CasADi expressions (so they compile into the law) and on numpy arrays alike.

* :func:`speed_scale` -- the governor's factor ``g`` in [0, 1] on the commanded speed
  ``v*``: 1 at margins of at least ``3 x threshold``, falling with a C1 smoothstep to 0
  at the threshold. Only the ``s`` row's right-hand side changes, so every deviation
  still decays like ``exp(-K t)``.
* :func:`damping_factor` -- the squared damping ``lambda^2 (1 - (margin / band)^2)``
  inside the band, 0 outside it (the variable damping of Nakamura and Hanafusa, 1986).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

#: Full speed from this many thresholds of longitudinal margin up (the governor's upper knee).
GOVERNOR_SPAN = 3.0


def _clip01(x):
    if isinstance(x, (ca.SX, ca.MX)):
        return ca.fmin(ca.fmax(x, 0), 1)
    return np.clip(x, 0.0, 1.0)


def speed_scale(margin: float | np.ndarray | ca.SX | ca.MX, threshold: float) -> float | np.ndarray | ca.SX | ca.MX:
    """The governor's speed factor: 0 at ``margin <= threshold``, 1 from ``3 x threshold`` up.

    Parameters
    ----------
    margin : float, ndarray or CasADi expression
        Longitudinal margin (dimensionless, 0 = singular).
    threshold : float
        Margin at which the commanded speed reaches 0 (dimensionless, > 0).

    Returns
    -------
    Same type as ``margin``
        ``x^2 (3 - 2 x)`` with ``x = clip((margin - threshold) / ((3 - 1) threshold), 0, 1)``:
        continuous with a continuous derivative (C1), monotone.
    """
    x = _clip01((margin - threshold) / ((GOVERNOR_SPAN - 1.0) * threshold))
    return x * x * (3 - 2 * x)


def damping_factor(margin: float | np.ndarray | ca.SX | ca.MX, lam: float,
                   band: float) -> float | np.ndarray | ca.SX | ca.MX:
    """Squared damping of the variable-damping least-squares solve [same unit as ``lam^2``].

    Parameters
    ----------
    margin : float, ndarray or CasADi expression
        The smallest singularity margin (dimensionless, 0 = singular).
    lam : float
        Largest damping ``lambda`` (reached at margin 0) [m/rad, the unit of the
        decoupling matrix's entries].
    band : float
        Width of the band of margins in which damping acts (dimensionless, > 0).

    Returns
    -------
    Same type as ``margin``
        ``lam^2 (1 - (margin / band)^2)`` for ``margin < band``, else 0.
    """
    x = _clip01(margin / band)
    return lam * lam * (1 - x * x)
