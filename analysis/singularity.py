"""Singularity margins of the coordinating law at a configuration and along a run.

Every margin is dimensionless and 0 exactly at its singularity:

``links``
    ``|grad phi(y^j) . n(alpha_j)| / |grad phi(y^j)|`` for links 2..m: the link pivots of
    the structured solve (docs/model.md, *The O(m) solve*), 0 when link j stands perpendicular to the
    curve. Computed here from the chain and curve geometry, independently of the law.
``longitudinal``
    How far the end point can still be pushed along the curve: with ``n`` a null vector of
    the ``e`` rows of the decoupling matrix (the one-parameter family of joint rates that
    keeps every centre on the curve), ``|ds^m/dq . n| / (xi |L n|_1)``, ``L`` the lower
    triangular matrix of ones (``w = L qdot``). This is scale-free in ``n`` and equals the
    structured solve's normalised longitudinal pivot, ``(m-1)/m sin(beta)`` on a zig-zag on a
    line, 0 at a stretched chain. Here it comes from a QR factorisation of the dense matrix, so it stays
    defined where a link pivot vanishes (where the structured recursion divides by zero).
``sigma_min``, ``inverse_cond``, ``inverse_cond_scaled``
    Smallest singular value of ``M / xi`` (``M`` the decoupling matrix, eq. 26), ``1/cond(M)``
    and ``1/cond`` of ``M`` with rows and then columns equilibrated to unit 2-norm (invariant
    to the units chosen for each task coordinate and joint rate).

Also returned, not margins: ``cond`` and ``cond_scaled`` (infinite at a singular ``M``),
``amplification`` = ``xi |u|_2 / |v*|`` (``u`` from a dense solve; ``nan`` when ``v* = 0``),
``u_max`` = ``|u|_inf`` [rad/s for B = I] and ``worst_link`` (1-based index of the smallest
link margin).
"""
from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from coordarm.symbolic import ConfigError, CoordinatingController
from coordarm.symbolic.chain import normal

#: Margins (dimensionless, 0 = singular), in report order.
MARGINS = ("links", "longitudinal", "sigma_min", "inverse_cond", "inverse_cond_scaled")
#: Default report thresholds of the margins (the simulator's stop thresholds for links and
#: longitudinal live in :data:`simulation.run.DEFAULT_THRESHOLDS`).
REPORT_THRESHOLDS = {"sigma_min": 1e-3, "inverse_cond": 1e-6, "inverse_cond_scaled": 1e-6}
#: Link margins this close to the smallest count as tied: the lowest such link is the worst.
TIE = 1e-9


def _worst_link(links: np.ndarray) -> np.ndarray:
    """1-based index of the smallest link margin; among margins tied to within :data:`TIE`, the lowest."""
    return np.argmax(links <= links.min(axis=-1, keepdims=True) + TIE, axis=-1) + 2


def _equilibrated(M: np.ndarray) -> np.ndarray:
    """``M`` (..., m, m) with rows, then columns, scaled to unit 2-norm (zero rows left alone)."""
    r = np.linalg.norm(M, axis=-1, keepdims=True)
    M = M / np.where(r > 0, r, 1.0)
    c = np.linalg.norm(M, axis=-2, keepdims=True)
    return M / np.where(c > 0, c, 1.0)


