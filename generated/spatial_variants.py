"""The C-only variants of the spatial law's Functions (:mod:`coordarm.symbolic.spatial_recursion`).

The interpreted spatial solve builds each joint's rotation ``Rz(a_j) Ry(b_j)`` from its angles. The
generated C computes the cosines and sines of every joint angle in vectorised loops first and passes
them in, so the per-link step (:func:`spatial_link_step_trig`) and the per-joint step
(:func:`spatial_joint_step_trig`) have no trigonometry; the time-only terms of the curve's geometry
are computed once per law call (:func:`spatial_time_features`). The head and the end solve are the
interpreted ones (called once per law call). The Functions are cached per controller here.
"""
from __future__ import annotations

import weakref
from typing import Any

import casadi as ca

from coordarm.symbolic import SpatialController
from coordarm.symbolic.recursion import split_time_terms
from coordarm.symbolic.spatial_recursion import singular_values_2x2, solve_2x2, unpack_carry

from .spatial_frame import frame_geometry, frame_of

_CACHE: "weakref.WeakKeyDictionary[SpatialController, dict]" = weakref.WeakKeyDictionary()
#: Inputs of the per-link step: the carry, the joint's four cosines and sines, the time features.
LINK_INPUTS = ["carry", "cos_a", "sin_a", "cos_b", "sin_b", "w"]
#: Size of the per-link step's second output: ``(e^j (2), link margin, xi/2 W0_j (2), xi/2 vec W1_j (4))``.
LINK_OUT = 9
#: Size of the compiled forward carry: ``R`` (9), ``y`` (3), ``A`` affine in ``p`` (3 + 6), ``sum ||W1||`` (1).
FRAME_CARRY = 22
#: Size of the joint loop's carry: the previous link's angular velocity in its own frame.
JOINT_CARRY = 3


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
    """``(smallest, largest)`` singular value of a 2x2 matrix, with ``fmax(x, 0)`` written as a select.

    As :func:`~coordarm.symbolic.spatial_recursion.singular_values_2x2`; C's ``fmax`` is a library call unless NaN may be ignored; ``x > 0 ? x : 0`` is one instruction and
    gives the same value, NaN included (``fmax(NaN, 0) = 0``).

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
    plus, minus = ca.sqrt(F + 2 * D), ca.sqrt(ca.if_else(gap > 0, gap, 0))
    return 0.5 * (plus - minus), 0.5 * (plus + minus)


def pack_frame_carry(R: Any, y: Any, A0: Any, A1: Any, total: Any) -> Any:
    """The compiled forward carry as one column (:data:`FRAME_CARRY` doubles).

    Parameters
    ----------
    R : casadi.SX, shape (3, 3)
        The link frame, in the law's frame (:mod:`.spatial_frame`).
    y : casadi.SX, shape (3,)
        The link's centre [m].
    A0, A1 : casadi.SX, shapes (3,) and (3, 2)
        ``y^j' + xi/2 E_j w_j = A0 + A1 p`` [m/s]: the next centre's velocity before the next link's rate.
    total : casadi.SX
        The running ``sum ||W1||`` [-].

    Returns
    -------
    casadi.SX, shape (22, 1)
    """
    return ca.vertcat(ca.vec(R), y, A0, ca.vec(A1), total)


def unpack_frame_carry(c: Any) -> tuple[Any, ...]:
    """``(R, y, A0, A1, total)`` of a compiled carry column (inverse of :func:`pack_frame_carry`).

    Parameters
    ----------
    c : casadi.SX, shape (22, 1)

    Returns
    -------
    tuple of casadi.SX
    """
    return ca.reshape(c[0:9], 3, 3), c[9:12], c[12:15], ca.reshape(c[15:21], 3, 2), c[21]


def _link_expressions(ctrl: SpatialController):
    """Symbolic inputs ``(carry, trig, t, inv_det)`` and ``(carry_next, out_j, 1 / det P_j)`` of one link step.

    As :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.link_step` with the joint's cosines and
    sines as inputs and the reciprocal of the link pivot's determinant as an input too (its expression is
    returned for :func:`spatial_link_inv_det`): one division per link instead of six (CasADi would fold
    ``x * (1/y)`` back into a division). In the law's frame (:mod:`.spatial_frame`: on a line the
    geometry and ``dPhi/dy`` are free). The pivot is taken over ``xi/2`` (``J E_j``): the carried
    ``xi/2 E_j w_j`` is then ``E_j V_j`` with ``V_j = xi/2 w_j`` (the joint loop scales ``V_j`` back);
    ``-P^-1`` is formed once and applied to both right-hand sides. The carry holds
    ``A = y^j' + xi/2 E_j w_j`` only (the next centre's rate before the next link's own), updated as
    ``A + 2 E_j V_j``.
    """
    xi, K = ctrl.chain.xi, ctrl.gain
    carry, t, inv = ca.SX.sym("carry", FRAME_CARRY), ca.SX.sym("t"), ca.SX.sym("inv_det")
    trig = [ca.SX.sym(name) for name in LINK_INPUTS[1:5]]
    R_prev, y_prev, A0, A1, total = unpack_frame_carry(carry)
    rz, ry = joint_rotation(*trig)
    R = ca.mtimes(ca.mtimes(R_prev, rz), ry)
    E = R[:, 1:3]
    y = y_prev + 0.5 * xi * (R_prev[:, 0] + R[:, 0])
    Phi, J, Phit, *_ = frame_geometry(ctrl)(y, t)
    P = ca.mtimes(J, E)                  # the link pivot over xi/2 (the xi/2 cancels from xi/2 E w_j)
    neg_inv = ca.vertcat(ca.horzcat(-P[1, 1], P[0, 1]), ca.horzcat(P[1, 0], -P[0, 0])) * inv   # -P^-1
    V0 = ca.mtimes(neg_inv, K * Phi + Phit + ca.mtimes(J, A0))      # xi/2 W0_j
    V1 = ca.mtimes(neg_inv, ca.mtimes(J, A1))                        # xi/2 W1_j
    new = pack_frame_carry(R, y, A0 + 2 * ca.mtimes(E, V0), A1 + 2 * ca.mtimes(E, V1),
                           total + singular_values_2x2_select(V1)[1] * (2 / xi))
    out = ca.vertcat(Phi, singular_values_2x2_select(P)[0], V0, ca.vec(V1))
    inv_expr = 1 / (P[0, 0] * P[1, 1] - P[0, 1] * P[1, 0])
    return (carry, trig, t, inv), (new, out, inv_expr)


def _head_function(ctrl: SpatialController) -> ca.Function:
    """The interpreted head with its carry turned into the compiled one, in the law's frame."""
    ab, t = ca.SX.sym("ab", 2), ca.SX.sym("t")
    carry, *rest = ctrl.recursion.head()(ab, t)
    R, y, Y0, Y1, H0, H1, total = unpack_carry(carry)
    A0, A1 = Y0 + H0, Y1 + H1
    frame = frame_of(ctrl, t)
    if frame is not None:
        F, p = frame
        R, y, A0, A1 = ca.mtimes(F.T, R), ca.mtimes(F.T, y - p), ca.mtimes(F.T, A0), ca.mtimes(F.T, A1)
    return ca.Function("spatial_frame_head", [ab, t], [pack_frame_carry(R, y, A0, A1, total), *rest],
                       ["ab", "t"], ["carry", "roll", "roll_row", "roll_rhs", "roll_scale"])


def _tail_function(ctrl: SpatialController) -> ca.Function:
    """The interpreted end solve on the compiled carry of link m and link m's ``xi/2 (W0_m, vec W1_m)``."""
    carry, v, t = ca.SX.sym("carry", FRAME_CARRY), ca.SX.sym("v", 6), ca.SX.sym("t")
    row, rhs, scale = ca.SX.sym("roll_row", 1, 2), ca.SX.sym("roll_rhs"), ca.SX.sym("roll_scale")
    R, y, A0, A1, total = unpack_frame_carry(carry)
    E = R[:, 1:3]
    Y0, Y1 = A0 - ca.mtimes(E, v[0:2]), A1 - ca.mtimes(E, ca.reshape(v[2:6], 2, 2))   # y^m' = A - xi/2 E_m w_m
    _, _, _, psi, h, psit = frame_geometry(ctrl)(y, t)
    s_row = ca.mtimes(h.T, Y1)
    N = ca.vertcat(s_row, row)
    p = solve_2x2(N, ca.vertcat(ca.SX(ctrl.task.speed(t)) - psit - ca.dot(h, Y0), rhs))
    margin = singular_values_2x2(ca.vertcat(s_row / (ctrl.chain.xi * total), row / scale))[0]
    return ca.Function("spatial_frame_tail", [carry, v, t, row, rhs, scale], [psi, p, margin],
                       ["carry", "v", "t", "roll_row", "roll_rhs", "roll_scale"], ["s", "p", "end_margin"])


def _link_functions(ctrl: SpatialController) -> tuple[ca.Function, ...]:
    """``(time_features, link_step_trig, link_inv_det, head, tail)`` of ``ctrl``."""
    (carry, trig, t, inv), (new, out, inv_expr) = _link_expressions(ctrl)
    expr, wsym, wexpr = split_time_terms(ca.vertcat(new, out, inv_expr), t)
    n = FRAME_CARRY + LINK_OUT
    tf = ca.Function("spatial_time_features", [t], [ca.cse(wexpr)], ["t"], ["w"])
    body = ca.cse(expr[:n])
    step = ca.Function("spatial_link_step_trig", [carry, *trig, wsym, inv],
                       [body[:FRAME_CARRY], body[FRAME_CARRY:]],
                       LINK_INPUTS + ["inv_det"], ["carry_next", "out"])
    inv_det = ca.Function("spatial_link_inv_det", [carry, *trig, wsym], [ca.cse(expr[n])], LINK_INPUTS, ["inv_det"])
    return tf, step, inv_det, _head_function(ctrl), _tail_function(ctrl)


def _cached(ctrl: SpatialController) -> tuple[ca.Function, ...]:
    per_ctrl = _CACHE.setdefault(ctrl, {})
    if "link" not in per_ctrl:
        per_ctrl["link"] = _link_functions(ctrl)
    return per_ctrl["link"]


def spatial_time_features(ctrl: SpatialController) -> ca.Function:
    """``t -> w``: the time-only terms of :func:`spatial_link_step_trig`, computed once per law call.

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


def spatial_link_step_trig(ctrl: SpatialController) -> ca.Function:
    """One link ``j >= 2`` of the spatial solve with the joint's cosines and sines as inputs.

    ``(carry, cos a_j, sin a_j, cos b_j, sin b_j, w, inv_det) -> (carry_next, out_j)``, the operations of
    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.link_step` without trigonometry and with
    the reciprocal of the link pivot's determinant from :func:`spatial_link_inv_det`.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Carry layout of :func:`pack_frame_carry` (:data:`FRAME_CARRY`, in the law's frame);
        ``out_j = (e^j [m] (2), link margin [-], xi/2 W0_j [m/s] (2), xi/2 vec W1_j [m] (4))``
        (the link rates ``w_j = W0_j + W1_j p`` times ``xi/2``).
    """
    return _cached(ctrl)[1]


def spatial_link_inv_det(ctrl: SpatialController) -> ca.Function:
    """``(carry, cos a_j, sin a_j, cos b_j, sin b_j, w) -> 1 / det P_j`` for :func:`spatial_link_step_trig`.

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
    return _cached(ctrl)[2]


