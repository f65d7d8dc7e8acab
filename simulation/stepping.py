"""The chunk loop of :func:`~coordarm.simulation.run.simulate`: fixed-step RK4 chunk by chunk, with
the stops (margins, tube, contacts), the rows kept in memory and the chunk Functions it calls."""
from __future__ import annotations

import time as _time
import weakref
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from coordarm.symbolic import CollisionError, CoordarmError, CoordinatingController, SingularityError, TubeError
from coordarm.symbolic.errors import BaseOffPathError, NonFiniteError
from coordarm.symbolic.curves import unwrap_s
from coordarm.symbolic.errors import JointRateError
from coordarm.symbolic.interrupts import check as check_interrupt
from coordarm.symbolic.outputs import spatial_split, split
from coordarm.symbolic.records import record

from .base_margin import BASE_THRESHOLD, base_stop
from .every_step import STracking, governed_steps, summary_rows
from .joint_rates import JointRates
from .limits import kept_capacity
from .log_layout import PLANAR, ChainLayout, MarginCheck, layout_of_chain
from .result import OPTIONAL, Run, deviation_norms

if TYPE_CHECKING:
    import casadi

    from coordarm.generated.compiled import CompiledController

    from .progress import Progress


def first_violation(link_margins: np.ndarray, longitudinal: np.ndarray,
                    thresholds: dict[str, float]) -> tuple[int, str, int | None, float] | None:
    """First row whose margins are below threshold or not finite: ``(row, kind, link, margin)``.

    Parameters
    ----------
    link_margins : (n, m-1) ndarray
        Link margins of links 2..m at each row [-].
    longitudinal : (n,) ndarray
        Longitudinal margin at each row [-].
    thresholds : dict
        ``{"link": .., "longitudinal": ..}`` margin thresholds [-].

    Returns
    -------
    tuple or None
        ``(row, kind, link, margin)``: the first offending row, ``"link"`` (checked first) or
        ``"longitudinal"``, the link number (2..m; None for the longitudinal margin) and its margin
        [-]; None when every row is above both thresholds.
    """
    return margin_violation({"link_margins": link_margins, "longitudinal": longitudinal}, PLANAR.margins, thresholds)


def margin_lows(arrays: Any, checks: tuple[MarginCheck, ...]) -> dict[str, np.ndarray]:
    """Each margin's smallest value at each row (NaN where a value of the row is NaN), by array name.

    Parameters
    ----------
    arrays : mapping of str to ndarray
        The margin arrays by name, ``(n,)`` or ``(n, k)`` [-] (a Run's attributes or a dict).
    checks : tuple of MarginCheck
        The margins (:attr:`~.log_layout.ChainLayout.margins`).

    Returns
    -------
    dict of str to ndarray, shape (n,)
        ``np.min(values, axis=1)`` of a 2-D margin, the values themselves of a 1-D one [-].
    """
    get = arrays.get if isinstance(arrays, dict) else lambda name: getattr(arrays, name)
    out = {}
    for c in checks:
        values = np.asarray(get(c.array))
        out[c.array] = np.min(values, axis=1) if values.ndim == 2 else values
    return out


def margin_violation(arrays: Any, checks: tuple[MarginCheck, ...], thresholds: dict[str, float],
                     lows: dict[str, np.ndarray] | None = None) -> tuple[int, str, int | None, float] | None:
    """First row where a margin of ``checks`` is below its threshold or not finite: ``(row, kind, index, margin)``.

    Parameters
    ----------
    arrays : mapping of str to ndarray
        The margin arrays by name, ``(n,)`` or ``(n, k)`` [-] (a Run's attributes or a dict).
    checks : tuple of MarginCheck
        The margins to check (:attr:`~.log_layout.ChainLayout.margins`); at the first bad row the
        first bad one in this order is reported.
    thresholds : dict
        ``{"link": .., "longitudinal": ..}`` margin thresholds [-].
    lows : dict, optional
        :func:`margin_lows` of ``arrays`` (computed here when not given).

    Returns
    -------
    tuple or None
        ``(row, kind, index, margin)``: the first offending row, the check's ``kind``, the link or joint
        number (``first`` + column; None for a scalar margin) and its margin [-]; None when every row
        is above every threshold.
    """
    get = arrays.get if isinstance(arrays, dict) else lambda name: getattr(arrays, name)
    lows = margin_lows(arrays, checks) if lows is None else lows
    below = [(c, np.asarray(get(c.array)), ~(lows[c.array] >= thresholds[c.threshold])) for c in checks]
    bad = np.logical_or.reduce([b for _, _, b in below])
    if not bad.any():
        return None
    k = int(np.argmax(bad))
    c, values, _ = next(x for x in below if x[2][k])
    if values.ndim == 1:
        return k, c.kind, None, float(values[k])
    j = int(np.nanargmin(values[k])) if np.isfinite(values[k]).any() else 0
    return k, c.kind, j + c.first, float(values[k, j])