def _solve(M: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Batched ``M u = r``; a singular ``M`` gives ``u = inf``."""
    try:
        return np.linalg.solve(M, r[..., None])[..., 0]
    except np.linalg.LinAlgError:
        out = np.full(r.shape, np.inf)
        for i in range(len(M)):
            try:
                out[i] = np.linalg.solve(M[i], r[i])
            except np.linalg.LinAlgError:
                pass
        return out


def _margins_batch(ctrl: CoordinatingController, Q: np.ndarray, T: np.ndarray) -> dict[str, np.ndarray]:
    """Margins at N configurations ``Q`` (N, m) and times ``T`` (N,): arrays with leading axis N."""
    chain = ctrl.chain
    xi = chain.xi
    geo = ctrl.centre_geometry(Q, T)
    M, r = ctrl.decoupling_matrices(Q, T, geo)

    # link margins from the geometry: grad phi at the centres, normals of the links
    g = geo["gphi"][:, 1:]                                    # (N, m-1, 2)
    nrm = normal(np.cumsum(chain.revolute(Q), axis=-1))[:, 1:, :]
    links = np.abs(np.sum(g * nrm, axis=-1)) / np.linalg.norm(g, axis=-1)

    # longitudinal margin from the null vector of the e rows (in joint-rate space); on a rail
    # the span row fixes d_dot first, so the e rows and the s row act on the revolute joints
    Mq = M @ np.linalg.inv(ctrl.B_joints)                     # rows d(task)/dq
    r0 = int(chain.rail)
    Qf, _ = np.linalg.qr(np.swapaxes(Mq[:, 1 + r0:, r0:], 1, 2), mode="complete")
    n = Qf[:, :, -1]                                          # (N, m) null direction of the e rows
    pivot = np.einsum("ni,ni->n", Mq[:, 0, r0:], n)
    longitudinal = np.abs(pivot) / (xi * np.sum(np.abs(np.cumsum(n, axis=-1)), axis=-1))

    sv = np.linalg.svd(M, compute_uv=False)
    sve = np.linalg.svd(_equilibrated(M), compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = _solve(M, r)
        v = ctrl.speeds(T)
        amp = np.where(v != 0, xi * np.linalg.norm(u, axis=-1) / np.abs(v), np.nan)
        cond = sv[:, 0] / sv[:, -1]
        cond_s = sve[:, 0] / sve[:, -1]
    return {"links": links, "worst_link": _worst_link(links), "longitudinal": longitudinal,
            "sigma_min": sv[:, -1] / xi, "cond": cond, "inverse_cond": sv[:, -1] / sv[:, 0],
            "cond_scaled": cond_s, "inverse_cond_scaled": sve[:, -1] / sve[:, 0],
            "amplification": amp, "u_max": np.max(np.abs(u), axis=-1)}


def margins(controller: CoordinatingController, q: ArrayLike, t: float = 0.0) -> dict[str, Any]:
    """Singularity margins of ``controller`` at configuration ``q`` and time ``t``.

    Parameters
    ----------
    controller : CoordinatingController
        Chain, curve, gain and speed.
    q : (m,) array_like
        Joint coordinates [rad].
    t : float
        Time [s].

    Returns
    -------
    dict
        ``links`` ((m-1,) array, links 2..m), ``worst_link`` (int, 1-based), ``longitudinal``,
        ``sigma_min``, ``inverse_cond``, ``inverse_cond_scaled`` (margins, 0 = singular),
        ``cond``, ``cond_scaled``, ``amplification``, ``u_max`` (floats); see the module notes.
    """
    q = controller.chain.check_q(q)
    out = _margins_batch(controller, q[None, :], np.array([float(t)]))
    return {k: (v[0] if k == "links" else (int(v[0]) if k == "worst_link" else float(v[0])))
            for k, v in out.items()}


def run_margins(controller: CoordinatingController, t: ArrayLike, q: ArrayLike, batch: int | None = None) -> dict[str, np.ndarray]:
    """:func:`margins` along a trajectory: every value becomes an array over samples.

    Parameters
    ----------
    controller : CoordinatingController
        The controller the run used.
    t : (N,) array_like
        Sample times [s].
    q : (N, dof) array_like
        Configurations [rad] (``d`` [m] first on a rail).
    batch : int, optional
        Samples evaluated together (default: as many as keep one stack of m x m matrices
        near 128 MiB, at most 500; a few such stacks are alive at once).

    Returns
    -------
    dict
        Same keys as :func:`margins`; ``links`` has shape (N, m-1), the others (N,).

    Raises
    ------
    ConfigError
        ``q`` is not of shape (N, dof).
    """
    t = np.asarray(t, dtype=float).ravel()
    q = np.asarray(q, dtype=float)
    if q.shape != (len(t), controller.chain.dof):
        raise ConfigError(f"q: need shape ({len(t)}, {controller.chain.dof}), got {q.shape}")
    m = controller.chain.m
    batch = batch or max(1, min(500, 2**24 // (m * m)))
    parts = [_margins_batch(controller, q[i:i + batch], t[i:i + batch]) for i in range(0, len(t), batch)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
