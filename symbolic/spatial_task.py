"""The spatial task: a 3-D curve's geometry to task outputs, and the commands on them (the spatial law, docs/guide/spatial.md).

A :class:`SpatialCurve`-like object (``psi(y, t)``, ``Phi(y, t)``, ``frame(y, t)``, see
``symbolic/curves3d.py``) gives, at the closest point of a centre ``y``, the
arc length ``psi`` and the normal coordinates ``Phi = (phi_1, phi_2)`` in the transported frame
``(t, n_1, n_2)``. The outputs of a spatial chain are ``s = psi(y^m)``, ``e^j = Phi(y^j)`` (j = 2..m)
and the roll ``theta = atan2(n_2 . d_1, n_1 . d_1)`` with the frame at the closest point of ``y^1``.
The commands: ``s' = v*``, ``e' = -K e``, ``theta' = theta*' - K (theta - theta*)``. On a rail (the
feed axis) the span ``sigma = psi(y^m) - psi(y^1)`` is one more output: held (``sigma' = 0``) or
commanded, ``sigma' = sigma*' - K (sigma - sigma*)``.
"""
from __future__ import annotations

import sys
import weakref
from typing import Any, Callable

import casadi as ca

from .errors import ConfigError
from .function_buffer import PointwiseFunction, two_point_function
from .lazy import made_once

#: Output names of :func:`spatial_geometry_function`, in order.
SPATIAL_GEOMETRY_OUTPUTS = ("Phi", "JPhi", "Phit", "psi", "gpsi", "psit")
#: Output names of :func:`roll_function`, in order.
ROLL_OUTPUTS = ("theta", "gtheta_d", "theta_t", "gtheta_y")


def roll_expr(curve: Any, y: Any, d: Any, t: Any) -> Any:
    """The roll ``atan2(n_2 . d, n_1 . d)`` of a direction ``d`` in the curve's frame at the closest point of ``y``.

    Parameters
    ----------
    curve : SpatialCurve
        The goal curve.
    y : casadi.SX, shape (3,)
        Point whose closest point gives the frame [m].
    d : casadi.SX, shape (3,)
        Direction (the first link's).
    t : casadi.SX
        Time [s].

    Returns
    -------
    casadi.SX
        The roll [rad], in (-pi, pi].
    """
    _, n1, n2 = curve.frame(y, t)
    return ca.atan2(ca.dot(n2, d), ca.dot(n1, d))


def is_built_in3d(curve: Any) -> bool:
    """Whether ``curve`` is one of coordarm's 3-D curves: a Line3D, Circle3D, Arc3D or
    :class:`~.paths3d.Path3D` (not a subclass); any other curve is user-defined.

    No Path3D exists before :mod:`.paths3d` is loaded, so the question does not load it.

    Parameters
    ----------
    curve : SpatialCurve
        The curve.

    Returns
    -------
    bool
        True for coordarm's own 3-D curve classes.
    """
    from .curves3d import Arc3D, Circle3D, Line3D       # loaded with any spatial curve

    kind = type(curve)
    if kind in (Line3D, Circle3D, Arc3D):
        return True
    paths = sys.modules.get(f"{__package__}.paths3d")
    return paths is not None and kind is paths.Path3D


def spatial_geometry_function(curve: Any) -> ca.Function:
    """``(y, t) -> (Phi, dPhi/dy, dPhi/dt, psi, grad psi, dpsi/dt)`` of a 3-D curve, by AD.

    Built once per curve (a curve does not change): the start's placement and the task share it (a path's
    is 30 ms of CasADi graph).

    Parameters
    ----------
    curve : SpatialCurve
        The goal curve.

    Returns
    -------
    casadi.Function
        Inputs ``y`` (3,) [m] and ``t`` [s]; outputs :data:`SPATIAL_GEOMETRY_OUTPUTS`: ``Phi`` (2,)
        [m], ``JPhi`` (2, 3) [-], ``Phit`` (2,) [m/s], ``psi`` [m], ``gpsi`` (3,) [-], ``psit`` [m/s].

    Raises
    ------
    ConfigError
        ``Phi`` is not a 2-vector or ``psi`` not a scalar.
    """
    return made_once(_GEOMETRIES, curve, lambda: _geometry_function(curve))


#: :func:`spatial_geometry_function` of each curve alive.
_GEOMETRIES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _geometry_function(curve: Any) -> ca.Function:
    y, t = ca.SX.sym("y", 3), ca.SX.sym("t")
    Phi, psi = ca.SX(curve.Phi(y, t)), ca.SX(curve.psi(y, t))
    if Phi.numel() != 2 or psi.numel() != 1:
        raise ConfigError("curve: Phi must be a 2-vector and psi a scalar")
    Phi = ca.reshape(Phi, 2, 1)
    return ca.Function("spatial_geometry", [y, t],
                       [Phi, ca.jacobian(Phi, y), ca.jacobian(Phi, t),
                        psi, ca.gradient(psi, y), ca.jacobian(psi, t)],
                       ["y", "t"], list(SPATIAL_GEOMETRY_OUTPUTS))


