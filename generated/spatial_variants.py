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
from coordarm.symbolic.spatial_recursion import (SPATIAL_CARRY, pack_carry, singular_values_2x2, solve_2x2,
                                                 unpack_carry)

_CACHE: "weakref.WeakKeyDictionary[SpatialController, dict]" = weakref.WeakKeyDictionary()
#: Inputs of the per-link step: the carry, the joint's four cosines and sines, the time features.
LINK_INPUTS = ["carry", "cos_a", "sin_a", "cos_b", "sin_b", "w"]
#: Size of the per-link step's second output: ``(e^j (2), link margin, W0_j (2), vec W1_j (4))``.
LINK_OUT = 9
#: Size of the joint loop's carry: ``vec R_{j-1}`` (9) and ``omega_{j-1}`` (3).
JOINT_CARRY = 12


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


def _link_functions(ctrl: SpatialController) -> tuple[ca.Function, ca.Function]:
    """``(time_features, link_step_trig)``: the link step of ``SpatialRecursion.link_step`` with trig inputs."""
    xi, K = ctrl.chain.xi, ctrl.gain
    carry, t = ca.SX.sym("carry", SPATIAL_CARRY), ca.SX.sym("t")
    trig = [ca.SX.sym(name) for name in LINK_INPUTS[1:5]]
    R_prev, y_prev, Y0, Y1, H0, H1, total = unpack_carry(carry)
    R = ca.mtimes(R_prev, ca.mtimes(*joint_rotation(*trig)))
    E = R[:, 1:3]
    y = y_prev + 0.5 * xi * (R_prev[:, 0] + R[:, 0])
    Phi, J, Phit, *_ = ctrl.task.geometry(y, t)
    P = 0.5 * xi * ca.mtimes(J, E)                       # the link pivot
    A0, A1 = Y0 + H0, Y1 + H1
    W0 = solve_2x2(P, -K * Phi - Phit - ca.mtimes(J, A0))
    W1 = solve_2x2(P, -ca.mtimes(J, A1))
    H0n, H1n = 0.5 * xi * ca.mtimes(E, W0), 0.5 * xi * ca.mtimes(E, W1)
    new = pack_carry(R, y, A0 + H0n, A1 + H1n, H0n, H1n, total + singular_values_2x2(W1)[1])
    out = ca.vertcat(Phi, singular_values_2x2(P)[0] / (0.5 * xi), W0, ca.vec(W1))
    expr, wsym, wexpr = split_time_terms(ca.vertcat(new, out), t)
    expr = ca.cse(expr)
    tf = ca.Function("spatial_time_features", [t], [ca.cse(wexpr)], ["t"], ["w"])
    step = ca.Function("spatial_link_step_trig", [carry, *trig, wsym], [expr[:SPATIAL_CARRY], expr[SPATIAL_CARRY:]],
                       LINK_INPUTS, ["carry_next", "out"])
    return tf, step


def _cached(ctrl: SpatialController) -> tuple[ca.Function, ca.Function]:
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

    ``(carry, cos a_j, sin a_j, cos b_j, sin b_j, w) -> (carry_next, out_j)``, the operations of
    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.link_step` without trigonometry.

    Parameters
    ----------
    ctrl : SpatialController
        The controller.

    Returns
    -------
    casadi.Function
        Carry layout of :data:`~coordarm.symbolic.spatial_recursion.SPATIAL_CARRY` (31);
        ``out_j = (e^j [m] (2), link margin [-], W0_j [rad/s] (2), vec W1_j [-] (4))``.
    """
    return _cached(ctrl)[1]


def spatial_joint_step_trig() -> ca.Function:
    """Link rates to joint rates, one joint, with the joint's cosines and sines as inputs.

    ``(carry, x) -> (carry_next, out)``, ``x = (cos a_j, sin a_j, cos b_j, sin b_j, w_j1, w_j2)``,
    ``out = (a_j', b_j', |cos b_j|)``; the carry is ``(vec R_{j-1}, omega_{j-1})`` (12), as in
    :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.joint_step`.

    Returns
    -------
    casadi.Function
        Rates in [rad/s].
    """
    carry, x = ca.SX.sym("carry", JOINT_CARRY), ca.SX.sym("x", 6)
    R_prev, omega = ca.reshape(carry[0:9], 3, 3), carry[9:12]
    rz, ry = joint_rotation(x[0], x[1], x[2], x[3])
    Ra = ca.mtimes(R_prev, rz)
    R = ca.mtimes(Ra, ry)
    local = ca.mtimes(R.T, omega)
    b_dot = -x[5] - local[1]
    a_dot = (x[4] - local[2]) / x[2]
    omega = omega + a_dot * R_prev[:, 2] + b_dot * Ra[:, 1]
    new = ca.cse(ca.vertcat(ca.vec(R), omega, a_dot, b_dot, ca.fabs(x[2])))
    return ca.Function("spatial_joint_step_trig", [carry, x], [new[:JOINT_CARRY], new[JOINT_CARRY:]],
                       ["carry", "x"], ["carry_next", "out"])
