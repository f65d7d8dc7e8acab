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

    Parameters
    ----------
    ctrl : CoordinatingController
        Chain and curve.
    q_guess : array_like, shape (m,)
        Start guess [rad].
    t0 : float
        Time [s] of the curve to project onto.
    tol : float
        Absolute tolerance of the Newton iteration [m].

    Returns
    -------
    ndarray, shape (m,)
        Joint coordinates [rad] with every centre on the curve.

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
