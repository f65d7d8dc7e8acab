"""The C-only variants of the spatial law's Functions (:mod:`coordarm.symbolic.spatial_recursion`).

The interpreted spatial solve is one loop over links (frames, centres, pivots and rates together).
The generated C splits it into loops over links, the sequential ones with a carry that fits the
registers: the forward kinematics (:func:`spatial_kinematics_step`: ``R_j``, ``y^j`` from the cosines
and sines of the joint angles, computed before in vectorised loops), which stores each link's
``E_j = [R_j e_y, R_j e_z]`` and ``y^j``; the link pivots (:func:`spatial_link_pivot`,
:func:`spatial_link_inv_det`: independent per link, every argument a scalar so that the C loop
vectorises); the rates (:func:`spatial_rates_step`: the affine link rates, carrying only
``A = y^j' + xi/2 E_j w_j``). On a line all of it works in the line's own frame (:mod:`.spatial_frame`),
where the geometry and ``dPhi/dy`` cost nothing. The heads and the end solve (:func:`spatial_kinematics_head`,
:func:`spatial_rates_head`, :func:`spatial_frame_tail`, :func:`spatial_end_margin`) are the interpreted
ones with their carries in this layout, the heads on link 1's cosines and sines from the vectorised passes.
The time-only terms of the pivots, the heads and the end solve are pulled out together and computed once
per law call (:func:`spatial_time_features`). The later stages of an RK4 step, which read only the joint
rates, call :func:`spatial_link_pivot_rates` (the pivot without ``e^j`` and the link margin). The
Functions are cached per controller here.
"""
from __future__ import annotations

import weakref
from typing import Any

import casadi as ca
import numpy as np

from coordarm.symbolic import SpatialController
from coordarm.symbolic.recursion import split_time_terms
from coordarm.symbolic.spatial_recursion import singular_values_2x2, solve_2x2, unpack_carry

from .spatial_frame import frame_geometry, frame_of

_CACHE: "weakref.WeakKeyDictionary[SpatialController, dict]" = weakref.WeakKeyDictionary()
#: Size of the kinematics carry: ``vec R_j`` (9), ``y^j`` (3); its last 9 (``vec E_j``, ``y^j``) are the
#: link's geometry the rates step reads.
KIN_CARRY = 12
#: Size of a link's stored geometry: ``vec E_j`` (6) and ``y^j`` (3), the kinematics carry from index 3.
LINK_GEOMETRY = 9
#: Size of the rates carry: ``A = A0 + A1 p`` (3 + 6) [m/s].
RATE_CARRY = 9


def joint_rotation(ca_: Any, sa: Any, cb: Any, sb: Any) -> tuple[Any, Any]:
    """``(Rz(a), Ry(b))`` from the cosines and sines of ``a`` and ``b``.

    Parameters
    ----------
    ca_, sa, cb, sb : casadi.SX
        ``cos a``, ``sin a``, ``cos b``, ``sin b``.

    Returns
    -------
    (casadi.SX, casadi.SX)
        Both (3, 3).
    """
    rz = ca.vertcat(ca.horzcat(ca_, -sa, 0), ca.horzcat(sa, ca_, 0), ca.horzcat(0, 0, 1))
    ry = ca.vertcat(ca.horzcat(cb, 0, sb), ca.horzcat(0, 1, 0), ca.horzcat(-sb, 0, cb))
    return rz, ry


def singular_values_2x2_select(A: Any) -> tuple[Any, Any]:
    """``(smallest, largest)`` singular value of a 2x2 matrix, with ``fmax(x, 0)`` written without a branch.

    As :func:`~coordarm.symbolic.spatial_recursion.singular_values_2x2`. C's ``fmax`` is a library call
    unless NaN may be ignored, and gcc turns ``sqrt(x > 0 ? x : 0)`` into a branch around the square root,
    which stops a loop over links from vectorising; ``(x + |x|) / 2`` is ``fmax(x, 0)`` exactly for every
    number (``x + x`` and the halving are exact; ``x + |x| = 0`` for ``x < 0``), and where ``x`` is NaN the
    other square root of the pair is NaN too, so both forms give NaN singular values.

    Parameters
    ----------
    A : casadi.SX, shape (2, 2)

    Returns
    -------
    (casadi.SX, casadi.SX)
    """
    F = ca.sumsqr(A)
    D = ca.fabs(A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0])
    gap = F - 2 * D
    plus, minus = ca.sqrt(F + 2 * D), ca.sqrt(0.5 * (gap + ca.fabs(gap)))
    return 0.5 * (plus - minus), 0.5 * (plus + minus)


