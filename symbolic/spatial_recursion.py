"""The O(m) structured solve of the spatial law (docs/guide/spatial.md), as CasADi ``mapaccum`` loops.

Link rates: ``d_j' = E_j w_j`` with ``E_j = [R_j e_y, R_j e_z]`` (3x2), ``w_j`` in R^2, so
``y^j' = y^{j-1}' + xi/2 (E_{j-1} w_{j-1} + E_j w_j)`` and ``y^1' = 0`` (fixed base). With
``w_1 = p`` free, the forward loop carries ``y^j'`` and ``xi/2 E_j w_j`` as affine functions of
``p``; the two rows of ``e^j' = -K e^j`` give ``w_j = W0_j + W1_j p`` through the 2x2 **link pivot**
``P_j = xi/2 dPhi/dy(y^j) E_j``. The ``s`` row and the roll row (which sees ``w_1 = p`` only) then
fix ``p`` by a 2x2 **end solve**. A second loop turns link rates into joint rates: with
``omega_j`` the angular velocity of link j (``omega_0 = 0``),
``b_j' = -w_j2 - (R_j^T omega_{j-1})_y`` and ``a_j' = (w_j1 - (R_j^T omega_{j-1})_z) / cos b_j``.

Margins (dimensionless, 0 at a singularity):

* link margin of link j = 2..m: the smallest singular value of ``P_j`` over ``xi/2`` (1 when the
  link lies along the tangent; 0 when it stands across the curve);
* end margin: the smallest singular value of the end solve's 2x2 matrix with its ``s`` row divided by
  ``xi sum_j ||W1_j||`` (``W1_1 = I``, spectral norms; the planar longitudinal margin's scale) and its
  roll row by ``|d theta / d d_1|`` (which makes the roll row a unit vector);
* joint margin of joint j: ``|cos b_j|`` (0: the two angles cannot express the link's turn).

On a rail (the feed axis, ``q = (d, a_1, b_1, ...)``) the span row minus the ``s`` row leaves
``grad psi(y^1) . r d' = v* - sigma' - dpsi/dt(y^1)`` (``y^1 = d r`` depends on ``d`` alone, the frames
do not): the rail rate, dividing by the **rail pivot** ``grad psi(y^1) . r`` (:meth:`SpatialRecursion.rail_head`).
The forward loop then starts with ``y^1' = d' r``, and the roll row, whose frame sits at the closest
point of ``y^1``, loses ``dtheta/dy^1 . r d'`` from its right-hand side. The rail margin is
``|grad psi(y^1) . r| / |grad psi(y^1)|`` (0: the rail stands across the path).
"""
from __future__ import annotations

from typing import Any

import casadi as ca

from .spatial_chain import SpatialChain, rot_y, rot_z
from .spatial_task import SpatialTask

#: Size of the forward loop's carry: ``R`` (9), ``y`` (3), ``y'`` affine (3 + 6), ``xi/2 E w`` affine
#: (3 + 6) and the running ``sum ||W1||`` (1).
SPATIAL_CARRY = 31


def singular_values_2x2(A: Any) -> tuple[Any, Any]:
    """``(smallest, largest)`` singular value of a 2x2 matrix in closed form.

    With ``F = ||A||_F^2`` and ``D = |det A|``: ``s_max + s_min = sqrt(F + 2 D)``,
    ``s_max - s_min = sqrt(F - 2 D)``.

    Parameters
    ----------
    A : casadi expression, shape (2, 2)

    Returns
    -------
    (casadi expression, casadi expression)
    """
    F = ca.sumsqr(A)
    D = ca.fabs(A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0])
    plus, minus = ca.sqrt(F + 2 * D), ca.sqrt(ca.fmax(F - 2 * D, 0))
    return 0.5 * (plus - minus), 0.5 * (plus + minus)


def solve_2x2(A: Any, b: Any) -> Any:
    """``A^-1 b`` for a 2x2 ``A`` by the adjugate.

    Parameters
    ----------
    A : casadi expression, shape (2, 2)
    b : casadi expression, shape (2, k)

    Returns
    -------
    casadi expression, shape (2, k)
    """
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    adj = ca.vertcat(ca.horzcat(A[1, 1], -A[0, 1]), ca.horzcat(-A[1, 0], A[0, 0]))
    return ca.mtimes(adj, b) / det


