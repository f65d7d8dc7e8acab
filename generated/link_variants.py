"""The C-only variants of the law's Functions: the forms the generated C calls, owned by the code generator.

The interpreted law (:mod:`coordarm.symbolic.recursion`) computes each link's cosine and sine,
divides by the link pivot and evaluates the curve's full formulas. The generated C instead

* computes every link's cosine and sine in one vectorised loop and passes them in
  (:func:`link_step_trig`), with the reciprocal of the link pivot from :func:`link_pivot`, so no
  division sits on the loop-carried chain;
* on a :class:`~coordarm.symbolic.paths.Path`, searches each link's closest piece itself and calls
  the formulas of that piece's kind (:func:`piece_steps`, :func:`tail_piece`);
* on a rail with a commanded span, computes the span from the end's centre (:func:`rail_head_from_end`).

Every function takes the controller; the Functions are cached per controller here (never on it).
"""
from __future__ import annotations

import weakref
from typing import Any

import casadi as ca
import numpy as np

from coordarm.symbolic import CoordinatingController
from coordarm.symbolic.carry import CARRY, Carry
from coordarm.symbolic.path_pieces import PIECE_CONSTANTS
from coordarm.symbolic.recursion import TAIL_OUTPUTS, split_time_terms

_CACHE: "weakref.WeakKeyDictionary[CoordinatingController, dict]" = weakref.WeakKeyDictionary()
#: Input names of the per-link Functions that take the link's cosine and sine.
_TRIG_INPUTS = ["carry", "q_j", "cos_alpha_j", "sin_alpha_j"]


def _cached(ctrl: CoordinatingController, key: Any, make) -> Any:
    """``make()`` for ``ctrl``, built once per controller and key."""
    per_ctrl = _CACHE.setdefault(ctrl, {})
    if key not in per_ctrl:
        per_ctrl[key] = make()
    return per_ctrl[key]


def _trig_link_expressions(ctrl: CoordinatingController):
    """Symbolic carry, ``q_j``, ``(cos, sin, inv_pivot)``, ``t`` and the step's ``(carry_next, out_j)``.

    As :meth:`~coordarm.symbolic.recursion.StructuredRecursion.link_expressions`, with the cosine
    and sine of ``alpha_j`` and the reciprocal of the scaled link pivot as inputs (``out_j`` ends
    with that reciprocal's expression, for :func:`link_pivot`): CasADi would fold ``x * (1/y)``
    back into a division on the loop-carried chain of P and Q.
    """
    xi, K = ctrl.chain.xi, ctrl.gain
    carry, qj, t = CARRY.symbol(), ca.SX.sym("q_j"), ca.SX.sym("t")
    c = CARRY.unpack(carry)
    alpha = c.alpha + qj
    trig = ca.SX.sym("cos_sin_alpha_j", 2)
    n_j, y_j, phi, g, phit = ctrl.recursion.place_link(c, trig, t)
    pivot = ca.dot(g, n_j)
    inv_expr = 1 / (0.5 * xi * pivot)
    inv = ca.SX.sym("inv_pivot")
    r, gP, gQ = -K * phi - phit, ca.dot(g, c.P), ca.dot(g, c.Q)
    a_j = (r - gP) * inv
    b_j = -gQ * inv
    # the same P + xi n_j a_j, Q + xi n_j b_j, regrouped so that the loop-carried chain
    # P -> P' is g.P, one product and one difference (12 instead of 18 cycles of latency)
    u = (xi * inv) * n_j
    P_next, Q_next = (c.P + u * r) - u * gP, c.Q - u * gQ
    new = CARRY.pack(Carry(y_j, alpha, trig, P_next, Q_next, a_j, b_j, c.sum_abs_b + ca.fabs(b_j)))
    out = ca.vertcat(phi, ca.fabs(pivot) / ca.norm_2(g), a_j, b_j, inv_expr)
    both = ca.cse(ca.vertcat(new, out))          # one CSE over both, so a_j, b_j are shared
    return carry, qj, (trig[0], trig[1], inv), t, both[:new.numel()], both[new.numel():]