def _kinematics_function(ctrl: SpatialController) -> ca.Function:
    """``(carry, cos a, sin a, cos b, sin b) -> carry_next`` of :func:`spatial_kinematics_step`."""
    carry, trig = ca.SX.sym("carry", KIN_CARRY), [ca.SX.sym(n) for n in ("cos_a", "sin_a", "cos_b", "sin_b")]
    R_prev, y_prev = ca.reshape(carry[0:9], 3, 3), carry[9:12]
    rz, ry = joint_rotation(*trig)
    R = ca.mtimes(ca.mtimes(R_prev, rz), ry)
    y = y_prev + 0.5 * ctrl.chain.xi * (R_prev[:, 0] + R[:, 0])
    return ca.Function("spatial_kinematics_step", [carry, *trig], [ca.vertcat(ca.vec(R), y)],
                       ["carry", "cos_a", "sin_a", "cos_b", "sin_b"], ["carry_next"])


def _is_line_frame(J: Any) -> bool:
    """``dPhi/dy`` is the constant ``[[0, 1, 0], [0, 0, 1]]`` (a line in its own frame, :mod:`.spatial_frame`)."""
    return bool(J.is_constant()) and bool(np.array_equal(np.array(ca.DM(J)), np.eye(3)[1:3]))


def link_pivot_expressions(ctrl: SpatialController, t: Any, geometry: Any = None) -> tuple[tuple, tuple, Any]:
    """Inputs ``(geo, inv)``, outputs ``(pivot, out, inv_expr)`` and ``dPhi/dy`` of one link's pivot at ``t`` (no carry).

    ``pivot = (K Phi + Phit (2), vec(-P^-1) (4), vec M (6)[, vec dPhi/dy (6)])`` with ``M = 2 E_j (-P^-1)``,
    ``dPhi/dy`` only where it varies; on a line in its own frame only ``M``'s first row (2), the one
    the rates step (:func:`spatial_rates_step`) reads there. ``out = (e^j (2), link margin)``.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.
    t : casadi.SX
        Time [s].
    geometry : callable, optional
        ``(y, t) -> (Phi, dPhi/dy, dPhi/dt, ...)`` (default: :func:`~.spatial_frame.frame_geometry`, the
        curve's; :mod:`.spatial_path` passes one piece kind's).

    Returns
    -------
    tuple
        ``(geo (9 SX), inv (SX))``, ``(pivot, out, inv_expr)`` and ``dPhi/dy`` (2, 3).
    """
    K = ctrl.gain
    geo, inv = [ca.SX.sym(f"g{k}") for k in range(LINK_GEOMETRY)], ca.SX.sym("inv_det")
    E, y = ca.reshape(ca.vertcat(*geo[0:6]), 3, 2), ca.vertcat(*geo[6:9])
    Phi, J, Phit, *_ = (frame_geometry(ctrl) if geometry is None else geometry)(y, t)
    P = ca.mtimes(J, E)                  # the link pivot over xi/2 (the xi/2 cancels from xi/2 E w_j)
    neg_inv = ca.vertcat(ca.horzcat(-P[1, 1], P[0, 1]), ca.horzcat(P[1, 0], -P[0, 0])) * inv   # -P^-1
    M = 2 * ca.mtimes(E, neg_inv)
    parts = [K * Phi + Phit, ca.vec(neg_inv)]
    if _is_line_frame(J):
        parts.append(M[0, :].T)
    else:
        parts.append(ca.vec(M))
        if not J.is_constant():
            parts.append(ca.vec(J))
    out = ca.vertcat(Phi, singular_values_2x2_select(P)[0])
    inv_expr = 1 / (P[0, 0] * P[1, 1] - P[0, 1] * P[1, 0])
    return (geo, inv), (ca.vertcat(*parts), out, inv_expr), J


