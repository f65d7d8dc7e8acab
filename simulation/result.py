"""The result of a simulated run: :class:`Run`, its per-sample arrays and summary."""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from .log_layout import ARRAYS, OPTIONAL


class ExtraOutputs:
    """Mixin of :class:`Run` and :class:`~coordarm.analysis.replay.Replay`: the arrays in their
    ``extra`` dict (law outputs that have no field of their own) read as attributes."""

    def __getattr__(self, name: str) -> np.ndarray:
        extra = self.__dict__.get("extra") or {}
        if name in extra:
            return extra[name]
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")


@dataclass
class Run(ExtraOutputs):
    """A simulated run, sampled at every step (row k is time ``t[k]``).

    Attributes
    ----------
    t : (N+1,) array
        Time [s].
    q : (N+1, dof) array
        Joint coordinates [rad] (on a rail, ``d`` [m] first; ``dof = m + 1``).
    u : (N+1, dof) array
        Control at each sample [rad/s for B = I; on a rail, ``d_dot`` [m/s] first].
    e : (N+1, m-1) array
        Deviations ``e^2..e^m`` from the curve [m].
    s : (N+1,) array
        Arc length ``s^m`` of the end point [m].
    link_margins : (N+1, m-1) array
        Link margins of links 2..m (0 = link perpendicular to the curve).
    longitudinal : (N+1,) array
        Longitudinal margin (0 = end point cannot be pushed along the curve).
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
        with a log channel that are not fields above), also readable as attributes.

    On a rail ``q`` and ``u`` have m+1 columns, the rail position ``d`` [m] and its rate first.
    """

    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    e: np.ndarray
    s: np.ndarray
    link_margins: np.ndarray
    longitudinal: np.ndarray
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
            ``v_star`` [m/s]) and any of :data:`OPTIONAL` (rail outputs); other keys are ignored.
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
        keys = ARRAYS + tuple(a for a in OPTIONAL if a in arrays)
        return cls(**{a: arrays[a] for a in keys if a in named}, info=dict(info or {}),
                   extra={a: arrays[a] for a in keys if a not in named})

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
        return ARRAYS + tuple(a for a in OPTIONAL if getattr(self, a, None) is not None)

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

    def s_reference(self) -> np.ndarray:
        """``s(0) + integral of v_scale v*`` on the sample grid (trapezoidal rule).

        Returns
        -------
        ndarray, shape (N+1,)
            The arc length the end point should have [m] (the governed speed when governed).
        """
        dt = np.diff(self.t)
        v = self.speed_factor() * self.v_star
        return self.s[0] + np.concatenate([[0.0], np.cumsum(0.5 * dt * (v[1:] + v[:-1]))])

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
            its ``_time``, ``max_abs_u``.
        """
        lm = self.link_margins
        k, j = np.unravel_index(np.argmin(lm), lm.shape)
        return {"duration": float(self.t[-1] - self.t[0]), "steps": int(self.info.get("steps", len(self.t) - 1)),
                "final_max_abs_e": float(np.max(np.abs(self.e[-1]))),
                "max_s_tracking_error": float(np.max(np.abs(self.s - self.s_reference()))),
                "min_link_margin": float(lm[k, j]), "min_link_margin_link": int(j) + 2,
                "min_link_margin_time": float(self.t[k]),
                "min_longitudinal_margin": float(np.min(self.longitudinal)),
                "min_longitudinal_margin_time": float(self.t[np.argmin(self.longitudinal)]),
                "max_abs_u": float(np.max(np.abs(self.u)))}