def _hoisted_trig(ctrl: CoordinatingController) -> tuple[ca.Function, ca.Function, ca.Function]:
    """``(time_features, link_step_trig, link_pivot)`` of ``ctrl`` (built once)."""
    carry, qj, (c, s, inv), t, new, out = _trig_link_expressions(ctrl)
    expr, wsym, wexpr = split_time_terms(ca.vertcat(new, out), t)
    n_new, n_out = new.numel(), expr.numel() - 1
    tf = ca.Function("time_features", [t], [ca.cse(wexpr)], ["t"], ["w"])
    pivot = ca.Function("link_pivot", [carry, qj, c, s, wsym], [expr[n_out]], _TRIG_INPUTS + ["w"], ["inv_pivot"])
    step = ca.Function("link_step_trig", [carry, qj, c, s, wsym, inv], [expr[:n_new], expr[n_new:n_out]],
                       _TRIG_INPUTS + ["w", "inv_pivot"], ["carry_next", "out"])
    return tf, step, pivot


def time_features_trig(ctrl: CoordinatingController) -> ca.Function:
    """``t -> w``: the time-only terms of :func:`link_step_trig`, computed once per ``t``.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller.

    Returns
    -------
    casadi.Function
        Input ``t`` [s], output ``w`` (one 0 for a static curve).
    """
    return _cached(ctrl, "trig", lambda: _hoisted_trig(ctrl))[0]


def link_step_trig(ctrl: CoordinatingController) -> ca.Function:
    """The link step with ``cos(alpha_j)``, ``sin(alpha_j)`` and the reciprocal of the scaled link pivot as
    inputs: ``(carry, q_j, cos_alpha_j, sin_alpha_j, w, inv_pivot) -> (carry_next, out_j)``.

    The generated C computes every link's cosine and sine in one loop the compiler vectorises,
    then runs this step over the links (no trigonometry inside the recursion); ``inv_pivot``
    comes from :func:`link_pivot`, so no division sits on the carried chain.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller.

    Returns
    -------
    casadi.Function
        Inputs ``carry`` (layout :data:`~coordarm.symbolic.carry.CARRY`), ``q_j`` [rad],
        ``cos_alpha_j``, ``sin_alpha_j``, ``w`` (:func:`time_features_trig`), ``inv_pivot`` [1/m];
        outputs ``carry_next`` and ``out`` as the interpreted ``link_step``'s.
    """
    return _cached(ctrl, "trig", lambda: _hoisted_trig(ctrl))[1]


def link_pivot(ctrl: CoordinatingController) -> ca.Function:
    """``(carry, q_j, cos_alpha_j, sin_alpha_j, w) -> 1 / (xi/2 pivot_j)`` for :func:`link_step_trig`.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller.

    Returns
    -------
    casadi.Function
        Output ``inv_pivot`` [1/m], the reciprocal of half a link length times the link pivot.
    """
    return _cached(ctrl, "trig", lambda: _hoisted_trig(ctrl))[2]


def _piece_geometries(ctrl: CoordinatingController, carry: ca.SX, qj: ca.SX, cs: ca.SX, t: ca.SX,
                      sel: ca.SX) -> tuple[ca.Function, dict[str, ca.Function]]:
    """``(time_features, {kind: link_geometry_kind})``: each kind's geometry of link ``j``, one ``w(t)``."""
    xi, K = ctrl.chain.xi, ctrl.gain
    c = CARRY.unpack(carry)
    n_j = ctrl.chain.link_normal(cs)
    y_j = c.y + ctrl.chain.centre_step(c.direction, cs)
    geos, kinds = [], piece_kinds(ctrl)
    for kind in kinds:
        phi, g, phit = ctrl.task.piece_geometry(kind)(y_j, t, sel)[:3]
        pivot = ca.dot(g, n_j)
        # |grad phi| = 1 for a distance to a line or a circle: the margin is |pivot| (the
        # full form's |pivot| / |grad phi| differs by the rounding of a unit norm, 1e-16)
        geos.append(ca.vertcat(1 / (0.5 * xi * pivot), phi, ca.fabs(pivot), g, -K * phi - phit))
    expr, wsym, wexpr = split_time_terms(ca.vertcat(*geos), t)
    tf = ca.Function("time_features", [t], [ca.cse(wexpr)], ["t"], ["w"])
    geometry = {kind: ca.Function(f"link_geometry_{function_kind(kind, kinds)}", [carry, qj, cs[0], cs[1], wsym, sel],
                                  [ca.cse(expr[6 * i:6 * i + 6])], _TRIG_INPUTS + ["w", "piece"], ["geometry"])
                for i, kind in enumerate(kinds)}
    return tf, geometry


