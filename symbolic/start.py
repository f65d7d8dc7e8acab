"""Start configurations: put every central point exactly on the curve, compactly and validly."""
from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from .chain import direction
from .controller import CoordinatingController
from .errors import ConfigError
from .geometry import self_distances, touching

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

#: Candidate joint angles sampled per link when looking for the curve (then bisected).
GRID = 721


def place_on_curve(ctrl: CoordinatingController, q_guess: ArrayLike, t0: float = 0.0) -> np.ndarray:
    """Place the links one after the other with every central point on the curve at ``t0``.

    Link 1 keeps its angle ``q_guess[0]`` (its centre is the pinned base). For link j the
    centre ``y^j`` lies on a circle of radius ``xi/2`` about the end of link j-1; among the
    joint angles within the joint limit that put ``y^j`` on the curve (``phi = 0``) it takes
    the one closest to ``q_guess[j]``, so a zig-zag guess gives a compact zig-zag along the
    curve (a straight line: exactly the guess).

    Parameters
    ----------
    ctrl : CoordinatingController
        Chain and curve.
    q_guess : array_like, shape (dof,)
        Start guess [rad] (on a rail ``d`` [m] first: the base stays at ``d``).
    t0 : float
        Time [s] of the curve to project onto.

    Returns
    -------
    ndarray, shape (dof,)
        Joint coordinates [rad] with every centre on the curve (on a rail ``d`` first, kept).

    Raises
    ------
    ConfigError
        No joint angle within the limit puts link j's centre on the curve (named).
    """
    chain = ctrl.chain
    q_full = chain.check_q(q_guess, "q_guess")
    q_guess = chain.revolute(q_full)
    xi, lim = chain.xi, chain.joint_limits
    mapped: dict[int, ca.Function] = {}

    def phi_at(pts: np.ndarray) -> np.ndarray:
        n = len(pts)
        if n not in mapped:
            mapped[n] = ctrl.task.geometry.map(n)
        return np.asarray(mapped[n](pts.T, t0)[0]).ravel()

    q = np.empty(chain.m)
    q[0] = q_guess[0]
    alpha, y = q[0], chain.base_point(q_full)
    for j in range(1, chain.m):
        end = y + 0.5 * xi * direction(alpha)

        def phi(dq: np.ndarray) -> np.ndarray:
            return phi_at(end + 0.5 * xi * direction(alpha + dq))

        grid = np.linspace(-lim[j - 1], lim[j - 1], GRID)
        f = phi(grid)
        sign = np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) <= 0)
        if not len(sign):
            gap = float(np.min(np.abs(f)))
            raise ConfigError(
                f"start: link {j + 1} cannot be placed: no joint angle within its limit ±{lim[j - 1]:.3f} rad puts "
                f"its centre on the curve at t0 = {t0} (closest {gap:.3g} m away); choose another start "
                f"(heading, beta) or curve, or raise chain.joint_limit")
        lo, hi = grid[sign], grid[sign + 1]
        flo = f[sign]
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            fm = phi(mid)
            left = np.sign(fm) * np.sign(flo) <= 0
            hi, lo, flo = np.where(left, mid, hi), np.where(left, lo, mid), np.where(left, flo, fm)
        roots = 0.5 * (lo + hi)
        q[j] = roots[np.argmin(np.abs(roots - q_guess[j]))]
        alpha += q[j]
        y = end + 0.5 * xi * direction(alpha)
    return np.r_[q_full[0], q] if chain.rail else q


def check_start(ctrl: CoordinatingController, q: np.ndarray) -> None:
    """Raise a ConfigError naming the joint or links if ``q`` breaks a joint limit or self-intersects.

    Parameters
    ----------
    ctrl : CoordinatingController
        Its chain's joint limits and clearance.
    q : ndarray, shape (m,)
        Joint coordinates [rad].

    Raises
    ------
    ConfigError
        A joint beyond its limit or two non-adjacent links closer than the clearance.
    """
    chain = ctrl.chain
    q_all, q = q, chain.revolute(np.asarray(q, float))
    if chain.rail and not chain.rail_limits[0] <= q_all[0] <= chain.rail_limits[1]:
        raise ConfigError(f"start: the rail position d = {q_all[0]:+.4f} m is outside chain.base.limits "
                          f"{list(chain.rail_limits)}")
    bad = np.flatnonzero(~(np.abs(q[1:]) <= chain.joint_limits))
    if len(bad):
        j = int(bad[0]) + 2
        raise ConfigError(f"start: joint {j} (between links {j - 1} and {j}) is at {q[j - 1]:+.3f} rad, beyond its "
                          f"limit ±{chain.joint_limits[j - 2]:.3f} rad; choose a smaller start.beta or another start")
    s, la, lb, d = self_distances(chain.joints_np(q_all[None]), chain.clearance)
    hit = np.flatnonzero(touching(d, chain.clearance))
    if len(hit):
        k = hit[np.argmin(la[hit])]
        raise ConfigError(f"start: links {la[k]} and {lb[k]} intersect or come closer than the clearance "
                          f"{chain.clearance:g} m ({d[k]:.4f} m): the start folds the body onto itself; choose "
                          f"another start (beta, heading) or curve")


