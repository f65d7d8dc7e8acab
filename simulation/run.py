"""Fixed-step RK4 simulation of the closed loop ``qdot = B u(q, t)``, chunk by chunk."""
from __future__ import annotations

import math
import time as _time
import warnings
import weakref
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from coordarm.generated import compile as compile_controller
from coordarm.symbolic import (BuildError, CollisionError, ConfigError, CoordarmError, CoordinatingController,
                               SingularityError, TubeError)
from coordarm.symbolic.curves import unwrap_s
from coordarm.symbolic.errors import shown
from coordarm.symbolic.interrupts import check as check_interrupt
from coordarm.symbolic.outputs import RAIL_OUTPUTS, RUN_OUTPUTS, SCALAR_OUTPUTS, split

from .choices import BACKENDS
from .limits import KEEP_ROWS, check_gain_step

if TYPE_CHECKING:
    import casadi

    from coordarm.generated.compiled import CompiledController

    from .progress import Progress

#: Default singularity thresholds on the dimensionless margins (0 = singular).
DEFAULT_THRESHOLDS = {"link": 0.02, "longitudinal": 0.15}
#: Most physical checks per simulated second in ``coordarm run`` (fewer when the log rate is lower);
#: a contact found is located to the step (``simulate(check_every=...)``).
CHECK_RATE = 200.0
#: Steps integrated per call of the closed-loop chunk Function.
DEFAULT_CHUNK = 2000


class BackendFallbackWarning(UserWarning):
    """``backend="auto"`` could not build the compiled controller and runs interpreted CasADi."""


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
    q : (N+1, m) array
        Joint coordinates [rad].
    u : (N+1, m) array
        Control at each sample [rad/s for B = I].
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


def check_number(value: Any, name: str, positive: bool = True) -> float:
    """``value`` as a float; a ConfigError naming ``name`` unless it is a finite real number (> 0 if ``positive``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{name}: need a finite number, got {shown(value)}")
    if positive and value <= 0:
        raise ConfigError(f"{name}: must be > 0, got {shown(value)}")
    return float(value)


def check_curve_reaches_base(ctrl: CoordinatingController, t0: float, t1: float, samples: int = 201) -> None:
    """Raise a ConfigError if the curve passes farther than one link length from the base."""
    for t in np.linspace(t0, t1, samples):
        off = ctrl.base_offset(float(t))
        if not off <= ctrl.chain.xi:
            raise ConfigError(f"curve: passes {off:.4g} m from the base at t = {t:.3f} s, more than "
                              f"one link length ({ctrl.chain.xi} m); the pinned base cannot follow it")


def first_violation(link_margins: np.ndarray, longitudinal: np.ndarray,
                    thresholds: dict[str, float]) -> tuple[int, str, int | None, float] | None:
    """First row whose margins are below threshold or not finite: ``(row, kind, link, margin)``."""
    lm_min = np.min(link_margins, axis=1)
    bad = ~(lm_min >= thresholds["link"]) | ~(longitudinal >= thresholds["longitudinal"])
    if not bad.any():
        return None
    k = int(np.argmax(bad))
    if not lm_min[k] >= thresholds["link"]:
        j = int(np.nanargmin(link_margins[k])) if np.isfinite(link_margins[k]).any() else 0
        return k, "link", j + 2, float(link_margins[k, j])
    return k, "longitudinal", None, float(longitudinal[k])


def tube_exit(e: np.ndarray, radius: float) -> tuple[int, int, float] | None:
    """First row where a deviation ``|e^j|`` reaches the tube radius: ``(row, link, |e|)``, else None."""
    if not np.isfinite(radius):
        return None
    bad = ~(np.abs(e) < radius)
    if not bad.any():
        return None
    k = int(np.argmax(bad.any(axis=1)))
    j = int(np.argmax(bad[k]))
    return k, j + 2, float(abs(e[k, j]))


def even_indices(n: int, k: int) -> np.ndarray:
    """Up to ``k`` indices evenly spread over ``range(n)``, first and last included, no repeats."""
    return np.unique(np.linspace(0, n - 1, k).round().astype(int))


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


def select_backend(ctrl: CoordinatingController, backend: str = "auto"):
    """Resolve ``backend`` to ``(name, compiled controller or None, info)``.

    ``"auto"`` compiles (or takes from the cache) the generated library and falls back to
    ``"interpreted"`` with a :class:`BackendFallbackWarning` when that fails (e.g. no C
    compiler); ``"compiled"`` raises the BuildError instead. The compiled controller is
    kept on ``ctrl`` so later runs reuse it.

    Raises
    ------
    ConfigError
        Unknown backend.
    BuildError
        ``backend="compiled"`` and the library cannot be built or loaded.
    """
    if backend not in BACKENDS:
        raise ConfigError(f"backend: expected one of {BACKENDS}, got {shown(backend)}")
    if backend == "interpreted":
        return "interpreted", None, {"backend": "interpreted"}
    try:
        compiled = ctrl.memo(("compiled", ctrl.law_form), lambda: compile_controller(ctrl))
    except BuildError as exc:
        if backend == "compiled":
            raise
        warnings.warn(f"compiled backend unavailable, running the interpreted CasADi backend "
                      f"instead (much slower): {exc}", BackendFallbackWarning, stacklevel=3)
        return "interpreted", None, {"backend": "interpreted", "fallback_reason": str(exc)}
    check_interrupt()  # a Ctrl-C swallowed by a CasADi call while generating the code
    return "compiled", compiled, {"backend": "compiled", "cache_hit": compiled.cache_hit,
                                  "library": str(compiled.library.path)}


@dataclass(frozen=True)
class Stepping:
    """The checked settings of one run's chunk loop (made by :func:`simulate`).

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