def roll_function(curve: Any) -> ca.Function:
    """``(y, d, t) -> (theta, dtheta/dd, dtheta/dt, dtheta/dy)``: the roll of :func:`roll_expr` and its derivatives, by AD.

    Parameters
    ----------
    curve : SpatialCurve
        The goal curve.

    Returns
    -------
    casadi.Function
        Inputs ``y`` (3,) [m], ``d`` (3,) and ``t`` [s]; outputs :data:`ROLL_OUTPUTS` ([rad], [rad],
        [rad/s], [rad/m]).
    """
    y, d, t = ca.SX.sym("y", 3), ca.SX.sym("d", 3), ca.SX.sym("t")
    theta = roll_expr(curve, y, d, t)
    return ca.Function("roll", [y, d, t], [theta, ca.gradient(theta, d), ca.jacobian(theta, t),
                                           ca.gradient(theta, y)],
                       ["y", "d", "t"], list(ROLL_OUTPUTS))


class SpatialTask:
    """The task outputs of a 3-D curve and their commands.

    Parameters
    ----------
    curve : SpatialCurve
        The goal curve ``S(t)``.
    speed : callable
        Commanded end-point speed ``t -> v*(t)`` [m/s] (CasADi in, CasADi out).
    gain : float
        Error gain K > 0 [1/s].
    roll : callable
        Commanded roll ``t -> theta*(t)`` [rad] (CasADi in, CasADi out).
    span : callable, optional
        On a rail, the commanded span ``t -> sigma*(t)`` [m]; None: the span is held.

    Attributes
    ----------
    geometry : casadi.Function
        :func:`spatial_geometry_function` of ``curve``: built at once for a user-defined curve (its
        errors surface with the controller), on first use for coordarm's curves (:func:`is_built_in3d`;
        a compiled run whose library is at hand never needs it: ~50 ms saved at the start of path3d).
    roll_geometry : casadi.Function
        :func:`roll_function` of ``curve``, built as ``geometry``.
    """

    def __init__(self, curve: Any, speed: Callable[[Any], Any], gain: float, roll: Callable[[Any], Any],
                 span: Callable[[Any], Any] | None = None) -> None:
        self.curve, self.speed, self.gain, self.roll, self.span = curve, speed, gain, roll, span
        self._cache: dict[str, Any] = {}
        if not is_built_in3d(curve):
            self._cache.update(geometry=spatial_geometry_function(curve), roll_geometry=roll_function(curve))

    @property
    def geometry(self) -> ca.Function:
        """:func:`spatial_geometry_function` of the curve (built once)."""
        if "geometry" not in self._cache:
            self._cache["geometry"] = spatial_geometry_function(self.curve)
        return self._cache["geometry"]

    def base_geometry(self) -> PointwiseFunction:
        """``Phi`` at ``y^1`` and ``grad psi`` at ``y^2`` of many rows, in one evaluation (the base margin's).

        Returns
        -------
        PointwiseFunction
            Called with ``y^1`` and ``y^2`` (each ``(3, N)``, [m]) and ``t`` (``(N,)``, [s]); returns ``Phi(y^1)``
            ``(2, N)`` [m] and ``grad psi(y^2)`` ``(3, N)``: :attr:`geometry`'s outputs, bit for bit.
        """
        if "base geometry" not in self._cache:
            self._cache["base geometry"] = PointwiseFunction(two_point_function(self.geometry, 0, 4))
        return self._cache["base geometry"]

    @property
    def roll_geometry(self) -> ca.Function:
        """:func:`roll_function` of the curve (built once)."""
        if "roll_geometry" not in self._cache:
            self._cache["roll_geometry"] = roll_function(self.curve)
        return self._cache["roll_geometry"]

    def tracking_rate(self, command: Callable[[Any], Any], value: Any, t: Any) -> Any:
        """Commanded rate of an output that tracks ``command``: ``c*' - K (value - c*)``.

        Parameters
        ----------
        command : callable
            ``t -> c*(t)`` (CasADi in, CasADi out).
        value : casadi.SX or casadi.MX
            The output now.
        t : casadi.SX or casadi.MX
            Time [s].

        Returns
        -------
        casadi expression
            The commanded rate.
        """
        ts = ca.SX.sym("ts")
        target = ca.SX(command(ts))
        target_and_rate = ca.Function("target", [ts], [target, ca.jacobian(target, ts)])
        c_star, c_star_dot = target_and_rate(t)
        return c_star_dot - self.gain * (value - c_star)

    def roll_rate(self, theta: Any, t: Any) -> Any:
        """Commanded roll rate ``theta*' - K (theta - theta*)``.

        Parameters
        ----------
        theta : casadi.SX or casadi.MX
            The roll now [rad].
        t : casadi.SX or casadi.MX
            Time [s].

        Returns
        -------
        casadi expression
            ``theta'`` commanded [rad/s].
        """
        return self.tracking_rate(self.roll, theta, t)

    def span_rate(self, sigma: Any, t: Any) -> Any:
        """Commanded span rate: ``sigma*' - K (sigma - sigma*)``, or 0 when the span is held.

        Parameters
        ----------
        sigma : casadi.SX or casadi.MX
            The span now [m].
        t : casadi.SX or casadi.MX
            Time [s].

        Returns
        -------
        casadi expression
            ``sigma'`` commanded [m/s].
        """
        if self.span is None:
            return 0 * t
        return self.tracking_rate(self.span, sigma, t)
