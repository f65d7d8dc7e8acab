"""The scores of ``coordarm compare``: one table (:data:`SCORE_TABLE`), every score computed from a run's joint trajectory.

Each :class:`Score` row names its JSON key, its table column (with the unit), how a cell is printed
and the function that computes it from a :class:`Scoring` (the run, its scenario and what several
scores share, computed once). A new score is one more row. The scores, for planar and spatial chains
alike (a spatial centre's deviation is the length of its two normal coordinates ``|Phi|``):

* ``max_deviation`` [m]: the largest distance of a central point ``y^2..y^m`` from the path over the
  run (``y^1`` is the base);
* ``shape_deviation`` [%]: the mean over the run's samples and the central points ``y^2..y^m`` of
  their distance from the path, over the body length ``m xi``, times 100 (:func:`shape_deviation`);
* ``wall_contacts``, ``self_collisions``: samples (at :data:`CONTACT_RATE`) in which some link touches
  an obstacle, or two non-adjacent links (capsules, in 3-D) touch each other;
* ``peak_u``, ``peak_joint_rate``: largest ``|u|`` and ``|qdot| = |B u|`` of the joints [rad/s];
* ``peak_rail_rate`` (a robot on a rail only): largest ``|d_dot|`` [m/s];
* ``peak_du_dt``: the largest joint acceleration ``|du/dt|`` over every step [rad/s^2] (the run's own
  record ``run.info["joint_rates"]`` where the simulation kept one, else from the samples kept);
* ``peak_rail_accel`` (a robot on a rail only): the largest ``|d''|`` likewise [m/s^2];
* ``final_s_error``: ``|psi(y^m) - (s(0) + integral of v*)|`` at the run's last sample [m];
* ``step_time``: wall time of the stepping loop per step [s] (``ftl``: of its one mapped call per sample).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Callable

import numpy as np

from coordarm.simulation.physical import distinct

#: Samples per simulated second at which contacts are counted [Hz].
CONTACT_RATE = 100.0
#: Lengths below this are rounding noise in the table (the JSON keeps them) [m].
LENGTH_FLOOR = 1e-9
#: Percentages below this are rounding noise in the table [%].
PERCENT_FLOOR = 1e-7


def centre_distances(ctrl: Any, Q: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from the path and arc length of every link centre at every sample.

    Planar: ``|phi|`` and ``psi`` (:meth:`~coordarm.symbolic.CoordinatingController.centre_geometry`);
    spatial: ``|Phi| = sqrt(phi_1^2 + phi_2^2)`` and ``psi`` from one mapped call of the curve's geometry.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The chain and the curve.
    Q : ndarray, shape (N, dof)
        Joint coordinates [rad] (on a rail, ``d`` [m] first).
    T : ndarray, shape (N,)
        Times [s].

    Returns
    -------
    distance, psi : ndarray, each shape (N, m)
        [m].
    """
    Q, T = np.atleast_2d(np.asarray(Q, float)), np.atleast_1d(np.asarray(T, float))
    if not hasattr(ctrl, "roll_target"):                  # planar
        geo = ctrl.centre_geometry(Q, T)
        return np.abs(geo["phi"]), geo["psi"]
    m = ctrl.chain.m
    Y = ctrl.chain.centres_np(Q).reshape(-1, 3)
    Phi, _, _, psi = ctrl.task.geometry.map(len(Y))(Y.T, np.repeat(T, m)[None])[:4]
    return np.linalg.norm(np.asarray(Phi), axis=0).reshape(-1, m), np.asarray(psi).reshape(-1, m)


def shape_deviation(distance: np.ndarray, body_length: float) -> float:
    """The mean shape deviation as a percentage of the body length.

    ``100 / (m xi) * mean over samples k and centres j = 2..m of dist(y^j(t_k), path)``.

    Parameters
    ----------
    distance : ndarray, shape (N, m)
        Distance of every centre from the path at every sample [m] (column 0, the base, is left out).
    body_length : float
        ``m xi`` [m].

    Returns
    -------
    float
        [%].
    """
    return float(100.0 * np.mean(distance[:, 1:]) / body_length)


#: Legend label of the red rings of ``compare.png`` (planar and spatial): :func:`contacts_between`.
SINCE = "contact since the previous panel (where)"