def simulate(ctrl: CoordinatingController, q0, duration: float, step: float = 0.001,
             t0: float = 0.0, *, backend: str = "auto", chunk: int = DEFAULT_CHUNK,
             thresholds: dict[str, float] | None = None, progress: bool | None = None,
             on_chunk: Callable[[Run], None] | None = None, physical: Any = None,
             check_every: int = 1, allow_contact: bool = False, keep: int | None = None) -> Run:
    """Integrate the closed loop with fixed-step RK4 from ``q0`` at ``t0`` for ``duration``.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller (chain, curve, gain, speed).
    q0 : (m,) array_like
        Start configuration [rad].
    duration, step, t0 : float
        Simulated time span, RK4 step and start time [s].
    backend : {"auto", "compiled", "interpreted"}
        ``"compiled"``: generated C (built or taken from the cache, see :mod:`generated`);
        ``"interpreted"``: CasADi's virtual machine; ``"auto"``: compiled when a C compiler
        is found, else interpreted with a :class:`BackendFallbackWarning`. ``run.info``
        records the backend used, ``cache_hit`` and the ``library`` path.
    chunk : int
        Steps per call of the closed-loop Function (and per ``on_chunk`` call).
    thresholds : dict, optional
        ``{"link": .., "longitudinal": ..}`` margins below which the run stops.
    progress : bool, optional
        Show a progress bar on stderr (default: for runs of more than 20,000 steps).
    on_chunk : callable, optional
        Called with each completed chunk (a :class:`Run` of its rows), e.g. a logger.
    physical : Physical, optional
        Joint limits, self-collision and obstacles to check
        (:class:`coordarm.simulation.physical.Physical`, anything with ``check(t, q)``).
    check_every : int
        Check every this many steps (and the first and last step of every chunk); when a
        check finds a contact, the steps since the previous check are checked too, so the
        run stops at the first step in contact (:data:`CHECK_RATE` sets the CLI's stride).
    allow_contact : bool
        Keep going after a contact; ``run.info["contacts"]`` then lists the first contact of
        every (kind, links, obstacle).
    keep : int, optional
        Rows to keep in memory (about): the returned run holds every ``ceil(steps / keep)``-th
        step plus, in each chunk, the rows of the smallest margins and the largest ``|u|`` and
        the chunk's last row, so its summary's extremes, final values and step count are exact. Default:
        :data:`~simulation.limits.KEEP_ROWS` when ``on_chunk`` is given (a logger streams the
        rest to disk), else every row. ``run.info["kept_every"]`` records the thinning.

    Returns
    -------
    Run
        ``s`` is continuous on closed curves (unwrapped past the branch cut, turns kept).

    Raises
    ------
    ConfigError
        Bad input or a singular start, before any integration.
    BuildError
        ``backend="compiled"`` and the generated library cannot be built.
    SingularityError
        A margin fell below its threshold; ``err.run`` holds the run up to there.
    TubeError
        (a SingularityError, ``kind = "tube"``) a central point reached the tube radius of a
        :class:`~symbolic.paths.Path` (its smallest arc radius), where ``phi``, ``psi`` stop being
        smooth; ``err.run`` holds the run up to there.
    CollisionError
        A contact (joint limit, self-collision, obstacle) and not ``allow_contact``;
        ``err.contact`` is the first, ``err.run`` holds the run up to there.
    """
    duration, step, t0, thr = check_settings(ctrl, duration, step, t0, chunk, backend, thresholds)
    q0, tube = check_start(ctrl, q0, t0, duration, thr, check_every, physical)
    backend, compiled, info = select_backend(ctrl, backend)
    check_interrupt()
    n_steps = int(round(duration / step))
    every = kept_every(keep, on_chunk is not None, n_steps)
    loop = Stepping(ctrl, compiled, t0, step, n_steps, chunk, thr, tube, every, physical, check_every, allow_contact)
    bar = progress_bar(duration, n_steps, progress)
    try:
        return integrate(loop, q0, dict(info, kept_every=every), on_chunk, bar)
    finally:
        if bar:
            bar.close()