def tube_exit(e: np.ndarray, radius: float, per_link: int = 1) -> tuple[int, int, float] | None:
    """First row where a deviation ``|e^j|`` reaches the tube radius: ``(row, link, |e|)``, else None.

    Parameters
    ----------
    e : (n, per_link * (m-1)) ndarray
        Deviations of the central points of links 2..m from the curve at each row [m].
    radius : float
        Tube radius of the path [m] (inf: no tube, never left).
    per_link : int, optional
        Columns of ``e`` per link (2 for a spatial chain: ``|e^j|`` is the norm of the pair).

    Returns
    -------
    tuple or None
        ``(row, link, |e|)``: the first row where some ``|e^j| >= radius`` (or is not a number), the
        first such link (2..m) and its ``|e^j|`` [m]; None when there is none.
    """
    if not np.isfinite(radius):
        return None
    dist = deviation_norms(e, per_link)
    bad = ~(dist < radius)
    if not bad.any():
        return None
    k = int(np.argmax(bad.any(axis=1)))
    j = int(np.argmax(bad[k]))
    return k, j + 2, float(dist[k, j])


#: The interpreted chunk Functions built for each controller, by ``(law form, step, steps)``;
#: an entry goes with its controller.
_CHUNKS: weakref.WeakKeyDictionary[CoordinatingController, dict[tuple, Any]] = weakref.WeakKeyDictionary()


def chunk_function(ctrl: CoordinatingController, step: float, n: int) -> casadi.Function:
    """Interpreted closed-loop Function over ``n`` RK4 steps: ``(q0, t[1 x n]) -> (Q, *RUN_OUTPUTS)``.

    Column k of ``Q`` is the state after step k; the diagnostics are at each step's start.
    Built once per controller, law form, step and ``n`` (kept while ``ctrl`` lives).

    Parameters
    ----------
    ctrl : CoordinatingController
        The closed loop (its :meth:`~CoordinatingController.rk4_step`, expanded to SX).
    step : float
        RK4 step [s].
    n : int
        Steps per call.

    Returns
    -------
    casadi.Function
        ``(q0 (dof,), t (1, n)) -> (Q (dof, n), *RUN_OUTPUTS (one column per step))``.
    """
    made = _CHUNKS.setdefault(ctrl, {})
    key = (ctrl.law_form, float(step), n)
    if key not in made:
        made[key] = ctrl.rk4_step(step).expand().mapaccum("chunk", n)
    return made[key]


@record(frozen=True)
class Stepping:
    """The checked settings of one run's chunk loop (made by :func:`~coordarm.simulation.run.simulate`).

    Attributes
    ----------
    ctrl : CoordinatingController
        The closed loop.
    compiled : CompiledController or None
        The generated library that steps it, None for CasADi's interpreter.
    t0, step : float
        Start time and RK4 step [s].
    n_steps, chunk : int
        Steps of the run; steps per call of the chunk Function.
    thresholds : dict
        ``{"link": .., "longitudinal": ..}`` margins below which the run stops [-].
    tube : float
        Tube radius of the path [m] (inf without one).
    every : int
        Keep every this many rows in memory (plus each chunk's extremes and last row).
    physical : Physical or None
        Joint limits, self-collision and obstacles to check.
    check_every : int
        Physical check stride [steps].
    allow_contact : bool
        Keep going after a contact.
    """

    ctrl: CoordinatingController
    compiled: CompiledController | None
    t0: float
    step: float
    n_steps: int
    chunk: int
    thresholds: dict[str, float]
    tube: float
    every: int
    physical: Any = None
    check_every: int = 1
    allow_contact: bool = False

    @property
    def layout(self) -> ChainLayout:
        """The layout of the run's arrays and its stops (planar or spatial)."""
        return layout_of_chain(self.ctrl.chain)


