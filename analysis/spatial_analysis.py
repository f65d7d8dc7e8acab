"""Margins along a spatial run (universal joints), their minima and first threshold crossings, and the blow-up.

A spatial run carries its margins in its arrays (logged at every kept row): ``link_margins`` (N, m-1)
(the smallest singular value of each 2x2 link pivot over ``xi/2``, links 2..m), ``end_margin`` (N,)
(the scaled 2x2 end solve of ``s`` and roll) and ``joint_margins`` (N, m) (``|cos b_j|``, joints 1..m).
They are read as they are, not recomputed. The link and joint margins are checked against the run's
``link`` threshold, the end margin against its ``longitudinal`` one, as the simulator does. The
blow-up (``|u|_inf`` above :data:`~.run_analysis.BLOWUP_FACTOR` times its nominal value) is the
planar report's (:mod:`.run_analysis`). Read by :mod:`.spatial_report` and :mod:`.spatial_report_figures`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from coordarm.simulation.run import DEFAULT_THRESHOLDS, even_indices

from .run_analysis import BLOWUP_FACTOR, blowup_joint, nominal_u

#: The spatial margins: name -> (array of the run, threshold key, first index number or None for a scalar).
SPATIAL_MARGINS = {"link": ("link_margins", "link", 2), "end": ("end_margin", "longitudinal", None),
                   "joint": ("joint_margins", "link", 1)}
#: Descriptions of the spatial margins, for tables and legends.
SPATIAL_LABELS = {"link": "smallest link margin (2x2 link pivots)", "end": "end margin (2x2 end solve: s, roll)",
                  "joint": "smallest joint margin abs(cos b_j)"}
#: Largest chain (links) whose decoupling matrix's condition number is sampled (an SVD of 2m x 2m each).
COND_LINKS = 32
#: Samples of the condition number over the run.
COND_SAMPLES = 60


@dataclass
class SpatialAnalysis:
    """Margins of a spatial run, their minima and crossings, and the blow-up.

    Attributes
    ----------
    t : (N,) array
        Times of the finite rows [s].
    margins : dict
        ``"link"`` (N, m-1), ``"end"`` (N,), ``"joint"`` (N, m) margins [-] (0 = singular).
    u_norm : (N,) array
        ``|u|_inf`` [rad/s].
    nominal_u : float
        Nominal ``|u|_inf`` [rad/s] (:func:`~.run_analysis.nominal_u`).
    blowup_time : float or None
        First time ``|u|_inf > BLOWUP_FACTOR * nominal_u`` [s].
    thresholds : dict
        Margin name -> threshold [-].
    minima : dict
        Margin name -> ``(value, time [s], index)``: the smallest value over the run and the links, its
        time and its link (2..m) or joint (1..m) number (None for the end margin).
    crossings : dict
        Margin name -> first time below its threshold [s] (None: never).
    cond_t, cond : (n,) arrays
        Times [s] and 2-norm condition numbers of the decoupling matrix (empty above :data:`COND_LINKS`).
    blowup_joint : int or None
        The universal joint (1..m, a rail's ``d`` not counted) with the largest rate ``|a_j'|`` or ``|b_j'|`` at
        the blow-up (:func:`~.run_analysis.blowup_joint`); None without one or when the rail's was the largest.
    blowup_rail : bool
        The rail's ``|d_dot|`` [m/s] was the largest entry of ``u`` at the blow-up.
    """

    t: np.ndarray
    margins: dict
    u_norm: np.ndarray
    nominal_u: float
    blowup_time: float | None
    thresholds: dict
    minima: dict
    crossings: dict
    cond_t: np.ndarray
    cond: np.ndarray
    blowup_joint: int | None = None
    blowup_rail: bool = False

    def smallest(self, name: str) -> np.ndarray:
        """Margin ``name`` per row, the smallest over links or joints.

        Parameters
        ----------
        name : {"link", "end", "joint"}
            A margin of :data:`SPATIAL_MARGINS`.

        Returns
        -------
        (N,) ndarray
            Its value at each row [-].
        """
        v = self.margins[name]
        return np.min(v, axis=1) if v.ndim == 2 else v

    def predicted(self) -> dict[str, bool | None]:
        """Margin -> crossed its threshold strictly before the blow-up (None for all without a blow-up).

        Returns
        -------
        dict of str to bool or None
        """
        if self.blowup_time is None:
            return {k: None for k in self.crossings}
        return {k: (c is not None and c < self.blowup_time) for k, c in self.crossings.items()}


def analyse_spatial_run(ctrl: Any, run: Any, thresholds: dict[str, float] | None = None) -> SpatialAnalysis:
    """The margins of a spatial run, their minima and crossings, the blow-up and (small chains) cond(M).

    Parameters
    ----------
    ctrl : SpatialController
        The controller of the run (gain, speed, link length; its decoupling matrix for cond).
    run : Run or Replay
        A spatial run: ``t`` (N,), ``q``, ``u`` (N, 2m), ``e``, ``link_margins``, ``end_margin``,
        ``joint_margins``.
    thresholds : dict, optional
        ``{"link": .., "longitudinal": ..}`` replacing the simulator's defaults.

    Returns
    -------
    SpatialAnalysis
        Rows with a non-finite ``t`` or ``q`` are left out.
    """
    t, q, u = (np.asarray(getattr(run, k), dtype=float) for k in ("t", "q", "u"))
    ok = np.all(np.isfinite(q), axis=1) & np.isfinite(t)
    t, q, u = t[ok], q[ok], u[ok]
    thr_in = dict(DEFAULT_THRESHOLDS, **(thresholds or {}))
    thr = {name: float(thr_in[key]) for name, (_, key, _) in SPATIAL_MARGINS.items()}
    margins = {name: np.asarray(getattr(run, field), dtype=float)[ok]
               for name, (field, _, _) in SPATIAL_MARGINS.items()}
    minima, crossings = {}, {}
    for name, (_, _, first) in SPATIAL_MARGINS.items():
        v = margins[name]
        flat = np.where(np.isfinite(v), v, np.inf)
        k, j = np.unravel_index(np.argmin(flat), v.shape) if v.ndim == 2 else (int(np.argmin(flat)), None)
        minima[name] = (float(v[k] if j is None else v[k, j]), float(t[k]), None if j is None else int(j) + first)
        smallest = np.min(v, axis=1) if v.ndim == 2 else v
        below = np.flatnonzero(~(smallest >= thr[name]))          # NaN counts as crossed
        crossings[name] = float(t[below[0]]) if len(below) else None
    u_norm = np.max(np.abs(u), axis=1)
    nominal = nominal_u(ctrl, t, q, u_norm)
    over = np.flatnonzero(~(u_norm <= BLOWUP_FACTOR * nominal))
    cond_t, cond = np.empty(0), np.empty(0)
    if ctrl.chain.m <= COND_LINKS and len(t):
        rows = even_indices(len(t), COND_SAMPLES)
        cond_t, cond = t[rows], ctrl.conds(q[rows], t[rows])
    joint, rail = blowup_joint(u[over[0]], ctrl.chain.rail, 2) if len(over) else (None, False)
    return SpatialAnalysis(t, margins, u_norm, nominal, float(t[over[0]]) if len(over) else None,
                           thr, minima, crossings, cond_t, cond, joint, rail)