def _rates_function(ctrl: SpatialController, J: Any, n_pivot: int) -> ca.Function:
    """``(carry, pivot_0, ..., pivot_n-1) -> (carry_next, v_0, ..., v_5)`` of :func:`spatial_rates_step`.

    ``G = dPhi/dy A + (K Phi + Phit, 0, 0)``, ``V = -P^-1 G`` (``xi/2 (W0_j, W1_j)``), ``A <- A + M G``.
    On a line in its own frame ``dPhi/dy`` takes ``A``'s rows 2-3 (``b``), the same at every link, and
    ``dPhi/dy M = 2 P (-P^-1) = -2 I``: ``b <- b - 2 G = -b - 2 (K Phi + Phit, 0, 0)`` exactly, and only
    ``A``'s first row needs ``M`` (its first row).
    """
    carry, piv = ca.SX.sym("carry", RATE_CARRY), [ca.SX.sym(f"p{k}") for k in range(n_pivot)]
    A = ca.horzcat(carry[0:3], ca.reshape(carry[3:9], 3, 2))
    r, neg_inv = ca.vertcat(*piv[0:2]), ca.reshape(ca.vertcat(*piv[2:6]), 2, 2)
    rhs = ca.horzcat(r, ca.SX.zeros(2, 2))
    if _is_line_frame(J):
        G = A[1:3, :] + rhs
        new = ca.vertcat(A[0, :] + ca.mtimes(ca.horzcat(*piv[6:8]), G), -A[1:3, :] - 2 * rhs)
    else:
        M = ca.reshape(ca.vertcat(*piv[6:12]), 3, 2)
        if n_pivot > 12:
            J = ca.reshape(ca.vertcat(*piv[12:18]), 2, 3)
        G = ca.mtimes(J, A) + rhs
        new = A + ca.mtimes(M, G)
    V = ca.vec(ca.mtimes(neg_inv, G))                 # xi/2 (W0_j, vec W1_j)
    return ca.Function("spatial_rates_step", [carry, *piv], [ca.vec(new), *(V[k] for k in range(6))],
                       ["carry"] + [f"pivot_{k}" for k in range(n_pivot)],
                       ["carry_next"] + [f"v_{k}" for k in range(6)])


def _rate_norm_function(ctrl: SpatialController) -> ca.Function:
    """``(v_2, v_3, v_4, v_5) -> ||W1_j||`` (spectral) from ``xi/2 vec W1_j``, for the end margin's scale."""
    v = [ca.SX.sym(f"v_{k}") for k in range(2, 6)]
    norm = singular_values_2x2_select(ca.reshape(ca.vertcat(*v), 2, 2))[1] * (2 / ctrl.chain.xi)
    return ca.Function("spatial_rate_norm", v, [norm], [f"v_{k}" for k in range(2, 6)], ["norm"])


def _end_margin_function(ctrl: SpatialController) -> ca.Function:
    """``(s_row, roll_row, roll_scale, total) -> end_margin``, the end margin of the interpreted tail."""
    s_row, row = ca.SX.sym("s_row", 1, 2), ca.SX.sym("roll_row", 1, 2)
    scale, total = ca.SX.sym("roll_scale"), ca.SX.sym("total")
    margin = singular_values_2x2(ca.vertcat(s_row / (ctrl.chain.xi * total), row / scale))[0]
    return ca.Function("spatial_end_margin", [s_row, row, scale, total], [margin],
                       ["s_row", "roll_row", "roll_scale", "total"], ["end_margin"])


#: Link 1's trigonometry, the heads' inputs after the feed ``d`` (on a rail): from the law's vectorised passes.
HEAD_TRIG = ("cos_a", "sin_a", "cos_b", "sin_b")


