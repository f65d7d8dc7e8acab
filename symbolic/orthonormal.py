"""Check that a curve description is orthonormalised (docs/model.md, *The curve*; paper eqs. 10-11).

On the curve, the Jacobian of ``(psi, phi)`` with respect to ``y`` must be a rotation
``T(alpha*) = [[cos a, sin a], [-sin a, cos a]]``: ``grad psi`` and ``grad phi`` of unit length,
orthogonal, and ``grad phi`` to the left of ``grad psi`` (determinant +1). The law's
``sdot = v*`` and ``e -> 0 like exp(-K t)`` hold as stated only then; a description that is
merely proportional (e.g. ``phi`` scaled by 2) changes the meaning of ``e`` and ``s``.
"""
from __future__ import annotations

import warnings
from collections.abc import Sequence

import casadi as ca
import numpy as np

from .curves import Curve
from .errors import ConfigError
from .records import record


class OrthonormalityWarning(UserWarning):
    """A curve's ``(psi, phi)`` Jacobian is not a rotation on the curve."""


@record
class OrthonormalityCheck:
    """Result of :func:`check_orthonormal`.

    Attributes
    ----------
    ok : bool
        Every checked point passed.
    worst_deviation : float
        Largest ``|J J^T - I|`` entry or ``|det J - 1|`` over the checked points [-].
    worst_point : (2,) array
        Where it occurred [m].
    worst_time : float
        When [s].
    off_curve : float
        Largest ``|phi|`` at the sampled points (they should lie on the curve) [m].
    points : int
        Number of points checked.
    """

    ok: bool
    worst_deviation: float
    worst_point: np.ndarray
    worst_time: float
    off_curve: float
    points: int

    def message(self) -> str:
        """One line naming the offending point (or confirming the check).

        Returns
        -------
        str
            The message, with the point [m], time [s] and deviation.
        """
        x, y = self.worst_point
        if self.ok:
            return (f"curve is orthonormalised: the (psi, phi) Jacobian is a rotation to "
                    f"{self.worst_deviation:.2g} at {self.points} points")
        return (f"curve is not orthonormalised: the (psi, phi) Jacobian at y = ({x:.4g}, {y:.4g}) m, "
                f"t = {self.worst_time:.4g} s, deviates from a rotation by {self.worst_deviation:.3g} "
                f"(|phi| there up to {self.off_curve:.3g} m)")


def check_orthonormal(curve: Curve, times: Sequence[float] = (0.0,), points: int = 64, extent: float = 5.0,
                      tol: float = 1e-6, warn: bool = True) -> OrthonormalityCheck:
    """Check that ``curve``'s description is orthonormalised at points sampled on it.

    Parameters
    ----------
    curve : Curve
        The curve (its :meth:`~symbolic.Curve.sample` gives the points checked).
    times : sequence of float
        Times at which to check [s].
    points : int
        Points per time.
    extent : float
        Half-length of the sampled stretch of unbounded curves [m].
    tol : float
        Allowed deviation of ``J J^T`` from ``I`` and of ``det J`` from 1.
    warn : bool
        Issue an :class:`OrthonormalityWarning` naming the worst point when the check fails.

    Returns
    -------
    OrthonormalityCheck
        Whether the worst deviation is within ``tol``, the deviation, where and when it occurs,
        the largest ``|phi|`` at the sampled points and how many were checked.

    Raises
    ------
    ConfigError
        ``curve`` is not a :class:`~symbolic.Curve`.

    Warns
    -----
    OrthonormalityWarning
        With ``warn``, when the check fails.
    """
    if not isinstance(curve, Curve):
        raise ConfigError(f"curve: expected a Curve, got {type(curve).__name__}")
    y, t = ca.SX.sym("y", 2), ca.SX.sym("t")
    phi = curve.phi(y, t)
    f = ca.Function("psi_phi", [y, t], [ca.jacobian(ca.vertcat(curve.psi(y, t), phi), y), phi])
    worst, where, when, off, count = -1.0, np.zeros(2), 0.0, 0.0, 0
    for tk in np.atleast_1d(np.asarray(times, dtype=float)):
        pts = np.asarray(curve.sample(float(tk), n=points, extent=extent), dtype=float)
        J, phi = f.map(len(pts))(pts.T, float(tk))
        J = np.asarray(J).reshape(2, len(pts), 2).transpose(1, 0, 2)
        dev = np.maximum(np.max(np.abs(J @ J.transpose(0, 2, 1) - np.eye(2)), axis=(1, 2)),
                         np.abs(np.linalg.det(J) - 1.0))
        dev = np.where(np.isfinite(dev), dev, np.inf)
        k = int(np.argmax(dev))
        if dev[k] > worst:
            worst, where, when = float(dev[k]), pts[k], float(tk)
        off = max(off, float(np.max(np.abs(np.asarray(phi)))))
        count += len(pts)
    res = OrthonormalityCheck(bool(worst <= tol), worst, where, when, off, count)
    if warn and not res.ok:
        warnings.warn(res.message(), OrthonormalityWarning, stacklevel=2)
    return res