def integrate(loop: Stepping, q0: np.ndarray, info: dict, on_chunk: Callable[[Run], None] | None,
              bar: Progress | None) -> Run:
    """Run the chunk loop of :func:`~coordarm.simulation.run.simulate` from ``q0`` at ``loop.t0`` (see there).

    Parameters
    ----------
    loop : Stepping
        The checked settings.
    q0 : (dof,) ndarray
        Start configuration [rad].
    info : dict
        Backend information (:func:`~coordarm.simulation.run.select_backend`) and ``kept_every``.
    on_chunk : callable or None
        Called with each completed chunk.
    bar : Progress or None
        Progress bar to update after each chunk.

    Returns
    -------
    Run
        The completed run (rows thinned to ``loop.every``).

    Raises
    ------
    SingularityError, TubeError, CollisionError
        The run stopped; ``err.run`` holds it up to there.
    """
    kept, tracking = KeptRows(loop), STracking(getattr(loop.ctrl, "speeds", None))
    governed = 0.0          # simulated time with v_scale < 1, over every step (the kept rows are thinned) [s]
    contacts: list = []
    q, k, wall = q0, 0, _time.perf_counter()
    rates = JointRates(bool(getattr(loop.ctrl.chain, "rail", False)),       # peaks, and the physical's limits
                       *getattr(loop.physical, "rate_limits", (None, None)), per_joint=loop.layout.deviations_per_link)
    prev: tuple[float, float] | None = None
    while k <= loop.n_steps:
        part, Q, n = next_part(loop, q, k)
        part.s = unwrap_s(loop.ctrl.curve, part.t, part.s, prev)
        prev = (float(part.t[-1]), float(part.s[-1]))
        lows = margin_lows(part, loop.layout.margins)     # each margin's smallest value per row, once
        stop = _first_stop(part, k, loop, contacts, lows)
        fast = rates.update(part.t[:len(part.t) if stop is None else stop[0] + 1],
                            part.u[:len(part.t) if stop is None else stop[0] + 1])
        if fast is not None and (stop is None or fast[0] < stop[0]):
            stop = fast
        info = dict(info, joint_rates=dict(rates.peaks))
        if stop is not None:
            row, error = stop
            part = part.rows(slice(0, row + 1))
            kept.add(part, k)
            tracking.add(part)
            if on_chunk:
                on_chunk(part)
            raise stopped(loop.ctrl, error, kept, dict(info, stopped=_STOPS[type(error)], contacts=_records(contacts),
                                                       steps=k + row, wall_time=_time.perf_counter() - wall,
                                                       governed=governed + governed_steps(part) * loop.step,
                                                       **tracking.info()))
        kept.add(part, k, lows)
        tracking.add(part)
        governed += governed_steps(part) * loop.step
        if on_chunk:
            on_chunk(part)
        check_interrupt()
        if k == loop.n_steps:
            break
        q, k = Q[-1], k + n
        if bar:
            bar.update(loop.step * k)
    info = dict(info, contacts=_records(contacts))
    return kept.run(dict(info, stopped="completed", steps=loop.n_steps, wall_time=_time.perf_counter() - wall,
                         governed=governed, **tracking.info()))