def _head_inputs(ctrl: SpatialController) -> tuple[list, Any, Any]:
    """The heads' inputs ``([d,] cos a_1, sin a_1, cos b_1, sin b_1)``, ``d`` (None for a fixed base) and ``R_1``."""
    trig = [ca.SX.sym(n) for n in HEAD_TRIG]
    d = ca.SX.sym("d") if ctrl.chain.rail else None
    return ([d] if ctrl.chain.rail else []) + trig, d, ca.mtimes(*joint_rotation(*trig))


def _to_frame(ctrl: SpatialController, t: Any, *pairs: tuple[Any, bool]) -> list:
    """Base-frame ``(value, is_point)`` pairs in the law's frame: ``F^T (y - p)`` for a point, ``F^T v`` else."""
    frame = frame_of(ctrl, t)
    if frame is None:
        return [v for v, _ in pairs]
    F, p = frame
    return [ca.mtimes(F.T, v - p if point else v) for v, point in pairs]


def _kinematics_head_expressions(ctrl: SpatialController, t: Any) -> tuple[list, list]:
    """Inputs and output of link 1's frame and centre (``y^1 = d r`` on a rail, else 0) in the law's frame at ``t``."""
    inputs, d, R = _head_inputs(ctrl)
    y = d * ca.DM(ctrl.chain.rail_direction) if ctrl.chain.rail else ca.SX.zeros(3, 1)
    R, y = _to_frame(ctrl, t, (R, False), (y, True))
    return inputs, [ca.vertcat(ca.vec(R), y)]


def _rates_head_expressions(ctrl: SpatialController, t: Any) -> tuple[list, list, list]:
    """Inputs, outputs and input names of the interpreted head (on a rail the rail head) at ``t``, with its carry
    turned into the rates carry in the law's frame.

    On a rail the last input is the end's centre ``y^m`` in the law's frame (from the kinematics loop),
    which gives the span ``sigma = psi(y^m) - psi(y^1)`` the rail head reads when the span is commanded.
    """
    inputs, d, R = _head_inputs(ctrl)
    names = list(HEAD_TRIG)
    if ctrl.chain.rail:
        y_m = ca.SX.sym("y_m", 3)
        frame = frame_of(ctrl, t)
        y_world = y_m if frame is None else ca.mtimes(frame[0], y_m) + frame[1]
        geometry = ctrl.task.geometry
        sigma = geometry(y_world, t)[3] - geometry(d * ca.DM(ctrl.chain.rail_direction), t)[3]
        carry, *rest = ctrl.recursion.rail_head_terms(d, R, t, sigma)
        inputs, names = inputs + [y_m], ["d", *names, "y_m"]
    else:
        carry, *rest = ctrl.recursion.head_terms(R, t)
    _, _, Y0, Y1, H0, H1, total = unpack_carry(carry)
    A0, A1 = _to_frame(ctrl, t, (Y0 + H0, False), (Y1 + H1, False))
    return inputs, [ca.vertcat(A0, ca.vec(A1)), total, *rest], names


def _tail_expressions(ctrl: SpatialController, t: Any) -> tuple[list, list]:
    """Inputs (but ``t``) and outputs of the interpreted end solve on link m's geometry, the rates carry after it and
    its ``xi/2 (W0_m, vec W1_m)``, at ``t``."""
    geo, carry, v = ca.SX.sym("geo", LINK_GEOMETRY), ca.SX.sym("carry", RATE_CARRY), ca.SX.sym("v", 6)
    row, rhs = ca.SX.sym("roll_row", 1, 2), ca.SX.sym("roll_rhs")
    E, y = ca.reshape(geo[0:6], 3, 2), geo[6:9]
    A0, A1 = carry[0:3], ca.reshape(carry[3:9], 3, 2)
    Y0, Y1 = A0 - ca.mtimes(E, v[0:2]), A1 - ca.mtimes(E, ca.reshape(v[2:6], 2, 2))   # y^m' = A - xi/2 E_m w_m
    _, _, _, psi, h, psit = frame_geometry(ctrl)(y, t)
    s_row = ca.mtimes(h.T, Y1)
    N = ca.vertcat(s_row, row)
    p = solve_2x2(N, ca.vertcat(ca.SX(ctrl.task.speed(t)) - psit - ca.dot(h, Y0), rhs))
    return [geo, carry, v, row, rhs], [psi, p, s_row]


