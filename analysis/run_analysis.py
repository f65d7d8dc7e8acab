"""Margins along a run, their first threshold crossings, and the blow-up they should predict.

Works from any object with arrays ``t`` (N,), ``q`` (N, m) and ``u`` (N, m) — a
:class:`simulation.run.Run` or a replayed log. Margins are recomputed from ``q``
(:func:`analysis.singularity.run_margins`) on an even subsample of the run, refined to full
resolution around every threshold crossing.

A *blow-up* is the first sample where ``|u|_inf`` exceeds ``BLOWUP_FACTOR`` (10) times its
nominal value (:func:`nominal_u`: the median of ``|u|_inf`` over the whole run, but never
less than the rate the commanded motion itself asks for, ``(max v* + K max|e(0)|) / xi``,
so a run that starts at rest does not get a vanishing nominal). A margin *predicts* it when
it falls below its threshold strictly before that time. Read by :mod:`coordarm.analysis.report` (tables,
``report.json``) and :mod:`.report_figures` (plots).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coordarm.simulation.run import even_indices
from coordarm.symbolic import CoordinatingController

from .singularity import MARGINS, REPORT_THRESHOLDS, run_margins

#: ``|u|`` above this many times its nominal value counts as a blow-up.
BLOWUP_FACTOR = 10.0
#: Descriptions of the margins, for tables and legends.
LABELS = {"links": "smallest link margin", "longitudinal": "longitudinal margin",
          "sigma_min": "sigma_min(M)/xi", "inverse_cond": "1/cond(M)",
          "inverse_cond_scaled": "1/cond(M), equilibrated"}


@dataclass
class RunAnalysis:
    """Margins of a run and what they predicted.

    Attributes
    ----------
    t : (n,) array
        Times of the margin samples [s].
    margins : dict
        :func:`~analysis.singularity.run_margins` at those samples.
    t_all, u_norm : (N,) arrays
        All sample times [s] and ``|u|_inf`` there [rad/s].
    nominal_u : float
        Nominal ``|u|_inf`` (:func:`nominal_u`) [rad/s].
    blowup_time : float or None
        First time ``|u|_inf > BLOWUP_FACTOR * nominal_u`` [s].
    blowup_link : int or None
        The joint (1..m, a rail's ``d`` not counted) with the largest ``|u_j|`` at the blow-up
        (:func:`blowup_joint`); None without a blow-up or when the rail's rate was the largest.
    thresholds : dict
        Threshold of each margin.
    crossings : dict
        Margin -> first time below its threshold [s] (None: never).
    minima : dict
        Margin -> (smallest value, time) over the run.
    blowup_rail : bool
        The rail's ``|d_dot|`` [m/s] was the largest entry of ``u`` at the blow-up.
    """

    t: np.ndarray
    margins: dict
    t_all: np.ndarray
    u_norm: np.ndarray
    nominal_u: float
    blowup_time: float | None
    blowup_link: int | None
    thresholds: dict
    crossings: dict
    minima: dict
    blowup_rail: bool = False

    def smallest(self, name: str) -> np.ndarray:
        """Margin ``name`` per sample (the smallest link margin for ``"links"``).

        Parameters
        ----------
        name : str
            A margin, one of :data:`~analysis.singularity.MARGINS`.

        Returns
        -------
        (n,) ndarray
            Its value at each of the samples :attr:`t` [-]; for ``"links"`` the smallest over the links.
        """
        return _smallest(self.margins, name)

    def predicted(self) -> dict[str, bool | None]:
        """Margin -> crossed its threshold before the blow-up (None when there was no blow-up).

        Returns
        -------
        dict of str to bool or None
            For every margin of :attr:`crossings`: True when its first crossing is strictly before
            :attr:`blowup_time`, False when later or never, None for all when there was no blow-up.
        """
        if self.blowup_time is None:
            return {k: None for k in self.crossings}
        return {k: (c is not None and c < self.blowup_time) for k, c in self.crossings.items()}


def _smallest(mg: dict, name: str) -> np.ndarray:
    v = mg[name]
    return np.min(v, axis=1) if v.ndim == 2 else v


def _below(values: np.ndarray, thr: float) -> np.ndarray:
    return ~(values >= thr)          # NaN counts as crossed


def default_samples(links: int) -> int:
    """Margin samples of a report before refinement: 1200 up to 64 links, then ``* (64/m)^2``, at least 100.

    Each sample costs SVDs and a QR of the m x m decoupling matrix, O(m^3).

    Parameters
    ----------
    links : int
        Number of links m (> 0).

    Returns
    -------
    int
        Samples, between 100 and 1200.
    """
    return max(100, min(1200, round(1200 * (64 / links) ** 2)))


def _merge(idx: np.ndarray, mg: dict, new: np.ndarray, more: dict) -> tuple[np.ndarray, dict]:
    """Samples ``idx`` with margins ``mg`` plus samples ``new`` with margins ``more``, sorted by index."""
    order = np.argsort(np.concatenate([idx, new]), kind="stable")
    return np.concatenate([idx, new])[order], {k: np.concatenate([mg[k], more[k]])[order] for k in mg}


#: Most margin evaluations per zoom level when locating a first threshold crossing.
ZOOM = 32


def analyse_run(ctrl: CoordinatingController, t, q, u, thresholds: dict[str, float] | None = None,
                samples: int | None = None) -> RunAnalysis:
    """Margins along a run, their first threshold crossings and the blow-up time.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller of the run.
    t : (N,) array_like
        Times [s].
    q, u : (N, m) array_like
        Configurations [rad] and controls [rad/s].
    thresholds : dict, optional
        Thresholds per margin (defaults: the simulator's for links and longitudinal,
        :data:`~analysis.singularity.REPORT_THRESHOLDS` for the others).
    samples : int, optional
        Margin samples spread evenly over the run (default :func:`default_samples`). Around
        the first crossing of every margin the samples are then refined down to single rows,
        at most :data:`ZOOM` evaluations per level.

    Returns
    -------
    RunAnalysis
        The margins at the (refined) samples, their crossings and minima, and the blow-up;
        rows with a non-finite ``q`` or ``t`` are left out.
    """
    from coordarm.simulation.run import DEFAULT_THRESHOLDS

    t, q, u = (np.asarray(a, dtype=float) for a in (t, q, u))
    finite = np.all(np.isfinite(q), axis=1) & np.isfinite(t)
    t, q, u = t[finite], q[finite], u[finite]
    thr = {"links": DEFAULT_THRESHOLDS["link"], "longitudinal": DEFAULT_THRESHOLDS["longitudinal"],
           **REPORT_THRESHOLDS}
    for k, v in (thresholds or {}).items():
        thr["links" if k == "link" else k] = float(v)
    u_norm = np.max(np.abs(u), axis=1)
    nominal = nominal_u(ctrl, t, q, u_norm)
    over = np.flatnonzero(~(u_norm <= BLOWUP_FACTOR * nominal))
    blowup = float(t[over[0]]) if len(over) else None
    blowup_link, blowup_rail = blowup_joint(u[over[0]], ctrl.chain.rail) if len(over) else (None, False)

    idx = even_indices(len(t), samples or default_samples(ctrl.chain.m))
    mg = run_margins(ctrl, t[idx], q[idx])
    for name in MARGINS:                     # zoom in on the first crossing of every margin
        while True:
            hit = np.flatnonzero(_below(_smallest(mg, name), thr[name]))
            if not len(hit) or hit[0] == 0:
                break
            lo, hi = int(idx[hit[0] - 1]), int(idx[hit[0]])
            inside = np.unique(np.linspace(lo, hi, min(ZOOM, hi - lo - 1) + 2).round().astype(int))[1:-1]
            if not len(inside):
                break                        # adjacent rows: located
            idx, mg = _merge(idx, mg, inside, run_margins(ctrl, t[inside], q[inside]))
    ts = t[idx]
    crossings, minima = {}, {}
    for name in MARGINS:
        v = _smallest(mg, name)
        hit = np.flatnonzero(_below(v, thr[name]))
        crossings[name] = float(ts[hit[0]]) if len(hit) else None
        k = int(np.nanargmin(v)) if np.isfinite(v).any() else 0
        minima[name] = (float(v[k]), float(ts[k]))
    return RunAnalysis(ts, mg, t, u_norm, nominal, blowup, blowup_link, thr, crossings, minima, blowup_rail)


def blowup_joint(u_row: np.ndarray, rail: bool, per_joint: int = 1) -> tuple[int | None, bool]:
    """The joint whose rate is the largest in ``u_row``, numbered as the user sees the joints, or the rail.

    Parameters
    ----------
    u_row : (n,) array_like
        The control at one sample: ``(d_dot, u_1, ...)`` on a rail (``d_dot`` [m/s] first), else
        ``(u_1, ...)`` [rad/s]; a universal joint has ``per_joint = 2`` entries ``(a_j', b_j')``.
    rail : bool
        Whether the chain is on a rail (the first entry is ``d_dot``).
    per_joint : int
        Entries of ``u`` per joint: 1 planar, 2 universal.

    Returns
    -------
    joint : int or None
        1..m, the rail not counted; None when the rail's ``|d_dot|`` is the largest entry or no entry is finite.
    rail_largest : bool
        The rail's ``|d_dot|`` is the largest entry.
    """
    size = np.abs(np.asarray(u_row, dtype=float))
    if not np.isfinite(size).any():
        return None, False
    k = int(np.nanargmax(size))
    if rail and k == 0:
        return None, True
    return (k - int(rail)) // per_joint + 1, False


def nominal_u(ctrl: CoordinatingController, t: np.ndarray, q: np.ndarray, u_norm: np.ndarray) -> float:
    """Nominal ``|u|_inf`` of a run [rad/s]: robust, and not vanishing when the robot starts at rest.

    The larger of the median of ``|u|_inf`` over the whole run and ``(max v* + K max|e(0)|) / xi``,
    the joint rate the commanded motion asks of a link (end point speed and the decay of the
    initial deviations, over one link length).

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller of the run (speed ``v*`` [m/s], gain ``K`` [1/s], link length ``xi`` [m]).
    t : (N,) ndarray
        Sample times [s], N >= 1.
    q : (N, dof) ndarray
        Configurations [rad] (``d`` [m] first on a rail); only the first row is read (``e(0)``).
    u_norm : (N,) ndarray
        ``|u|_inf`` at each sample [rad/s]; non-finite values are left out of the median.

    Returns
    -------
    float
        The nominal ``|u|_inf`` [rad/s].
    """
    e0 = float(np.max(np.abs(ctrl.evaluate(q[0], float(t[0]))["e"])))
    commanded = (float(np.max(np.abs(ctrl.speeds(t)))) + ctrl.gain * e0) / ctrl.chain.xi
    finite = u_norm[np.isfinite(u_norm)]
    return max(float(np.median(finite)) if len(finite) else 0.0, commanded)
