"""Link rates to joint rates in the compiled spatial law: one multiply-add per joint in sequence.

The interpreted :meth:`~coordarm.symbolic.spatial_recursion.SpatialRecursion.joint_step` carries the
previous link's frame and angular velocity from joint to joint. In link j's own frame its angular
velocity is ``omega^(j) = (x_j, -w_j2, w_j1)``: the two components across the link are its link
rates (``d_j' = E_j w_j``), only the spin ``x_j`` about the link is carried. With ``u = Ry(b_j)^T
Rz(a_j)^T omega^(j-1)`` (``x, y, z`` the components of ``omega^(j-1)``, zero before the first joint):

* ``b_j' = -w_j2 - u_y``, ``a_j' = (w_j1 - u_z) / cos b_j`` (the interpreted formulas);
* ``x_j = u_x - a_j' sin b_j = (cos a_j x + sin a_j y) / cos b_j - tan b_j w_j1`` (with
  ``cos b + sin^2 b / cos b = 1 / cos b``), i.e. ``x_j = alpha_j x_{j-1} + beta_j``.

So ``alpha_j, beta_j`` (:func:`spatial_joint_prep`) and the rates (:func:`spatial_joint_rates`) are
independent per joint (vectorised C loops), and only ``x_j = alpha_j x_{j-1} + beta_j`` runs in
sequence. Every argument is a scalar, so the C passes pointers into an array per quantity.
"""
from __future__ import annotations

import casadi as ca

#: Inputs of :func:`spatial_joint_prep`.
PREP_INPUTS = ["cos_a", "sin_a", "sin_b", "inv_cos_b", "w1", "w2_prev"]
#: Inputs of :func:`spatial_joint_rates`.
RATES_INPUTS = ["cos_a", "sin_a", "cos_b", "sin_b", "inv_cos_b", "x_prev", "w1_prev", "w2_prev", "w1", "w2"]


def spatial_joint_prep() -> ca.Function:
    """``alpha_j, beta_j`` of the spin recursion ``x_j = alpha_j x_{j-1} + beta_j`` at joint j.

    Returns
    -------
    casadi.Function
        Inputs :data:`PREP_INPUTS`: the joint's ``cos a_j, sin a_j, sin b_j, 1 / cos b_j``, link j's rate
        ``w_j1`` and link j-1's ``w_{j-1,2}`` (0 before link 1) [rad/s]; outputs ``alpha`` [-], ``beta`` [rad/s].
    """
    ca_, sa, sb, ic, w1, w2p = (ca.SX.sym(n) for n in PREP_INPUTS)
    alpha, beta = ic * ca_, ic * (sa * -w2p - sb * w1)
    return ca.Function("spatial_joint_prep", [ca_, sa, sb, ic, w1, w2p], [alpha, beta], PREP_INPUTS,
                       ["alpha", "beta"])


def spatial_joint_rates() -> ca.Function:
    """Joint j's rates from link j-1's angular velocity ``(x_{j-1}, -w_{j-1,2}, w_{j-1,1})`` and link j's rates.

    Returns
    -------
    casadi.Function
        Inputs :data:`RATES_INPUTS` (trigonometry of ``a_j, b_j``; the spin [rad/s] and link rates
        [rad/s] of link j-1, zero before link 1; link j's rates); outputs ``a_dot``, ``b_dot`` [rad/s] and
        the joint margin ``|cos b_j|``.
    """
    ca_, sa, cb, sb, ic, x, w1p, w2p, w1, w2 = (ca.SX.sym(n) for n in RATES_INPUTS)
    y, z = -w2p, w1p
    v0, v1 = ca_ * x + sa * y, ca_ * y - sa * x                  # Rz(a)^T omega
    b_dot = -w2 - v1
    a_dot = (w1 - (sb * v0 + cb * z)) * ic
    return ca.Function("spatial_joint_rates", [ca_, sa, cb, sb, ic, x, w1p, w2p, w1, w2],
                       [a_dot, b_dot, ca.fabs(cb)], RATES_INPUTS, ["a_dot", "b_dot", "joint_margin"])