def pack_carry(R: Any, y: Any, Y0: Any, Y1: Any, H0: Any, H1: Any, total: Any) -> Any:
    """The forward carry as one column (layout of :data:`SPATIAL_CARRY`).

    Parameters
    ----------
    R : casadi.SX, shape (3, 3)
        The link frame.
    y : casadi.SX, shape (3,)
        The link's centre [m].
    Y0, Y1 : casadi.SX, shapes (3,) and (3, 2)
        ``y' = Y0 + Y1 p`` [m/s].
    H0, H1 : casadi.SX, shapes (3,) and (3, 2)
        ``xi/2 E w = H0 + H1 p`` [m/s].
    total : casadi.SX
        The running ``sum ||W1||``.

    Returns
    -------
    casadi.SX, shape (31, 1)
    """
    return ca.vertcat(ca.vec(R), y, Y0, ca.vec(Y1), H0, ca.vec(H1), total)


def unpack_carry(c: Any) -> tuple[Any, ...]:
    """``(R, y, Y0, Y1, H0, H1, total)`` of a carry column (inverse of :func:`pack_carry`).

    Parameters
    ----------
    c : casadi.SX, shape (31, 1)

    Returns
    -------
    tuple of casadi.SX
    """
    return (ca.reshape(c[0:9], 3, 3), c[9:12], c[12:15], ca.reshape(c[15:21], 3, 2),
            c[21:24], ca.reshape(c[24:30], 3, 2), c[30])


