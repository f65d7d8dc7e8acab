"""Start configurations: put every central point exactly on the curve."""
from __future__ import annotations

import casadi as ca
import numpy as np

from .controller import CoordinatingController
from .errors import ConfigError


def project_onto_curve(ctrl: CoordinatingController, q_guess, t0: float = 0.0,
                       tol: float = 1e-12) -> np.ndarray:
    """Newton-project ``q_guess`` so that ``e^j(q, t0) = 0`` for j = 2..m.

    The end point keeps its arc length ``s^m(q_guess)``: the m equations
    ``(s^m - s_guess, e^2, ..., e^m) = 0`` have the decoupling matrix as Jacobian.

    Raises
    ------
    ConfigError
        If the rootfinder does not converge (e.g. a singular start or a curve out of reach).
    """
    chain = ctrl.chain
    q_guess = chain.check_q(q_guess, "q_guess")
    q = ca.SX.sym("q", chain.m)
    y = chain.centres(q)
    geo = ctrl._geometry
    s_target = float(geo(chain.centres_np(q_guess)[-1], t0)[3])
    res = [geo(y[:, chain.m - 1], t0)[3] - s_target] + [geo(y[:, j], t0)[0] for j in range(1, chain.m)]
    g = ca.Function("project_residual", [q], [ca.vertcat(*res)])
    solver = ca.rootfinder("project", "newton", g, {"abstol": tol, "max_iter": 50,
                                                    "error_on_fail": False})
    q_star = np.asarray(solver(q_guess)).ravel()
    residual = float(np.max(np.abs(np.asarray(g(q_star))))) if np.all(np.isfinite(q_star)) else np.inf
    if not residual <= 1e-9:
        raise ConfigError(f"start: could not project the chain onto the curve at t0 = {t0} "
                          f"(residual {residual:.3g} m); choose another start guess or curve")
    return q_star


def follow_curve(ctrl: CoordinatingController, beta: float, t0: float = 0.0, base=(0.0, 0.0),
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
    base : (float, float)
        Position of the first central point [m].

    Returns
    -------
    (m,) ndarray
        Joint angles ``q`` [rad] (revolute joints only).

    Raises
    ------
    ConfigError
        ``beta`` out of range, or a link that cannot reach the curve going forward.
    """
    if not 0 < abs(beta) < np.pi / 2:
        raise ConfigError(f"start.beta: need 0 < |beta| < pi/2, got {beta}")
    geo, h = ctrl._geometry, 0.5 * ctrl.chain.xi
    y = np.asarray(base, float)

    def tangent(p):
        g = np.asarray(geo(p, t0)[4]).ravel()
        return float(np.arctan2(g[1], g[0]))

    alphas = [tangent(y) + beta]
    s_prev = float(geo(y, t0)[3])
    for j in range(2, ctrl.chain.m + 1):
        end = y + h * np.array([np.cos(alphas[-1]), np.sin(alphas[-1])])
        a = 2 * tangent(end) - alphas[-1]
        for _ in range(60):
            d = np.array([np.cos(a), np.sin(a)])
            phi, g = (np.asarray(v).ravel() for v in geo(end + h * d, t0)[:2])
            slope = h * float(g @ np.array([-d[1], d[0]]))
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
    return np.diff(np.r_[0.0, alphas])