def _without_time(ctrl: SpatialController) -> tuple[Any, Any, list[list], Any, list]:
    """Every once-per-call and per-link expression of the law with its time-only terms pulled out together.

    Returns ``(t, w(t), groups, w, inputs)``: ``groups`` = pivot (pivot, out), 1/det, kinematics head, rates head, tail,
    each a list of expressions of ``w`` (the time features' symbols) instead of ``t``; ``inputs`` their other
    inputs (geo, inv, J, pivot width; kinematics head's; rates head's and names; tail's).
    """
    t = ca.SX.sym("t")
    (geo, inv), (piv, out, inv_expr), J = link_pivot_expressions(ctrl, t)
    kin_in, kin_out = _kinematics_head_expressions(ctrl, t)
    head_in, head_out, head_names = _rates_head_expressions(ctrl, t)
    tail_in, tail_out = _tail_expressions(ctrl, t)
    groups = [[piv, out], [inv_expr], kin_out, head_out, tail_out]
    flat = [e for g in groups for e in g]
    expr, wsym, wexpr = split_time_terms(ca.vertcat(*[ca.vec(e) for e in flat]), t)
    ends = np.cumsum([0] + [e.numel() for e in flat])
    parts = iter(ca.reshape(expr[i:j], e.size1(), e.size2()) for i, j, e in zip(ends[:-1], ends[1:], flat))
    groups = [[next(parts) for _ in g] for g in groups]
    return t, wexpr, groups, wsym, [(geo, inv, J, piv.numel()), kin_in, (head_in, head_names), tail_in]


def _shared(outs: list) -> list:
    """``outs`` as one common-subexpression-eliminated graph (the outputs share their terms), in their shapes."""
    both = ca.cse(ca.vertcat(*[ca.vec(o) for o in outs]))
    ends = np.cumsum([0] + [o.numel() for o in outs])
    return [ca.reshape(both[i:j], o.size1(), o.size2()) for i, j, o in zip(ends[:-1], ends[1:], outs)]


def _link_functions(ctrl: SpatialController) -> tuple[ca.Function, ...]:
    """``(time_features, kinematics_step, link_pivot, link_inv_det, rates_step, kinematics_head, tail, rate_norm,
    end_margin, rates_head, link_pivot_rates)`` of ``ctrl``: every time-only term (of the pivots, heads and tail) in the time features."""
    t, wexpr, (pivot_out, inv_out, kin_out, head_out, tail_out), w, inputs = _without_time(ctrl)
    (geo, inv, J, n), kin_in, (head_in, head_names), tail_in = inputs
    tf = ca.Function("spatial_time_features", [t], [ca.cse(wexpr)], ["t"], ["w"])
    body = ca.cse(ca.vertcat(*pivot_out))
    names = [f"g{k}" for k in range(LINK_GEOMETRY)]
    pivot = ca.Function("spatial_link_pivot", [*geo, w, inv], [body[k] for k in range(n + 3)],
                        names + ["w", "inv_det"], [f"pivot_{k}" for k in range(n)] + ["e_1", "e_2", "margin"])
    inv_det = ca.Function("spatial_link_inv_det", [*geo, w], [ca.cse(inv_out[0])], names + ["w"], ["inv_det"])
    rates_only = ca.cse(pivot_out[0])
    pivot_rates = ca.Function("spatial_link_pivot_rates", [*geo, w, inv], [rates_only[k] for k in range(n)],
                              names + ["w", "inv_det"], [f"pivot_{k}" for k in range(n)])
    kin_head = ca.Function("spatial_kinematics_head", [*kin_in, w], _shared(kin_out),
                           (["d"] if ctrl.chain.rail else []) + list(HEAD_TRIG) + ["w"], ["kinematics"])
    if ctrl.chain.rail:
        head_in = head_in[:-1] + [w, head_in[-1]]
        head_names = head_names[:-1] + ["w", head_names[-1]]
    else:
        head_in, head_names = head_in + [w], head_names + ["w"]
    rail = ["d_dot", "rail_margin", "psi_1"] if ctrl.chain.rail else []
    rates_head = ca.Function("spatial_rates_head", head_in, _shared(head_out), head_names,
                             ["rates", "total", "roll", "roll_row", "roll_rhs", "roll_scale"] + rail)
    tail = ca.Function("spatial_frame_tail", [*tail_in[:3], w, *tail_in[3:]], _shared(tail_out),
                       ["geo", "carry", "v", "w", "roll_row", "roll_rhs"], ["s", "p", "s_row"])
    return (tf, _kinematics_function(ctrl), pivot, inv_det, _rates_function(ctrl, J, n), kin_head, tail,
            _rate_norm_function(ctrl), _end_margin_function(ctrl), rates_head, pivot_rates)