def kept_every(keep: int | None, logged: bool, n_steps: int) -> int:
    """Keep every this many steps of a run in memory, to keep about ``keep`` rows.

    ``keep`` defaults to :data:`KEEP_ROWS` when the run is logged, else to every row.

    Parameters
    ----------
    keep : int or None
        Asked for by the caller.
    logged : bool
        The run streams every row to a log (``on_chunk`` given).
    n_steps : int
        Steps of the run.

    Returns
    -------
    int
        The stride, >= 1.
    """
    if keep is None:
        keep = KEEP_ROWS if logged else n_steps + 1
    return max(1, -(-n_steps // max(1, int(keep))))


def progress_bar(duration: float, n_steps: int, shown: bool | None) -> Progress | None:
    """The run's progress bar on stderr if ``shown`` (by default for runs over 20,000 steps), else None.

    Parameters
    ----------
    duration : float
        Simulated time of the run [s] (the bar's total).
    n_steps : int
        Steps of the run.
    shown : bool or None
        Whether to show one (None: decide from ``n_steps``).

    Returns
    -------
    Progress or None
    """
    if not (shown if shown is not None else n_steps > 20000):
        return None
    from .progress import Progress      # here: the progress library loads only when a bar is shown
    return Progress(duration)


def check_settings(ctrl: CoordinatingController, duration: Any, step: Any, t0: Any, chunk: Any, backend: Any,
                   thresholds: dict[str, float] | None) -> tuple[float, float, float, dict[str, float]]:
    """Check :func:`simulate`'s time span, chunk and backend (before anything is evaluated).

    Warns (:func:`~simulation.limits.check_gain_step`) when the gain is beyond the sampled-data
    limit of the step.

    Parameters
    ----------
    ctrl : CoordinatingController
        The closed loop (its gain).
    duration, step, t0 : float
        Simulated time, RK4 step and start time [s].
    chunk : int
        Steps per call of the chunk Function.
    backend : str
        One of :data:`~simulation.choices.BACKENDS`.
    thresholds : dict or None
        Margin thresholds that replace some of :data:`DEFAULT_THRESHOLDS`.

    Returns
    -------
    duration, step, t0 : float
        As floats [s].
    thresholds : dict
        ``{"link": .., "longitudinal": ..}`` [-].

    Raises
    ------
    ConfigError
        Not a finite number (``duration``, ``step`` not > 0), a step longer than the run, a chunk
        that is not a positive integer, or an unknown backend.
    """
    duration, step = check_number(duration, "duration"), check_number(step, "step")
    t0 = check_number(t0, "t0", positive=False)
    if step > duration:
        raise ConfigError(f"step: {step} s is longer than the duration {duration} s")
    if isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1:
        raise ConfigError(f"chunk: need a positive integer, got {shown(chunk)}")
    if backend not in BACKENDS:   # select_backend checks too, but only after the start checks
        raise ConfigError(f"backend: expected one of {BACKENDS}, got {shown(backend)}")
    thr = dict(DEFAULT_THRESHOLDS, **(thresholds or {}))
    check_gain_step(ctrl.gain, step, refuse=False)
    return duration, step, t0, thr


def check_start(ctrl: CoordinatingController, q0: Any, t0: float, duration: float, thr: dict[str, float],
                check_every: Any, physical: Any) -> tuple[np.ndarray, float]:
    """Check the start of a run: ``q0``, the curve's reach, the margins, the contacts and the tube at ``t0``.

    Parameters
    ----------
    ctrl : CoordinatingController
        The closed loop.
    q0 : (dof,) array_like
        Start configuration [rad].
    t0, duration : float
        Start time and simulated time [s].
    thr : dict
        ``{"link": .., "longitudinal": ..}`` margin thresholds [-].
    check_every : int
        Physical check stride [steps] (checked here, where its error has always been reported).
    physical : Physical or None
        Joint limits, self-collision and obstacles.

    Returns
    -------
    q0 : (dof,) ndarray
        The start configuration [rad].
    tube : float
        Tube radius of the path [m] (inf without one).

    Raises
    ------
    ConfigError
        A bad or (near) singular start, a curve out of the base's reach, a bad ``check_every``, a
        start in contact or outside the path's tube.
    """
    q0 = ctrl.chain.check_q(q0, "q0")
    if not ctrl.chain.rail:          # a rail carries the base along; its own margin guards it
        check_curve_reaches_base(ctrl, t0, t0 + duration)
    start = ctrl.evaluate(q0, t0)
    bad = first_violation(start["link_margins"][None], np.array([start["longitudinal"]]), thr)
    if bad is not None:
        _, kind, link, margin = bad
        where = f"link {link}" if link else "the end point"
        raise ConfigError(f"q0: start configuration is (near) singular: {kind} margin of {where} is "
                          f"{margin:.3g} < {thr[kind]}")
    if isinstance(check_every, bool) or not isinstance(check_every, int) or check_every < 1:
        raise ConfigError(f"check_every: need a positive integer, got {check_every!r}")
    if physical is not None:
        invalid = physical.check(np.array([t0]), q0[None])
        if invalid:
            raise ConfigError(f"q0: start configuration is not physically valid: {invalid[0].describe()}")
    tube = float(getattr(ctrl.curve, "tube_radius", math.inf))
    start_out = tube_exit(start["e"][None], tube)
    if start_out is not None:
        raise ConfigError(f"q0: the central point of link {start_out[1]} is {start_out[2]:.4g} m from the path, "
                          f"not inside its tube (|phi| < {tube:.4g} m, the smallest radius)")
    return q0, tube


def integrate(loop: Stepping, q0: np.ndarray, info: dict, on_chunk: Callable[[Run], None] | None,
              bar: Progress | None) -> Run:
    """Run the chunk loop of :func:`simulate` from ``q0`` at ``loop.t0`` (see there).

    Parameters
    ----------
    loop : Stepping
        The checked settings.
    q0 : (dof,) ndarray
        Start configuration [rad].
    info : dict
        Backend information (:func:`select_backend`) and ``kept_every``.
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
    parts: list[Run] = []
    contacts: list = []
    q, k, wall = q0, 0, _time.perf_counter()
    prev: tuple[float, float] | None = None
    while k <= loop.n_steps:
        part, Q, n = next_part(loop, q, k)
        part.s = unwrap_s(loop.ctrl.curve, part.t, part.s, prev)
        prev = (float(part.t[-1]), float(part.s[-1]))
        stop = _first_stop(part, k, loop, contacts)
        if stop is not None:
            row, error = stop
            part = part.rows(slice(0, row + 1))
            parts.append(_thin(part, k, loop.every))
            if on_chunk:
                on_chunk(part)
            raise stopped(loop.ctrl, error, parts, dict(info, stopped=_STOPS[type(error)], contacts=_records(contacts),
                                                        steps=k + row, wall_time=_time.perf_counter() - wall))
        parts.append(_thin(part, k, loop.every))
        if on_chunk:
            on_chunk(part)
        check_interrupt()
        if k == loop.n_steps:
            break
        q, k = Q[-1], k + n
        if bar:
            bar.update(loop.step * k)
    info = dict(info, contacts=_records(contacts))
    run = _concat(parts, dict(info, stopped="completed", steps=loop.n_steps, wall_time=_time.perf_counter() - wall))
    run.info["governed"] = run.governed_time()
    return run


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
        Q, outs = _advance(ctrl, loop.compiled, q, times, loop.step)
        return Run.from_arrays(dict(outs, t=times, q=np.vstack([q[None], Q[:-1]]), v_star=ctrl.speeds(times))), Q, n
    t_end = loop.t0 + loop.step * loop.n_steps
    final = (loop.compiled or ctrl).evaluate(q, t_end)
    return Run.from_arrays({a: np.asarray(v)[None] for a, v in
                            dict(final, t=t_end, q=q, v_star=ctrl.speed_at(t_end)).items()
                            if a in ARRAYS + OPTIONAL}), None, 0


def stopped(ctrl: CoordinatingController, error: CoordarmError, parts: list[Run], info: dict) -> CoordarmError:
    """``error``, holding the run up to the stop (with a hint for a longitudinal stop without the governor).

    Parameters
    ----------
    ctrl : CoordinatingController
        The closed loop (its ``governor`` decides the hint).
    error : SingularityError, TubeError or CollisionError
        Why the run stopped.
    parts : list of Run
        The chunks run, the last one cut at the stop.
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
    error.run = _concat(parts, info)
    error.run.info["governed"] = error.run.governed_time()
    return error


_STOPS = {SingularityError: "singularity", TubeError: "tube", CollisionError: "collision"}


def _records(contacts: list) -> list[dict]:
    return [c.to_dict() for c in contacts]


def _first_stop(part: Run, k: int, loop: Stepping, contacts: list) -> tuple[int, CoordarmError] | None:
    """The first row of ``part`` (global step ``k`` at row 0) where the run must stop, and why.

    A contact at or before the first singular row wins. With ``allow_contact`` the first
    contact of every (kind, links, obstacle) is appended to ``contacts`` instead.
    """
    thr, tube, physical = loop.thresholds, loop.tube, loop.physical
    stop = None
    bad = first_violation(part.link_margins, part.longitudinal, thr)
    if bad is not None:
        row, kind, link, margin = bad
        stop = row, SingularityError(part.t[row], link, margin, kind, thr[kind])
    if part.rail_margin is not None:
        low = np.flatnonzero(~(part.rail_margin >= thr["link"]))
        if len(low) and (stop is None or low[0] < stop[0]):
            row = int(low[0])
            stop = row, SingularityError(part.t[row], 1, float(part.rail_margin[row]), "rail", thr["link"])
    out = tube_exit(part.e, tube)
    if out is not None and (stop is None or out[0] <= stop[0]):
        row, link, dist = out
        stop = row, TubeError(part.t[row], link, dist, "tube", tube)
    if physical is not None:
        n = len(part.t)
        rows = np.flatnonzero(((k + np.arange(n)) % loop.check_every == 0) | (np.arange(n) % (n - 1 or 1) == 0))
        if stop is not None:
            rows = np.union1d(rows[rows < stop[0]], [stop[0]])
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


def _advance(ctrl, compiled, q, times, step):
    """RK4 steps from ``q`` at each of ``times``: states after each step (rows) and the law's
    :data:`RUN_OUTPUTS` at each start (dict of row blocks)."""
    if compiled is not None:
        Q, D = compiled.chunk(q, times, step)
        d = split(D, ctrl.chain.m, ctrl.chain.rail)
        return Q, {a: d[a] for a in ctrl.run_outputs}
    Q, *outs = (np.asarray(x) for x in chunk_function(ctrl, step, len(times))(q, times))
    return Q.T, {a: (v.ravel() if a in SCALAR_OUTPUTS else v.T) for a, v in zip(ctrl.run_outputs, outs)}


#: The per-sample arrays of a :class:`Run`: time, state, the law's run outputs, commanded speed.
ARRAYS = ("t", "q", *RUN_OUTPUTS, "v_star")
#: Arrays present only on some runs (a chain on a rail).
OPTIONAL = RAIL_OUTPUTS


def _thin(part: Run, k0: int, every: int) -> Run:
    """Rows of ``part`` (steps ``k0, k0+1, ...``) kept in memory: every ``every``-th, the extremes, the last."""
    n = len(part.t)
    if every == 1 or n == 0:
        return part
    rows = np.concatenate([np.flatnonzero((k0 + np.arange(n)) % every == 0),
                           [np.argmin(np.min(part.link_margins, axis=1)), np.argmin(part.longitudinal),
                            np.argmax(np.max(np.abs(part.u), axis=1)), n - 1]])
    return part.rows(np.unique(rows))


def _concat(parts: list[Run], info: dict) -> Run:
    return Run.from_arrays({a: np.concatenate([getattr(p, a) for p in parts]) for a in parts[0].array_names()},
                          info)