def contacts_between(physical: Any, run: Any, step: float, after: float, upto: float) -> list[Any]:
    """The first contact of every (kind, links, obstacle) among the samples :data:`CONTACT_RATE` apart with
    ``after < t <= upto`` (what ``compare.png`` rings in the panel at ``upto``).

    Parameters
    ----------
    physical : Physical or Physical3D
        The scenario's checks (:meth:`Scenario.physical`).
    run : Run
        A method's run.
    step : float
        Its RK4 step [s].
    after, upto : float
        The window [s].

    Returns
    -------
    list of Contact
        In time order.
    """
    every = max(1, int(round(1.0 / (CONTACT_RATE * step))))
    rows = np.arange(0, len(run.t), every)
    rows = rows[(run.t[rows] > after) & (run.t[rows] <= upto)]
    return distinct(physical.check(run.t[rows], run.q[rows])) if len(rows) else []


@dataclass
class Scoring:
    """One run of a scenario and what its scores share (computed on first use).

    Attributes
    ----------
    run : Run
        The run (``t``, ``q``, ``u``, ``v_star``, ``info``).
    scenario : Scenario
        Its scenario (chain, curve, obstacles, step).
    controller : CoordinatingController or SpatialController, optional
        The scenario's controller, if already built.
    """

    run: Any
    scenario: Any
    controller: Any = field(default=None, repr=False)

    @cached_property
    def ctrl(self) -> Any:
        """The scenario's controller (chain and curve): ``controller`` if given, else built from the scenario."""
        return self.controller if self.controller is not None else self.scenario.controller()

    @cached_property
    def geometry(self) -> tuple[np.ndarray, np.ndarray]:
        """:func:`centre_distances` of the run: ``(distance, psi)``, each (N, m) [m]."""
        return centre_distances(self.ctrl, self.run.q, self.run.t)

    @cached_property
    def contacts(self) -> list[Any]:
        """The contacts at the samples :data:`CONTACT_RATE` apart (and the last)."""
        run, every = self.run, max(1, int(round(1.0 / (CONTACT_RATE * self.scenario.step))))
        rows = np.unique(np.r_[np.arange(0, len(run.t), every), len(run.t) - 1])
        return self.scenario.physical(self.ctrl.chain).check(run.t[rows], run.q[rows])

    @cached_property
    def joint_u(self) -> np.ndarray:
        """``u`` of the joints (the rail's ``d_dot`` dropped), (N, joints) [rad/s]."""
        chain = self.ctrl.chain
        if hasattr(chain, "revolute"):
            return np.asarray(chain.revolute(self.run.u))
        return np.asarray(self.run.u)[:, 1:] if chain.rail else np.asarray(self.run.u)

    @cached_property
    def joint_rates(self) -> np.ndarray:
        """``qdot = B u`` of the joints, (N, joints) [rad/s] (``B = I`` for universal joints)."""
        chain = self.ctrl.chain
        return chain.apply_B(self.joint_u) if hasattr(chain, "apply_B") else self.joint_u

    def peak_rate_change(self, column: str) -> float:
        """The largest ``|du/dt|`` of the joints (``column="du_dt"``) or of the rail (``"rail_accel"``).

        Taken from the simulation's record of every step (``run.info["joint_rates"]``) where there is
        one, else from the differences of the samples kept (a baseline's run).

        Parameters
        ----------
        column : {"du_dt", "rail_accel"}
            Which peak.

        Returns
        -------
        float
            [rad/s^2] or [m/s^2].
        """
        peaks = self.run.info.get("joint_rates") or {}
        if column in peaks:
            return float(peaks[column])
        u = self.joint_u if column == "du_dt" else np.asarray(self.run.u)[:, :1]
        dt = np.diff(self.run.t)[:, None]
        return float(np.max(np.abs(np.diff(u, axis=0)) / dt, initial=0.0))

    def contact_samples(self, kind: str) -> int:
        """Samples with at least one contact of ``kind`` (``"wall"`` or ``"self"``).

        Parameters
        ----------
        kind : str
            Contact kind.

        Returns
        -------
        int
        """
        return len({c.time for c in self.contacts if c.kind == kind})

    def final_s_error(self) -> float:
        """``|psi(y^m) - (s(0) + integral of v*)|`` at the last sample [m].

        Returns
        -------
        float
        """
        run, psi = self.run, self.geometry[1][:, -1]
        s_ref = psi[0] + float(np.sum(0.5 * np.diff(run.t) * (run.v_star[1:] + run.v_star[:-1])))
        return float(abs(psi[-1] - s_ref))


