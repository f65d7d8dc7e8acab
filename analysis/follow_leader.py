"""Follow-the-leader (``ftl``), the classic baseline of snake-arm robots on an introduction axis.

The end point leads along the path at ``s*(t) = s(0) + integral of v*`` (Simpson's rule on each step)
and the body follows it:
the commanded configuration at time ``t`` lays the chain on the path link by link from the end
point back to the base, as the ``follow`` start lays it from the base
(:func:`coordarm.symbolic.start.follow_curve`):

* ``y^m`` is the path's point at ``s*(t)``; link m keeps the start's angle to the path's tangent there;
* link j's centre ``y^j`` is the point of the path at distance ``xi/2`` behind the rear end of
  link j+1, the root of ``phi = 0`` nearest to link j+1 mirrored across the local tangent
  (Newton's method), going back along the path;
* the base ``y^1`` then lies on the path, which runs along the rail there: the rail position is
  ``d = y^1 . rail`` and the rail feeds the body at whatever speed that takes (``v*`` while the
  body lies on a straight part: then every joint is at rest).

So every central point is on the path (to the Newton tolerance) and travels along the path the
end point traced (on a straight part each link takes the place the link two ahead had, the fold's
period): the classic follow-the-leader of snake-arm robots, for a body that keeps its compact fold. It never unfolds (its span is what the path's bends make of
it), so the rail must feed as far as the end point travels. The joint rates are differences of
consecutive configurations (``u_k = (q_{k+1} - q_k) / h``). The configurations are independent
of each other, so one mapped call lays them all (``step_time`` is its time per sample). A run
stops where ``d`` would leave the rail's limits (outcome ``rail_limit``: the rail cannot feed the
body further) or where a link cannot reach the path or the base would leave the rail (``off_path``).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from coordarm.simulation.run import Run
from coordarm.symbolic import ConfigError, CoordinatingController
from coordarm.symbolic.chain import direction, normal

from .baselines import mapped_once, stop_at_rail_limit

#: Newton iterations placing one link's centre on the path (quadratic convergence from the mirror guess).
NEWTON = 8
#: Largest ``|phi|`` of a laid centre, ``|s - s*|`` of the end point and offset of the base from the rail [m].
TOLERANCE = 1e-9


@dataclass
class FollowTheLeader:
    """Follow-the-leader of a chain on a rail along the controller's path.

    Attributes
    ----------
    ctrl : CoordinatingController
        A chain on a rail (``ctrl.chain.rail``), the path and ``v*(t)`` [m/s].
    q0 : (m+1,) ndarray
        Start ``(d, q_1..q_m)`` [m, rad] with every central point on the path (a ``follow`` start).
    t0 : float
        Start time [s].

    Raises
    ------
    ConfigError
        The chain has no rail, or ``q0`` is not the chain laid on the path from its base.
    """

    ctrl: CoordinatingController
    q0: np.ndarray
    t0: float = 0.0

    def __post_init__(self) -> None:
        chain = self.ctrl.chain
        if not chain.rail:
            raise ConfigError("ftl: follow-the-leader needs a robot with an introduction axis (rail)")
        self.q0 = chain.check_q(self.q0, "q0")
        geo = self.ctrl.task.geometry
        y_m = chain.centres_np(self.q0)[-1]
        g = np.asarray(geo(y_m, self.t0)[4]).ravel()
        #: Angle of link m to the path's tangent at the end point [rad], kept as it leads.
        self.beta = float(np.sum(chain.revolute(self.q0)) - np.arctan2(g[1], g[0]))
        #: Arc length of the end point at the start [m].
        self.s0 = float(geo(y_m, self.t0)[3])
        self._y0 = y_m
        self._cache: dict = {}
        q, _, residual = self.configuration(self.t0, self.s0)
        if not residual < TOLERANCE or not np.max(np.abs(q - self.q0)) < 1e-9:
            raise ConfigError("ftl: the start must be the chain laid on the path "
                              "(start.kind = \"follow\"); this one differs from the laid chain by "
                              f"{np.max(np.abs(q - self.q0)):.3g} rad (coordarm compare: leave ftl out with "
                              "--methods coordinating,pinv,dls)")

    def _link(self) -> ca.Function:
        """``(y^{j+1}, alpha_{j+1}, t) -> (y^j, alpha_j, |phi(y^j)|, psi(y^j))``: one link laid behind the next."""
        geo, h = self.ctrl.task.geometry, 0.5 * self.ctrl.chain.xi
        y, alpha, t = ca.SX.sym("y", 2), ca.SX.sym("alpha"), ca.SX.sym("t")
        rear = y - h * direction(alpha)
        g = geo(rear, t)[4]
        a = 2 * ca.atan2(g[1], g[0]) - alpha           # the next link mirrored across the tangent
        for _ in range(NEWTON):
            phi, gphi = geo(rear - h * direction(a), t)[:2]
            slope = -h * ca.dot(gphi, normal(a))
            step = ca.if_else(slope != 0, phi / slope, 0)
            a = a - ca.fmin(ca.fmax(step, -0.5), 0.5)
        y_new = rear - h * direction(a)
        phi, _, _, psi = geo(y_new, t)[:4]
        return ca.Function("ftl_link", [y, alpha, t], [y_new, a, ca.fabs(phi), psi])

    def _tip(self) -> ca.Function:
        """``(t, s*, guess) -> (y, psi(y) - s*, |phi(y)|)``: the path's point at ``s*`` (Newton from ``guess``).

        The Jacobian of ``(phi, psi)`` is a rotation on the path (orthonormalised curves), so each
        step subtracts ``phi grad phi + (psi - s*) grad psi``.
        """
        geo = self.ctrl.task.geometry
        t, target, y = ca.SX.sym("t"), ca.SX.sym("s_target"), ca.SX.sym("guess", 2)
        p = y
        for _ in range(3):
            phi, gphi, _, psi, gpsi, _ = geo(p, t)
            p = p - phi * gphi - (psi - target) * gpsi
        phi, _, _, psi = geo(p, t)[:4]
        return ca.Function("ftl_tip", [t, target, y], [p, psi - target, ca.fabs(phi)])

    def function(self) -> ca.Function:
        """``(t, s*, guess of y^m) -> (q (m+1,), |s - s*|, worst |phi| or offset from the rail)``.

        The commanded configuration at ``t``; ``worst`` also counts ``psi`` going forwards while
        laying backwards (a link that found the path ahead of its successor). Built once, then kept.

        Returns
        -------
        casadi.Function
            ``(t [s], s_target [m], guess (2,) [m]) -> (q (m+1,) [m, rad], s_error [m], worst [m])``,
            as in :meth:`configuration`.
        """
        if "fn" not in self._cache:
            chain, geo, m = self.ctrl.chain, self.ctrl.task.geometry, self.ctrl.chain.m
            link = self._link()
            carry, ts = ca.SX.sym("carry", 5), ca.SX.sym("t")   # y, alpha, psi, worst
            y_new, a, phi, psi = link(carry[0:2], carry[2], ts)
            worst = ca.fmax(ca.fmax(carry[4], phi), ca.fmax(psi - carry[3], 0))
            step = ca.Function("ftl_step", [carry, ts], [ca.vertcat(y_new, a, psi, worst), a])
            fold = step.mapaccum("ftl_links", m - 1)
            t, target, guess = ca.MX.sym("t"), ca.MX.sym("s_target"), ca.MX.sym("guess", 2)
            y_m, s_err, phi_m = self._tip()(t, target, guess)
            g = geo(y_m, t)[4]
            alpha_m = ca.atan2(g[1], g[0]) + self.beta
            carries, alphas = fold(ca.vertcat(y_m, alpha_m, target + s_err, phi_m), ca.repmat(t, 1, m - 1))
            last = carries[:, m - 2]
            rail = chain.rail_direction
            off_rail = ca.fabs(rail[0] * last[1] - rail[1] * last[0])
            alphas = ca.vertcat(alphas[0, ::-1].T, alpha_m)        # alpha_1 .. alpha_m
            rel = alphas[1:] - alphas[:-1]
            q = ca.vertcat(ca.dot(ca.DM(rail), last[0:2]), alphas[0], ca.atan2(ca.sin(rel), ca.cos(rel)))
            self._cache["fn"] = ca.Function("ftl_configuration", [t, target, guess],
                                            [q, ca.fabs(s_err), ca.fmax(last[4], off_rail)],
                                            ["t", "s_target", "guess"], ["q", "s_error", "worst"])
        return self._cache["fn"]

    def configuration(self, t: float, s_target: float) -> tuple[np.ndarray, float, float]:
        """The chain laid on the path at ``t`` with its end point at ``s_target``.

        Parameters
        ----------
        t : float
            Time [s].
        s_target : float
            Arc length of the end point [m].

        Returns
        -------
        q : (m+1,) ndarray
            ``(d, q_1..q_m)`` [m, rad].
        s_error : float
            ``|psi(y^m) - s_target|`` [m].
        worst : float
            Largest ``|phi|`` of a laid centre, ``psi`` going forwards, or the base's distance from
            the rail [m].
        """
        q, err, worst = self.function()(t, s_target, self.guess(t, s_target))
        return np.asarray(q).ravel(), float(err), float(worst)

    def guess(self, t: float, s_target: float) -> np.ndarray:
        """A first guess of the path's point at ``s_target`` (``curve.point_at``, else the start's end point) [m].

        Parameters
        ----------
        t : float
            Time [s].
        s_target : float
            Arc length of the end point [m].

        Returns
        -------
        (2,) ndarray
            The guess of ``y^m`` [m].
        """
        try:
            return np.asarray(self.ctrl.curve.point_at(float(s_target), float(t)), float)
        except NotImplementedError:
            return self._y0

    def continuous(self, Q: np.ndarray) -> np.ndarray:
        """``Q`` (N, m+1) with link 1's absolute angle ``q_1`` unwrapped in time (an ``atan2`` in ``(-pi, pi]``).

        Parameters
        ----------
        Q : ndarray, shape (N, m+1)
            Laid configurations, one per sample.

        Returns
        -------
        ndarray, shape (N, m+1)
        """
        Q = np.array(Q, float)
        Q[:, 1] = np.unwrap(Q[:, 1])
        return Q

    def mapped(self, n: int, backend: str) -> ca.Function:
        """:meth:`function` over ``n`` times in one call (generated C for ``backend="compiled"``).

        Built once per ``(n, backend)``, then kept.

        Parameters
        ----------
        n : int
            Number of samples.
        backend : {"compiled", "interpreted"}
            Generated C (built or taken from the build cache), or CasADi's virtual machine.

        Returns
        -------
        casadi.Function
            ``(t (1, n), s_target (1, n), guess (2, n)) -> (q (m+1, n), s_error (1, n), worst (1, n))``.

        Raises
        ------
        ConfigError
            Unknown ``backend``.
        BuildError
            ``backend="compiled"`` and the C code cannot be built.
        """
        return mapped_once(self._cache, self.function(), "ftl", self.ctrl.chain.m, n, backend)


def simulate_ftl(law: FollowTheLeader, duration: float, step: float, backend: str = "compiled") -> Run:
    """The follow-the-leader run on the grid ``t0 + k step``, scored like the others.

    ``q`` is the commanded configuration at each sample, ``u`` the forward difference of ``q``
    (the last sample repeats the one before); ``e``, ``s`` and the margins are NaN (score runs from
    ``q``); ``info["stopped"]`` is ``completed``, ``rail_limit`` (``d`` would leave the rail's limits:
    the run ends at the last sample inside) or ``off_path`` (a link could not reach the path).

    Parameters
    ----------
    law : FollowTheLeader or SpatialFollowTheLeader
        The laying (its ``mapped``, ``guess``, ``continuous``, ``s0``, ``t0`` and ``ctrl``).
    duration, step : float
        Simulated time and sample step [s].
    backend : {"compiled", "interpreted"}
        Generated C, or CasADi's virtual machine.

    Returns
    -------
    Run

    Raises
    ------
    ConfigError
        Unknown ``backend``.
    BuildError
        ``backend="compiled"`` and the C code cannot be built.
    """
    ctrl, chain = law.ctrl, law.ctrl.chain
    n = int(round(duration / step)) + 1
    T = law.t0 + step * np.arange(n)
    v, mid = ctrl.speeds(T), ctrl.speeds(T[:-1] + 0.5 * step)
    target = law.s0 + np.concatenate([[0.0], np.cumsum(step / 6 * (v[:-1] + 4 * mid + v[1:]))])   # Simpson's rule
    fn = law.mapped(n, backend)                     # built before the clock starts
    wall = time.perf_counter()
    guess = np.array([law.guess(t, s) for t, s in zip(T, target)])
    Q, s_err, worst = (np.asarray(x) for x in fn(T[None], target[None], guess.T))
    wall = time.perf_counter() - wall
    Q = law.continuous(Q.T)
    Q[0] = law.q0            # the start itself (the laid chain equals it to 1e-9, checked when the law was built;
    #                          a rail position rounded a hair outside its limit would end the run at once)
    bad = ~((worst.ravel() < TOLERANCE) & (s_err.ravel() < TOLERANCE))
    stopped, end = ("off_path", max(int(np.argmax(bad)), 1)) if bad.any() else ("completed", n)
    Q, T = Q[:end], T[:end]
    U = np.diff(Q, axis=0) / step
    U = np.vstack([U, U[-1:]]) if len(U) else np.zeros_like(Q)
    run = Run.from_states(T, Q, U, v[:end], chain.m,
                          info={"backend": backend, "stopped": stopped, "wall_time": wall, "steps": max(n - 1, 1)})
    return stop_at_rail_limit(run, chain)
