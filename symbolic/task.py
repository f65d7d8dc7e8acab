"""The task: curve geometry to task outputs, and the commands on them (paper eqs. 8-11).

The outputs of a centre ``y`` at time ``t`` are ``phi(y, t)`` (signed distance to the curve) and
``psi(y, t)`` (arc length of its closest point); :class:`Task` holds them as one CasADi Function
with their gradients and time derivatives (by AD), with the commanded speed ``v*(t)``, the error
gain ``K`` and, on a rail, the commanded span ``sigma*(t)``.
"""
from __future__ import annotations

import sys
from typing import Any, Callable, Sequence

import casadi as ca

from .curves import Arc, Circle, Curve, Line
from .errors import ConfigError
from .function_buffer import BufferedFunction, PointwiseFunction, two_point_function

#: Output names of the geometry Functions, in order.
GEOMETRY_OUTPUTS = ("phi", "gphi", "phit", "psi", "gpsi", "psit")


def is_built_in(curve: Any) -> bool:
    """Whether ``curve`` is one of coordarm's curves: a Line, Circle, Arc or :class:`~.paths.Path` (not a
    subclass); any other Curve is user-defined.

    No Path exists before :mod:`.paths` is loaded, so the question does not load it (nor its pieces and
    transitions, 1.6 ms at the start of a run without a path).

    Parameters
    ----------
    curve : Curve
        The curve.

    Returns
    -------
    bool
        True for coordarm's own curve classes.
    """
    kind = type(curve)
    if kind in (Line, Circle, Arc):
        return True
    paths = sys.modules.get(f"{__package__}.paths")
    return paths is not None and kind is paths.Path


def check_user_curve(curve: Curve, times: Sequence[float] = (0.0, 1.0)) -> None:
    """Check a user-defined curve's description is orthonormalised on it (paper eqs. 10-11).

    Parameters
    ----------
    curve : Curve
        A user-defined curve (with ``sample``).
    times : sequence of float
        Times at which to check [s].

    Raises
    ------
    ConfigError
        ``sample`` is missing (the points to check come from it), or the ``(psi, phi)``
        Jacobian is not a rotation at a sampled point (named).
    """
    from .orthonormal import check_orthonormal
    try:
        res = check_orthonormal(curve, times=times, warn=False)
    except NotImplementedError:
        raise ConfigError(f"curve: the user-defined {type(curve).__name__} must implement sample(t, n, extent) "
                          f"(points on the curve) so that its description can be checked") from None
    if not res.ok:
        raise ConfigError(f"curve: user-defined {type(curve).__name__}: {res.message()}")


def geometry_function(curve: Curve) -> ca.Function:
    """``(y, t) -> (phi, grad phi, dphi/dt, psi, grad psi, dpsi/dt)`` of ``curve``, by AD.

    Parameters
    ----------
    curve : Curve
        The goal curve.

    Returns
    -------
    casadi.Function
        Inputs ``y`` (2,) [m] and ``t`` [s]; outputs :data:`GEOMETRY_OUTPUTS` ([m], [-], [m/s]).

    Raises
    ------
    ConfigError
        The curve's ``phi`` or ``psi`` is not a CasADi scalar.
    """
    y, t = ca.SX.sym("y", 2), ca.SX.sym("t")
    try:
        phi, psi = curve.phi(y, t), curve.psi(y, t)
        phi, psi = ca.SX(phi), ca.SX(psi)
    except Exception as exc:  # a user callable returned something unusable
        raise ConfigError(f"curve: its parameters must be numbers or callables of t "
                          f"returning CasADi scalars ({exc})") from None
    if phi.numel() != 1 or psi.numel() != 1:
        raise ConfigError("curve: phi and psi must be scalars")
    return ca.Function("geometry", [y, t],
                       [phi, ca.gradient(phi, y), ca.jacobian(phi, t),
                        psi, ca.gradient(psi, y), ca.jacobian(psi, t)],
                       ["y", "t"], list(GEOMETRY_OUTPUTS))


