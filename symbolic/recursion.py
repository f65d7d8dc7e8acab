"""The O(m) structured solve of the coordinating law (docs/model.md, *The O(m) solve*) as CasADi Functions.

One link of the recursion maps the carry (:data:`~coordarm.symbolic.carry.CARRY`) of link ``j-1``
to that of link ``j`` and the link's row of the law; a CasADi ``mapaccum`` runs it over the links,
the tail fixes the free rate from the ``s`` equation and a backward pass recovers the link rates.
It is written against :class:`~coordarm.symbolic.chain_model.ChainModel` (link frames, first carry,
controls from link rates) and :class:`~coordarm.symbolic.task.Task` (curve geometry, commands).
"""
from __future__ import annotations

from typing import Any, Callable, NamedTuple

import casadi as ca

from .carry import CARRY, Carry
from .chain_model import ChainModel
from .near_singular import speed_scale
from .task import Task

#: Below this ``|cos|`` between a link's normal and the curve normal the recursion re-pivots that
#: link: it solves the link's ``e`` row for the free rate instead (when that is better conditioned).
REPIVOT = 0.05
#: Output names of the tail Functions.
TAIL_OUTPUTS = ["s", "p", "longitudinal", "longitudinal_pivot", "v_scale"]


class LinkGeometry(NamedTuple):
    """Link ``j`` placed from the carry of link ``j-1``, with the curve's geometry at its centre.

    Parameters
    ----------
    n : casadi.SX, shape (2, 1)
        The link's normal.
    y : casadi.SX, shape (2, 1)
        Its centre ``y^j`` [m].
    phi, g, phit : casadi.SX
        ``phi`` [m], ``grad phi`` (2, 1) and ``dphi/dt`` [m/s] at ``y^j``.
    """

    n: Any
    y: Any
    phi: Any
    g: Any
    phit: Any