def spatial_frame_head(ctrl: SpatialController) -> ca.Function:
    """Link 1: ``(ab_1, t) -> (carry, roll, roll_row, roll_rhs, roll_scale)`` with the compiled carry.

    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.head` with its carry turned into the
    layout of :func:`pack_frame_carry` in the law's frame (:mod:`.spatial_frame`).

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Inputs ``ab`` (2,) [rad], ``t`` [s]; the roll [rad], ``roll_row`` (1, 2), ``roll_rhs`` [rad/s], ``roll_scale``.
    """
    return _cached(ctrl)[3]


def spatial_frame_tail(ctrl: SpatialController) -> ca.Function:
    """The 2x2 end solve: ``(carry_m, v_m, t, roll_row, roll_rhs, roll_scale) -> (s, p, end_margin)``.

    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.tail` on the compiled carry after link m,
    whose ``A = y^m' + xi/2 E_m w_m`` gives ``y^m' = A - E_m v_m`` with ``v_m = xi/2 (W0_m, vec W1_m)``
    (link m's second output, :func:`spatial_link_step_trig`).

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        ``s`` [m], ``p = w_1`` (2,) [rad/s], ``end_margin`` [-].
    """
    return _cached(ctrl)[4]


def spatial_joint_step_trig() -> ca.Function:
    """Link rates to joint rates, one joint, with the joint's cosines and sines as inputs.

    ``(carry, x) -> (carry_next, out)``, ``x = (cos a_j, sin a_j, cos b_j, sin b_j, 1 / cos b_j, w_j1, w_j2)``,
    ``out = (a_j', b_j', |cos b_j|)``. The carry is the angular velocity of link ``j - 1`` in its own
    frame, ``R_{j-1}^T omega_{j-1}`` (3) [rad/s], zero before the first joint: the rates of
    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.joint_step` (which carries ``R_{j-1}`` and
    ``omega_{j-1}`` in the base frame) without a frame product.

    Returns
    -------
    casadi.Function
        Rates in [rad/s].
    """
    omega, x = ca.SX.sym("carry", JOINT_CARRY), ca.SX.sym("x", 7)
    ca_, sa, cb, sb, inv_cb, w1, w2 = (x[k] for k in range(7))
    v0, v1 = ca_ * omega[0] + sa * omega[1], ca_ * omega[1] - sa * omega[0]     # Rz(a)^T omega
    local = ca.vertcat(cb * v0 - sb * omega[2], v1, sb * v0 + cb * omega[2])       # Ry(b)^T Rz(a)^T omega
    b_dot = -w2 - local[1]
    a_dot = (w1 - local[2]) * inv_cb
    # R_j^T (omega + a_dot R_{j-1} e_z + b_dot R_{j-1} Rz(a) e_y), with Ry^T Rz^T e_z = (-sb, 0, cb)
    new = ca.vertcat(local[0] - a_dot * sb, local[1] + b_dot, local[2] + a_dot * cb)
    return ca.Function("spatial_joint_step_trig", [omega, x], [new, ca.vertcat(a_dot, b_dot, ca.fabs(cb))],
                       ["carry", "x"], ["carry_next", "out"])