def _cached(ctrl: SpatialController) -> tuple[ca.Function, ...]:
    per_ctrl = _CACHE.setdefault(ctrl, {})
    if "link" not in per_ctrl:
        per_ctrl["link"] = _link_functions(ctrl)
    return per_ctrl["link"]


def spatial_time_features(ctrl: SpatialController) -> ca.Function:
    """``t -> w``: the time-only terms of the link pivots, both heads and the end solve, computed once per law call.

    For a line: its frame and point, their rates and the roll and speed commands (the C's third RK4 stage
    reuses the second's, at the same time).

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Input ``t`` [s], output ``w`` (one 0 for a static curve).
    """
    return _cached(ctrl)[0]


def spatial_kinematics_step(ctrl: SpatialController) -> ca.Function:
    """One link's forward kinematics: ``(carry, cos a_j, sin a_j, cos b_j, sin b_j) -> carry_next``.

    ``R_j = R_{j-1} Rz(a_j) Ry(b_j)``, ``y^j = y^{j-1} + xi/2 (d_{j-1} + d_j)``, in the law's frame.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Carry ``(vec R_j (9), y^j (3) [m])`` (:data:`KIN_CARRY`); its entries 3..11 are the link's
        geometry ``(vec E_j, y^j)`` that :func:`spatial_rates_step` reads.
    """
    return _cached(ctrl)[1]


def spatial_rates_step(ctrl: SpatialController) -> ca.Function:
    """One link ``j >= 2`` of the spatial solve's rates: ``(carry, pivot_0, ..., pivot_n-1) -> (carry_next, v_0, ..., v_5)``.

    The operations of :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.link_step` after the
    kinematics and the link pivot (:func:`spatial_link_pivot`'s first outputs).

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Carry ``(A0 (3), vec A1 (6))`` (:data:`RATE_CARRY`, ``A0 + A1 p = y^j' + xi/2 E_j w_j`` [m/s]);
        ``v = (xi/2 W0_j [m/s] (2), xi/2 vec W1_j [m] (4))`` (the link rates ``w_j = W0_j + W1_j p`` times
        ``xi/2``).
    """
    return _cached(ctrl)[4]


def spatial_link_inv_det(ctrl: SpatialController) -> ca.Function:
    """``(geo_j, w) -> 1 / det P_j`` for :func:`spatial_rates_step`.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Output ``inv_det`` [-]: the reciprocal of the determinant of the link pivot over ``xi/2``,
        ``dPhi/dy E_j`` (2x2, [1/rad]) [rad^2].
    """
    return _cached(ctrl)[3]


def spatial_link_pivot(ctrl: SpatialController) -> ca.Function:
    """One link's pivot, no carry: ``(g_0, ..., g_8, w, inv_det) -> (pivot_0, ..., pivot_n-1, e_1, e_2, margin)``.

    All scalars (the C loop over links passes each as a pointer into an array per quantity, so the
    loop vectorises): the link's geometry ``(vec E_j, y^j)`` from :func:`spatial_kinematics_step`, the
    time features, ``1 / det P_j`` (:func:`spatial_link_inv_det`); out the rates step's inputs
    ``K Phi + Phit`` [m/s] (2), ``vec(-P_j^-1)`` (4), ``vec(2 E_j (-P_j^-1))`` (6) and, where
    ``dPhi/dy`` varies along the curve, ``vec dPhi/dy`` (6); then ``e^j`` [m] and the link margin.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
    """
    return _cached(ctrl)[2]