def piece_kinds(ctrl: CoordinatingController) -> tuple[str, ...]:
    """The kinds of piece of the controller's path: ``("line", "arc")``, and ``"spiral"`` with transitions.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its curve a :class:`~coordarm.symbolic.paths.Path`).

    Returns
    -------
    tuple of str
        The kinds the generated C has a link geometry and a tail for.
    """
    spiral = any(pc.c != 0 for pc in ctrl.curve.pieces)
    return ("line", "arc", "spiral") if spiral else ("line", "arc")


def function_kind(kind: str, kinds: tuple[str, ...]) -> str:
    """The C name's suffix of a kind's Function: on a path with clothoids the arc's is ``arc_only``.

    The C glue calls ``link_geometry_arc`` and ``tail_arc`` for a piece flagged arc-like; with clothoids
    those names are wrappers (:func:`~coordarm.generated.path_search.spiral_wrappers`) that call the
    arc's or the clothoid's Function by the piece's flag.

    Parameters
    ----------
    kind : str
        ``"line"``, ``"arc"`` or ``"spiral"``.
    kinds : tuple of str
        The path's kinds (:func:`piece_kinds`).

    Returns
    -------
    str
        ``kind``, or ``"arc_only"``.
    """
    return "arc_only" if kind == "arc" and "spiral" in kinds else kind


def _piece_step(ctrl: CoordinatingController, carry: ca.SX, qj: ca.SX, cs: ca.SX) -> ca.Function:
    """``(carry, q_j, cos_alpha_j, sin_alpha_j, geometry) -> (carry_next, out_j)``, the same for both kinds."""
    xi = ctrl.chain.xi
    c = CARRY.unpack(carry)
    n_j = ctrl.chain.link_normal(cs)
    y_j = c.y + ctrl.chain.centre_step(c.direction, cs)
    geo = ca.SX.sym("geometry", 6)
    inv, phi, margin, g, r = geo[0], geo[1], geo[2], geo[3:5], geo[5]
    gP, gQ = ca.dot(g, c.P), ca.dot(g, c.Q)
    a_j, b_j = (r - gP) * inv, -gQ * inv
    u = (xi * inv) * n_j                     # regrouped as in link_step_trig
    new = CARRY.pack(Carry(y_j, c.alpha + qj, cs, (c.P + u * r) - u * gP, c.Q - u * gQ, a_j, b_j,
                           c.sum_abs_b + ca.fabs(b_j)))
    both = ca.cse(ca.vertcat(new, phi, margin, a_j, b_j))
    return ca.Function("link_step_piece", [carry, qj, cs[0], cs[1], geo], [both[:new.numel()], both[new.numel():]],
                       _TRIG_INPUTS + ["geometry"], ["carry_next", "out"])