def project_onto_curve(ctrl: CoordinatingController, q_guess: ArrayLike, t0: float = 0.0,
                       tol: float = 1e-12) -> np.ndarray:
    """A start with ``e^j(q, t0) = 0`` for j = 2..m, inside the joint limits and without self-contact.

    The links are placed one by one (:func:`place_on_curve`: each joint angle is the one
    within its limit closest to ``q_guess``'s, so a zig-zag guess stays a compact zig-zag
    along the curve), then a Newton step polishes the residual to ``tol`` keeping the end
    point's arc length.

    Parameters
    ----------
    ctrl : CoordinatingController
        Chain (with its joint limits and clearance) and curve.
    q_guess : array_like, shape (dof,)
        Start guess [rad]: link 1's angle (and on a rail the base's ``d`` [m], first) is kept,
        the other joint angles guide the choice.
    t0 : float
        Time [s] of the curve to project onto.
    tol : float
        Absolute tolerance of the Newton polish [m].

    Returns
    -------
    ndarray, shape (dof,)
        Joint coordinates [rad] with every centre on the curve (``d`` first on a rail).

    Raises
    ------
    ConfigError
        A link cannot be placed within its joint limit, the result self-intersects (the
        links are named), or the polish does not converge.
    """
    chain = ctrl.chain
    q_place = place_on_curve(ctrl, q_guess, t0)
    base = [float(q_place[0])] if chain.rail else []        # the rail position stays where it is
    q = ca.SX.sym("q", chain.m)
    y = chain.centres(ca.vertcat(*base, q))
    geo = ctrl.task.geometry
    s_target = float(geo(chain.centres_np(q_place)[-1], t0)[3])
    res = [geo(y[:, chain.m - 1], t0)[3] - s_target] + [geo(y[:, j], t0)[0] for j in range(1, chain.m)]
    g = ca.Function("project_residual", [q], [ca.vertcat(*res)])
    solver = ca.rootfinder("project", "newton", g, {"abstol": tol, "max_iter": 50,
                                                    "error_on_fail": False})
    q_rev = chain.revolute(q_place)
    q_star = np.asarray(solver(q_rev)).ravel()
    residual = float(np.max(np.abs(np.asarray(g(q_star))))) if np.all(np.isfinite(q_star)) else np.inf
    q_star_full = np.r_[base, q_star]
    if not residual <= 1e-9 or not np.max(np.abs(q_star - q_rev)) < 1e-3:
        raise ConfigError(f"start: could not project the chain onto the curve at t0 = {t0} "
                          f"(residual {residual:.3g} m); choose another start guess or curve")
    check_start(ctrl, q_star_full)
    return q_star_full


def follow_curve(ctrl: CoordinatingController, beta: float, t0: float = 0.0, d: float = 0.0,
                 tol: float = 1e-13) -> np.ndarray:
    """A zig-zag laid along the curve link by link: every central point ``y^2..y^m`` on it.

    Link 1 leaves the base at ``beta`` to the curve's tangent there; each next link is the
    root of ``phi(y^j) = 0`` nearest to the previous link mirrored across the local tangent
    (on a straight line: the uniform zig-zag), found by a scalar Newton iteration, with
    ``psi`` increasing. Unlike :func:`project_onto_curve` it follows bends of a path.

    Parameters
    ----------
    ctrl : CoordinatingController
        Chain and curve.
    beta : float
        Fold angle [rad], ``0 < |beta| < pi/2``.
    t0 : float
        Time at which to lay the chain on the curve [s].
    d : float
        Rail position [m] (a chain on a rail only; the base is then ``d`` along the rail).
    tol : float
        The Newton iteration stops once its step of the link angle is below ``tol`` [rad].

    Returns
    -------
    (dof,) ndarray
        Joint coordinates ``q`` (``d`` first on a rail) [m, rad].

    Raises
    ------
    ConfigError
        ``beta`` out of range, or a link that cannot reach the curve going forward.
    """
    if not 0 < abs(beta) < np.pi / 2:
        raise ConfigError(f"start.beta: need 0 < |beta| < pi/2, got {beta}")
    geo, h = ctrl.task.geometry, 0.5 * ctrl.chain.xi
    y = ctrl.chain.base_point(np.array([float(d)]))

    def tangent(p):
        g = np.asarray(geo(p, t0)[4]).ravel()
        return float(np.arctan2(g[1], g[0]))

    alphas = [tangent(y) + beta]
    s_prev = float(geo(y, t0)[3])
    for j in range(2, ctrl.chain.m + 1):
        end = y + h * np.array([np.cos(alphas[-1]), np.sin(alphas[-1])])
        a = 2 * tangent(end) - alphas[-1]
        for _ in range(60):
            dv = np.array([np.cos(a), np.sin(a)])
            phi, g = (np.asarray(v).ravel() for v in geo(end + h * dv, t0)[:2])
            slope = h * float(g @ np.array([-dv[1], dv[0]]))
            if slope == 0:
                break
            step = float(phi[0]) / slope
            a -= float(np.clip(step, -0.5, 0.5))
            if abs(step) < tol:
                break
        y_new = end + h * np.array([np.cos(a), np.sin(a)])
        phi, s = float(geo(y_new, t0)[0]), float(geo(y_new, t0)[3])
        if not (abs(phi) < 1e-9 and s > s_prev):
            raise ConfigError(f"start: link {j} cannot be laid on the curve going forward at t0 = {t0} "
                              f"(beta = {beta}); try another beta or a gentler curve")
        alphas.append(a)
        y, s_prev = y_new, s
    q = np.diff(np.r_[0.0, alphas])
    return np.r_[float(d), q] if ctrl.chain.rail else q