def next_part(loop: Stepping, q: np.ndarray, k: int) -> tuple[Run, np.ndarray | None, int]:
    """The rows of the chunk that starts at step ``k`` in state ``q``, or the final state's row.

    Parameters
    ----------
    loop : Stepping
        The checked settings.
    q : (dof,) ndarray
        State at step ``k`` [rad].
    k : int
        Global step index (``loop.n_steps``: the final state).

    Returns
    -------
    part : Run
        One row per step of the chunk (the law at each step's start), or the final state's one row.
    Q : (n, dof) ndarray or None
        States after each step (None for the final state).
    n : int
        Steps in the chunk (0 for the final state).
    """
    ctrl = loop.ctrl
    if k < loop.n_steps:
        n = min(loop.chunk, loop.n_steps - k)
        times = loop.t0 + loop.step * np.arange(k, k + n)
        S, outs = _advance(ctrl, loop.compiled, q, times, loop.step, loop.layout)
        return Run.from_arrays(dict(outs, t=times, q=S[:-1], **commands(ctrl, times))), S[1:], n
    t_end = loop.t0 + loop.step * loop.n_steps
    final = (loop.compiled or ctrl).evaluate(q, t_end)
    return Run.from_arrays({a: np.asarray(v)[None] for a, v in
                            dict(final, t=t_end, q=q, **commands(ctrl, t_end)).items()
                            if a in loop.layout.arrays + OPTIONAL}), None, 0


def commands(ctrl: Any, times: np.ndarray | float) -> dict[str, Any]:
    """The commanded values a run keeps beside the law's outputs: ``v_star`` and, for a spatial chain, ``roll_star``.

    Parameters
    ----------
    ctrl : CoordinatingController or SpatialController
        The closed loop (``speeds``/``speed_at``; ``roll_targets``/``roll_at`` for a spatial chain).
    times : (n,) ndarray or float
        Times [s] (a float: the values at one time).

    Returns
    -------
    dict
        ``v_star`` [m/s] (and ``roll_star`` [rad]), arrays for an array of times, floats for one time.
    """
    spatial = "roll_star" in layout_of_chain(ctrl.chain).commands
    if np.ndim(times) == 0:
        out = {"v_star": ctrl.speed_at(times)}
        return dict(out, roll_star=ctrl.roll_at(times)) if spatial else out
    out = {"v_star": ctrl.speeds(times)}
    return dict(out, roll_star=ctrl.roll_targets(times)) if spatial else out


def stopped(ctrl: CoordinatingController, error: CoordarmError, kept: KeptRows, info: dict) -> CoordarmError:
    """``error``, holding the run up to the stop (with a hint for a longitudinal stop without the governor).

    Parameters
    ----------
    ctrl : CoordinatingController
        The closed loop (its ``governor`` decides the hint).
    error : SingularityError, TubeError or CollisionError
        Why the run stopped.
    kept : KeptRows
        The rows kept of the chunks run, the last one cut at the stop.
    info : dict
        Info of the run up to the stop.

    Returns
    -------
    CoordarmError
        The error to raise, ``.run`` the run up to the stop.
    """
    if isinstance(error, SingularityError) and error.kind == "longitudinal" and not ctrl.governor:
        error = SingularityError(error.time, error.link, error.margin, error.kind, error.threshold,
                                 hint="the speed governor ([control] governor = true, --governor) "
                                      "slows v* instead of stopping")
    error.run = kept.run(info)
    return error


_STOPS = {SingularityError: "singularity", TubeError: "tube", BaseOffPathError: "base_off_path",
          CollisionError: "collision", JointRateError: "rate_limit"}


def _records(contacts: list) -> list[dict]:
    return [c.to_dict() for c in contacts]


