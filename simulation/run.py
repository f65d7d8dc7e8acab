"""Fixed-step RK4 simulation of the closed loop ``qdot = B u(q, t)``, chunk by chunk.

:func:`simulate` checks its input and the start, picks the backend (:func:`select_backend`) and
runs the chunk loop of :mod:`.stepping`; the result is a :class:`~.result.Run` (its module's
names are re-exported here, as are :func:`~.stepping.chunk_function` and the margin checks).
"""
from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from coordarm.generated import compile as compile_controller
from coordarm.generated import compiled_at_hand
from coordarm.symbolic import BuildError, ConfigError, CoordinatingController, NonFiniteError
from coordarm.symbolic.checks import is_integer, is_real
from coordarm.symbolic.errors import shown
from coordarm.symbolic.interrupts import check as check_interrupt

from .choices import BACKENDS, Backend
from .limits import check_gain_step, kept_every
from .result import ARRAYS, OPTIONAL, ExtraOutputs, Run
from .log_layout import layout_of_chain
from .stepping import Stepping, chunk_function, first_violation, integrate, margin_violation, tube_exit

if TYPE_CHECKING:
    from .progress import Progress

__all__ = ["ARRAYS", "CHECK_RATE", "DEFAULT_CHUNK", "check_stride", "DEFAULT_THRESHOLDS", "OPTIONAL", "BackendFallbackWarning",
           "ExtraOutputs", "Run", "check_curve_reaches_base", "check_number", "check_settings", "check_start",
           "chunk_function", "even_indices", "first_violation", "kept_every", "progress_bar", "select_backend",
           "simulate", "tube_exit"]

#: Default singularity thresholds on the dimensionless margins (0 = singular).
DEFAULT_THRESHOLDS = {"link": 0.02, "longitudinal": 0.15}
#: Physical checks per simulated second in ``coordarm run`` and a sweep, whatever the log's rate (every
#: step when the step is longer); a contact found is located to the step (``simulate(check_every=...)``).
CHECK_RATE = 200.0
#: Steps integrated per call of the closed-loop chunk Function.
DEFAULT_CHUNK = 2000


def check_stride(step: float) -> int:
    """Steps between two physical checks at :data:`CHECK_RATE` (``simulate(check_every=...)``).

    Parameters
    ----------
    step : float
        The RK4 step [s].

    Returns
    -------
    int
        ``round(1 / (CHECK_RATE * step))``, at least 1.
    """
    return max(1, round(1.0 / (CHECK_RATE * step)))


class BackendFallbackWarning(UserWarning):
    """``backend="auto"`` could not build the compiled controller and runs interpreted CasADi."""


def check_number(value: Any, name: str, positive: bool = True) -> float:
    """``value`` as a float; a ConfigError naming ``name`` unless it is a finite real number (> 0 if ``positive``).

    Parameters
    ----------
    value : Any
        The number to check (an ``int`` or ``float``, not a ``bool``).
    name : str
        The setting's name, for the error message.
    positive : bool, optional
        Also require ``value > 0`` (default True).

    Returns
    -------
    float
        ``value`` as a float.

    Raises
    ------
    ConfigError
        ``value`` is not a finite real number, or not > 0 when ``positive``.
    """
    if not is_real(value) or not math.isfinite(value):
        raise ConfigError(f"{name}: need a finite number, got {shown(value)}")
    if positive and value <= 0:
        raise ConfigError(f"{name}: must be > 0, got {shown(value)}")
    return float(value)


def check_time_span(duration: Any, step: Any, t0: Any = 0.0) -> tuple[float, float, float]:
    """A run's simulated time, step and start time checked: finite numbers, ``0 < step <= duration``.

    Parameters
    ----------
    duration, step, t0 : float
        Simulated time, RK4 step and start time [s].

    Returns
    -------
    duration, step, t0 : float
        As floats [s].

    Raises
    ------
    ConfigError
        One that is not a finite number (naming ``duration``, ``step`` or ``t0``), ``duration`` or ``step``
        not > 0, or a step longer than the run.
    """
    duration, step = check_number(duration, "duration"), check_number(step, "step")
    t0 = check_number(t0, "t0", positive=False)
    if step > duration:
        raise ConfigError(f"step: {step} s is longer than the duration {duration} s")
    return duration, step, t0


