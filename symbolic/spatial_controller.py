"""The coordinating law of a spatial chain (universal joints) along a 3-D curve: a thin face (docs/guide/spatial.md).

Outputs ``s = psi(y^m)``, ``e^j = Phi(y^j)`` (j = 2..m) and the roll ``theta = atan2(n_2 . d_1,
n_1 . d_1)``; law ``s' = v*``, ``e' = -K e``, ``theta' = theta*' - K (theta - theta*)``. Two forms
agree to rounding: ``"structured"`` (the O(m) solve of :mod:`.spatial_recursion`, default) and
``"dense"`` (the AD decoupling matrix of :mod:`.spatial_dense`). The commanded roll ``theta*`` is a
number, a motion (callable of ``t``) or None: held at the roll of the ``start`` configuration at
``t0``, a constant fixed when the controller is built (:attr:`SpatialController.roll_target`).

On a rail (``chain.rail``: ``q = (d, a_1, b_1, ...)``) one more output, the span
``sigma = psi(y^m) - psi(y^1)``, is held (``span=None``) or tracks ``span``; ``u`` then holds the rail
rate ``d_dot`` [m/s] first and the law adds the outputs ``sigma`` and ``rail_margin``.
"""
from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np

from .checks import is_real
from .errors import ConfigError
from .function_buffer import PointwiseFunction
from .law_face import LawFace, condition_numbers
from .laws import LAWS
from .motions import Constant
from .outputs import RAIL_OUTPUTS, SCALAR_OUTPUTS, SPATIAL_OUTPUTS, SPATIAL_RUN_OUTPUTS, SPATIAL_SCALAR_OUTPUTS
from .params import as_param
from .spatial_chain import SpatialChain
from .spatial_dense import spatial_decoupling_expr, spatial_law_function
from .spatial_recursion import SpatialRecursion
from .spatial_task import SpatialTask, roll_expr


def check_spatial_curve(curve: Any) -> None:
    """Check ``curve`` has the 3-D curve interface (``psi``, ``Phi``, ``frame``; see ``curves3d.SpatialCurve``).

    Parameters
    ----------
    curve : object
        The goal curve.

    Raises
    ------
    ConfigError
        A member is missing.
    """
    missing = [name for name in ("psi", "Phi", "frame") if not callable(getattr(curve, name, None))]
    if missing:
        raise ConfigError(f"curve: expected a 3-D curve (SpatialCurve) with psi, Phi and frame; "
                          f"{type(curve).__name__} lacks {', '.join(missing)}")


def start_roll(chain: SpatialChain, curve: Any, q: Any, t: float) -> float:
    """The roll ``atan2(n_2 . d_1, n_1 . d_1)`` of a configuration (frame at the closest point of ``y^1``).

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    curve : SpatialCurve
        The goal curve.
    q : array_like, shape (dof,)
        Joint coordinates [rad] (``d`` [m] first on a rail).
    t : float
        Time [s].

    Returns
    -------
    float
        The roll [rad].
    """
    q = chain.check_q(q, "start")
    y, d, ts = ca.SX.sym("y", 3), ca.SX.sym("d", 3), ca.SX.sym("t")
    f = ca.Function("roll", [y, d, ts], [roll_expr(curve, y, d, ts)])
    return float(f(chain.centres_np(q)[0], chain.directions_np(q)[0], t))