def piece_steps(ctrl: CoordinatingController) -> tuple[ca.Function, dict[str, ca.Function], ca.Function]:
    """The path's per-piece link step for the generated C (a :class:`~coordarm.symbolic.paths.Path` only).

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its curve a Path).

    Returns
    -------
    time_features : casadi.Function
        ``t -> w``, the time-only terms of both kinds.
    geometry : dict
        ``{"line": link_geometry_line, "arc": link_geometry_arc}`` (and ``"spiral"`` on a path with
        transitions, :func:`piece_kinds`): ``(carry, q_j, cos_alpha_j,
        sin_alpha_j, w, piece) -> geometry``, ``piece`` the ten constants
        (:func:`~coordarm.symbolic.path_pieces.piece_parameters` with ``derived=True``) of the closest
        piece, which is of that kind; ``geometry = (1 / (xi/2 pivot_j) [1/m], phi [m], link
        margin, grad phi, -K phi - dphi/dt [m/s])``.
    step : casadi.Function
        ``(carry, q_j, cos_alpha_j, sin_alpha_j, geometry) -> (carry_next, out_j)``, the
        operations of :func:`link_step_trig` after its geometry.
    """
    def make():
        carry, qj, t = CARRY.symbol(), ca.SX.sym("q_j"), ca.SX.sym("t")
        cs, sel = ca.SX.sym("cos_sin_alpha_j", 2), ca.SX.sym("piece", PIECE_CONSTANTS)
        tf, geometry = _piece_geometries(ctrl, carry, qj, cs, t, sel)
        return tf, geometry, _piece_step(ctrl, carry, qj, cs)
    return _cached(ctrl, "pieces", make)


def tail_piece(ctrl: CoordinatingController, kind: str) -> ca.Function:
    """The tail by the formulas of one piece of a path: ``(carry_m, t, piece) -> (s, p, longitudinal,
    longitudinal_pivot, v_scale)``, ``piece`` the ten constants (:func:`~coordarm.symbolic.path_pieces.piece_parameters`,
    ``derived=True``) of the closest piece to ``y^m``, which the generated C searches.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its curve a :class:`~coordarm.symbolic.paths.Path`).
    kind : {"line", "arc", "spiral"}
        The kind of the piece.

    Returns
    -------
    casadi.Function
        ``tail_<kind>``; outputs as :meth:`~coordarm.symbolic.recursion.StructuredRecursion.tail`'s.
    """
    def make():
        carry, t = CARRY.symbol(), ca.SX.sym("t")
        sel = ca.SX.sym("piece", PIECE_CONSTANTS)
        geometry = ctrl.task.piece_geometry(kind)
        outs = ctrl.recursion.tail_expressions(carry, t, lambda y: geometry(y, t, sel))
        name = f"tail_{function_kind(kind, piece_kinds(ctrl))}"
        return ca.Function(name, [carry, t, sel], list(outs), ["carry", "t", "piece"], TAIL_OUTPUTS)
    return _cached(ctrl, ("tail", kind), make)


def rail_head_from_end(ctrl: CoordinatingController, governed: bool = False) -> ca.Function:
    """The rail head with the span computed inside: ``(d, q_1, t, y_m) -> (carry, d_dot, rail_margin, psi_1)``,
    ``sigma = psi(y_m) - psi(y^1)`` (for the generated C of a commanded span, whose loop knows the end's
    centre ``y_m`` [m] from its cosines and sines).

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (its chain on a rail).
    governed : bool
        A fifth input ``v_scale`` scales the commands (see
        :meth:`~coordarm.symbolic.recursion.StructuredRecursion.rail_head`).

    Returns
    -------
    casadi.Function
        ``rail_head_from_end``; outputs ``carry``, ``d_dot`` [m/s], ``rail_margin`` [-] and ``psi_1`` [m].
    """
    geometry = ctrl.task.geometry
    d, q1, t, y_m = ca.SX.sym("d"), ca.SX.sym("q_1"), ca.SX.sym("t"), ca.SX.sym("y_m", 2)
    scale = [ca.SX.sym("v_scale")] if governed else []
    psi_1 = geometry(d * ca.DM(ctrl.chain.rail_direction), t)[3]
    outs = ctrl.recursion.rail_head(governed)(d, q1, t, geometry(y_m, t)[3] - psi_1, *scale)
    both = ca.cse(ca.vertcat(*outs))
    sizes = np.cumsum([0] + [o.numel() for o in outs])
    return ca.Function("rail_head_from_end", [d, q1, t, y_m] + scale,
                       [both[a:b] for a, b in zip(sizes[:-1], sizes[1:])],
                       ["d", "q_1", "t", "y_m"] + (["v_scale"] if governed else []),
                       ["carry", "d_dot", "rail_margin", "psi_1"])