def check_curve_reaches_base(ctrl: CoordinatingController, t0: float, t1: float, samples: int = 201) -> None:
    """Raise a ConfigError if the curve passes farther than one link length from the base.

    Parameters
    ----------
    ctrl : CoordinatingController
        The closed loop (its curve and chain, :meth:`~CoordinatingController.base_offsets`).
    t0, t1 : float
        Time span checked [s].
    samples : int, optional
        Times checked, evenly spread over ``[t0, t1]`` (ends included).

    Raises
    ------
    ConfigError
        At a sampled time the curve is farther than one link length ``xi`` [m] from the base
        (or its distance is not a number).
    """
    times = np.linspace(t0, t1, samples)
    offsets = ctrl.base_offsets(times)                     # one mapped call, not one per time
    far = np.flatnonzero(~(offsets <= ctrl.chain.xi))
    if len(far):
        t, off = times[far[0]], offsets[far[0]]
        raise ConfigError(f"curve: passes {off:.4g} m from the base at t = {t:.3f} s, more than "
                          f"one link length ({ctrl.chain.xi} m); the pinned base cannot follow it")


def even_indices(n: int, k: int) -> np.ndarray:
    """Up to ``k`` indices evenly spread over ``range(n)``, first and last included, no repeats.

    Parameters
    ----------
    n : int
        Length of the range (>= 1).
    k : int
        Indices wanted (>= 1; fewer are returned when ``k > n``).

    Returns
    -------
    (<= k,) ndarray of int
        Sorted, unique indices in ``[0, n - 1]``.
    """
    rows = np.sort(np.linspace(0, n - 1, k).round().astype(int))
    return rows[np.r_[True, rows[1:] != rows[:-1]]]     # np.unique without numpy.ma (~10 ms to import)


def select_backend(ctrl: CoordinatingController, backend: str = "auto",
                   progress: bool = False) -> tuple[str, Any, dict[str, Any]]:
    """Resolve ``backend`` to ``(name, compiled controller or None, info)``.

    ``"auto"`` compiles (or takes from the cache) the generated library and falls back to
    ``"interpreted"`` with a :class:`BackendFallbackWarning` when that fails (e.g. no C
    compiler); ``"compiled"`` raises the BuildError instead. The compiled controller is
    kept by :func:`coordarm.generated.compile`, so later runs reuse it.

    Parameters
    ----------
    ctrl : CoordinatingController
        The closed loop to run.
    backend : {"auto", "compiled", "interpreted"}, optional
        The backend asked for.

    progress : bool
        Say on stderr what is happening when building the library takes more than a second
        (:class:`~.progress.Phase`).

    Returns
    -------
    name : str
        ``"compiled"`` or ``"interpreted"``: the backend that will run.
    compiled : CompiledController or None
        The compiled law, None with the interpreted backend.
    info : dict
        ``{"backend": name}`` plus ``cache_hit`` and ``library`` (compiled) or
        ``fallback_reason`` (``"auto"`` fell back).

    Raises
    ------
    ConfigError
        Unknown backend.
    BuildError
        ``backend="compiled"`` and the library cannot be built or loaded.
    """
    if backend not in BACKENDS:
        raise ConfigError(f"backend: expected one of {BACKENDS}, got {shown(backend)}")
    if backend == Backend.INTERPRETED:
        return "interpreted", None, {"backend": "interpreted"}
    try:
        from .progress import Phase
        with Phase(f"law: building the compiled library of the {ctrl.chain.m}-link law (cached for later runs)",
                   enabled=progress):
            compiled = compile_controller(ctrl)
    except BuildError as exc:
        if backend == Backend.COMPILED:
            raise
        warnings.warn(f"compiled backend unavailable, running the interpreted CasADi backend "
                      f"instead (much slower): {exc}", BackendFallbackWarning, stacklevel=3)
        return "interpreted", None, {"backend": "interpreted", "fallback_reason": str(exc)}
    check_interrupt()  # a Ctrl-C swallowed by a CasADi call while generating the code
    return "compiled", compiled, {"backend": "compiled", "cache_hit": compiled.cache_hit,
                                  "library": str(compiled.library.path)}


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
    q0 : (dof,) array_like
        Start configuration [rad] (on a rail, ``d`` [m] first).
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
    at_hand = compiled_at_hand(ctrl) if backend != Backend.INTERPRETED else None
    q0, tube = check_start(ctrl, q0, t0, duration, thr, check_every, physical, law=at_hand)
    backend, compiled, info = select_backend(ctrl, backend, progress=bool(progress))
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
    duration, step, t0 = check_time_span(duration, step, t0)
    if not is_integer(chunk) or chunk < 1:
        raise ConfigError(f"chunk: need a positive integer, got {shown(chunk)}")
    if backend not in BACKENDS:   # select_backend checks too, but only after the start checks
        raise ConfigError(f"backend: expected one of {BACKENDS}, got {shown(backend)}")
    thr = dict(DEFAULT_THRESHOLDS, **(thresholds or {}))
    check_gain_step(ctrl.gain, step, refuse=False)
    return duration, step, t0, thr