class Task:
    """The task outputs of a curve and their commands.

    Parameters
    ----------
    curve : Curve
        The goal curve ``S(t)``.
    speed : callable
        Commanded end-point speed ``t -> v*(t)`` [m/s] (CasADi in, CasADi out).
    gain : float
        Error gain K > 0 [1/s].
    span : callable, optional
        On a rail, the commanded span ``t -> sigma*(t)`` [m]; None: the span is held.

    Attributes
    ----------
    geometry : casadi.Function
        :func:`geometry_function` of ``curve``: built at once for a user-defined curve (its errors
        surface with the controller), on first use for coordarm's curves (a compiled run whose library
        is at hand never needs it: 2 ms saved at the start of a run).
    """

    def __init__(self, curve: Curve, speed: Callable[[Any], Any], gain: float,
                 span: Callable[[Any], Any] | None = None) -> None:
        self.curve, self.speed, self.gain, self.span = curve, speed, gain, span
        self._cache: dict = {}
        if not is_built_in(curve):
            self._cache["geometry"] = geometry_function(curve)

    @property
    def geometry(self) -> ca.Function:
        """:func:`geometry_function` of the curve (built once)."""
        if "geometry" not in self._cache:
            self._cache["geometry"] = geometry_function(self.curve)
        return self._cache["geometry"]

    def piece_geometry(self, kind: str) -> ca.Function:
        """``(y, t, piece) -> (phi, grad phi, dphi/dt, psi, grad psi, dpsi/dt)`` of a path by the formulas
        of one piece of ``kind``, by AD (cached).

        Parameters
        ----------
        kind : {"line", "arc", "spiral"}
            The kind of piece (the curve is a :class:`~coordarm.symbolic.paths.Path`).

        Returns
        -------
        casadi.Function
            Inputs ``y`` [m], ``t`` [s] and ``piece`` (the ten constants of
            :func:`~coordarm.symbolic.path_pieces.piece_parameters` with ``derived=True``).
        """
        key = ("piece_geometry", kind)
        if key not in self._cache:
            from .path_pieces import PIECE_CONSTANTS

            y, t, sel = ca.SX.sym("y", 2), ca.SX.sym("t"), ca.SX.sym("piece", PIECE_CONSTANTS)
            phi, psi = self.curve.phi_psi_piece(y, t, sel, kind)
            self._cache[key] = ca.Function(
                "piece_geometry", [y, t, sel], [phi, ca.gradient(phi, y), ca.jacobian(phi, t),
                                                psi, ca.gradient(psi, y), ca.jacobian(psi, t)],
                ["y", "t", "piece"], list(GEOMETRY_OUTPUTS))
        return self._cache[key]

    def span_rate(self, sigma: Any, t: Any) -> Any:
        """Commanded ``sigma_dot``: ``sigma*' - K (sigma - sigma*)``, or 0 when the span is held.

        Parameters
        ----------
        sigma : casadi.SX
            The span now [m].
        t : casadi.SX
            Time [s].

        Returns
        -------
        casadi.SX
            ``sigma_dot`` [m/s].
        """
        if self.span is None:
            return 0 * t
        ts = ca.SX.sym("ts")
        target = ca.SX(self.span(ts))
        rate = ca.Function("span", [ts], [target, ca.jacobian(target, ts)])
        sig_t, sig_dot = rate(t)
        return sig_dot - self.gain * (sigma - sig_t)

    def speed_function(self) -> ca.Function:
        """``t -> v*(t)``: the commanded speed [m/s] as a CasADi Function.

        Returns
        -------
        casadi.Function
            Input ``t`` [s], output ``v`` [m/s].
        """
        t = ca.SX.sym("t")
        return ca.Function("speed", [t], [ca.SX(self.speed(t))], ["t"], ["v"])

    def span_rate_function(self) -> ca.Function:
        """``(sigma, t) -> sigma_dot`` commanded (see :meth:`span_rate`).

        Returns
        -------
        casadi.Function
            Inputs ``sigma`` [m] and ``t`` [s], output ``sigma_dot`` [m/s].
        """
        sigma, t = ca.SX.sym("sigma"), ca.SX.sym("t")
        return ca.Function("span_rate", [sigma, t], [ca.SX(self.span_rate(sigma, t))])

    def mapped(self, name: str, n: int) -> ca.Function:
        """One of ``"geometry"``, ``"speed"``, ``"span_rate"`` evaluated at ``n`` points in one call (cached).

        Parameters
        ----------
        name : {"geometry", "speed", "span_rate"}
            The Function: :attr:`geometry`, :meth:`speed_function` or :meth:`span_rate_function`.
        n : int
            Number of points (columns of each input).

        Returns
        -------
        casadi.Function
            The Function mapped over ``n`` columns (itself when ``n`` is 1).
        """
        key = ("map", name, n)
        if key not in self._cache:
            make = {"geometry": lambda: self.geometry, "speed": self.speed_function,
                    "span_rate": self.span_rate_function}[name]
            fn = make()
            self._cache[key] = fn.map(n) if n > 1 else fn
        return self._cache[key]

    def pointwise(self, name: str) -> PointwiseFunction:
        """One of the Functions of :meth:`mapped` evaluated at any number of points, a block at a time (cached).

        Parameters
        ----------
        name : {"geometry", "speed", "span_rate"}
            The Function (see :meth:`mapped`).

        Returns
        -------
        PointwiseFunction
            Called with arrays of ``n`` columns; returns the outputs at the ``n`` points, as ``mapped(name, n)``.
        """
        key = ("pointwise", name)
        if key not in self._cache:
            self._cache[key] = PointwiseFunction(self.mapped(name, 1))
        return self._cache[key]

    def base_geometry(self) -> PointwiseFunction:
        """``phi`` at ``y^1`` and ``grad phi`` at ``y^2`` of many rows, in one evaluation (the base margin's).

        Returns
        -------
        PointwiseFunction
            Called with ``y^1`` and ``y^2`` (each ``(2, N)``, [m]) and ``t`` (``(N,)``, [s]); returns ``phi(y^1)``
            ``(1, N)`` [m] and ``grad phi(y^2)`` ``(2, N)``: :attr:`geometry`'s outputs, bit for bit.
        """
        if "base geometry" not in self._cache:
            self._cache["base geometry"] = PointwiseFunction(two_point_function(self.geometry, 0, 1))
        return self._cache["base geometry"]

    def buffered(self, name: str, n: int) -> BufferedFunction:
        """:meth:`mapped` called through a reused buffer (cached): the same values, ~5x cheaper a call.

        Parameters
        ----------
        name : {"geometry", "speed", "span_rate"}
            The Function (see :meth:`mapped`).
        n : int
            Number of points (columns of each input).

        Returns
        -------
        BufferedFunction
            Called with numpy arrays of the mapped Function's input shapes; returns its outputs as arrays.
        """
        key = ("buffer", name, n)
        if key not in self._cache:
            self._cache[key] = BufferedFunction(self.mapped(name, n))
        return self._cache[key]