def spatial_link_pivot_rates(ctrl: SpatialController) -> ca.Function:
    """:func:`spatial_link_pivot` without ``e^j`` and the link margin: ``(g_0, ..., g_8, w, inv_det) -> (pivot_0, ...)``.

    The same arithmetic for the rates step's inputs; the C law calls it in the later stages of an RK4 step,
    which read only the joint rates.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
    """
    return _cached(ctrl)[10]


def spatial_kinematics_head(ctrl: SpatialController) -> ca.Function:
    """Link 1's kinematics carry: ``([d,] cos a_1, sin a_1, cos b_1, sin b_1, w) -> kinematics``.

    ``(vec R_1, y^1)`` (:data:`KIN_CARRY`) in the law's frame (:mod:`.spatial_frame`), ``y^1 = d r`` on a
    rail (``d`` first), the origin else.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Inputs ``d`` [m] (on a rail only), the cosines and sines of ``a_1``, ``b_1`` [-] (:data:`HEAD_TRIG`),
        the time features ``w`` (:func:`spatial_time_features`); output the carry (12).
    """
    return _cached(ctrl)[5]


def spatial_rates_head(ctrl: SpatialController) -> ca.Function:
    """Link 1's rates carry and the roll row: ``([d,] cos a_1, sin a_1, cos b_1, sin b_1, w[, y_m]) -> (rates,
    total, roll, roll_row, roll_rhs, roll_scale[, d_dot, rail_margin, psi_1])``.

    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.head` (on a rail
    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.rail_head`, given the end's centre ``y^m``
    in the law's frame for the span) with its carry as the rates carry ``A = y^1' + xi/2 E_1 w_1``
    (:func:`spatial_rates_step`) in the law's frame, and the end margin's running sum (1); built over ``R_1``
    (:meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.head_terms`) from the cosines and sines,
    its time-only terms read from the time features ``w``.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        The rates carry (9) [m/s], ``total`` [-], the roll [rad], ``roll_row`` (1, 2), ``roll_rhs`` [rad/s],
        ``roll_scale``; on a rail ``d_dot`` [m/s], ``rail_margin`` [-] and ``psi_1`` [m].
    """
    return _cached(ctrl)[9]


def spatial_frame_tail(ctrl: SpatialController) -> ca.Function:
    """The 2x2 end solve: ``(geo_m, carry_m, v_m, w, roll_row, roll_rhs) -> (s, p, s_row)``.

    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.tail` on link m's geometry and the
    rates carry after link m, whose ``A = y^m' + xi/2 E_m w_m`` gives ``y^m' = A - E_m v_m`` with
    ``v_m = xi/2 (W0_m, vec W1_m)`` (link m's second output, :func:`spatial_rates_step`); its time-only terms
    read from the time features ``w`` (:func:`spatial_time_features`).

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        ``s`` [m], ``p = w_1`` (2,) [rad/s], the ``s`` row ``grad psi . Y1`` (1, 2) for the end margin.
    """
    return _cached(ctrl)[6]


def spatial_rate_norm(ctrl: SpatialController) -> ca.Function:
    """``||W1_j||`` (spectral norm) from link j's ``xi/2 vec W1_j`` (4 scalars), for the end margin.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Inputs ``v_2 .. v_5`` [m] (:func:`spatial_rates_step`'s outputs 2-5); output ``norm`` [-].
    """
    return _cached(ctrl)[7]


def spatial_end_margin(ctrl: SpatialController) -> ca.Function:
    """The end margin: ``(s_row, roll_row, roll_scale, total) -> end_margin``.

    The smallest singular value of the end solve's matrix with its ``s`` row over ``xi total``
    (``total = sum_j ||W1_j||``, ``W1_1 = I``) and its roll row over ``roll_scale``, as in
    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.tail`.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Output ``end_margin`` [-].
    """
    return _cached(ctrl)[8]