def _first_stop(part: Run, k: int, loop: Stepping, contacts: list,
                lows: dict[str, np.ndarray] | None = None) -> tuple[int, CoordarmError] | None:
    """The first row of ``part`` (global step ``k`` at row 0) where the run must stop, and why (``lows``:
    :func:`margin_lows` of ``part``).

    A contact at or before the first singular row wins. With ``allow_contact`` the first
    contact of every (kind, links, obstacle) is appended to ``contacts`` instead.
    """
    thr, tube, physical = loop.thresholds, loop.tube, loop.physical
    stop = None
    bad = margin_violation(part, loop.layout.margins, thr, lows)
    if bad is not None:
        row, kind, link, margin = bad
        stop = row, SingularityError(part.t[row], link, margin, kind, thr[loop.layout.threshold_key(kind)])
    stops_on = any(v > 0 for v in thr.values())        # NO_STOP (report, threshold study): none of them either
    base = base_stop(loop.ctrl, part.t, part.q, thr.get("base", BASE_THRESHOLD if stops_on else 0.0))
    if base is not None and (stop is None or base[0] <= stop[0]):     # (the cause of a margin's fall there)
        stop = base
    if part.rail_margin is not None:   # a rail across the path puts the base off it: the rail is the cause
        low = np.flatnonzero(~(part.rail_margin >= thr["link"]))
        if len(low) and (stop is None or low[0] < stop[0] or (low[0] == stop[0] and stop is base)):
            row = int(low[0])
            stop = row, SingularityError(part.t[row], 1, float(part.rail_margin[row]), "rail", thr["link"])
    out = tube_exit(part.e, tube, loop.layout.deviations_per_link)
    if out is not None and (stop is None or out[0] <= stop[0]):
        row, link, dist = out
        stop = row, TubeError(part.t[row], link, dist, "tube", tube)
    broken = np.flatnonzero(~np.isfinite(part.q).all(axis=1))
    if len(broken) and (stop is None or broken[0] < stop[0]):   # (a margin there is not finite either: a stop)
        row, joint = int(broken[0]), int(np.flatnonzero(~np.isfinite(part.q[broken[0]]))[0])
        raise NonFiniteError(f"non-finite state at t = {part.t[row]:.4f} s: joint coordinate {joint + 1} is "
                             f"{part.q[row, joint]}; the run diverged (a commanded speed, span or gain too large "
                             "for the step?); run stopped")
    if physical is not None:
        n = len(part.t)
        rows = np.flatnonzero(((k + np.arange(n)) % loop.check_every == 0) | (np.arange(n) % (n - 1 or 1) == 0))
        if stop is not None:
            rows = np.append(rows[rows < stop[0]], stop[0])        # (sorted, unique: no np.unique)
        rows = rows[np.isfinite(part.q[rows]).all(axis=1)]      # a NaN state is not a joint limit
        if len(rows):
            found = physical.check(part.t[rows], part.q[rows])
            if found and not loop.allow_contact:
                i = int(np.searchsorted(part.t[rows], found[0].time))
                row = int(rows[i])
                if i > 0 and rows[i - 1] + 1 < row:     # locate the first contact to the step
                    between = np.arange(rows[i - 1] + 1, row)
                    earlier = physical.check(part.t[between], part.q[between])
                    if earlier:
                        found = earlier
                        row = int(between[np.searchsorted(part.t[between], found[0].time)])
                return row, CollisionError(found[0])
            seen = {(c.kind, c.links, c.obstacle) for c in contacts}
            for c in found:
                if (c.kind, c.links, c.obstacle) not in seen:
                    seen.add((c.kind, c.links, c.obstacle))
                    contacts.append(c)
    return stop


def _advance(ctrl, compiled, q, times, step, layout):
    """RK4 steps from ``q`` at each of ``times``: the states, ``q`` then after each step (rows, ``(n + 1, dof)``),
    and the law's run outputs (``layout.run_outputs``) at each start (dict of row blocks)."""
    if compiled is not None:
        S, D = compiled.chunk(q, times, step, with_start=True)
        d = split(D, ctrl.chain.m, ctrl.chain.rail) if layout is PLANAR else spatial_split(D, ctrl.chain.m, ctrl.chain.rail)
        return S, {a: d[a] for a in ctrl.run_outputs}
    Q, *outs = (np.asarray(x) for x in chunk_function(ctrl, step, len(times))(q, times))
    scalars = getattr(ctrl, "SCALAR_OUTPUTS", layout.scalars)          # a spatial rail adds sigma, rail_margin
    return np.vstack([q[None], Q.T]), {a: (v.ravel() if a in scalars else v.T) for a, v in zip(ctrl.run_outputs, outs)}