class SpatialController(LawFace):
    """Coordinating controller of a spatial chain along a time-varying 3-D curve.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator (fixed base at the origin, or on a rail).
    curve : SpatialCurve
        The goal curve (``psi``, ``Phi``, ``frame``); it must pass near the base.
    gain : float
        Error gain K > 0 [1/s]: every ``e^j`` and the roll error decay like ``exp(-K t)``.
    speed : float or callable
        Commanded end-point speed ``v*(t)`` along the curve [m/s].
    roll : None, float or callable
        Commanded roll ``theta*(t)`` [rad]. None (default): held at the roll of ``start`` at ``t0``.
    law : {"structured", "dense"}
        Form of the law used by :meth:`control` and :meth:`rk4_step`.
    start : array_like, shape (dof,), optional
        The start configuration; required when ``roll`` is None.
    t0 : float
        Start time [s] (for ``roll=None``).
    span : None, float or callable
        Only on a rail: the commanded span ``sigma*(t)`` [m], tracked by ``sigma' = sigma*' - K (sigma -
        sigma*)``; None (default): held, ``sigma' = 0``.

    Attributes
    ----------
    roll_target : callable
        ``t -> theta*(t)`` [rad] (a :class:`~.motions.Constant` when held).
    task : SpatialTask
        The curve's geometry and the commands.
    recursion : SpatialRecursion
        The O(m) solve's Functions.
    outputs, run_outputs : tuple of str
        :data:`~.outputs.SPATIAL_OUTPUTS` and :data:`~.outputs.SPATIAL_RUN_OUTPUTS` (on a rail plus
        :data:`~.outputs.RAIL_OUTPUTS`: ``sigma``, ``rail_margin``).
    span : callable or None
        The commanded span (None: held).

    Raises
    ------
    ConfigError
        A value of the wrong type or out of range, ``roll=None`` without ``start``, or a span without a rail.
    """

    def __init__(self, chain: SpatialChain, curve: Any, gain: float, speed: Any, roll: Any = None,
                 law: str = "structured", start: Any = None, t0: float = 0.0, span: Any = None) -> None:
        if not isinstance(chain, SpatialChain):
            raise ConfigError(f"chain: expected a SpatialChain, got {type(chain).__name__}")
        check_spatial_curve(curve)
        if not is_real(gain) or not math.isfinite(gain) or gain <= 0:
            raise ConfigError(f"gain: K must be a finite number > 0, got {gain!r}")
        if law not in LAWS:
            raise ConfigError(f"law: expected one of {LAWS}, got {law!r}")
        if roll is None and start is None:
            raise ConfigError("roll: None holds the start's roll; give the start configuration (start=q0)")
        self.chain, self.curve, self.gain, self.law_form = chain, curve, float(gain), law
        self.speed = as_param(speed, "speed")
        self.roll_target = (Constant(start_roll(chain, curve, start, t0)) if roll is None
                            else as_param(roll, "roll"))
        if span is not None and not chain.rail:
            raise ConfigError("span: only a chain on a rail (base = 'rail') has a span output")
        self.span = None if span is None else as_param(span, "span")
        rail = RAIL_OUTPUTS if chain.rail else ()
        self.outputs, self.run_outputs = SPATIAL_OUTPUTS + rail, SPATIAL_RUN_OUTPUTS + rail
        self.task = SpatialTask(curve, self.speed, self.gain, self.roll_target, self.span)
        self.recursion = SpatialRecursion(chain, self.task)
        self._cache: dict = {}

    SCALAR_OUTPUTS = SPATIAL_SCALAR_OUTPUTS + tuple(n for n in RAIL_OUTPUTS if n in SCALAR_OUTPUTS)
    RK4_NAME, DECOUPLING_NAME = "spatial_rk4_step", "spatial_decoupling"

    def _build_law(self, form: str) -> ca.Function:
        """The law of ``form`` (:func:`.spatial_dense.spatial_law_function`)."""
        return spatial_law_function(self.recursion, form, self.outputs)

    def _decoupling_expr(self, q: ca.SX, t: ca.SX) -> tuple[ca.SX, ca.SX]:
        """The dense decoupling matrix (rows ``s, roll, e^2_1, e^2_2, ...``) and right-hand side."""
        return spatial_decoupling_expr(self.chain, self.task, q, t)

    def _check_time(self, t: Any) -> None:
        """Raise :class:`ConfigError` unless ``t`` is a finite real number (``int`` or ``float``)."""
        if not is_real(t) or not math.isfinite(t):
            raise ConfigError(f"t: must be finite, got {t!r}")

    def _command_function(self, name: str) -> ca.Function:
        """``t -> command(t)`` as a CasADi Function (``"speed"`` or ``"roll"``), cached."""
        key = ("command", name)
        if key not in self._cache:
            t = ca.SX.sym("t")
            param = self.speed if name == "speed" else self.roll_target
            self._cache[key] = ca.Function(name, [t], [ca.SX(param(t)) + 0 * t])
        return self._cache[key]

    def _commands(self, name: str, T: Any) -> np.ndarray:
        """The command ``name`` (``"speed"`` or ``"roll"``) at each of the times ``T`` (a :class:`PointwiseFunction`)."""
        key = ("pointwise", name)
        if key not in self._cache:
            self._cache[key] = PointwiseFunction(self._command_function(name))
        return self._cache[key](np.atleast_1d(np.asarray(T, float)))[0].ravel()

    def speeds(self, T: Any) -> np.ndarray:
        """``v*(t)`` at each of the times ``T``, in one call.

        Parameters
        ----------
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            Commanded speeds [m/s].
        """
        return self._commands("speed", T)

    def speed_at(self, t: float) -> float:
        """The commanded speed at one time.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        float
            ``v*(t)`` [m/s].
        """
        return float(self.speeds([t])[0])

    def roll_targets(self, T: Any) -> np.ndarray:
        """The commanded roll ``theta*(t)`` at each of the times ``T``.

        Parameters
        ----------
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            ``theta*`` [rad].
        """
        return self._commands("roll", T)

    def roll_at(self, t: float) -> float:
        """The commanded roll at one time.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        float
            ``theta*(t)`` [rad].
        """
        return float(self.roll_targets([t])[0])

    def base_offset(self, t: float = 0.0) -> float:
        """``|Phi(0, t)|``: how far the curve passes from the fixed base (the origin).

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        float
            Distance [m].
        """
        return float(self._base_function()(t))

    def base_offsets(self, T: Any) -> np.ndarray:
        """:meth:`base_offset` at each of the times ``T``, in one call (the same values).

        Parameters
        ----------
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            Distances [m].
        """
        T = np.atleast_1d(np.asarray(T, float))
        key = ("base map", len(T))
        if key not in self._cache:
            self._cache[key] = self._base_function().map(len(T))
        return np.asarray(self._cache[key](T[None]), dtype=float).ravel()

    def _base_function(self) -> ca.Function:
        """``t -> |Phi(0, t)|`` (built once)."""
        if "base" not in self._cache:
            ts = ca.SX.sym("t")
            self._cache["base"] = ca.Function("base_offset", [ts], [ca.norm_2(self.curve.Phi(ca.SX.zeros(3), ts))])
        return self._cache["base"]

    def conds(self, Q: Any, T: Any) -> np.ndarray:
        """2-norm condition numbers of the dense decoupling matrices at N states (an SVD each, O(m^3)).

        Parameters
        ----------
        Q : array_like, shape (N, 2 m)
            Joint coordinates [rad].
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            ``sigma_max / sigma_min`` of each (inf when singular).
        """
        f = self.decoupling_function()
        M = np.array([np.asarray(f(q, t)[0]) for q, t in zip(np.atleast_2d(Q), np.atleast_1d(T))])
        return condition_numbers(M)

    def __repr__(self) -> str:
        return f"SpatialController({self.chain!r}, {type(self.curve).__name__}, gain={self.gain}, law={self.law_form!r})"
