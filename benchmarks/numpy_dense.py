"""The dense law (eq. 27) as a user would write it in vectorised numpy, for a moving line.

This is the fair baseline of the benchmarks: same law and same line as the controller,
tested against it in ``tests/test_numpy_dense.py``.
"""
from __future__ import annotations

import numpy as np


def dense_law_line(q: np.ndarray, xi: float, gain: float, v_star: float, theta: float, theta_dot: float,
                   point=(0.0, 0.0), point_dot=(0.0, 0.0)) -> np.ndarray:
    """Control ``u`` (B = I) for the line through ``point`` at angle ``theta`` (both moving).

    Parameters
    ----------
    q : (m,) array
        Joint coordinates [rad].
    xi, gain, v_star : float
        Link length [m], error gain K [1/s], commanded end-point speed [m/s].
    theta, theta_dot : float
        Angle of the line and its rate at the current time.
    point, point_dot : pair of float
        A point of the line and its velocity at the current time.
    """
    m = len(q)
    alpha = np.cumsum(q)
    c, s = np.cos(alpha), np.sin(alpha)
    # centres y^j = sum of xi/2 (d(alpha_{l-1}) + d(alpha_l)), l = 1..j
    steps = 0.5 * xi * (np.stack([c[:-1] + c[1:], s[:-1] + s[1:]], axis=1))
    y = np.vstack([np.zeros(2), np.cumsum(steps, axis=0)])
    # dy^j/dalpha_i = xi/2 n(alpha_i) weight[j, i]: weight 1 for i = 0 and i = j, 2 in between
    weight = 2.0 * np.tri(m, m, -1) + np.eye(m)
    weight[1:, 0] = 1.0
    weight[0, 0] = 0.0
    normals = np.stack([-s, c], axis=1)
    st, ct = np.sin(theta), np.cos(theta)
    r = y - np.asarray(point)
    phi = -st * r[:, 0] + ct * r[:, 1]
    psi = ct * r[:, 0] + st * r[:, 1]
    g, h, pd = np.array([-st, ct]), np.array([ct, st]), np.asarray(point_dot)
    phit = -theta_dot * psi - g @ pd
    psit = theta_dot * phi - h @ pd
    G = np.tile(g, (m, 1))                       # gradient of phi at every centre (rows)
    # rows grad(phi)(y^j) . C^j, with C^j = (dy^j/dalpha) L and d alpha_i / d q_k = 1 for k <= i:
    # the product with L is a reversed cumulative sum along each row
    Jg = 0.5 * xi * weight * (G @ normals.T)
    M = np.cumsum(Jg[:, ::-1], axis=1)[:, ::-1]
    M[0] = np.cumsum((0.5 * xi * weight[-1] * (normals @ h))[::-1])[::-1]   # the s^m row
    rhs = np.concatenate([[v_star - psit[-1]], -gain * phi[1:] - phit[1:]])
    return np.linalg.solve(M, rhs)
