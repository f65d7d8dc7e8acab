"""The coordinating control law (paper eqs. 12-27) as CasADi Functions.

Task outputs are ``e^j = phi(y^j, t)`` (j = 2..m) and ``s^m = psi(y^m, t)``. The law
sets ``u_s = v*(t) - dpsi/dt``, ``u_e^j = -K e^j - dphi/dt`` and solves
``C(q) u = (u_s, u_e)`` with the decoupling matrix of eq. 26, whose rows are ordered
``(s^m, e^2, ..., e^m)`` here. Two forms agree to rounding:

* ``"structured"`` (default): the O(m) recursion of DESIGN.md section 3, a CasADi
  ``mapaccum`` over links, which also yields the singularity margins;
* ``"dense"``: the decoupling matrix from AD Jacobians ``C^j = dc^j/dq`` and a dense
  linear solve (the reference, O(m^3)).

Near a singularity (see :mod:`.near_singular`): ``governor=True`` scales ``v*`` by a smooth
factor of the longitudinal margin (output ``v_scale``); ``damping`` solves the damped
least-squares system in a band of small margins. A link pivot that is small while the
decoupling matrix is regular is re-pivoted inside the recursion (:data:`REPIVOT`).
"""
from __future__ import annotations

import math
from typing import Any, Callable, Hashable

import casadi as ca
import numpy as np

from .chain import PlanarChain, direction, normal
from .curves import Arc, Circle, Curve, Line, _param, evaluate
from .errors import ConfigError
from .laws import LAWS
from .outputs import OUTPUTS, RAIL_OUTPUTS, RUN_OUTPUTS, SCALAR_OUTPUTS
from .paths import PIECE_CONSTANTS, Path
from .near_singular import damping_factor, speed_scale

#: Below this ``|cos|`` between a link's normal and the curve normal the recursion re-pivots that
#: link: it solves the link's ``e`` row for the free rate instead (when that is better conditioned).
REPIVOT = 0.05
#: Default zero point of the governor (the simulator's default longitudinal stop threshold).
GOVERNOR_THRESHOLD = 0.15
#: Damping kinds of ``damping = {"kind": ..., "lambda": ..., "band": ...}``.
DAMPING_KINDS = ("dls",)


#: The curve classes of coordarm; any other Curve (a subclass too) is user-defined.
BUILT_IN_CURVES = (Line, Circle, Arc, Path)


def check_user_curve(curve: Curve, times=(0.0, 1.0)) -> None:
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


