"""The result of a simulated run: :class:`Run`, its per-sample arrays and summary."""
from __future__ import annotations

from dataclasses import field, fields
from typing import Callable

import numpy as np

from coordarm.symbolic.records import record

from .log_layout import ARRAYS, OPTIONAL, ChainLayout, layout_of_arrays
from .s_reference import ArcReference


class ExtraOutputs:
    """Mixin of :class:`Run` and :class:`~coordarm.analysis.replay.Replay`: the arrays in their
    ``extra`` dict (law outputs that have no field of their own) read as attributes."""

    def __getattr__(self, name: str) -> np.ndarray:
        extra = self.__dict__.get("extra") or {}
        if name in extra:
            return extra[name]
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")


@record
class Run(ExtraOutputs):
    """A simulated run, sampled at every step (row k is time ``t[k]``).

    Attributes
    ----------
    t : (N+1,) array
        Time [s].
    q : (N+1, dof) array
        Joint coordinates [rad] (on a rail, ``d`` [m] first; ``dof = m + 1``; a spatial chain
        ``(a_1, b_1, ..., a_m, b_m)``, ``dof = 2 m``).
    u : (N+1, dof) array
        Control at each sample [rad/s for B = I; on a rail, ``d_dot`` [m/s] first].
    e : (N+1, m-1) array
        Deviations ``e^2..e^m`` from the curve [m] (spatial: ``(N+1, 2(m-1))``, ``e^2_1, e^2_2, e^3_1, ...``).
    s : (N+1,) array
        Arc length ``s^m`` of the end point [m].
    link_margins : (N+1, m-1) array
        Link margins of links 2..m (0 = link perpendicular to the curve).
    longitudinal : (N+1,) array or None
        Longitudinal margin (0 = end point cannot be pushed along the curve); None for a spatial chain
        (its ``end_margin``, ``joint_margins``, ``roll`` and ``roll_star`` are in ``extra``).
    v_star : (N+1,) array
        Commanded speed [m/s].
    sigma, rail_margin : (N+1,) array or None
        On a rail only: the span ``psi(y^m) - psi(y^1)`` [m] and the rail margin [-].
    v_scale : (N+1,) array
        The governor's factor on ``v*`` (all ones without the governor; default ones).
    info : dict
        Backend, wall time, stop reason, ``governed`` time [s] (steps with ``v_scale < 1``).
    extra : dict
        Arrays of the law's other run outputs (rows of :data:`~coordarm.symbolic.outputs.LAW_OUTPUTS`
        with a log channel that are not fields above; for a spatial chain the rows of ``SPATIAL_LAW_OUTPUTS``
        and the commanded roll ``roll_star``), also readable as attributes. The arrays of each kind of
        chain are those of its :class:`~.log_layout.ChainLayout` (:attr:`layout`).

    On a rail ``q`` and ``u`` have m+1 columns, the rail position ``d`` [m] and its rate first.
    """

    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    e: np.ndarray
    s: np.ndarray
    link_margins: np.ndarray
    longitudinal: np.ndarray | None
    v_star: np.ndarray
    sigma: np.ndarray | None = None
    rail_margin: np.ndarray | None = None
    info: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], info: dict | None = None) -> "Run":
        """A Run from arrays keyed by :data:`ARRAYS` (law outputs without a field go to ``extra``).

        Parameters
        ----------
        arrays : dict of str to ndarray
            Every array of :data:`ARRAYS` (``t`` ``(N,)`` [s], ``q`` ``(N, dof)`` [rad], the law outputs,
            ``v_star`` [m/s]) and any of :data:`OPTIONAL` (rail outputs), or every array of the spatial
            layout (:data:`~.log_layout.SPATIAL`); other keys are ignored.
        info : dict, optional
            The run's ``info`` (copied).

        Returns
        -------
        Run

        Raises
        ------
        KeyError
            An array of :data:`ARRAYS` is missing.
        """
        named = {f.name for f in fields(cls)} - {"info", "extra"}
        keys = layout_of_arrays(arrays).arrays + tuple(a for a in OPTIONAL if a in arrays)
        given = {a: arrays[a] for a in keys if a in named}
        given.setdefault("longitudinal", None)          # a spatial chain has none (its end_margin instead)
        return cls(**given, info=dict(info or {}), extra={a: arrays[a] for a in keys if a not in named})

    @classmethod
    def from_states(cls, t: np.ndarray, q: np.ndarray, u: np.ndarray, v_star: np.ndarray, links: int,
                    info: dict | None = None) -> "Run":
        """A Run of a method other than the coordinating law (a baseline): states and inputs only.

        The law's diagnostics are not computed for such a run: ``e``, ``s``, ``link_margins`` and
        ``longitudinal`` are NaN (score it from ``q``, see :mod:`coordarm.analysis.compare`), it has
        no rail outputs and ``v_scale`` is all ones (not governed).

        Parameters
        ----------
        t : (N,) ndarray
            Time [s].
        q : (N, dof) ndarray
            Joint coordinates [rad; on a rail the position ``d`` [m] first].
        u : (N, dof) ndarray
            Control at each sample [rad/s; on a rail ``d_dot`` [m/s] first].
        v_star : (N,) ndarray
            Commanded speed [m/s].
        links : int
            Number of links ``m`` (the diagnostics per link have m-1 columns).
        info : dict, optional
            Backend, stop reason, wall time, steps (see :attr:`info`).

        Returns
        -------
        Run
        """
        n = len(t)
        return cls(t=t, q=q, u=u, e=np.full((n, links - 1), np.nan), s=np.full(n, np.nan),
                   link_margins=np.full((n, links - 1), np.nan), longitudinal=np.full(n, np.nan),
                   v_star=v_star, info=dict(info or {}))

    def rows(self, index: slice | np.ndarray, info: dict | None = None) -> "Run":
        """The run at the rows ``index`` of every per-sample array (:data:`ARRAYS`, rail outputs if any).

        Parameters
        ----------
        index : slice or integer ndarray
            Rows to keep.
        info : dict, optional
            Info of the result (default: this run's).

        Returns
        -------
        Run
        """
        return Run.from_arrays({a: getattr(self, a)[index] for a in self.array_names()},
                               self.info if info is None else info)

    def array_names(self) -> tuple[str, ...]:
        """Names of this run's per-sample arrays: :data:`ARRAYS` and the rail outputs it has.

        Returns
        -------
        tuple of str
        """
        return self.layout.arrays + tuple(a for a in OPTIONAL if getattr(self, a, None) is not None)

    @property
    def layout(self) -> ChainLayout:
        """The layout of this run's arrays (planar or spatial, :mod:`.log_layout`)."""
        return layout_of_arrays({f.name for f in fields(self)} | set(self.extra))

    def __post_init__(self) -> None:
        # A run made without the governor's output (e.g. by a baseline) was not governed.
        if "v_scale" not in self.extra:
            self.extra["v_scale"] = np.ones(len(self.t))

    def speed_factor(self) -> np.ndarray:
        """The governor's factor on ``v*`` at each sample (1 where unknown, e.g. replayed from an older log).

        Returns
        -------
        ndarray, shape (N+1,)
            In [0, 1] (dimensionless).
        """
        scale = np.asarray(self.extra["v_scale"], dtype=float)
        return np.where(np.isfinite(scale), scale, 1.0)

    def s_reference(self, speeds: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
        """``s(0) + integral of v_scale v*`` on the sample grid.

        Parameters
        ----------
        speeds : callable, optional
            ``v*`` at an array of times [m/s] (``ctrl.speeds``): Simpson's rule with ``v*`` at the middle
            of each interval the governor left whole (as the summary's s tracking,
            :class:`~.every_step.STracking`); None: the trapezoidal rule (its own error, O(step^2) where
            ``v*`` is not affine, e.g. 3e-8 m on a smoothstep ramp at 2 ms steps).

        Returns
        -------
        ndarray, shape (N+1,)
            The arc length the end point should have [m] (the governed speed when governed).
        """
        return ArcReference(speeds).add(self.t, self.s[0], self.v_star, self.speed_factor())

    def max_s_tracking_error(self) -> float:
        """The largest ``|s - s_reference|`` of the run.

        Returns
        -------
        float
            [m]: over every step of a simulated run (``info["max_s_tracking_error"]``, see
            :class:`~.every_step.STracking`), else over these rows (a replayed log has every logged row).
        """
        if "max_s_tracking_error" in self.info:
            return float(self.info["max_s_tracking_error"])
        return float(np.max(np.abs(self.s - self.s_reference())))

    def governed_time(self) -> float:
        """Time the governor slowed ``v*``: samples with ``v_scale < 1`` times the step.

        Returns
        -------
        float
            Simulated time [s].
        """
        step = float(self.t[1] - self.t[0]) if len(self.t) > 1 else 0.0
        return step * int(np.count_nonzero(self.speed_factor() < 1))

    def summary(self) -> dict[str, float]:
        """Final ``max|e|``, worst ``s`` tracking error, smallest margins and where.

        Returns
        -------
        dict
            ``duration`` [s], ``steps``, ``final_max_abs_e`` [m], ``max_s_tracking_error`` [m],
            ``min_link_margin`` with its ``_link`` and ``_time``, ``min_longitudinal_margin`` with
            its ``_time``, ``max_abs_u`` (a spatial run: :meth:`spatial_summary`).
        """
        if self.layout.kind != "revolute":
            return self.spatial_summary()
        lm = self.link_margins
        k, j = np.unravel_index(np.argmin(lm), lm.shape)
        return {"duration": float(self.t[-1] - self.t[0]), "steps": int(self.info.get("steps", len(self.t) - 1)),
                "final_max_abs_e": float(np.max(np.abs(self.e[-1]))),
                "max_s_tracking_error": self.max_s_tracking_error(),
                "min_link_margin": float(lm[k, j]), "min_link_margin_link": int(j) + 2,
                "min_link_margin_time": float(self.t[k]),
                "min_longitudinal_margin": float(np.min(self.longitudinal)),
                "min_longitudinal_margin_time": float(self.t[np.argmin(self.longitudinal)]),
                "max_abs_u": float(np.max(np.abs(self.u)))}

    def spatial_summary(self) -> dict[str, float]:
        """The summary of a spatial run: final ``max|e^j|``, ``s`` and roll tracking, smallest margins and where.

        Returns
        -------
        dict
            ``duration`` [s], ``steps``, ``final_max_abs_e`` (largest distance ``|(e^j_1, e^j_2)|`` at the
            end) [m], ``max_s_tracking_error`` [m], ``max_roll_tracking_error`` (largest ``|roll - roll*|``,
            wrapped to (-pi, pi]) [rad], ``min_link_margin`` with its ``_link`` and ``_time``,
            ``min_end_margin`` with its ``_time``, ``min_joint_margin`` with its ``_joint`` and ``_time``,
            ``max_abs_u`` [rad/s].
        """
        lm, jm, end = self.link_margins, self.extra["joint_margins"], self.extra["end_margin"]
        k, j = np.unravel_index(np.argmin(lm), lm.shape)
        kj, jj = np.unravel_index(np.argmin(jm), jm.shape)
        roll_error = np.angle(np.exp(1j * (self.extra["roll"] - self.extra["roll_star"])))
        return {"duration": float(self.t[-1] - self.t[0]), "steps": int(self.info.get("steps", len(self.t) - 1)),
                "final_max_abs_e": float(np.max(deviation_norms(self.e[-1:], 2))),
                "max_s_tracking_error": self.max_s_tracking_error(),
                "max_roll_tracking_error": float(np.max(np.abs(roll_error))),
                "min_link_margin": float(lm[k, j]), "min_link_margin_link": int(j) + 2,
                "min_link_margin_time": float(self.t[k]),
                "min_end_margin": float(np.min(end)), "min_end_margin_time": float(self.t[np.argmin(end)]),
                "min_joint_margin": float(jm[kj, jj]), "min_joint_margin_joint": int(jj) + 1,
                "min_joint_margin_time": float(self.t[kj]),
                "max_abs_u": float(np.max(np.abs(self.u)))}


def deviation_norms(e: np.ndarray, per_link: int) -> np.ndarray:
    """The distance of each central point from the curve: ``|e^j|`` per link.

    Parameters
    ----------
    e : ndarray, shape (n, per_link * (m-1))
        Deviations [m]: ``e^j`` (planar, ``per_link = 1``) or ``(e^j_1, e^j_2)`` pairs (spatial, 2).
    per_link : int
        Columns per link.

    Returns
    -------
    ndarray, shape (n, m-1)
        ``|e^j|`` [m] (for ``per_link = 1`` exactly ``abs(e)``).
    """
    e = np.asarray(e)
    if per_link == 1:
        return np.abs(e)
    return np.linalg.norm(e.reshape(*e.shape[:-1], -1, per_link), axis=-1)
