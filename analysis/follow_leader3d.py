"""Follow-the-leader of a spatial chain: the body laid on a 3-D path link by link behind its end point.

The spatial counterpart of :mod:`.follow_leader`. At time ``t`` with the end point's target arc
length ``s*`` (:class:`SpatialLaying`, one CasADi Function, O(m)):

* ``y^m`` is the path's point at ``s*`` (Newton: ``p <- p - dPhi/dy^T Phi - (psi - s*) grad psi``, the
  Jacobian of ``(psi, Phi)`` being orthogonal on the path);
* link m keeps the components its direction had at the start in the path's transported frame
  ``(t, n_1, n_2)`` at the end point: its angle to the tangent and its roll about it, so the body's
  fold plane keeps its roll;
* going back, link j's direction ``d_j`` is the unit vector with ``Phi(y^{j+1} - h d_{j+1} - h d_j) = 0``
  (``h = xi/2``: the centre ``y^j`` on the path at distance ``h`` behind the rear end of link j+1),
  found by Newton's method on the unit sphere (a 2 x 2 solve per iteration in the tangent plane of the
  current guess) from ``d_{j+1}`` mirrored about the tangent at that rear end, the fold's other side;
* the joint angles follow from the directions (``R_j = R_{j-1} Rz(a_j) Ry(b_j)``, ``R_0 = I``,
  :func:`~coordarm.symbolic.spatial_chain.joint_angles_of_direction` in CasADi) and the base point
  ``y^1`` is where the last laid centre lies.

``worst`` is the largest ``|Phi|`` of a laid centre, or how far ``psi`` went forwards while laying
backwards (a link that found the path ahead of its successor): below :data:`.follow_leader.TOLERANCE`
the body is on the path. A robot on a rail (``[chain] base = { kind = "rail" }``) feeds its base along
the rail to ``y^1``; a fixed base cannot follow (``ftl`` is refused, :func:`check_rail`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from coordarm.symbolic import ConfigError

from .baselines import mapped_once
from .follow_leader import NEWTON
from .follow_leader import TOLERANCE as LAID_TOLERANCE

#: Newton iterations projecting the end point's guess onto the path at ``s*``.
TIP_NEWTON = 4
#: Largest change of a direction's tangent-plane coordinates in one Newton iteration [-].
STEP_LIMIT = 0.5


def check_rail(chain: Any, scenario: str = "") -> None:
    """Raise a ConfigError unless ``chain`` is on a rail: follow-the-leader feeds the body from its base.

    Parameters
    ----------
    chain : SpatialChain
        The manipulator (``rail``).
    scenario : str
        The scenario's name, for the message.

    Raises
    ------
    ConfigError
        A fixed base.
    """
    if not getattr(chain, "rail", False):
        where = f"scenario {scenario!r} has" if scenario else "this chain has"
        raise ConfigError(f"ftl: follow-the-leader needs a robot on a rail ([chain] base = {{ kind = \"rail\", "
                          f"direction = [...], limits = [lo, hi] }}); {where} a fixed base (coordarm compare: "
                          "leave ftl out with --methods coordinating,pinv,dls)")


def normalised(v: Any) -> Any:
    """``v / |v|`` (CasADi).

    Parameters
    ----------
    v : casadi.SX or casadi.MX, shape (3,)
        A non-zero vector.

    Returns
    -------
    casadi expression, shape (3,)
        The unit vector.
    """
    return v / ca.norm_2(v)


def tip_components(ctrl: Any, q0: np.ndarray, t0: float) -> np.ndarray:
    """The last link's direction at the start in the path's frame ``(t, n_1, n_2)`` at its centre ``y^m``.

    Parameters
    ----------
    ctrl : SpatialController
        The chain and the curve.
    q0 : ndarray, shape (dof,)
        Start configuration [rad] (on a rail, ``d`` [m] first).
    t0 : float
        Start time [s].

    Returns
    -------
    ndarray, shape (3,)
        ``(t . d_m, n_1 . d_m, n_2 . d_m)`` [-], a unit vector.
    """
    chain = ctrl.chain
    y_m, d_m = chain.centres_np(q0)[-1], chain.directions_np(q0)[-1]
    frame = ctrl.curve.functions()(y_m, float(t0))[2:5]
    return np.array([float(np.dot(np.asarray(f, float).ravel(), d_m)) for f in frame])


@dataclass
class SpatialLaying:
    """A spatial chain laid on the controller's 3-D path behind its end point (pure geometry, CasADi).

    Attributes
    ----------
    ctrl : SpatialController
        The chain (``m``, ``xi``) and the path (``curve``, ``task.geometry``).
    tip : ndarray, shape (3,)
        The last link's direction in the frame ``(t, n_1, n_2)`` at ``y^m`` (:func:`tip_components`).
    """

    ctrl: Any
    tip: np.ndarray

    def __post_init__(self) -> None:
        self.tip = np.asarray(self.tip, float) / np.linalg.norm(self.tip)
        self._cache: dict = {}

    def link(self) -> ca.Function:
        """``(y^{j+1}, d_{j+1}, t) -> (y^j, d_j, |Phi(y^j)|, psi(y^j))``: one link laid behind the next.

        Returns
        -------
        casadi.Function
            Points [m], unit directions, ``|Phi|`` [m], ``psi`` [m].
        """
        geo, frames, h = self.ctrl.task.geometry, self.ctrl.curve.functions(), 0.5 * self.ctrl.chain.xi
        y, d, t = ca.SX.sym("y", 3), ca.SX.sym("d", 3), ca.SX.sym("t")
        rear = y - h * d
        tangent = frames(rear, t)[2]
        a = 2 * ca.dot(tangent, d) * tangent - d                  # mirrored about the tangent
        for _ in range(NEWTON):
            helper = ca.if_else(ca.fabs(a[0]) < 0.9, ca.DM([1.0, 0.0, 0.0]), ca.DM([0.0, 1.0, 0.0]))
            b1 = normalised(ca.cross(a, helper))
            b2 = ca.cross(a, b1)
            Phi, JPhi = geo(rear - h * a, t)[:2]
            J = -h * ca.mtimes(JPhi, ca.horzcat(b1, b2))          # dPhi / d(tangent-plane coordinates)
            det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
            step = ca.vertcat(J[1, 1] * Phi[0] - J[0, 1] * Phi[1], J[0, 0] * Phi[1] - J[1, 0] * Phi[0])
            step = ca.if_else(det != 0, step / det, ca.DM.zeros(2))
            step = ca.fmin(ca.fmax(step, -STEP_LIMIT), STEP_LIMIT)
            a = normalised(a - step[0] * b1 - step[1] * b2)
        y_new = rear - h * a
        Phi, _, _, psi = geo(y_new, t)[:4]
        return ca.Function("ftl3d_link", [y, d, t], [y_new, a, ca.norm_2(Phi), psi])

    def end_point(self) -> ca.Function:
        """``(t, s*, guess) -> (y^m, d_m, psi(y^m) - s*, |Phi(y^m)|)``: the path's point at ``s*`` and the last link.

        Returns
        -------
        casadi.Function
            Point [m], unit direction, arc-length error [m], distance from the path [m].
        """
        geo, frames = self.ctrl.task.geometry, self.ctrl.curve.functions()
        t, target, p = ca.SX.sym("t"), ca.SX.sym("s_target"), ca.SX.sym("guess", 3)
        y = p
        for _ in range(TIP_NEWTON):
            Phi, JPhi, _, psi, gpsi, _ = geo(y, t)
            y = y - ca.mtimes(JPhi.T, Phi) - (psi - target) * gpsi
        Phi, _, _, psi = geo(y, t)[:4]
        tangent, n1, n2 = frames(y, t)[2:5]
        d = normalised(self.tip[0] * tangent + self.tip[1] * n1 + self.tip[2] * n2)
        return ca.Function("ftl3d_tip", [t, target, p], [y, d, psi - target, ca.norm_2(Phi)])

    def angles(self) -> ca.Function:
        """``D (3, m) -> q (2m,)``: joint angles of link directions, ``a = atan2(l_y, l_x)``, ``b = atan2(-l_z, |l_xy|)``.

        ``l = R_{j-1}^T d_j``; the frames are carried link by link (O(m)).

        Returns
        -------
        casadi.Function
            Unit directions in, ``(a_1, b_1, ..., a_m, b_m)`` [rad] out.
        """
        from coordarm.symbolic.spatial_chain import rot_y, rot_z

        R, d = ca.SX.sym("R", 3, 3), ca.SX.sym("d", 3)
        l = ca.mtimes(R.T, d)
        a, b = ca.atan2(l[1], l[0]), ca.atan2(-l[2], ca.sqrt(l[0] ** 2 + l[1] ** 2))
        step = ca.Function("ftl3d_angles", [ca.reshape(R, 9, 1), d],
                           [ca.reshape(ca.mtimes(R, ca.mtimes(rot_z(a), rot_y(b))), 9, 1), ca.vertcat(a, b)])
        m = self.ctrl.chain.m
        D = ca.SX.sym("D", 3, m)
        _, ab = step.mapaccum("ftl3d_frames", m)(ca.reshape(ca.SX.eye(3), 9, 1), D)
        return ca.Function("ftl3d_joint_angles", [D], [ca.reshape(ab, 2 * m, 1)])

    def function(self) -> ca.Function:
        """``(t, s*, guess of y^m) -> (q (2m,), Y (3, m), |s - s*|, worst)``: the chain laid at ``t``. Built once.

        Returns
        -------
        casadi.Function
            Joint angles [rad], centres ``y^1..y^m`` (columns) [m], arc-length error of the end point
            [m], ``worst`` [m] (the module's docstring).
        """
        if "fn" not in self._cache:
            m = self.ctrl.chain.m
            link = self.link()
            carry, ts = ca.SX.sym("carry", 8), ca.SX.sym("t")        # y, d, psi, worst
            y_new, d_new, phi, psi = link(carry[0:3], carry[3:6], ts)
            worst = ca.fmax(ca.fmax(carry[7], phi), ca.fmax(psi - carry[6], 0))
            out = ca.vertcat(y_new, d_new)
            step = ca.Function("ftl3d_step", [carry, ts], [ca.vertcat(y_new, d_new, psi, worst), out])
            fold = step.mapaccum("ftl3d_links", m - 1)
            t, target, guess = ca.MX.sym("t"), ca.MX.sym("s_target"), ca.MX.sym("guess", 3)
            y_m, d_m, s_err, phi_m = self.end_point()(t, target, guess)
            carries, laid = fold(ca.vertcat(y_m, d_m, target + s_err, phi_m), ca.repmat(t, 1, m - 1))
            Y = ca.horzcat(laid[0:3, ::-1], y_m)                    # y^1 .. y^m
            D = ca.horzcat(laid[3:6, ::-1], d_m)
            q = self.angles()(D)
            self._cache["fn"] = ca.Function("ftl3d_configuration", [t, target, guess],
                                            [q, Y, ca.fabs(s_err), carries[7, m - 2]],
                                            ["t", "s_target", "guess"], ["q", "Y", "s_error", "worst"])
        return self._cache["fn"]

    def guess(self, t: float, s_target: float, fallback: np.ndarray) -> np.ndarray:
        """A first guess of the path's point at ``s_target`` (``curve.point_at``, else ``fallback``) [m].

        Parameters
        ----------
        t : float
            Time [s].
        s_target : float
            Arc length of the end point [m].
        fallback : ndarray, shape (3,)
            Used when the curve has no ``point_at``.

        Returns
        -------
        ndarray, shape (3,)
        """
        try:
            return np.asarray(self.ctrl.curve.point_at(float(s_target), float(t)), float)
        except (AttributeError, NotImplementedError):
            return np.asarray(fallback, float)

    def lay(self, t: float, s_target: float, guess: np.ndarray | None = None) -> dict[str, Any]:
        """The chain laid on the path at ``t`` with its end point at ``s_target`` (numpy in and out).

        Parameters
        ----------
        t : float
            Time [s].
        s_target : float
            Arc length of the end point [m].
        guess : ndarray, shape (3,), optional
            First guess of ``y^m`` (default: :meth:`guess` from the curve, else the origin).

        Returns
        -------
        dict
            ``q`` (2m,) joint angles [rad], ``centres`` (m, 3) [m], ``base`` (3,) = ``y^1`` [m],
            ``s_error`` [m], ``worst`` [m].
        """
        if guess is None:
            guess = self.guess(t, s_target, np.zeros(3))
        q, Y, err, worst = self.function()(t, s_target, guess)
        Y = np.asarray(Y).T
        return {"q": np.asarray(q).ravel(), "centres": Y, "base": Y[0], "s_error": float(err),
                "worst": float(worst)}


@dataclass
class SpatialFollowTheLeader:
    """Follow-the-leader of a spatial chain on a rail: :class:`SpatialLaying` with the rail fed to the base.

    ``q = (d, a_1, b_1, ..., a_m, b_m)`` with ``d = y^1 . rail`` (the base point on the rail); ``worst``
    also counts the base's distance from the rail. The same interface as
    :class:`~.follow_leader.FollowTheLeader` (:func:`~.follow_leader.simulate_ftl` runs either).

    Attributes
    ----------
    ctrl : SpatialController
        A chain on a rail (``rail``, ``rail_direction`` (3,), ``rail_limits`` [m]), the path and ``v*(t)``.
    q0 : ndarray, shape (dof,)
        Start with every central point on the path (a ``follow`` start).
    t0 : float
        Start time [s].

    Raises
    ------
    ConfigError
        No rail, or ``q0`` is not the chain laid on the path.
    """

    ctrl: Any
    q0: np.ndarray
    t0: float = 0.0

    def __post_init__(self) -> None:
        chain = self.ctrl.chain
        check_rail(chain)
        self.q0 = chain.check_q(self.q0, "q0")
        self._y0 = chain.centres_np(self.q0)[-1]
        #: Arc length of the end point at the start [m].
        self.s0 = float(self.ctrl.curve.functions()(self._y0, float(self.t0))[0])
        #: The geometry: the body laid behind the end point.
        self.laying = SpatialLaying(self.ctrl, tip_components(self.ctrl, self.q0, self.t0))
        self._cache: dict = {}
        q, _, worst = self.configuration(self.t0, self.s0)
        # compared by the links' directions and the rail position (the body itself): the joint angles of
        # equal directions may differ by more than rounding at the tip of a long zig-zag with large b_j
        # (each joint's a_j absorbs the previous frame's error over cos b_j)
        off = max(float(np.max(np.abs(chain.directions_np(q) - chain.directions_np(self.q0)))),
                  abs(float(q[0] - self.q0[0])))
        if not worst < LAID_TOLERANCE or not off < 1e-9:
            raise ConfigError("ftl: the start must be the chain laid on the path (start.kind = \"follow\"); this "
                              f"one differs from the laid chain by {off:.3g} (a link direction or the rail "
                              "position; coordarm compare: leave ftl out with --methods coordinating,pinv,dls)")

    def function(self) -> ca.Function:
        """``(t, s*, guess of y^m) -> (q (dof,), |s - s*|, worst)``: the commanded configuration. Built once.

        Returns
        -------
        casadi.Function
            ``(t [s], s_target [m], guess (3,) [m]) -> (q (dof,) [m, rad], s_error [m], worst [m])``.
        """
        if "fn" not in self._cache:
            rail = ca.DM(np.asarray(self.ctrl.chain.rail_direction, float).reshape(3, 1))
            t, target, guess = ca.MX.sym("t"), ca.MX.sym("s_target"), ca.MX.sym("guess", 3)
            q, Y, s_err, worst = self.laying.function()(t, target, guess)
            base = Y[:, 0]
            d = ca.dot(rail, base)
            off_rail = ca.norm_2(base - d * rail)
            self._cache["fn"] = ca.Function("ftl3d_rail_configuration", [t, target, guess],
                                            [ca.vertcat(d, q), s_err, ca.fmax(worst, off_rail)],
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
        q : ndarray, shape (dof,)
            ``(d, a_1, b_1, ...)`` [m, rad].
        s_error : float
            ``|psi(y^m) - s_target|`` [m].
        worst : float
            Largest ``|Phi|`` of a laid centre, ``psi`` going forwards, or the base's distance from the rail [m].
        """
        q, err, worst = self.function()(t, s_target, self.guess(t, s_target))
        return np.asarray(q).ravel(), float(err), float(worst)

    def guess(self, t: float, s_target: float) -> np.ndarray:
        """A first guess of the path's point at ``s_target`` (the start's end point if the curve has no ``point_at``).

        Parameters
        ----------
        t : float
            Time [s].
        s_target : float
            Arc length of the end point [m].

        Returns
        -------
        ndarray, shape (3,)
            [m].
        """
        return self.laying.guess(t, s_target, self._y0)

    def mapped(self, n: int, backend: str) -> ca.Function:
        """:meth:`function` over ``n`` times in one call (generated C for ``backend="compiled"``). Built once.

        Parameters
        ----------
        n : int
            Number of samples.
        backend : {"compiled", "interpreted"}
            Generated C (built or taken from the build cache), or CasADi's virtual machine.

        Returns
        -------
        casadi.Function
            ``(t (1, n), s_target (1, n), guess (3, n)) -> (q (dof, n), s_error (1, n), worst (1, n))``.

        Raises
        ------
        ConfigError
            Unknown ``backend``.
        BuildError
            ``backend="compiled"`` and the C code cannot be built.
        """
        return mapped_once(self._cache, self.function(), "ftl3d", self.ctrl.chain.m, n, backend)

    def continuous(self, Q: np.ndarray) -> np.ndarray:
        """``Q`` (N, dof) with every ``a_j`` unwrapped in time (each is an ``atan2`` in ``(-pi, pi]``).

        Parameters
        ----------
        Q : ndarray, shape (N, dof)
            Laid configurations, one per sample.

        Returns
        -------
        ndarray, shape (N, dof)
        """
        Q = np.array(Q, float)
        Q[:, 1::2] = np.unwrap(Q[:, 1::2], axis=0)
        return Q