def check_damping(damping: Any) -> dict | None:
    """``damping`` validated, defaults filled in: None or ``{"kind": "dls", "lambda": > 0, "band": in (0, 1]}``.

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
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 < v <= upper:
            raise ConfigError(f"damping.{key}: need a finite number in (0, {upper}], got {v!r}")
        out[key] = float(v)
    return out


class CoordinatingController:
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
        if not isinstance(chain, PlanarChain):
            raise ConfigError(f"chain: expected a PlanarChain, got {type(chain).__name__}")
        if not isinstance(curve, Curve):
            raise ConfigError(f"curve: expected a Curve (Line, Circle, Arc), got {type(curve).__name__}")
        if (isinstance(gain, bool) or not isinstance(gain, (int, float))
                or not math.isfinite(gain) or gain <= 0):
            raise ConfigError(f"gain: K must be a finite number > 0, got {gain!r}")
        if law not in LAWS:
            raise ConfigError(f"law: expected one of {LAWS}, got {law!r}")
        if not isinstance(governor, bool):
            raise ConfigError(f"governor: expected true or false, got {governor!r}")
        if governor and (isinstance(governor_threshold, bool) or not isinstance(governor_threshold, (int, float))
                         or not 0 < governor_threshold < 1):
            raise ConfigError(f"governor_threshold: need a number in (0, 1), got {governor_threshold!r}")
        self.chain, self.curve, self.gain, self.law_form = chain, curve, float(gain), law
        self.governor, self.governor_threshold = governor, float(governor_threshold)
        self.damping = check_damping(damping)
        self.speed = _param(speed, "speed")
        if type(curve) not in BUILT_IN_CURVES:
            check_user_curve(curve)
        if span is not None and not chain.rail:
            raise ConfigError("span: only a chain on a rail (base = 'rail') has a span output")
        self.span = None if span is None else _param(span, "span")
        #: Names of the outputs of :meth:`law`, in order (the rail adds :data:`RAIL_OUTPUTS`).
        self.outputs = OUTPUTS + (RAIL_OUTPUTS if chain.rail else ())
        #: The outputs kept at every sample of a run (the law's logged ones; the rail's too).
        self.run_outputs = RUN_OUTPUTS + (RAIL_OUTPUTS if chain.rail else ())
        self._geometry = self._geometry_function()
        self._cache: dict = {}

    # ------------------------------------------------------------ building blocks
    def _geometry_function(self) -> ca.Function:
        """``(y, t) -> (phi, grad phi, dphi/dt, psi, grad psi, dpsi/dt)`` by AD."""
        y, t = ca.SX.sym("y", 2), ca.SX.sym("t")
        try:
            phi, psi = self.curve.phi(y, t), self.curve.psi(y, t)
            phi, psi = ca.SX(phi), ca.SX(psi)
        except Exception as exc:  # a user callable returned something unusable
            raise ConfigError(f"curve: its parameters must be numbers or callables of t "
                              f"returning CasADi scalars ({exc})") from None
        if phi.numel() != 1 or psi.numel() != 1:
            raise ConfigError("curve: phi and psi must be scalars")
        return ca.Function("geometry", [y, t],
                           [phi, ca.gradient(phi, y), ca.jacobian(phi, t),
                            psi, ca.gradient(psi, y), ca.jacobian(psi, t)],
                           ["y", "t"], ["phi", "gphi", "phit", "psi", "gpsi", "psit"])

    def speed_function(self) -> ca.Function:
        """``t -> v*(t)``: the commanded speed [m/s] as a CasADi Function.

        Returns
        -------
        casadi.Function
            Input ``t`` [s], output ``v`` [m/s].
        """
        t = ca.SX.sym("t")
        return ca.Function("speed", [t], [ca.SX(self.speed(t))], ["t"], ["v"])

    #: Layout of the carry of the link recursion (see :meth:`link_step`).
    CARRY = ("y1", "y2", "alpha", "cos_alpha", "sin_alpha", "P1", "P2", "Q1", "Q2", "a", "b", "sum_abs_b")

    def _piece_geometry(self, kind: str) -> ca.Function:
        """``(y, t, piece) -> (phi, grad phi, dphi/dt, psi, grad psi, dpsi/dt)`` of a path by the
        formulas of one piece of ``kind`` (``"line"`` or ``"arc"``), by AD."""
        key = ("piece_geometry", kind)
        if key not in self._cache:
            y, t, sel = ca.SX.sym("y", 2), ca.SX.sym("t"), ca.SX.sym("piece", PIECE_CONSTANTS)
            phi, psi = self.curve.phi_psi_piece(y, t, sel, kind)
            self._cache[key] = ca.Function(
                "piece_geometry", [y, t, sel], [phi, ca.gradient(phi, y), ca.jacobian(phi, t),
                                                psi, ca.gradient(psi, y), ca.jacobian(psi, t)],
                ["y", "t", "piece"], ["phi", "gphi", "phit", "psi", "gpsi", "psit"])
        return self._cache[key]

    def _link_expressions(self, trig_inputs: bool = False):
        """Symbolic carry, ``q_j``, ``t`` and the link step's outputs in terms of them (CSE'd).

        The carried ``P + Q p = ydot^{j-1} + xi/2 n(alpha_{j-1}) w_{j-1}`` is the part of
        ``ydot^j`` known before ``w_j``; the only division (by the link pivot) is turned into
        a reciprocal off the loop-carried dependency chain, which sets the speed of the
        compiled loop (see benchmarks/RESULTS.md). With ``trig_inputs`` the cosine and sine
        of ``alpha_j`` are two more inputs (computed beforehand for all links at once) and
        the step has no trigonometry of its own.
        """
        xi, K = self.chain.xi, self.gain
        carry, qj, t = ca.SX.sym("carry", len(self.CARRY)), ca.SX.sym("q_j"), ca.SX.sym("t")
        y, alpha_prev, d_prev, P, Q = carry[0:2], carry[2], carry[3:5], carry[5:7], carry[7:9]
        nb = carry[11]
        alpha = alpha_prev + qj
        trig = ca.SX.sym("cos_sin_alpha_j", 2) if trig_inputs else None
        d_j = trig if trig_inputs else direction(alpha)   # the only sine/cosine pair of the link
        n_j = ca.vertcat(-d_j[1], d_j[0])
        y_j = y + 0.5 * xi * (d_prev + d_j)
        phi, g, phit, *_ = self._geometry(y_j, t)
        pivot = ca.dot(g, n_j)                       # the link pivot (eq. 26 row, divided out)
        inv_expr = 1 / (0.5 * xi * pivot)
        # with trig inputs the reciprocal is an input too (computed by link_pivot): CasADi would
        # fold ``x * (1/y)`` back into a division on the loop-carried chain of P and Q
        inv = ca.SX.sym("inv_pivot") if trig_inputs else inv_expr
        r, gP, gQ = -K * phi - phit, ca.dot(g, P), ca.dot(g, Q)
        a_j = (r - gP) * inv
        b_j = -gQ * inv
        step = xi * n_j                              # ydot^j = P + xi/2 n_j w_j; next P adds it again
        if trig_inputs:
            # the same P + step a_j, Q + step b_j, regrouped so that the loop-carried chain
            # P -> P' is g.P, one product and one difference (12 instead of 18 cycles of latency)
            u = (xi * inv) * n_j
            P_next, Q_next = (P + u * r) - u * gP, Q - u * gQ
        else:
            P_next, Q_next = P + step * a_j, Q + step * b_j
        new = ca.vertcat(y_j, alpha, d_j, P_next, Q_next, a_j, b_j, nb + ca.fabs(b_j))
        out = ca.vertcat(phi, ca.fabs(pivot) / ca.norm_2(g), a_j, b_j)
        if trig_inputs:
            out = ca.vertcat(out, inv_expr)
            trig = (trig[0], trig[1], inv)
        both = ca.cse(ca.vertcat(new, out))          # one CSE over both, so a_j, b_j are shared
        return carry, qj, trig, t, both[:new.numel()], both[new.numel():]

    def _hoisted_pieces(self):
        """``(time_features, {kind: link_geometry_kind}, link_step_piece)`` of a path (cached).

        The link's geometry by the formulas of one kind of piece (``"line"``, ``"arc"``; no
        selection): ``(carry, q_j, cos_alpha_j, sin_alpha_j, w, piece) -> geometry``, ``geometry =
        (1 / (xi/2 pivot_j), phi, link margin, grad phi, -K phi - dphi/dt)``, with one vector
        ``w(t)`` of time-only terms for both kinds; then the step, the same for both kinds:
        ``(carry, q_j, cos_alpha_j, sin_alpha_j, geometry) -> (carry_next, out_j)``, the
        operations of :meth:`link_step_trig` after its geometry.
        """
        key = ("hoisted", True, "pieces")
        if key not in self._cache:
            xi, K = self.chain.xi, self.gain
            carry, qj, t = ca.SX.sym("carry", len(self.CARRY)), ca.SX.sym("q_j"), ca.SX.sym("t")
            cs, sel = ca.SX.sym("cos_sin_alpha_j", 2), ca.SX.sym("piece", PIECE_CONSTANTS)
            y, d_prev, P, Q, nb = carry[0:2], carry[3:5], carry[5:7], carry[7:9], carry[11]
            n_j = ca.vertcat(-cs[1], cs[0])
            y_j = y + 0.5 * xi * (d_prev + cs)
            geos = []
            for kind in ("line", "arc"):
                phi, g, phit = self._piece_geometry(kind)(y_j, t, sel)[:3]
                pivot = ca.dot(g, n_j)
                # |grad phi| = 1 for a distance to a line or a circle: the margin is |pivot| (the
                # full form's |pivot| / |grad phi| differs by the rounding of a unit norm, 1e-16)
                geos.append(ca.vertcat(1 / (0.5 * xi * pivot), phi, ca.fabs(pivot), g, -K * phi - phit))
            expr, wsym, wexpr = ca.extract_parametric(ca.vertcat(*geos), t)
            wsym = ca.vertcat(*wsym) if len(wsym) else ca.SX.sym("w", 1)
            wexpr = ca.vertcat(*wexpr) if len(wexpr) else ca.SX.zeros(1, 1)
            tf = ca.Function("time_features", [t], [ca.cse(wexpr)], ["t"], ["w"])
            names = ["carry", "q_j", "cos_alpha_j", "sin_alpha_j"]
            geometry = {kind: ca.Function(f"link_geometry_{kind}", [carry, qj, cs[0], cs[1], wsym, sel],
                                          [ca.cse(expr[6 * i:6 * i + 6])], names + ["w", "piece"], ["geometry"])
                        for i, kind in enumerate(("line", "arc"))}
            geo = ca.SX.sym("geometry", 6)
            inv, phi, margin, g, r = geo[0], geo[1], geo[2], geo[3:5], geo[5]
            gP, gQ = ca.dot(g, P), ca.dot(g, Q)
            a_j, b_j = (r - gP) * inv, -gQ * inv
            u = (xi * inv) * n_j                     # regrouped as in link_step_trig
            new = ca.vertcat(y_j, carry[2] + qj, cs, (P + u * r) - u * gP, Q - u * gQ, a_j, b_j, nb + ca.fabs(b_j))
            both = ca.cse(ca.vertcat(new, phi, margin, a_j, b_j))
            step = ca.Function("link_step_piece", [carry, qj, cs[0], cs[1], geo], [both[:new.numel()], both[new.numel():]],
                               names + ["geometry"], ["carry_next", "out"])
            self._cache[key] = (tf, geometry, step)
        return self._cache[key]

    def piece_steps(self) -> tuple[ca.Function, dict, ca.Function]:
        """The path's per-piece link step for the generated C (a :class:`~coordarm.symbolic.paths.Path` only).

        Returns
        -------
        time_features : casadi.Function
            ``t -> w``, the time-only terms of both kinds.
        geometry : dict
            ``{"line": link_geometry_line, "arc": link_geometry_arc}``: ``(carry, q_j, cos_alpha_j,
            sin_alpha_j, w, piece) -> geometry``, ``piece`` the ten constants
            (:func:`~coordarm.symbolic.paths.piece_parameters` with ``derived=True``) of the closest
            piece, which is of that kind; ``geometry = (1 / (xi/2 pivot_j) [1/m], phi [m], link
            margin, grad phi, -K phi - dphi/dt [m/s])``.
        step : casadi.Function
            ``(carry, q_j, cos_alpha_j, sin_alpha_j, geometry) -> (carry_next, out_j)``, as
            :meth:`link_step_trig`'s outputs.
        """
        return self._hoisted_pieces()

    def _hoisted_link(self, trig_inputs: bool = False):
        """The link step split into time-only terms ``w(t)`` and the per-link rest (cached)."""
        key = ("hoisted", trig_inputs)
        if key not in self._cache:
            carry, qj, trig, t, new, out = self._link_expressions(trig_inputs)
            expr, wsym, wexpr = ca.extract_parametric(ca.vertcat(new, out), t)
            # A static curve has no time-only terms: w is then one unused 0 rather than empty
            # (an empty input makes CasADi emit a copy to a null pointer in mapped code).
            wsym = ca.vertcat(*wsym) if len(wsym) else ca.SX.sym("w", 1)
            wexpr = ca.vertcat(*wexpr) if len(wexpr) else ca.SX.zeros(1, 1)
            n_new = new.numel()
            tf = ca.Function("time_features", [t], [ca.cse(wexpr)], ["t"], ["w"])
            if trig_inputs:
                c, s, inv = trig
                n_out = expr.numel() - 1
                pivot = ca.Function("link_pivot", [carry, qj, c, s, wsym], [expr[n_out]],
                                    ["carry", "q_j", "cos_alpha_j", "sin_alpha_j", "w"], ["inv_pivot"])
                step = ca.Function("link_step_trig", [carry, qj, c, s, wsym, inv],
                                   [expr[:n_new], expr[n_new:n_out]],
                                   ["carry", "q_j", "cos_alpha_j", "sin_alpha_j", "w", "inv_pivot"],
                                   ["carry_next", "out"])
                self._cache[key] = (tf, step, pivot)
                return self._cache[key]
            else:
                step = ca.Function("link_step", [carry, qj, wsym], [expr[:n_new], expr[n_new:]],
                                   ["carry", "q_j", "w"], ["carry_next", "out"])
            self._cache[key] = (tf, step)
        return self._cache[key]

    def _repivot_step(self):
        """The re-pivoting link step (no trig inputs): carry, ``q_j``, ``t``, ``(carry_next, out)``.

        Where the link pivot is small (``|cos| < REPIVOT``) and solving the link's ``e`` row
        ``g.(P + Q p) + xi/2 (g.n_j) w_j = r`` for the free rate is better conditioned, it does
        that: the old free rate becomes ``c + d w_j`` and ``w_j`` the new one, so a link standing
        across the curve is no singularity unless the decoupling matrix itself is singular.
        """
        xi, K = self.chain.xi, self.gain
        carry, qj, t = ca.SX.sym("carry", len(self.CARRY)), ca.SX.sym("q_j"), ca.SX.sym("t")
        y, alpha_prev, d_prev, P, Q = carry[0:2], carry[2], carry[3:5], carry[5:7], carry[7:9]
        nb = carry[11]
        alpha = alpha_prev + qj
        d_j = direction(alpha)
        n_j = ca.vertcat(-d_j[1], d_j[0])
        y_j = y + 0.5 * xi * (d_prev + d_j)
        phi, g, phit, *_ = self._geometry(y_j, t)
        pivot = ca.dot(g, n_j)
        gq = ca.dot(g, Q)
        r = -K * phi - phit - ca.dot(g, P)
        cos_n = ca.fabs(pivot) / ca.norm_2(g)
        step = xi * n_j
        inv = 1 / (0.5 * xi * pivot)
        a_j, b_j = r * inv, -gq * inv
        cos_q = ca.fabs(gq) / (ca.norm_2(g) * ca.norm_2(Q))
        swap = ca.logic_and(cos_n < REPIVOT, cos_q > cos_n)
        a_s, b_s = ca.if_else(swap, 0, a_j), ca.if_else(swap, 1, b_j)
        c_s, d_s = ca.if_else(swap, r / gq, 0), ca.if_else(swap, -0.5 * xi * pivot / gq, 1)
        P0, Q0 = P + Q * c_s, Q * d_s                # P + Q p in terms of the new free rate
        new = ca.vertcat(y_j, alpha, d_j, P0 + step * a_s, Q0 + step * b_s, a_s, b_s,
                         ca.fabs(d_s) * nb + ca.fabs(b_s))
        out = ca.vertcat(phi, ca.if_else(swap, cos_q, cos_n), a_s, b_s, c_s, d_s)
        both = ca.cse(ca.vertcat(new, out))
        return carry, qj, t, both[:new.numel()], both[new.numel():]

    def _hoisted_repivot(self):
        """``(time_features_repivot, link_step_repivot)``: the re-pivoting step and its time terms (cached)."""
        if "hoisted_repivot" not in self._cache:
            carry, qj, t, new, out = self._repivot_step()
            expr, wsym, wexpr = ca.extract_parametric(ca.vertcat(new, out), t)
            wsym = ca.vertcat(*wsym) if len(wsym) else ca.SX.sym("w", 1)
            wexpr = ca.vertcat(*wexpr) if len(wexpr) else ca.SX.zeros(1, 1)
            n_new = new.numel()
            tf = ca.Function("time_features_repivot", [t], [ca.cse(wexpr)], ["t"], ["w"])
            step = ca.Function("link_step_repivot", [carry, qj, wsym], [expr[:n_new], expr[n_new:]],
                               ["carry", "q_j", "w"], ["carry_next", "out"])
            self._cache["hoisted_repivot"] = (tf, step)
        return self._cache["hoisted_repivot"]

    def time_features_repivot(self) -> ca.Function:
        """``t -> w``: the time-only terms of :meth:`link_step_repivot`.

        Returns
        -------
        casadi.Function
            ``t -> w``.
        """
        return self._hoisted_repivot()[0]

    def time_features(self, trig_inputs: bool = False) -> ca.Function:
        """``t -> w``: the terms of :meth:`link_step` (:meth:`link_step_trig` if ``trig_inputs``)
        that depend on time only, computed once per ``t``.

        Parameters
        ----------
        trig_inputs : bool
            The terms of :meth:`link_step_trig` (the generated C's step) instead.

        Returns
        -------
        casadi.Function
            Input ``t`` [s], output ``w`` (one 0 for a static curve).
        """
        return self._hoisted_link(trig_inputs)[0]

    def link_step(self) -> ca.Function:
        """One link of the O(m) recursion: ``(carry, q_j, w) -> (carry_next, out_j)``.

        ``carry`` (layout :attr:`CARRY`) holds ``y^{j-1}``, ``alpha_{j-1}`` with its cosine
        and sine (so each link evaluates one sine/cosine pair), ``w_{j-1} = a + b p`` and
        ``P + Q p = ydot^{j-1} + xi/2 n(alpha_{j-1}) w_{j-1}``, affine in the free rate
        ``p``, and the running ``sum |b|``; ``w`` is :meth:`time_features` at the current time;
        ``out_j = (e^j, link margin, a_j, b_j)`` with ``w_j = a_j + b_j p``. It divides by the
        link pivot: see :meth:`link_step_repivot` for links across the curve.

        Returns
        -------
        casadi.Function
            ``(carry, q_j, w) -> (carry_next, out)``.
        """
        return self._hoisted_link()[1]

    def link_step_repivot(self) -> ca.Function:
        """:meth:`link_step` with re-pivoting: ``out_j = (e^j, link margin, a_j, b_j, c_j, d_j)``.

        Where the link pivot is small (``|cos| < REPIVOT``) and ``g.Q`` is better conditioned
        it solves the link's row for the free rate: then ``p_{j-1} = c_j + d_j p_j`` with
        ``p_j = w_j`` the new free rate (``a_j = 0, b_j = 1``); elsewhere it equals
        :meth:`link_step` with ``c_j = 0, d_j = 1``. The compiled loop calls it only for links
        whose plain margin is below ``REPIVOT``; the interpreted law uses it for every link.

        Returns
        -------
        casadi.Function
            ``(carry, q_j, w) -> (carry_next, out)``.
        """
        return self._hoisted_repivot()[1]

    def link_step_trig(self) -> ca.Function:
        """:meth:`link_step` with ``cos(alpha_j)``, ``sin(alpha_j)`` and the reciprocal of the
        scaled link pivot as inputs:
        ``(carry, q_j, cos_alpha_j, sin_alpha_j, w, inv_pivot) -> (carry_next, out_j)``.

        The generated C computes every link's cosine and sine in one loop the compiler
        vectorises, then runs this step over the links (no trigonometry inside the recursion);
        ``inv_pivot`` comes from :meth:`link_pivot`, so no division sits on the carried chain.

        Returns
        -------
        casadi.Function
            Inputs ``carry`` (layout :attr:`CARRY`), ``q_j`` [rad], ``cos_alpha_j``, ``sin_alpha_j``,
            ``w`` (:meth:`time_features` with ``trig_inputs=True``), ``inv_pivot`` [1/m]; outputs
            ``carry_next`` and ``out`` as :meth:`link_step`'s.
        """
        return self._hoisted_link(True)[1]

    def link_pivot(self) -> ca.Function:
        """``(carry, q_j, cos_alpha_j, sin_alpha_j, w) -> 1 / (xi/2 pivot_j)`` for :meth:`link_step_trig`.

        Returns
        -------
        casadi.Function
            Output ``inv_pivot`` [1/m], the reciprocal of half a link length times the link pivot.
        """
        return self._hoisted_link(True)[2]

    def first_carry(self) -> ca.Function:
        """``q_1 -> carry`` of link 1 (centre at the base, ``w_1 = p``).

        Returns
        -------
        casadi.Function
            Input ``q_1`` [rad], output ``carry`` (layout :attr:`CARRY`).
        """
        q1 = ca.SX.sym("q_1")
        c, s = ca.cos(q1), ca.sin(q1)
        h = 0.5 * self.chain.xi
        return ca.Function("first_carry", [q1], [ca.vertcat(0, 0, q1, c, s, 0, 0, -h * s, h * c, 0, 1, 1)],
                           ["q_1"], ["carry"])

    def span_rate(self, sigma, t):
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

    def rail_head(self, governed: bool = False) -> ca.Function:
        """``(d, q_1, t, sigma) -> (carry, d_dot, rail_margin, psi_1)`` of a chain on a rail.

        The span row minus the ``s`` row leaves ``grad psi(y^1) . rail d_dot = v* - sigma_dot -
        dpsi/dt(y^1)``: the rail rate, dividing by the rail pivot ``grad psi(y^1) . rail``; the carry
        is :meth:`first_carry`'s with ``y^1 = d rail`` and ``ydot^1 = d_dot rail``.

        Parameters
        ----------
        governed : bool
            A fifth input ``v_scale`` scales the commands: ``v_scale (v* - sigma_dot) - dpsi/dt(y^1)``.

        Returns
        -------
        casadi.Function
        """
        d, q1, t, sigma = ca.SX.sym("d"), ca.SX.sym("q_1"), ca.SX.sym("t"), ca.SX.sym("sigma")
        scale = ca.SX.sym("v_scale") if governed else None
        rail = ca.DM(self.chain.rail_direction)
        y1 = d * rail
        _, _, _, psi1, h1, psit1 = self._geometry(y1, t)
        pivot = ca.dot(h1, rail)
        command = ca.SX(self.speed(t)) - self.span_rate(sigma, t)
        rate = ((scale * command if governed else command) - psit1) / pivot
        carry = self.first_carry()(q1)
        carry = ca.vertcat(y1, carry[2:5], rate * rail, carry[7:])
        inputs = [d, q1, t, sigma] + ([scale] if governed else [])
        return ca.Function("rail_head", inputs, [carry, rate, ca.fabs(pivot) / ca.norm_2(h1), psi1],
                           ["d", "q_1", "t", "sigma"] + (["v_scale"] if governed else []),
                           ["carry", "d_dot", "rail_margin", "psi_1"])

    def rail_head_from_end(self, governed: bool = False) -> ca.Function:
        """:meth:`rail_head` with the span computed inside: ``(d, q_1, t, y_m) -> (carry, d_dot,
        rail_margin, psi_1)``, ``sigma = psi(y_m) - psi(y^1)`` (for the generated C of a commanded span,
        whose loop knows the end's centre ``y_m`` [m] from its cosines and sines).

        Parameters
        ----------
        governed : bool
            A fifth input ``v_scale`` scales the commands (see :meth:`rail_head`).

        Returns
        -------
        casadi.Function
        """
        d, q1, t, y_m = ca.SX.sym("d"), ca.SX.sym("q_1"), ca.SX.sym("t"), ca.SX.sym("y_m", 2)
        scale = [ca.SX.sym("v_scale")] if governed else []
        psi_1 = self._geometry(d * ca.DM(self.chain.rail_direction), t)[3]
        outs = self.rail_head(governed)(d, q1, t, self._geometry(y_m, t)[3] - psi_1, *scale)
        both = ca.cse(ca.vertcat(*outs))
        sizes = np.cumsum([0] + [o.numel() for o in outs])
        return ca.Function("rail_head_from_end", [d, q1, t, y_m] + scale,
                           [both[a:b] for a, b in zip(sizes[:-1], sizes[1:])],
                           ["d", "q_1", "t", "y_m"] + (["v_scale"] if governed else []),
                           ["carry", "d_dot", "rail_margin", "psi_1"])

    def _span_now(self, q, t):
        """``sigma = psi(y^m) - psi(y^1)`` from the forward kinematics (needed only for a commanded span)."""
        if self.span is None:
            return 0
        y = self.chain.centres(q)
        return self._geometry(y[:, self.chain.m - 1], t)[3] - self._geometry(y[:, 0], t)[3]

    def tail(self) -> ca.Function:
        """``(carry_m, t) -> (s, p, longitudinal, longitudinal_pivot, v_scale)`` after the last link.

        The ``s`` equation fixes the free rate ``p`` by dividing by the longitudinal
        pivot ``grad(psi)(y^m) . d ydot^m / dp`` [m/rad]; the longitudinal margin
        ``|pivot| / (xi sum |b|)`` is dimensionless (``(m-1)/m sin(beta)`` on a zig-zag of m links).
        With the governor the commanded speed is ``v_scale v*`` (``v_scale`` = 1 without).

        Returns
        -------
        casadi.Function
            ``(carry, t) -> (s, p, longitudinal, longitudinal_pivot, v_scale)``.
        """
        return self._tail()

    def tail_piece(self, kind: str) -> ca.Function:
        """:meth:`tail` by the formulas of one piece of a path, ``kind`` ``"line"`` or ``"arc"``:
        ``(carry_m, t, piece) -> (s, p, longitudinal, longitudinal_pivot, v_scale)``, ``piece`` the
        ten constants (:func:`~coordarm.symbolic.paths.piece_parameters`, ``derived=True``) of the
        closest piece to ``y^m``, which the generated C searches (a :class:`~coordarm.symbolic.paths.Path` only).

        Parameters
        ----------
        kind : {"line", "arc"}
            The kind of the piece.

        Returns
        -------
        casadi.Function
        """
        return self.memo(("tail", kind), lambda: self._tail(kind))

    def _tail(self, kind: str | None = None) -> ca.Function:
        """:meth:`tail` (``kind`` None) or :meth:`tail_piece`."""
        carry, t = ca.SX.sym("carry", len(self.CARRY)), ca.SX.sym("t")
        sel = ca.SX.sym("piece", PIECE_CONSTANTS)
        y_m, n_m, nb = carry[0:2], ca.vertcat(-carry[4], carry[3]), carry[11]
        half = 0.5 * self.chain.xi * n_m
        A_m, B_m = carry[5:7] - half * carry[9], carry[7:9] - half * carry[10]   # ydot^m = A_m + B_m p
        _, _, _, psi, h, psit = self._piece_geometry(kind)(y_m, t, sel) if kind else self._geometry(y_m, t)
        pivot = ca.dot(h, B_m)
        margin = ca.fabs(pivot) / (self.chain.xi * nb)
        scale = speed_scale(margin, self.governor_threshold) if self.governor else ca.SX(1)
        p = (scale * self.speed(t) - psit - ca.dot(h, A_m)) / pivot
        if kind:
            return ca.Function(f"tail_{kind}", [carry, t, sel], [psi, p, margin, pivot, scale], ["carry", "t", "piece"],
                               ["s", "p", "longitudinal", "longitudinal_pivot", "v_scale"])
        return ca.Function("tail", [carry, t], [psi, p, margin, pivot, scale], ["carry", "t"],
                           ["s", "p", "longitudinal", "longitudinal_pivot", "v_scale"])

    def _u_from_rates(self, qdot):
        """``u = B^{-1} qdot`` (a division when B is diagonal)."""
        bd = self.chain.b_diagonal
        if bd is not None:
            return qdot / ca.DM(bd) if not np.all(bd == 1) else qdot
        return ca.mtimes(ca.DM(np.linalg.inv(self.chain.B)), qdot)

    def back_step(self) -> ca.Function:
        """``(p_j, (c_j, d_j)) -> p_{j-1} = c_j + d_j p_j``: the free rate before link j.

        Returns
        -------
        casadi.Function
            ``(p, cd) -> p_prev`` [rad/s].
        """
        p, cd = ca.SX.sym("p"), ca.SX.sym("cd", 2)
        return ca.Function("back_step", [p, cd], [cd[0] + cd[1] * p], ["p", "cd"], ["p_prev"])

    def _structured(self, q, t) -> dict:
        """The law's outputs (keyed by :data:`~coordarm.symbolic.outputs.OUTPUTS`) by the O(m) recursion."""
        m = self.chain.m
        w_t = self.time_features_repivot()(t)
        fold = self.link_step_repivot().mapaccum("links", m - 1)
        qr = self.chain.revolute(q)
        if self.chain.rail:
            sigma = self._span_now(q, t)
            carry0, rail_rate, rail_margin, psi1 = self.rail_head()(q[0], qr[0], t, sigma)
        else:
            carry0 = self.first_carry()(qr[0])
        carries, outs = fold(carry0, qr[1:].T, ca.repmat(w_t, 1, m - 1))
        if self.chain.rail and self.governor:      # the margin (so v_scale) is independent of the rail rate
            scale = self.tail()(carries[:, m - 2], t)[4]
            carry0, rail_rate, rail_margin, psi1 = self.rail_head(True)(q[0], qr[0], t, sigma, scale)
            carries, outs = fold(carry0, qr[1:].T, ca.repmat(w_t, 1, m - 1))
        psi, p, margin, pivot, scale = self.tail()(carries[:, m - 2], t)
        back = self.back_step().mapaccum("back", m - 1)
        rev = list(range(m - 2, -1, -1))
        p_prev = back(p, outs[4:6, rev])                 # p_{m-1}, ..., p_1
        p_all = ca.vertcat(p_prev[:, rev].T, p)          # p_1, ..., p_m
        a = ca.vertcat(0, outs[2, :].T)
        b = ca.vertcat(1, outs[3, :].T)
        w = a + b * p_all                                # w_1 = p_1; w_j = a_j + b_j p_j
        qdot = w - ca.vertcat(0, w[:-1])
        out = {"u": self._u_from_rates(qdot), "e": outs[0, :].T, "s": psi, "link_margins": outs[1, :].T,
               "longitudinal": margin, "longitudinal_pivot": pivot, "v_scale": scale}
        if self.chain.rail:
            out.update(u=ca.vertcat(rail_rate, out["u"]), sigma=psi - psi1, rail_margin=rail_margin)
        return out

    @property
    def B_joints(self) -> np.ndarray:
        """``B`` over all joints: ``diag(1, B)`` on a rail (``qdot_d = u_d``), else ``B``."""
        if not self.chain.rail:
            return self.chain.B
        out = np.eye(self.chain.dof)
        out[1:, 1:] = self.chain.B
        return out

    def decoupling_matrix_expr(self, q, t, v_scale=1):
        """Decoupling matrix (eq. 26, rows ``s^m, e^2..e^m``) and right-hand side, by AD.

        Parameters
        ----------
        q : casadi.SX or casadi.MX, shape (m,)
            Symbolic joint coordinates [rad].
        t : casadi.SX or casadi.MX
            Symbolic time [s].
        v_scale : float or casadi expression
            Factor on ``v*`` in the ``s`` row (the governor's; default 1).

        Returns
        -------
        M : casadi expression, shape (m, m)
            Rows ``(s^m, e^2, ..., e^m)``, columns the controls ``u``.
        rhs : casadi expression, shape (m,)
            ``(v_scale v* - dpsi/dt, -K e^j - dphi/dt)`` (on a rail the span row's ``sigma_dot`` is
            scaled by ``v_scale`` too).
        """
        y = self.chain.centres(q)
        rows, rhs = [], []
        for j in [self.chain.m - 1] + list(range(1, self.chain.m)):
            phi, g, phit, psi, h, psit = self._geometry(y[:, j], t)
            Cj = ca.jacobian(y[:, j], q)
            if j == self.chain.m - 1 and not rows:
                rows.append(ca.mtimes(h.T, Cj))
                rhs.append(v_scale * self.speed(t) - psit)
                if self.chain.rail:        # the span row: sigma = psi(y^m) - psi(y^1)
                    _, _, _, psi1, h1, psit1 = self._geometry(y[:, 0], t)
                    rows.append(rows[0] - ca.mtimes(h1.T, ca.jacobian(y[:, 0], q)))
                    rhs.append(v_scale * self.span_rate(psi - psi1, t) - psit + psit1)
                continue
            rows.append(ca.mtimes(g.T, Cj))
            rhs.append(-self.gain * phi - phit)
        M = ca.vertcat(*rows)
        bd = self.chain.b_diagonal
        if bd is not None and self.chain.rail:
            bd = np.r_[1.0, bd]                           # qdot_d = u_d on a rail
        M = M * ca.repmat(ca.DM(bd).T, M.size1(), 1) if bd is not None else ca.mtimes(M, ca.DM(self.B_joints))
        return M, ca.vertcat(*rhs)

    # ------------------------------------------------------------ CasADi Functions
    def law(self, form: str | None = None) -> ca.Function:
        """The control law ``(q, t) -> outputs``, named and ordered as :data:`~coordarm.symbolic.outputs.OUTPUTS`.

        ``form="structured"`` is an MX Function with a loop over links (for code
        generation); ``form="dense"`` solves the dense eq. 27 and takes its margins
        from the structured recursion. With ``damping``, ``u`` is the damped least-squares
        solution wherever the smallest margin is inside the band.

        Parameters
        ----------
        form : {"structured", "dense"}, optional
            Law form (default: the controller's).

        Returns
        -------
        casadi.Function
            ``(q, t) -> outputs`` (cached per form).

        Raises
        ------
        ConfigError
            Unknown form.
        """
        form = form or self.law_form
        if form not in LAWS:
            raise ConfigError(f"law: expected one of {LAWS}, got {form!r}")
        key = ("law", form)
        if key not in self._cache:
            q, t = ca.MX.sym("q", self.chain.dof), ca.MX.sym("t")
            outs = self._structured(q, t)
            if form == "dense" or self.damping:
                qs, ts, vs = ca.SX.sym("q", self.chain.dof), ca.SX.sym("t"), ca.SX.sym("v_scale")
                M, r = self.decoupling_matrix_expr(qs, ts, vs)
                Mq, rq = ca.Function("decoupling", [qs, ts, vs], [M, r])(q, t, outs["v_scale"])
                if form == "dense":
                    outs["u"] = ca.solve(Mq, rq, "qr")
                if self.damping:
                    d = self.damping
                    smallest = ca.fmin(ca.mmin(outs["link_margins"]), outs["longitudinal"])
                    lam2 = damping_factor(smallest, d["lambda"], d["band"])
                    damped = ca.mtimes(Mq.T, ca.solve(ca.mtimes(Mq, Mq.T) + lam2 * ca.MX.eye(self.chain.dof),
                                                      rq, "qr"))
                    outs["u"] = ca.if_else(lam2 > 0, damped, outs["u"])
            self._cache[key] = ca.Function(f"coordinating_law_{form}", [q, t], [outs[n] for n in self.outputs],
                                           ["q", "t"], list(self.outputs))
        return self._cache[key]

    def fast_law(self, form: str | None = None) -> ca.Function:
        """:meth:`law` expanded to a flat SX Function: fastest in CasADi's interpreter.

        Parameters
        ----------
        form : {"structured", "dense"}, optional
            Law form (default: the controller's).

        Returns
        -------
        casadi.Function
            Same inputs and outputs as :meth:`law`.
        """
        form = form or self.law_form
        key = ("fast", form)
        if key not in self._cache:
            self._cache[key] = (self.law(form).expand() if form == "structured" and not self.damping
                               else self.law(form))
        return self._cache[key]

    def rk4_step(self, h: float, form: str | None = None) -> ca.Function:
        """Closed-loop RK4 step of ``qdot = B u(q, t)``: ``(q, t) -> (q_next, *RUN_OUTPUTS)``.

        The diagnostics (:data:`~coordarm.symbolic.outputs.RUN_OUTPUTS`) are those of the law
        at the step's start ``(q, t)``.

        Parameters
        ----------
        h : float
            Step length [s].
        form : {"structured", "dense"}, optional
            Law form (default: the controller's).

        Returns
        -------
        casadi.Function
            ``(q, t) -> (q_next, *RUN_OUTPUTS)`` (cached per form and ``h``).
        """
        from .integrator import rk4

        form = form or self.law_form
        key = ("rk4", form, float(h))
        if key not in self._cache:
            law = self.fast_law(form)
            bd = self.chain.b_diagonal
            if bd is not None and self.chain.rail:
                bd = np.r_[1.0, bd]                       # qdot_d = u_d on a rail
            apply_B = ((lambda u: ca.DM(bd) * u) if bd is not None
                       else (lambda u: ca.mtimes(ca.DM(self.B_joints), u)))
            q, t = ca.MX.sym("q", self.chain.dof), ca.MX.sym("t")
            out1 = law(q, t)                              # kept: the diagnostics at the step's start
            q_next = rk4(lambda x, s: apply_B(law(x, s)[0]), q, t, h, k1=apply_B(out1[0]))
            kept = [out1[self.outputs.index(name)] for name in self.run_outputs]
            self._cache[key] = ca.Function("rk4_step", [q, t], [q_next, *kept],
                                           ["q", "t"], ["q_next", *self.run_outputs])
        return self._cache[key]

    def decoupling_function(self) -> ca.Function:
        """``(q, t) -> (M, rhs)``: the dense decoupling matrix of eq. 26 and its right-hand side.

        Returns
        -------
        casadi.Function
            The AD form of :meth:`decoupling_matrix_expr` (O(m^2) graph).
        """
        if "M" not in self._cache:
            q, t = ca.SX.sym("q", self.chain.dof), ca.SX.sym("t")
            M, r = self.decoupling_matrix_expr(q, t)
            self._cache["M"] = ca.Function("decoupling", [q, t], [M, r], ["q", "t"], ["M", "rhs"])
        return self._cache["M"]

    def memo(self, key: Hashable, make: Callable[[], Any]) -> Any:
        """An object derived from this controller, built once by ``make()`` and kept under ``key``.

        The one way for other layers (simulation loops, analysis Functions, compiled libraries)
        to cache what they derive from this controller; the keys of this class are tuples
        starting with ``"law"``, ``"fast"``, ``"rk4"``, ``"map"``, ``"M"``, ``"hoisted"``.

        Parameters
        ----------
        key : hashable
            Cache key; use a tuple starting with a name of your own.
        make : callable
            Builds the object (called only on the first request; nothing is kept if it raises).

        Returns
        -------
        object
            What ``make()`` returned for ``key``.
        """
        if key not in self._cache:
            self._cache[key] = make()
        return self._cache[key]

    def compile(self, form: str | None = None, **build_options: Any):
        """The law as generated C, compiled (or taken from the build cache) and loaded.

        Parameters
        ----------
        form : {"structured", "dense"}, optional
            Law form (default: this controller's).
        **build_options
            Passed to :class:`coordarm.generated.compiled.CompiledController` (``cc``, ``flags``,
            ``build_dir``, ``force``).

        Returns
        -------
        coordarm.generated.compiled.CompiledController
            Same ``control(q, t)`` and ``evaluate(q, t)`` as this object, backed by C.

        Raises
        ------
        BuildError
            No C compiler, or the generated code did not compile or load.

        Notes
        -----
        A convenience for :func:`coordarm.generated.compile`, where compilation lives: the
        import is done at call time, so the model never loads the code generator (the one
        upward import allowed by the layer contract in ``pyproject.toml``).
        """
        from coordarm.generated import compile as compile_controller
        return compile_controller(self, form, **build_options)

    # --------------------------------------------------------------- numeric API
    def evaluate(self, q, t: float = 0.0, form: str | None = None) -> dict[str, Any]:
        """All outputs of the law at ``(q, t)`` as numpy values, keyed by :data:`OUTPUTS`.

        Parameters
        ----------
        q : array_like, shape (m,)
            Joint coordinates [rad].
        t : float
            Time [s].
        form : {"structured", "dense"}, optional
            Law form (default: the controller's).

        Returns
        -------
        dict
            Vectors as arrays, scalars as floats (see :data:`coordarm.symbolic.outputs.LAW_OUTPUTS`).

        Raises
        ------
        ConfigError
            ``q`` or ``t`` not finite, or ``q`` of the wrong shape.
        """
        q = self.chain.check_q(q)
        if not math.isfinite(t):
            raise ConfigError(f"t: must be finite, got {t!r}")
        res = self.fast_law(form)(q, t)
        out = {}
        for name, v in zip(self.outputs, res):
            v = np.asarray(v, dtype=float).ravel()
            out[name] = float(v[0]) if name in SCALAR_OUTPUTS else v
        return out

    def control(self, q, t: float = 0.0) -> np.ndarray:
        """Control ``u(q, t)``.

        Parameters
        ----------
        q : array_like, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (dof,)
            The control [rad/s for B = I] (``d_dot`` [m/s] first on a rail).
        """
        return self.evaluate(q, t)["u"]

    def centre_geometry(self, Q, T) -> dict[str, np.ndarray]:
        """The curve's ``phi``, ``psi`` and their derivatives at every link centre of N states.

        Parameters
        ----------
        Q : (N, dof) array_like
            Joint coordinates [rad] (``d`` [m] first on a rail).
        T : (N,) array_like
            Times [s].

        Returns
        -------
        dict
            ``phi``, ``phit``, ``psi``, ``psit`` of shape (N, m) and the gradients ``gphi``,
            ``gpsi`` of shape (N, m, 2), from one mapped call of the geometry Function.
        """
        Q, T = np.atleast_2d(np.asarray(Q, float)), np.atleast_1d(np.asarray(T, float))
        m, n = self.chain.m, self.chain.dof
        if Q.shape[1:] != (n,) or T.shape != (len(Q),):
            raise ConfigError(f"Q, T: need shapes (N, {n}) and (N,), got {Q.shape} and {T.shape}")
        N = len(Q)
        Y = self.chain.centres_np(Q)                                      # (N, m, 2)
        geo = self._mapped("geometry", lambda: self._geometry, N * m)
        values = geo(Y.reshape(-1, 2).T, np.repeat(T, m)[None])
        out = {}
        for name, v in zip(("phi", "gphi", "phit", "psi", "gpsi", "psit"), values):
            v = np.asarray(v)
            out[name] = v.T.reshape(N, m, 2) if name[0] == "g" else v.reshape(N, m)
        return out

    def speeds(self, T) -> np.ndarray:
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
        T = np.atleast_1d(np.asarray(T, float))
        return np.asarray(self._mapped("speed", self.speed_function, len(T))(T[None])).ravel()

    def decoupling_matrices(self, Q, T, geometry: dict[str, np.ndarray] | None = None
                            ) -> tuple[np.ndarray, np.ndarray]:
        """Decoupling matrices (eq. 26) and right-hand sides at N states, in O(N m^2).

        Numeric and batched: the Jacobians ``C^j`` by the closed form of eq. 7 through
        prefix sums of the link normals, the curve gradients from :meth:`centre_geometry`.
        Agrees with the AD :meth:`decoupling_function` to rounding, without building its
        O(m^2) symbolic graph (which takes minutes at 1000 links).

        Parameters
        ----------
        Q : (N, m) array_like
            Joint coordinates [rad].
        T : (N,) array_like
            Times [s].
        geometry : dict, optional
            :meth:`centre_geometry` of ``(Q, T)``, when the caller has it already.

        Returns
        -------
        M : (N, m, m) ndarray
            Rows ``(s^m, e^2, ..., e^m)``, columns the controls ``u``; on a rail (N, m+1, m+1),
            rows ``(s, sigma, e^2..e^m)``, columns ``(u_d, u)``.
        rhs : (N, m) ndarray
            ``(v* - dpsi/dt, -K e^j - dphi/dt)`` (on a rail with ``sigma_dot - dpsi/dt(y^m) +
            dpsi/dt(y^1)`` second).
        """
        geo = geometry if geometry is not None else self.centre_geometry(Q, T)
        Q, T = np.atleast_2d(np.asarray(Q, float)), np.atleast_1d(np.asarray(T, float))
        m, xi = self.chain.m, self.chain.xi
        # C^j[:, k] = xi/2 (S_{j-1} + S_j - P_k) for k <= j, with S the prefix sums of the
        # normals n_0..n_{m-1} and P_0 = n_0, P_k = 2 S_{k-1}  (0-based j, k; C^0 = 0).
        S = np.cumsum(normal(np.cumsum(self.chain.revolute(Q), axis=-1)), axis=-2)   # (N, m, 2)
        P = np.concatenate([S[:, :1], 2 * S[:, :-1]], axis=1)
        rows = np.r_[m - 1, 1:m]                                           # target centre of each row
        W = np.concatenate([geo["gpsi"][:, m - 1:], geo["gphi"][:, 1:]], axis=1)  # (N, m, 2) its gradient
        Tj = S[:, rows] + S[:, rows - 1]
        M = 0.5 * xi * (np.einsum("nri,nri->nr", W, Tj)[:, :, None] - W @ np.swapaxes(P, 1, 2))
        M *= np.arange(m)[None, :] <= rows[:, None]
        b = self.chain.b_diagonal
        M = M * b if b is not None else M @ self.chain.B
        rhs = np.concatenate([(self.speeds(T) - geo["psit"][:, m - 1])[:, None],
                              -self.gain * geo["phi"][:, 1:] - geo["phit"][:, 1:]], axis=1)
        if not self.chain.rail:
            return M, rhs
        # the rail: C^j gains the column ``rail`` (every centre slides with the base); the span
        # row sigma = psi(y^m) - psi(y^1) is the s row minus grad psi(y^1)^T C^1 = (h_1 . rail, 0, ...)
        rail = self.chain.rail_direction
        col = W @ rail                                                      # (N, m)
        M = np.concatenate([col[:, :, None], M], axis=2)
        span = M[:, :1].copy()
        span[:, 0, 0] -= geo["gpsi"][:, 0] @ rail
        M = np.concatenate([M[:, :1], span, M[:, 1:]], axis=1)
        sigma = geo["psi"][:, m - 1] - geo["psi"][:, 0]
        rate = np.asarray(self._mapped("span_rate", self._span_rate_function, len(T))(sigma[None], T[None])).ravel()
        rhs = np.concatenate([rhs[:, :1], (rate - geo["psit"][:, m - 1] + geo["psit"][:, 0])[:, None], rhs[:, 1:]],
                             axis=1)
        return M, rhs

    def _span_rate_function(self) -> ca.Function:
        """``(sigma, t) -> sigma_dot`` commanded (see :meth:`span_rate`)."""
        sigma, t = ca.SX.sym("sigma"), ca.SX.sym("t")
        return ca.Function("span_rate", [sigma, t], [ca.SX(self.span_rate(sigma, t))])

    def _mapped(self, name: str, make, n: int) -> ca.Function:
        """The Function ``make()`` evaluated at ``n`` points in one call (cached per name and ``n``)."""
        key = ("map", name, n)
        if key not in self._cache:
            fn = make()
            self._cache[key] = fn.map(n) if n > 1 else fn
        return self._cache[key]

    def decoupling_matrix(self, q, t: float = 0.0) -> np.ndarray:
        """Numeric decoupling matrix (eq. 26); see :meth:`decoupling_matrices`.

        Parameters
        ----------
        q : array_like, shape (m,)
            Joint coordinates [rad].
        t : float
            Time [s].

        Returns
        -------
        ndarray, shape (m, m)
            Rows ``(s^m, e^2, ..., e^m)``, columns the controls.
        """
        return self.decoupling_matrices(self.chain.check_q(q)[None], [t])[0][0]

    def cond(self, q, t: float = 0.0) -> float:
        """2-norm condition number of the decoupling matrix.

        Parameters
        ----------
        q : array_like, shape (m,)
            Joint coordinates [rad].
        t : float
            Time [s].

        Returns
        -------
        float
            ``sigma_max / sigma_min`` (inf when singular).
        """
        return float(self.conds(self.chain.check_q(q)[None], [t])[0])

    def conds(self, Q, T) -> np.ndarray:
        """2-norm condition numbers of the decoupling matrices at N states.

        Parameters
        ----------
        Q : array_like, shape (N, m)
            Joint coordinates [rad].
        T : array_like, shape (N,)
            Times [s].

        Returns
        -------
        ndarray, shape (N,)
            ``sigma_max / sigma_min`` of each (inf when singular).
        """
        sv = np.linalg.svd(self.decoupling_matrices(Q, T)[0], compute_uv=False)
        with np.errstate(divide="ignore"):
            return sv[:, 0] / sv[:, -1]

    def base_offset(self, t: float = 0.0) -> float:
        """``|phi(0, t)|``: how far the curve passes from the pinned base.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        float
            Distance [m].
        """
        return abs(float(self._geometry([0, 0], t)[0]))

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
        return evaluate(self.speed, t)

    def __repr__(self) -> str:
        extra = (", governor=True" if self.governor else "") + (f", damping={self.damping!r}" if self.damping else "")
        return (f"CoordinatingController({self.chain!r}, {type(self.curve).__name__}, "
                f"gain={self.gain}, law={self.law_form!r}{extra})")