def kept_rows(part: Run, k0: int, every: int, chain: Any = None,
              lows: dict[str, np.ndarray] | None = None) -> np.ndarray | slice:
    """Rows of ``part`` (steps ``k0, k0+1, ...``) kept in memory: every ``every``-th, the extremes, the last.

    Parameters
    ----------
    part : Run
        One chunk's rows.
    k0 : int
        Global step of its first row.
    every : int
        Keep every this many steps (1: every row).
    chain : Chain or SpatialChain, optional
        The run's chain: keep also the rows of :func:`~.every_step.summary_rows` (the largest joint
        angle against its limit, the largest roll tracking error).
    lows : dict, optional
        :func:`margin_lows` of ``part`` (computed here when not given).

    Returns
    -------
    ndarray of int or slice
        Sorted row indices (every row: ``slice(None)``); with the rows of each margin's smallest
        value and of the largest ``|u|``, the summary's rows, and the last row.
    """
    n = len(part.t)
    if every == 1 or n == 0:
        return slice(None)
    keep = (k0 + np.arange(n)) % every == 0
    for low in (margin_lows(part, part.layout.margins) if lows is None else lows).values():
        keep[np.argmin(low)] = True
    keep[np.argmax(np.max(np.abs(part.u), axis=1))] = True
    if chain is not None:
        keep[summary_rows(part, chain)] = True
    keep[n - 1] = True
    return np.flatnonzero(keep)


class KeptRows:
    """The rows of a run kept in memory, gathered chunk by chunk into arrays allocated once.

    One copy per kept row (a chunk's rows straight into place), instead of a thinned copy of each
    chunk and a concatenation of them all. The arrays hold at most every ``loop.every``-th step
    plus, per chunk, its extremes and last row, and the final state's row.

    Parameters
    ----------
    loop : Stepping
        The run's settings (steps, chunk length, ``every``).
    """

    def __init__(self, loop: Stepping) -> None:
        self.every = loop.every
        self.chain = loop.ctrl.chain
        self.capacity = kept_capacity(loop.n_steps, loop.every, loop.chunk, len(loop.layout.margins))
        self.arrays: dict[str, np.ndarray] = {}
        self.n = 0

    def add(self, part: Run, k0: int, lows: dict[str, np.ndarray] | None = None) -> None:
        """Keep the rows of ``part`` (global steps ``k0, k0+1, ...``) that :func:`kept_rows` selects.

        Parameters
        ----------
        part : Run
            One chunk's rows (or the final state's one row).
        k0 : int
            Global step of its first row.
        lows : dict, optional
            :func:`margin_lows` of ``part`` (computed when not given).
        """
        rows = kept_rows(part, k0, self.every, self.chain, lows)
        names = part.array_names()
        if not self.arrays:
            self.arrays = {a: np.empty((self.capacity,) + np.shape(v)[1:], dtype=np.asarray(v).dtype)
                           for a, v in ((a, getattr(part, a)) for a in names)}
        size = len(part.t) if isinstance(rows, slice) else len(rows)
        if self.n + size > self.capacity or set(names) != set(self.arrays):
            raise RuntimeError(f"kept rows: {self.n} + {size} rows exceed {self.capacity} or arrays changed")
        for a in names:
            v = np.asarray(getattr(part, a))
            if isinstance(rows, slice):
                self.arrays[a][self.n:self.n + size] = v
            else:
                # indexing, not np.take: take first copies a source that is not C-contiguous whole (the law's
                # outputs are column blocks of one array), 45 us against 7.5 us for 137 of 2000 rows of u
                self.arrays[a][self.n:self.n + size] = v[rows]
        self.n += size

    def run(self, info: dict) -> Run:
        """The kept rows as a Run: views of the arrays allocated once, or copies when a stop left
        more than an eighth of them unused (so a stopped run does not hold the memory of a whole one).

        Parameters
        ----------
        info : dict
            The run's info.

        Returns
        -------
        Run
        """
        trim = self.capacity - self.n > self.capacity // 8
        return Run.from_arrays({a: v[:self.n].copy() if trim else v[:self.n] for a, v in self.arrays.items()}, info)