#: Margins within this of their thresholds (and deviations within this fraction of a path's tube) at the
#: start are decided by the controller's own law, not the compiled one (which differs by ~1e-13, a spatial
#: chain's by ~1e-9): the start check then decides and reports exactly as with the interpreted law [-].
START_GUARD = 1e-6


def start_outputs(ctrl: CoordinatingController, q0: np.ndarray, t0: float, law: Any, thr: dict[str, float],
                  tube: float) -> dict[str, Any]:
    """The law's outputs at the start: the compiled ``law``'s when every margin and deviation is clear of its
    limit by :data:`START_GUARD`, else (or without ``law``) the controller's, evaluated once.

    Parameters
    ----------
    ctrl : CoordinatingController
        The controller.
    q0 : (dof,) ndarray
        Start configuration [rad].
    t0 : float
        Start time [s].
    law : CompiledController or None
        The compiled law at hand.
    thr : dict
        Margin thresholds [-].
    tube : float
        Tube radius of a path [m] (inf without one).

    Returns
    -------
    dict
        Outputs by name (see :meth:`~coordarm.symbolic.law_face.LawFace.evaluate`).
    """
    if law is not None:
        try:
            out = law.evaluate(q0, t0)
        except NonFiniteError:
            out = None
        layout = layout_of_chain(ctrl.chain)
        near = {k: v + START_GUARD for k, v in thr.items()}
        if out is not None and margin_violation({c.array: np.asarray(out[c.array])[None] for c in layout.margins},
                                                layout.margins, near) is None and tube_exit(
                np.asarray(out["e"])[None], tube * (1 - START_GUARD), layout.deviations_per_link) is None:
            return out
    return ctrl.evaluate(q0, t0, once=True)


def check_start(ctrl: CoordinatingController, q0: Any, t0: float, duration: float, thr: dict[str, float],
                check_every: Any, physical: Any, law: Any = None) -> tuple[np.ndarray, float]:
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
    law : CompiledController, optional
        The compiled law when it is at hand (:func:`coordarm.generated.compiled_at_hand`): it evaluates
        the start unless a margin or deviation is near its limit (:func:`start_outputs`); else the
        controller does, once (:meth:`~coordarm.symbolic.law_face.LawFace.evaluate`).

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
    tube = float(getattr(ctrl.curve, "tube_radius", math.inf))
    start = start_outputs(ctrl, q0, t0, law, thr, tube)
    layout = layout_of_chain(ctrl.chain)
    bad = margin_violation({c.array: np.asarray(start[c.array])[None] for c in layout.margins}, layout.margins, thr)
    if bad is not None:
        _, kind, link, margin = bad
        where = f"{'joint' if kind == 'joint' else 'link'} {link}" if link else "the end point"
        raise ConfigError(f"q0: start configuration is (near) singular: {kind} margin of {where} is "
                          f"{margin:.3g} < {thr[layout.threshold_key(kind)]}")
    if not is_integer(check_every) or check_every < 1:
        raise ConfigError(f"check_every: need a positive integer, got {check_every!r}")
    if physical is not None:
        invalid = physical.check(np.array([t0]), q0[None])
        if invalid:
            raise ConfigError(f"q0: start configuration is not physically valid: {invalid[0].describe()}")
    start_out = tube_exit(np.asarray(start["e"])[None], tube, layout.deviations_per_link)
    if start_out is not None:
        raise ConfigError(f"q0: the central point of link {start_out[1]} is {start_out[2]:.4g} m from the path, "
                          f"not inside its tube (|phi| < {tube:.4g} m, the smallest radius)")
    return q0, tube