def _length(value: float) -> str:
    return "< 1e-9" if value < LENGTH_FLOOR else f"{value:.3g}"


def _percent(value: float) -> str:
    return "< 1e-7" if value < PERCENT_FLOOR else f"{value:.3g}"


@dataclass(frozen=True)
class Score:
    """One score: its JSON key, its column title (with the unit), how a cell prints, how it is computed.

    Attributes
    ----------
    key : str
        JSON key.
    header : str
        Column title of the tables.
    cell : callable
        Value -> table cell.
    compute : callable
        :class:`Scoring` -> value.
    rail_only : bool
        Scored only for a robot on a rail.
    """

    key: str
    header: str
    cell: Callable[[Any], str]
    compute: Callable[[Scoring], Any]
    rail_only: bool = False


#: Every score, in table and JSON order.
SCORE_TABLE = (
    Score("outcome", "outcome", str, lambda s: s.run.info.get("stopped", "?")),
    Score("max_deviation", "max dev [m]", _length, lambda s: float(np.max(s.geometry[0][:, 1:]))),
    Score("shape_deviation", "shape dev [% of length]", _percent,
          lambda s: shape_deviation(s.geometry[0], s.ctrl.chain.m * s.ctrl.chain.xi)),
    Score("wall_contacts", "wall", str, lambda s: s.contact_samples("wall")),
    Score("self_collisions", "self", str, lambda s: s.contact_samples("self")),
    Score("peak_u", "peak u [rad/s]", "{:.3g}".format, lambda s: float(np.max(np.abs(s.joint_u)))),
    Score("peak_joint_rate", "peak rate [rad/s]", "{:.3g}".format, lambda s: float(np.max(np.abs(s.joint_rates)))),
    Score("peak_rail_rate", "peak rail rate [m/s]", "{:.3g}".format,
          lambda s: float(np.max(np.abs(np.asarray(s.run.u)[:, 0]))), rail_only=True),
    Score("peak_du_dt", "peak du/dt [rad/s²]", "{:.3g}".format, lambda s: s.peak_rate_change("du_dt")),
    Score("peak_rail_accel", "peak rail accel [m/s²]", "{:.3g}".format, lambda s: s.peak_rate_change("rail_accel"),
          rail_only=True),
    Score("final_s_error", "final s err [m]", _length, Scoring.final_s_error),
    Score("step_time", "step [µs]", lambda v: f"{1e6 * v:.1f}",
          lambda s: float(s.run.info["wall_time"] / s.run.info["steps"])),
)
#: Keys of the scores of every run, in order.
SCORES = tuple(s.key for s in SCORE_TABLE if not s.rail_only)
#: Keys of the scores of a robot on a rail only.
RAIL_SCORES = tuple(s.key for s in SCORE_TABLE if s.rail_only)


def score(run: Any, scenario: Any, ctrl: Any = None) -> dict[str, Any]:
    """The scores of one run (the rows of :data:`SCORE_TABLE` that apply), computed from ``run.q`` and ``run.u``.

    Parameters
    ----------
    run : Run
        A run of ``scenario``.
    scenario : Scenario
        Its scenario (chain, curve, obstacles, step).
    ctrl : CoordinatingController or SpatialController, optional
        The scenario's controller, if already built.

    Returns
    -------
    dict of str to Any
        Key -> value, in table order (units in :data:`SCORE_TABLE`'s headers).
    """
    s = Scoring(run, scenario, ctrl)
    rail = bool(s.ctrl.chain.rail)
    return {row.key: row.compute(s) for row in SCORE_TABLE if rail or not row.rail_only}


def score_rows(scores: dict[str, Any]) -> list[Score]:
    """The rows of :data:`SCORE_TABLE` present in ``scores``, in order.

    Parameters
    ----------
    scores : dict
        One run's scores.

    Returns
    -------
    list of Score
    """
    return [row for row in SCORE_TABLE if row.key in scores]