class SpatialRecursion:
    """The Functions of the spatial O(m) solve of one chain and task (cached).

    Parameters
    ----------
    chain : SpatialChain
        The manipulator.
    task : SpatialTask
        Curve geometry, commands and gain.
    """

    def __init__(self, chain: SpatialChain, task: SpatialTask) -> None:
        self.chain, self.task = chain, task
        self._cache: dict = {}

    def head_terms(self, R: Any, t: Any) -> tuple[Any, ...]:
        """:meth:`head`'s outputs as expressions of link 1's frame ``R`` (3, 3) and the time ``t`` [s].

        Parameters
        ----------
        R : casadi.SX, shape (3, 3)
            ``R_1 = Rz(a_1) Ry(b_1)``.
        t : casadi.SX
            Time [s].

        Returns
        -------
        tuple of casadi.SX
            ``(carry, roll, roll_row, roll_rhs, roll_scale)`` as :meth:`head`.
        """
        E, zero = R[:, 1:3], ca.SX.zeros(3, 1)
        theta, g, theta_t, _ = self.task.roll_geometry(zero, R[:, 0], t)
        carry = pack_carry(R, zero, zero, ca.SX.zeros(3, 2), zero, 0.5 * self.chain.xi * E, 1)
        row = ca.mtimes(g.T, E)
        return carry, theta, row, self.task.roll_rate(theta, t) - theta_t, ca.norm_2(g)

    def head(self) -> ca.Function:
        """``(ab_1, t) -> (carry, roll, roll_row, roll_rhs, roll_scale)`` of link 1.

        ``roll_row = dtheta/dd_1 . E_1`` (1x2), ``roll_rhs = theta*' - K (theta - theta*) - dtheta/dt``,
        ``roll_scale = |dtheta/dd_1|``.

        Returns
        -------
        casadi.Function
        """
        if "head" not in self._cache:
            ab, t = ca.SX.sym("ab", 2), ca.SX.sym("t")
            self._cache["head"] = ca.Function(
                "spatial_head", [ab, t], list(self.head_terms(ca.mtimes(rot_z(ab[0]), rot_y(ab[1])), t)),
                ["ab", "t"], ["carry", "roll", "roll_row", "roll_rhs", "roll_scale"])
        return self._cache["head"]

    def rail_head_terms(self, d: Any, R: Any, t: Any, sigma: Any) -> tuple[Any, ...]:
        """:meth:`rail_head`'s outputs as expressions of ``d`` [m], link 1's frame ``R`` (3, 3), ``t`` [s], ``sigma`` [m].

        Parameters
        ----------
        d : casadi.SX
            The feed [m].
        R : casadi.SX, shape (3, 3)
            ``R_1 = Rz(a_1) Ry(b_1)``.
        t : casadi.SX
            Time [s].
        sigma : casadi.SX
            The span now [m].

        Returns
        -------
        tuple of casadi.SX
            ``(carry, roll, roll_row, roll_rhs, roll_scale, d_dot, rail_margin, psi_1)`` as :meth:`rail_head`.
        """
        half, rail = 0.5 * self.chain.xi, ca.DM(self.chain.rail_direction)
        y1 = d * rail
        _, _, _, psi1, h1, psit1 = self.task.geometry(y1, t)
        pivot = ca.dot(h1, rail)
        d_dot = (ca.SX(self.task.speed(t)) - self.task.span_rate(sigma, t) - psit1) / pivot
        E = R[:, 1:3]
        theta, g, theta_t, gy = self.task.roll_geometry(y1, R[:, 0], t)
        carry = pack_carry(R, y1, d_dot * rail, ca.SX.zeros(3, 2), ca.SX.zeros(3, 1), half * E, 1)
        rhs = self.task.roll_rate(theta, t) - theta_t - ca.dot(gy, rail) * d_dot
        return (carry, theta, ca.mtimes(g.T, E), rhs, ca.norm_2(g), d_dot, ca.fabs(pivot) / ca.norm_2(h1), psi1)

    def rail_head(self) -> ca.Function:
        """``(d, ab_1, t, sigma) -> (carry, roll, roll_row, roll_rhs, roll_scale, d_dot, rail_margin, psi_1)`` on a rail.

        The rail rate ``d_dot = (v* - sigma' - dpsi/dt(y^1)) / (grad psi(y^1) . r)`` with ``y^1 = d r``; the
        carry of :meth:`head` with ``y^1 = d r`` and ``y^1' = d_dot r``; the roll's right-hand side less
        ``dtheta/dy . r d_dot``. ``sigma`` is the span now [m] (used only when it is commanded).

        Returns
        -------
        casadi.Function
            Outputs as :meth:`head`'s, then ``d_dot`` [m/s], ``rail_margin`` [-] and ``psi_1`` [m].
        """
        if "rail_head" not in self._cache:
            d, ab, t, sigma = ca.SX.sym("d"), ca.SX.sym("ab", 2), ca.SX.sym("t"), ca.SX.sym("sigma")
            R = ca.mtimes(rot_z(ab[0]), rot_y(ab[1]))
            self._cache["rail_head"] = ca.Function(
                "spatial_rail_head", [d, ab, t, sigma], list(self.rail_head_terms(d, R, t, sigma)),
                ["d", "ab", "t", "sigma"],
                ["carry", "roll", "roll_row", "roll_rhs", "roll_scale", "d_dot", "rail_margin", "psi_1"])
        return self._cache["rail_head"]

    @staticmethod
    def end_step() -> ca.Function:
        """One link of the forward kinematics alone: ``(carry, ab_j) -> carry_next``, carry ``(vec R_{j-1}, y^{j-1}, h)``.

        ``h = xi/2`` [m] rides in the carry so that the step has no constant of its own.

        Returns
        -------
        casadi.Function
            ``spatial_end_step``; the carry (13) holds the frame, the centre [m] and ``xi/2`` [m].
        """
        carry, ab = ca.SX.sym("carry", 13), ca.SX.sym("ab", 2)
        R_prev, y, h = ca.reshape(carry[0:9], 3, 3), carry[9:12], carry[12]
        R = ca.mtimes(R_prev, ca.mtimes(rot_z(ab[0]), rot_y(ab[1])))
        return ca.Function("spatial_end_step", [carry, ab], [ca.vertcat(ca.vec(R), y + h * (R_prev[:, 0] + R[:, 0]), h)],
                           ["carry", "ab"], ["carry_next"])

    def span_now(self, q: Any, t: Any) -> Any:
        """``sigma = psi(y^m) - psi(y^1)`` by an O(m) loop of forward kinematics (needed only for a commanded span).

        Parameters
        ----------
        q : casadi.MX, shape (2 m + 1,)
            Joint coordinates ``(d, a_1, b_1, ...)``.
        t : casadi.MX
            Time [s].

        Returns
        -------
        casadi.MX or int
            The span [m] (0 when the span is held: the head does not read it).
        """
        if self.task.span is None:
            return 0
        m, rail = self.chain.m, ca.DM(self.chain.rail_direction)
        ab = ca.reshape(q[1:], 2, m)
        first = ca.mtimes(rot_z(ab[0, 0]), rot_y(ab[1, 0]))
        y1 = q[0] * rail
        carry = self.end_step().mapaccum("ends", m - 1)(ca.vertcat(ca.vec(first), y1, 0.5 * self.chain.xi), ab[:, 1:])
        y_m = carry[9:12, m - 2]
        return self.task.geometry(y_m, t)[3] - self.task.geometry(y1, t)[3]

    def link_step(self) -> ca.Function:
        """One link j >= 2: ``(carry, ab_j, t) -> (carry_next, out_j)``, ``out_j = (e^j, margin, W0_j, vec W1_j)`` (9).

        Returns
        -------
        casadi.Function
        """
        if "step" not in self._cache:
            xi, K = self.chain.xi, self.task.gain
            carry, ab, t = ca.SX.sym("carry", SPATIAL_CARRY), ca.SX.sym("ab", 2), ca.SX.sym("t")
            R_prev, y_prev, Y0, Y1, H0, H1, total = unpack_carry(carry)
            R = ca.mtimes(R_prev, ca.mtimes(rot_z(ab[0]), rot_y(ab[1])))
            E = R[:, 1:3]
            y = y_prev + 0.5 * xi * (R_prev[:, 0] + R[:, 0])
            Phi, J, Phit, *_ = self.task.geometry(y, t)
            P = 0.5 * xi * ca.mtimes(J, E)                   # the link pivot
            A0, A1 = Y0 + H0, Y1 + H1                        # y^j' before link j's own rate
            W0 = solve_2x2(P, -K * Phi - Phit - ca.mtimes(J, A0))
            W1 = solve_2x2(P, -ca.mtimes(J, A1))
            H0n, H1n = 0.5 * xi * ca.mtimes(E, W0), 0.5 * xi * ca.mtimes(E, W1)
            total = total + singular_values_2x2(W1)[1]
            new = pack_carry(R, y, A0 + H0n, A1 + H1n, H0n, H1n, total)
            out = ca.vertcat(Phi, singular_values_2x2(P)[0] / (0.5 * xi), W0, ca.vec(W1))
            self._cache["step"] = ca.Function("spatial_link_step", [carry, ab, t], [new, out],
                                              ["carry", "ab", "t"], ["carry_next", "out"])
        return self._cache["step"]

    def tail(self) -> ca.Function:
        """``(carry_m, t, roll_row, roll_rhs, roll_scale) -> (s, p, end_margin)``: the 2x2 end solve.

        Returns
        -------
        casadi.Function
        """
        if "tail" not in self._cache:
            carry, t = ca.SX.sym("carry", SPATIAL_CARRY), ca.SX.sym("t")
            row, rhs, scale = ca.SX.sym("roll_row", 1, 2), ca.SX.sym("roll_rhs"), ca.SX.sym("roll_scale")
            _, y, Y0, Y1, _, _, total = unpack_carry(carry)
            _, _, _, psi, h, psit = self.task.geometry(y, t)
            s_row = ca.mtimes(h.T, Y1)
            N = ca.vertcat(s_row, row)
            p = solve_2x2(N, ca.vertcat(ca.SX(self.task.speed(t)) - psit - ca.dot(h, Y0), rhs))
            margin = singular_values_2x2(ca.vertcat(s_row / (self.chain.xi * total), row / scale))[0]
            self._cache["tail"] = ca.Function("spatial_tail", [carry, t, row, rhs, scale], [psi, p, margin],
                                              ["carry", "t", "roll_row", "roll_rhs", "roll_scale"],
                                              ["s", "p", "end_margin"])
        return self._cache["tail"]

    @staticmethod
    def joint_step() -> ca.Function:
        """Link rates to joint rates, one joint: ``(carry, (a_j, b_j, w_j)) -> (carry_next, (a_j', b_j', |cos b_j|))``.

        The carry is ``(vec R_{j-1}, omega_{j-1})`` (12): the previous frame and angular velocity [rad/s].

        Returns
        -------
        casadi.Function
        """
        carry, x = ca.SX.sym("carry", 12), ca.SX.sym("x", 4)
        R_prev, omega = ca.reshape(carry[0:9], 3, 3), carry[9:12]
        Ra = ca.mtimes(R_prev, rot_z(x[0]))
        R = ca.mtimes(Ra, rot_y(x[1]))
        local = ca.mtimes(R.T, omega)
        b_dot = -x[3] - local[1]
        a_dot = (x[2] - local[2]) / ca.cos(x[1])
        omega = omega + a_dot * R_prev[:, 2] + b_dot * Ra[:, 1]
        return ca.Function("spatial_joint_step", [carry, x],
                           [ca.vertcat(ca.vec(R), omega), ca.vertcat(a_dot, b_dot, ca.fabs(ca.cos(x[1])))],
                           ["carry", "x"], ["carry_next", "out"])

    def joint_rates(self, q: Any, w: Any) -> tuple[Any, Any]:
        """Joint rates ``q'`` and joint margins from link rates ``w`` (an O(m) loop).

        Parameters
        ----------
        q : casadi.MX, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail: dropped here).
        w : casadi.MX, shape (2, m)
            Link rates ``w_j`` (``d_j' = E_j w_j``) [rad/s].

        Returns
        -------
        (casadi.MX, casadi.MX)
            ``q'`` (2 m,) [rad/s] as ``(a_1', b_1', ...)``, and ``|cos b_j|`` (m,).
        """
        m = self.chain.m
        loop = self.joint_step().mapaccum("joints", m)
        start = ca.vertcat(ca.vec(ca.DM.eye(3)), ca.DM.zeros(3, 1))
        _, outs = loop(start, ca.vertcat(ca.reshape(self.chain.angles(q), 2, m), w))
        return ca.vec(outs[0:2, :]), outs[2, :].T

    def outputs(self, q: ca.MX, t: ca.MX) -> dict[str, Any]:
        """The law's outputs by the O(m) solve, keyed by :data:`~coordarm.symbolic.outputs.SPATIAL_OUTPUTS`.

        Parameters
        ----------
        q : casadi.MX, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).
        t : casadi.MX
            Time [s].

        Returns
        -------
        dict
            ``u`` (2 m; on a rail ``d_dot`` [m/s] first), ``e`` (2 (m-1): ``e^2_1, e^2_2, e^3_1, ...``), ``s``,
            ``roll``, ``link_margins`` (m-1), ``end_margin``, ``joint_margins`` (m) (on a rail also ``sigma``
            and ``rail_margin``) as MX expressions.
        """
        m = self.chain.m
        ab = ca.reshape(self.chain.angles(q), 2, m)
        if self.chain.rail:
            carry0, roll, row, rhs, scale, d_dot, rail_margin, psi1 = self.rail_head()(q[0], ab[:, 0], t,
                                                                                        self.span_now(q, t))
        else:
            carry0, roll, row, rhs, scale = self.head()(ab[:, 0], t)
        carries, outs = self.link_step().mapaccum("links", m - 1)(carry0, ab[:, 1:], ca.repmat(t, 1, m - 1))
        s, p, end_margin = self.tail()(carries[:, m - 2], t, row, rhs, scale)
        w = outs[3:5, :] + outs[5:7, :] * p[0] + outs[7:9, :] * p[1]      # w_j = W0_j + W1_j p
        u, joint_margins = self.joint_rates(q, ca.horzcat(p, w))
        out = {"u": u, "e": ca.vec(outs[0:2, :]), "s": s, "roll": roll, "link_margins": outs[2, :].T,
               "end_margin": end_margin, "joint_margins": joint_margins}
        if self.chain.rail:
            out.update(u=ca.vertcat(d_dot, u), sigma=s - psi1, rail_margin=rail_margin)
        return out