def split_time_terms(expr: ca.SX, t: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """``expr`` with its time-only terms pulled out: ``(expr in terms of w, w symbols, w(t))``.

    A static curve has no time-only terms: ``w`` is then one unused 0 rather than empty (an
    empty input makes CasADi emit a copy to a null pointer in mapped code).

    Parameters
    ----------
    expr : casadi.SX
        Expressions of ``t`` and other symbols.
    t : casadi.SX
        The time symbol.

    Returns
    -------
    expr : casadi.SX
        ``expr`` with each time-only term replaced by an element of ``w``.
    w : casadi.SX
        The symbols of the time-only terms.
    w_of_t : casadi.SX
        Their expressions in ``t``.
    """
    expr, wsym, wexpr = ca.extract_parametric(expr, t)
    wsym = ca.vertcat(*wsym) if len(wsym) else ca.SX.sym("w", 1)
    wexpr = ca.vertcat(*wexpr) if len(wexpr) else ca.SX.zeros(1, 1)
    return expr, wsym, wexpr


class StructuredRecursion:
    """The Functions of the O(m) recursion of one chain, task and governor (cached).

    Parameters
    ----------
    chain : ChainModel
        The manipulator.
    task : Task
        Curve geometry, commanded speed and span, gain K [1/s].
    governor : bool
        Scale ``v*`` by :func:`~.near_singular.speed_scale` of the longitudinal margin.
    governor_threshold : float
        Longitudinal margin at which the governed speed reaches 0 (in (0, 1)).
    """

    def __init__(self, chain: ChainModel, task: Task, governor: bool, governor_threshold: float) -> None:
        self.chain, self.task = chain, task
        self.governor, self.governor_threshold = governor, governor_threshold
        self._cache: dict = {}

    # ----------------------------------------------------------------------- one link
    def place_link(self, c: Carry, d_j: Any, t: Any) -> LinkGeometry:
        """Link ``j`` of direction ``d_j`` after the carry ``c`` of link ``j-1``, with the curve's geometry.

        Parameters
        ----------
        c : Carry
            The unpacked carry of link ``j-1``.
        d_j : casadi.SX, shape (2, 1)
            The link's direction (of ``alpha_j``, or given as its cosine and sine).
        t : casadi.SX
            Time [s].

        Returns
        -------
        LinkGeometry
            Normal ``n_j``, centre ``y_j`` [m], ``phi`` [m], its gradient and time derivative [m/s] at ``y_j``.
        """
        n_j = self.chain.link_normal(d_j)
        y_j = c.y + self.chain.centre_step(c.direction, d_j)
        phi, g, phit, *_ = self.task.geometry(y_j, t)
        return LinkGeometry(n_j, y_j, phi, g, phit)

    def link_expressions(self) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX, ca.SX]:
        """Symbolic carry, ``q_j``, ``t`` and the link step's ``(carry_next, out_j)`` in terms of them (CSE'd).

        The carried ``P + Q p = ydot^{j-1} + xi/2 n(alpha_{j-1}) w_{j-1}`` is the part of ``ydot^j``
        known before ``w_j``; the link pivot is divided out.

        Returns
        -------
        tuple of casadi.SX
            ``(carry, q_j, t, carry_next, out_j)``.
        """
        xi, K = self.chain.xi, self.task.gain
        carry, qj, t = CARRY.symbol(), ca.SX.sym("q_j"), ca.SX.sym("t")
        c = CARRY.unpack(carry)
        alpha = c.alpha + qj
        d_j = self.chain.link_direction(alpha)       # the only sine/cosine pair of the link
        n_j, y_j, phi, g, phit = self.place_link(c, d_j, t)
        pivot = ca.dot(g, n_j)                       # the link pivot (eq. 26 row, divided out)
        inv = 1 / (0.5 * xi * pivot)
        r, gP, gQ = -K * phi - phit, ca.dot(g, c.P), ca.dot(g, c.Q)
        a_j = (r - gP) * inv
        b_j = -gQ * inv
        step = xi * n_j                              # ydot^j = P + xi/2 n_j w_j; next P adds it again
        P_next, Q_next = c.P + step * a_j, c.Q + step * b_j
        new = CARRY.pack(Carry(y_j, alpha, d_j, P_next, Q_next, a_j, b_j, c.sum_abs_b + ca.fabs(b_j)))
        out = ca.vertcat(phi, ca.fabs(pivot) / ca.norm_2(g), a_j, b_j)
        both = ca.cse(ca.vertcat(new, out))          # one CSE over both, so a_j, b_j are shared
        return carry, qj, t, both[:new.numel()], both[new.numel():]

    def _hoisted_link(self) -> tuple[ca.Function, ca.Function]:
        """``(time_features, link_step)``: the link step split into time-only terms and the rest (cached)."""
        if "hoisted" not in self._cache:
            carry, qj, t, new, out = self.link_expressions()
            expr, wsym, wexpr = split_time_terms(ca.vertcat(new, out), t)
            n_new = new.numel()
            tf = ca.Function("time_features", [t], [ca.cse(wexpr)], ["t"], ["w"])
            step = ca.Function("link_step", [carry, qj, wsym], [expr[:n_new], expr[n_new:]],
                               ["carry", "q_j", "w"], ["carry_next", "out"])
            self._cache["hoisted"] = (tf, step)
        return self._cache["hoisted"]

    def time_features(self) -> ca.Function:
        """``t -> w``: the terms of :meth:`link_step` that depend on time only, computed once per ``t``.

        Returns
        -------
        casadi.Function
            Input ``t`` [s], output ``w`` (one 0 for a static curve).
        """
        return self._hoisted_link()[0]

    def link_step(self) -> ca.Function:
        """One link of the O(m) recursion: ``(carry, q_j, w) -> (carry_next, out_j)``.

        ``carry`` (layout :data:`~coordarm.symbolic.carry.CARRY`) holds ``y^{j-1}``, ``alpha_{j-1}``
        with its cosine and sine, ``w_{j-1} = a + b p``, ``P + Q p`` and the running ``sum |b|``; ``w``
        is :meth:`time_features` at the current time; ``out_j = (e^j, link margin, a_j, b_j)`` with
        ``w_j = a_j + b_j p``. It divides by the link pivot: see :meth:`link_step_repivot` for links
        across the curve.

        Returns
        -------
        casadi.Function
            ``(carry, q_j, w) -> (carry_next, out)``.
        """
        return self._hoisted_link()[1]

    def repivot_expressions(self) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX, ca.SX]:
        """The re-pivoting link step: symbolic carry, ``q_j``, ``t``, ``(carry_next, out_j)``.

        Where the link pivot is small (``|cos| < REPIVOT``) and solving the link's ``e`` row
        ``g.(P + Q p) + xi/2 (g.n_j) w_j = r`` for the free rate is better conditioned, it does
        that: the old free rate becomes ``c + d w_j`` and ``w_j`` the new one, so a link standing
        across the curve is no singularity unless the decoupling matrix itself is singular.

        Returns
        -------
        tuple of casadi.SX
            ``(carry, q_j, t, carry_next, out_j)``, ``out_j = (e^j, link margin, a_j, b_j, c_j, d_j)``.
        """
        xi, K = self.chain.xi, self.task.gain
        carry, qj, t = CARRY.symbol(), ca.SX.sym("q_j"), ca.SX.sym("t")
        c = CARRY.unpack(carry)
        alpha = c.alpha + qj
        d_j = self.chain.link_direction(alpha)
        n_j, y_j, phi, g, phit = self.place_link(c, d_j, t)
        P, Q = c.P, c.Q
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
        new = CARRY.pack(Carry(y_j, alpha, d_j, P0 + step * a_s, Q0 + step * b_s, a_s, b_s,
                               ca.fabs(d_s) * c.sum_abs_b + ca.fabs(b_s)))
        out = ca.vertcat(phi, ca.if_else(swap, cos_q, cos_n), a_s, b_s, c_s, d_s)
        both = ca.cse(ca.vertcat(new, out))
        return carry, qj, t, both[:new.numel()], both[new.numel():]

    def _hoisted_repivot(self) -> tuple[ca.Function, ca.Function]:
        """``(time_features_repivot, link_step_repivot)``: the re-pivoting step and its time terms (cached)."""
        if "hoisted_repivot" not in self._cache:
            carry, qj, t, new, out = self.repivot_expressions()
            expr, wsym, wexpr = split_time_terms(ca.vertcat(new, out), t)
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

    # ------------------------------------------------------------------ head and tail
    def first_carry(self) -> ca.Function:
        """``q_1 -> carry`` of link 1 (the chain's :meth:`~.ChainModel.first_carry`).

        Returns
        -------
        casadi.Function
            Input ``q_1`` [rad], output ``carry`` (layout :data:`~coordarm.symbolic.carry.CARRY`).
        """
        q1 = ca.SX.sym("q_1")
        return ca.Function("first_carry", [q1], [self.chain.first_carry(q1)], ["q_1"], ["carry"])

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
            ``rail_head``; outputs ``carry``, ``d_dot`` [m/s], ``rail_margin`` [-] and ``psi_1`` [m].
        """
        d, q1, t, sigma = ca.SX.sym("d"), ca.SX.sym("q_1"), ca.SX.sym("t"), ca.SX.sym("sigma")
        scale = ca.SX.sym("v_scale") if governed else None
        rail = ca.DM(self.chain.rail_direction)
        y1 = d * rail
        _, _, _, psi1, h1, psit1 = self.task.geometry(y1, t)
        pivot = ca.dot(h1, rail)
        command = ca.SX(self.task.speed(t)) - self.task.span_rate(sigma, t)
        rate = ((scale * command if governed else command) - psit1) / pivot
        carry = CARRY.pack(CARRY.unpack(self.first_carry()(q1))._replace(y=y1, P=rate * rail))
        inputs = [d, q1, t, sigma] + ([scale] if governed else [])
        return ca.Function("rail_head", inputs, [carry, rate, ca.fabs(pivot) / ca.norm_2(h1), psi1],
                           ["d", "q_1", "t", "sigma"] + (["v_scale"] if governed else []),
                           ["carry", "d_dot", "rail_margin", "psi_1"])

    def tail_expressions(self, carry: ca.SX, t: ca.SX,
                         geometry_at: Callable[[Any], Any]) -> tuple[Any, Any, Any, Any, Any]:
        """``(s, p, longitudinal, longitudinal_pivot, v_scale)`` after the last link, from its carry.

        Parameters
        ----------
        carry : casadi.SX, shape (CARRY.size, 1)
            The carry of link ``m``.
        t : casadi.SX
            Time [s].
        geometry_at : callable
            ``y -> (phi, grad phi, dphi/dt, psi, grad psi, dpsi/dt)`` at time ``t``.

        Returns
        -------
        tuple of casadi.SX
            ``s`` [m], ``p`` [rad/s], the longitudinal margin, its pivot [m/rad] and ``v_scale``.
        """
        c = CARRY.unpack(carry)
        n_m = ca.vertcat(-c.direction[1], c.direction[0])
        half = 0.5 * self.chain.xi * n_m
        A_m, B_m = c.P - half * c.a, c.Q - half * c.b     # ydot^m = A_m + B_m p
        _, _, _, psi, h, psit = geometry_at(c.y)
        pivot = ca.dot(h, B_m)
        margin = ca.fabs(pivot) / (self.chain.xi * c.sum_abs_b)
        scale = speed_scale(margin, self.governor_threshold) if self.governor else ca.SX(1)
        p = (scale * self.task.speed(t) - psit - ca.dot(h, A_m)) / pivot
        return psi, p, margin, pivot, scale

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
        carry, t = CARRY.symbol(), ca.SX.sym("t")
        outs = self.tail_expressions(carry, t, lambda y: self.task.geometry(y, t))
        return ca.Function("tail", [carry, t], list(outs), ["carry", "t"], TAIL_OUTPUTS)

    @staticmethod
    def back_step() -> ca.Function:
        """``(p_j, (c_j, d_j)) -> p_{j-1} = c_j + d_j p_j``: the free rate before link j.

        Returns
        -------
        casadi.Function
            ``(p, cd) -> p_prev`` [rad/s].
        """
        p, cd = ca.SX.sym("p"), ca.SX.sym("cd", 2)
        return ca.Function("back_step", [p, cd], [cd[0] + cd[1] * p], ["p", "cd"], ["p_prev"])

    # ------------------------------------------------------------------------ the law
    def span_now(self, q: Any, t: Any) -> Any:
        """``sigma = psi(y^m) - psi(y^1)`` from the forward kinematics (needed only for a commanded span).

        Parameters
        ----------
        q : casadi.MX, shape (dof,)
            Joint coordinates.
        t : casadi.MX
            Time [s].

        Returns
        -------
        casadi.MX or int
            The span [m] (0 when the span is held).
        """
        if self.task.span is None:
            return 0
        y = self.chain.centres(q)
        return self.task.geometry(y[:, self.chain.m - 1], t)[3] - self.task.geometry(y[:, 0], t)[3]

    def outputs(self, q: ca.MX, t: ca.MX) -> dict[str, Any]:
        """The law's outputs by the O(m) recursion, keyed by :data:`~coordarm.symbolic.outputs.OUTPUTS`.

        Parameters
        ----------
        q : casadi.MX, shape (dof,)
            Joint coordinates [rad] (``d`` [m] first on a rail).
        t : casadi.MX
            Time [s].

        Returns
        -------
        dict
            ``u``, ``e``, ``s``, ``link_margins``, ``longitudinal``, ``longitudinal_pivot``,
            ``v_scale`` (on a rail also ``sigma`` and ``rail_margin``) as MX expressions.
        """
        m = self.chain.m
        w_t = self.time_features_repivot()(t)
        fold = self.link_step_repivot().mapaccum("links", m - 1)
        qr = self.chain.revolute(q)
        if self.chain.rail:
            sigma = self.span_now(q, t)
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
        out = {"u": self.chain.controls_from_link_rates(w), "e": outs[0, :].T, "s": psi,
               "link_margins": outs[1, :].T, "longitudinal": margin, "longitudinal_pivot": pivot, "v_scale": scale}
        if self.chain.rail:
            out.update(u=ca.vertcat(rail_rate, out["u"]), sigma=psi - psi1, rail_margin=rail_margin)
        return out
