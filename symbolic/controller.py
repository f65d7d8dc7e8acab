"""The coordinating control law (paper eqs. 12-27): a thin face over the chain, the task and the law builder.

Task outputs are ``e^j = phi(y^j, t)`` (j = 2..m) and ``s^m = psi(y^m, t)``. The law
sets ``u_s = v*(t) - dpsi/dt``, ``u_e^j = -K e^j - dphi/dt`` and solves
``C(q) u = (u_s, u_e)`` with the decoupling matrix of eq. 26, whose rows are ordered
``(s^m, e^2, ..., e^m)`` here. Two forms agree to rounding:

* ``"structured"`` (default): the O(m) recursion (docs/model.md, *The O(m) solve*; :mod:`.recursion`), a
  CasADi ``mapaccum`` over links, which also yields the singularity margins;
* ``"dense"``: the decoupling matrix from AD Jacobians ``C^j = dc^j/dq`` and a dense
  linear solve (the reference, O(m^3); :mod:`.dense`).

Near a singularity (see :mod:`.near_singular`): ``governor=True`` scales ``v*`` by a smooth
factor of the longitudinal margin (output ``v_scale``); ``damping`` solves the damped
least-squares system in a band of small margins. A link pivot that is small while the
decoupling matrix is regular is re-pivoted inside the recursion (:data:`.recursion.REPIVOT`).

The parts: the chain (:mod:`.chain`, behind :class:`.chain_model.ChainModel`), the task outputs
(:mod:`.task`), the law builder (:mod:`.recursion`, :mod:`.dense`, :mod:`.law`) and the numeric
API (:mod:`.numeric`); the C-only variants of the link step belong to ``coordarm.generated``.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import casadi as ca
import numpy as np

from .checks import is_real
from .chain import PlanarChain
from .curves import Curve
from .errors import ConfigError, shown
from .law import law_function
from .law_face import LawFace
from .laws import LAWS, Law
from .numeric import NumericAPI
from .params import as_param
from .outputs import OUTPUTS, RAIL_OUTPUTS, RUN_OUTPUTS, SCALAR_OUTPUTS
from .recursion import StructuredRecursion
from .task import Task, check_user_curve, is_built_in

#: Default zero point of the governor (the simulator's default longitudinal stop threshold).
GOVERNOR_THRESHOLD = 0.15
#: Damping kinds of ``damping = {"kind": ..., "lambda": ..., "band": ...}``.
DAMPING_KINDS = ("dls",)


def check_damping(damping: Any) -> dict | None:
    """``damping`` validated, defaults filled in: None or ``{"kind": "dls", "lambda": > 0, "band": in (0, 1]}``.

    Parameters
    ----------
    damping : dict or None
        ``{"kind": "dls", "lambda": [m/rad], "band": in (0, 1]}``, keys other than ``kind`` optional.

    Returns
    -------
    dict or None
        The damping with its defaults (``lambda`` 0.01, ``band`` 0.1), or None (off).

    Raises
    ------
    ConfigError
        Not a table, an unknown key or kind, or a value out of range (named).
    """
    if damping is None:
        return None
    if not isinstance(damping, dict) or set(damping) - {"kind", "lambda", "band"} or "kind" not in damping:
        raise ConfigError(f"damping: expected a table {{kind = \"dls\", lambda = 0.01, band = 0.1}}, got {damping!r}")
    if damping["kind"] not in DAMPING_KINDS:
        raise ConfigError(f"damping.kind: expected one of {DAMPING_KINDS}, got {damping['kind']!r}")
    out = {"kind": damping["kind"]}
    for key, default, upper in (("lambda", 0.01, math.inf), ("band", 0.1, 1.0)):
        v = damping.get(key, default)
        if not is_real(v) or not math.isfinite(v) or not 0 < v <= upper:
            raise ConfigError(f"damping.{key}: need a finite number in (0, {upper}], got {v!r}")
        out[key] = float(v)
    return out


def check_controller(chain: Any, curve: Any, gain: Any, speed: Any, law: Any, span: Any, governor: Any,
                     governor_threshold: Any, damping: Any) -> dict[str, Any]:
    """The arguments of :class:`CoordinatingController` validated, in its order of checks.

    Parameters
    ----------
    chain : PlanarChain
        The manipulator (anything else is refused).
    curve : Curve
        The goal curve (anything else is refused; a user-defined one is checked orthonormalised).
    gain : float
        Error gain K > 0 [1/s].
    speed : float or callable
        Commanded end-point speed ``v*(t)`` [m/s].
    law : {"structured", "dense"}
        Form of the law.
    span : float or callable or None
        Commanded span ``sigma*(t)`` [m] of a chain on a rail; None: held.
    governor : bool
        Whether the speed governor is on.
    governor_threshold : float
        Longitudinal margin at which the governed speed reaches 0: a finite number, in (0, 1) with the
        governor on (off, it is unused).
    damping : dict or None
        Damped least squares settings (:func:`check_damping`), or None for none.

    Returns
    -------
    dict
        ``gain`` and ``governor_threshold`` as floats, ``damping`` with its defaults (or None),
        ``speed`` and ``span`` as callables of ``t`` (``span`` None when held).

    Raises
    ------
    ConfigError
        A value of the wrong type or out of range, an unknown law, a span without a rail, or a
        user-defined curve whose description is not orthonormalised (each named).
    """
    if not isinstance(chain, PlanarChain):
        raise ConfigError(f"chain: expected a PlanarChain, got {type(chain).__name__}")
    if not isinstance(curve, Curve):
        raise ConfigError(f"curve: expected a Curve (Line, Circle, Arc), got {type(curve).__name__}")
    if not is_real(gain) or not math.isfinite(gain) or gain <= 0:
        raise ConfigError(f"gain: K must be a finite number > 0, got {gain!r}")
    if law not in LAWS:
        raise ConfigError(f"law: expected one of {LAWS}, got {law!r}")
    if not isinstance(governor, bool):
        raise ConfigError(f"governor: expected true or false, got {governor!r}")
    if governor and (not is_real(governor_threshold) or not 0 < governor_threshold < 1):
        raise ConfigError(f"governor_threshold: need a number in (0, 1), got {shown(governor_threshold)}")
    if not is_real(governor_threshold) or not math.isfinite(governor_threshold):    # off: unused, still a number
        raise ConfigError(f"governor_threshold: need a finite number (in (0, 1) with the governor on), "
                          f"got {shown(governor_threshold)}")
    checked = {"gain": float(gain), "governor_threshold": float(governor_threshold),
               "damping": check_damping(damping), "speed": as_param(speed, "speed")}
    if not is_built_in(curve):
        check_user_curve(curve)
    if span is not None and not chain.rail:
        raise ConfigError("span: only a chain on a rail (base = 'rail') has a span output")
    checked["span"] = None if span is None else as_param(span, "span")
    return checked


class CoordinatingController(NumericAPI, LawFace):
    """Coordinating controller of a planar chain along a time-varying curve.

    Parameters
    ----------
    chain : PlanarChain
        The manipulator.
    curve : Curve
        The goal curve ``S(t)``; it must pass within one link length of the base.
    gain : float
        Error gain K > 0 [1/s]: every ``e^j`` decays like ``exp(-K t)``.
    speed : float or callable
        Commanded end-point speed ``v*(t)`` along the curve [m/s].
    law : {"structured", "dense"}
        Form of the inverse control transformation used by :meth:`control`.
    span : float or callable, optional
        Only for a chain on a rail: the commanded span ``sigma*(t)`` [m], tracked by
        ``sigma_dot = sigma*' - K (sigma - sigma*)``. None (default): the span is held,
        ``sigma_dot = 0``.
    governor : bool
        Scale ``v*`` by :func:`~.near_singular.speed_scale` of the longitudinal margin
        (output ``v_scale``; 1 when off). On a rail the commanded span rate ``sigma_dot`` is
        scaled too (it is what stretches the body between base and end point).
    governor_threshold : float
        Longitudinal margin at which the governed speed reaches 0 (dimensionless, in (0, 1);
        used only with the governor).
    damping : dict, optional
        ``{"kind": "dls", "lambda": 0.01, "band": 0.1}``: inside the band of the smallest
        margin solve ``u = M^T (M M^T + lambda_v^2 I)^-1 r`` with the variable damping
        :func:`~.near_singular.damping_factor` [lambda in m/rad]. Default: off.

    Attributes
    ----------
    task : Task
        The task outputs: the curve's geometry Function (``task.geometry``), speed, gain and span.
    recursion : StructuredRecursion
        The O(m) recursion's Functions (link steps, head, tail) for this chain and task.
    outputs, run_outputs : tuple of str
        Names of the law's outputs, and of those kept at every sample of a run.

    Notes
    -----
    On a rail (``chain.rail``) ``q = (d, q_1..q_m)`` and the outputs are ``(s, sigma, e^2..e^m)``:
    the rail rate follows from the span row alone, ``d_dot = (v* - sigma_dot - dpsi/dt(y^1)) /
    (grad psi(y^1) . rail)`` (the rail pivot), then the revolute joints from the usual O(m)
    recursion with ``ydot^1 = d_dot rail``. With the governor, ``v*`` and ``sigma_dot`` are both
    scaled by ``v_scale``; the longitudinal margin does not depend on the rail rate (only on the
    recursion's ``Q`` and ``b``, never on ``P``), so a first pass of the recursion finds it and a
    second one solves with the governed rail rate.
    """

    def __init__(self, chain: PlanarChain, curve: Curve, gain: float, speed: Any,
                 law: str = "structured", span: Any = None, governor: bool = False,
                 governor_threshold: float = GOVERNOR_THRESHOLD, damping: dict | None = None) -> None:
        checked = check_controller(chain, curve, gain, speed, law, span, governor, governor_threshold, damping)
        self.chain, self.curve, self.gain, self.law_form = chain, curve, checked["gain"], law
        self.governor, self.governor_threshold = governor, checked["governor_threshold"]
        self.damping, self.speed, self.span = checked["damping"], checked["speed"], checked["span"]
        #: Names of the outputs of :meth:`law`, in order (the rail adds :data:`RAIL_OUTPUTS`).
        self.outputs = OUTPUTS + (RAIL_OUTPUTS if chain.rail else ())
        #: The outputs kept at every sample of a run (the law's logged ones; the rail's too).
        self.run_outputs = RUN_OUTPUTS + (RAIL_OUTPUTS if chain.rail else ())
        #: The task outputs: curve geometry (``task.geometry``), commanded speed and span.
        self.task = Task(curve, self.speed, self.gain, self.span)
        #: The O(m) recursion's Functions (link steps, head, tail).
        self.recursion = StructuredRecursion(chain, self.task, governor, self.governor_threshold)
        self._cache: dict = {}

    @property
    def B_joints(self) -> np.ndarray:
        """``B`` over all joints: ``diag(1, B)`` on a rail (``qdot_d = u_d``), else ``B``."""
        return self.chain.B_joints

    def speed_function(self) -> ca.Function:
        """``t -> v*(t)``: the commanded speed [m/s] as a CasADi Function.

        Returns
        -------
        casadi.Function
            Input ``t`` [s], output ``v`` [m/s].
        """
        return self.task.speed_function()

    SCALAR_OUTPUTS = SCALAR_OUTPUTS

    def _build_law(self, form: str) -> ca.Function:
        """The law of ``form`` (:func:`.law.law_function`; with ``damping`` the damped least-squares
        solution wherever the smallest margin is inside the band); the dense form takes its margins
        from the structured recursion."""
        return law_function(self.recursion, form, self.damping, self.outputs)

    def _expands(self, form: str) -> bool:
        """Whether :meth:`fast_law` expands the law: the structured form without damping."""
        return form == Law.STRUCTURED and not self.damping

    def _input_matrix(self) -> Callable[[Any], Any]:
        """``u -> qdot``: ``B u`` (``qdot_d = u_d`` on a rail)."""
        bd = self.chain.b_diagonal
        if bd is not None and self.chain.rail:
            bd = np.r_[1.0, bd]                       # qdot_d = u_d on a rail
        return ((lambda u: ca.DM(bd) * u) if bd is not None
                else (lambda u: ca.mtimes(ca.DM(self.B_joints), u)))

    def _decoupling_expr(self, q: ca.SX, t: ca.SX) -> tuple[ca.SX, ca.SX]:
        """The dense decoupling matrix of eq. 26 (:func:`.dense.decoupling_matrix_expr`) and its right-hand side."""
        from .dense import decoupling_matrix_expr          # here: the structured law does not load it

        return decoupling_matrix_expr(self.chain, self.task, q, t)

    def __repr__(self) -> str:
        extra = (", governor=True" if self.governor else "") + (f", damping={self.damping!r}" if self.damping else "")
        return (f"CoordinatingController({self.chain!r}, {type(self.curve).__name__}, "
                f"gain={self.gain}, law={self.law_form!r}{extra})")
