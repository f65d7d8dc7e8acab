"""One scenario run as ``coordarm run`` does it: checks, controller, log, live view, outcome, figures.

:func:`run_scenario` is the library form of the command; the command only parses its options,
calls it and prints. The call prints nothing itself: the lines the command shows on standard
output go to an ``echo`` callback as soon as they are known (and are kept in the result), the
warnings of building the law go to ``on_warning`` (by default they are issued again as Python
warnings). A callback rather than a stream, so that a caller can collect, log or print the lines,
and so that the command prints each one at the moment it is known: the live view's address before
the run (a client needs it to connect), the summary before the figures are drawn.

A run stopped ahead of a singularity or at a collision is a result (its ``outcome`` and
``exit_status`` say so, ``stopped`` holds the error), not an exception: its log and figures are
written like those of a completed run. Bad input, an unwritable file and Ctrl-C
(:class:`~coordarm.symbolic.interrupts.Interrupted`) raise; the log is closed with its outcome
(``interrupted``, ``error``) whatever happens once it is open.
"""
from __future__ import annotations

import os
import warnings
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Sequence

from coordarm.simulation.choices import DEFAULT_COMPRESSION, DENSE_LINKS, SUMMARY_ROWS
from coordarm.symbolic.errors import CollisionError, ConfigError, JointRateError, LogError, SingularityError
from coordarm.symbolic.laws import Law
from coordarm.symbolic.records import record

if TYPE_CHECKING:   # numpy, CasADi, matplotlib and foxglove load only when a run starts
    from coordarm.simulation.run import Run
    from coordarm.simulation.scenario import Scenario
    from coordarm.symbolic.controller import CoordinatingController


#: Links of a dense law above which ``coordarm run`` says that building it can take minutes.
DENSE_NOTICE_LINKS = 16


@record(frozen=True)
class ScenarioResult:
    """What :func:`run_scenario` did: the run, how it ended, and the files it wrote.

    Attributes
    ----------
    scenario : Scenario
        The scenario as run (with the overrides applied).
    run : Run
        The simulated run, up to the stop when it stopped (``t`` [s] ``(n,)``, ``q`` ``(n, dof)``, ...).
    outcome : str
        ``"completed"``, ``"singularity"`` or ``"collision"``.
    exit_status : int
        The exit status of ``coordarm run`` for this outcome: 0, 3 or 4.
    log : Path
        The MCAP log, closed, with the outcome in its metadata.
    figures : tuple of Path
        The PNG figures (stages or panels, tracking); empty when figures were not asked for.
    backend : str
        ``"compiled"`` or ``"interpreted"`` (after an ``"auto"`` fallback, the one that ran).
    library : Path or None
        The compiled law's shared library, with the compiled backend.
    cache_hit : bool or None
        Whether that library came from the build cache (None with the interpreted backend).
    lines : tuple of str
        The lines ``coordarm run`` prints on standard output, in order (each also given to ``echo``).
    stopped : SingularityError or CollisionError or None
        The error that stopped the run (time, margin or contact, link), None when it completed.
    """

    scenario: Scenario
    run: Run
    outcome: str
    exit_status: int
    log: Path
    figures: tuple[Path, ...]
    backend: str
    library: Path | None
    cache_hit: bool | None
    lines: tuple[str, ...]
    stopped: SingularityError | CollisionError | None = None

    @property
    def summary(self) -> dict[str, Any]:
        """The run's figures of merit (:meth:`Run.summary`: duration [s], steps, final max|e| [m], margins, ...)."""
        return self.run.summary()

    @property
    def contacts(self) -> list[dict]:
        """The contacts recorded by an ``allow_contact`` run (kind, time [s], links), in order; else empty."""
        return list(self.run.info.get("contacts") or [])

    def stop_message(self) -> str | None:
        """What stopped the run and one line of advice, then the log and figures; None when it completed.

        Returns
        -------
        str or None
            Several lines: ``"<outcome>: <what>; run stopped"``, the advice, ``"log: <path>"``
            and one ``"figure: <path>"`` per figure.
        """
        if self.stopped is None:
            return None
        from coordarm.simulation.outcome import explain

        what, advice = explain(self.stopped)
        return (f"{self.outcome}: {what}; run stopped\n{advice}\nlog: {self.log}"
                + "".join(f"\nfigure: {p}" for p in self.figures))


def run_scenario(scenario: Scenario | str | os.PathLike, *, links: int | None = None,
                 duration: float | None = None, step: float | None = None, law: str | None = None,
                 governor: bool | None = None, backend: str = "auto", log: str | os.PathLike | None = None,
                 overwrite: bool = False, yes: bool = False, log_rate: float | None = None,
                 cond_rate: float | None = None, cond_exact: bool = False, compression: str = DEFAULT_COMPRESSION, live: bool = False,
                 port: int = 8765, live_speed: float = 1.0, live_wait: bool = False, figures: bool = True,
                 stages: Sequence[float] | None = None, allow_contact: bool = False, progress: bool = False,
                 echo: Callable[[str], None] | None = None, on_warning: Callable[[Warning], None] | None = None,
                 log_frames: str = "ends") -> ScenarioResult:
    """Simulate a scenario with its log, optional live view, outcome and figures (``coordarm run``).

    Parameters
    ----------
    scenario : Scenario, str or path-like
        A scenario, a preset name (``"line"``, ...) or a TOML file.
    links, duration, step, law, governor : optional
        Overrides: links, duration [s], RK4 step [s], form of the law, speed governor.
    backend : {"auto", "compiled", "interpreted"}, optional
        How the law runs (``"auto"``: compiled, else interpreted with a warning).
    log : str or path-like, optional
        The MCAP log (default ``logs/<name>.mcap``, replaced if there); figures go beside it.
    overwrite, yes : bool, optional
        Replace an existing ``log``; run above the cost limits or a dense law over ``DENSE_LINKS`` links.
    log_rate, cond_rate, cond_exact, compression, log_frames : optional
        Log samples [Hz], cond samples [Hz] (0 = off), the exact 2-norm cond (an SVD per sample) instead
        of the 1-norm one, chunk compression (zstd, lz4, none), the frames of ``/tf`` (log and live view:
        ``"ends"``, base and tip, or ``"all"``, one per link).
    live, port, live_speed, live_wait : optional
        Serve the run to Foxglove on ``port`` (0 = any) at ``live_speed`` simulated seconds per second
        [-], starting once a client subscribed if ``live_wait``.
    figures, stages : optional
        Draw the PNG figures beside the log (else keep :data:`~.choices.SUMMARY_ROWS` rows), stages at these times [s].
    allow_contact, progress : bool, optional
        Record contacts instead of stopping; show a progress bar on standard error.
    echo, on_warning : callable, optional
        Get each line ``coordarm run`` prints on stdout, once known; each warning of building the law
        (default: issued again by :mod:`warnings`).

    Returns
    -------
    ScenarioResult
        Run, outcome and exit status (also after a singularity or collision stop), log, figures, lines.

    Raises
    ------
    ConfigError
        Bad scenario or option, a cost above the limits without ``yes``, a live port in use.
    LogError
        The log or a figure cannot be written, or ``log`` exists without ``overwrite``.
    BuildError
        ``backend="compiled"`` and the law cannot be built.
    Interrupted
        Ctrl-C or SIGTERM (the log is closed with outcome ``interrupted``).
    """
    from coordarm.simulation.figure_files import write_figures
    from coordarm.simulation.outcome import EXIT_CODES, outcome_of

    lines: list[str] = []
    say = collector(lines, echo)
    scenario = prepared_scenario(scenario, links, duration, step, law, governor, (log_rate, cond_rate), yes)
    overwrite = overwrite or log is None   # the default log is a scratch file
    out = checked_log_path(Path("logs") / f"{scenario.name}.mcap" if log is None else Path(log), overwrite)
    ctrl = scenario.controller()
    try:     # a log replaced by this one is freed on another thread meanwhile (RunLogger free_replaced_later)
        run, stopped, chosen, compiled = simulate_logged(
            scenario, ctrl, out, overwrite=overwrite, backend=backend, log_rate=log_rate, cond_rate=cond_rate, cond_exact=cond_exact,
            compression=compression, live=live, port=port, live_speed=live_speed, live_wait=live_wait, allow_contact=allow_contact,
            progress=progress, say=say, on_warning=on_warning or reissue, log_frames=log_frames, keep=None if figures else SUMMARY_ROWS)
        status = outcome_of(stopped, None)["status"]
        for line in report_lines(run, scenario, compiled, out):
            say(line)
        drawn = write_figures(run, scenario, ctrl, out.with_suffix(""), stages, outcome=status) if figures else []
        for p in drawn:
            say(f"figure        {p}")
    finally:
        from coordarm.simulation.file_replace import wait_released
        wait_released()
    return ScenarioResult(scenario, run, status, EXIT_CODES[status], out, tuple(drawn), chosen,
                          Path(compiled.library.path) if compiled else None, compiled.cache_hit if compiled else None,
                          tuple(lines), stopped)


def collector(lines: list[str], echo: Callable[[str], None] | None) -> Callable[[str], None]:
    """A ``say`` function that appends each line to ``lines`` and passes it on to ``echo`` (if given).

    Parameters
    ----------
    lines : list of str
        Collects every line said.
    echo : callable or None
        Gets each line as soon as it is said.

    Returns
    -------
    callable
        ``say(line)``.
    """
    def say(line: str) -> None:
        lines.append(line)
        if echo is not None:
            echo(line)
    return say


def report_lines(run: Run, scenario: Scenario, compiled: Any, out: Path) -> list[str]:
    """The lines ``coordarm run`` prints once the run is over: summary, compiled library, log.

    Parameters
    ----------
    run : Run
        The run.
    scenario : Scenario
        Its scenario.
    compiled : CompiledController or None
        The compiled law (its library path and whether it came from the cache), None if interpreted.
    out : Path
        The log.

    Returns
    -------
    list of str
    """
    from coordarm.simulation.summary import summary_lines

    lines = summary_lines(run, scenario)
    if compiled:
        lines.append(f"library       {compiled.library.path} ({'cache hit' if compiled.cache_hit else 'built now'})")
    lines.append(f"log           {out}")
    return lines


def prepared_scenario(scenario: Scenario | str | os.PathLike, links: int | None, duration: float | None,
                      step: float | None, law: str | None, governor: bool | None,
                      log_rate: float | None | tuple[float | None, float | None], yes: bool) -> Scenario:
    """The scenario with its overrides, once its cost and the size of a dense law are accepted.

    Parameters
    ----------
    scenario : Scenario, str or path-like
        A scenario, a preset name or a TOML file.
    links, duration, step, law, governor : optional
        Overrides (see :meth:`Scenario.with_overrides`); duration and step in [s].
    log_rate : float or None, or (log_rate, cond_rate)
        Log samples per simulated second [Hz] (for the log size estimate), optionally with the
        rate of ``/margins/cond`` [Hz] (0 switches it off); both checked to be positive numbers.
    yes : bool
        Accept a cost above the limits and a dense law of more than ``DENSE_LINKS`` links.

    Returns
    -------
    Scenario

    Raises
    ------
    ConfigError
        A bad override, a cost above the limits or a large dense law without ``yes``.
    """
    from coordarm.simulation.limits import check_cost, estimate
    from coordarm.simulation.rates import steps_between
    from coordarm.simulation.scenario import Scenario, load_scenario

    if isinstance(scenario, Scenario):
        scenario = scenario.with_overrides(links, duration, step, law=law, governor=governor)
    else:    # overridden before validation: K h is checked at the step the run uses
        scenario = load_scenario(scenario, links=links, duration=duration, step=step, law=law, governor=governor)
    log_rate, cond_rate = log_rate if isinstance(log_rate, tuple) else (log_rate, None)
    for rate, flag in ((log_rate, "--log-rate"), (cond_rate, "--cond-rate")):
        if rate is not None and (rate != 0 or flag == "--log-rate"):       # a cond rate of 0 switches it off
            steps_between(rate, scenario.step, flag)
    check_cost(estimate(scenario.chain().m, scenario.step, scenario.duration, log_rate), yes)
    m = scenario.config.chain.links
    if scenario.config.control.law == Law.DENSE and m > DENSE_LINKS and not yes:
        raise ConfigError(f"--law dense with {m} links: generating and compiling it takes many minutes "
                          f"(its size grows as m^2); use the structured law, or pass --yes")
    return scenario


def checked_log_path(out: Path, overwrite: bool) -> Path:
    """``out``, once it is known to be writable as a new log: its directory is created.

    Parameters
    ----------
    out : Path
        The log file.
    overwrite : bool
        Whether an existing file may be replaced.

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    LogError
        ``out`` is not a regular file, exists without ``overwrite``, or its directory cannot be made.
    """
    if out.exists() and not out.is_file():
        raise LogError(f"--out {out}: not a regular file; choose a log file name")
    if not overwrite and out.exists():
        raise LogError(f"--out {out}: exists; choose another file or pass --overwrite")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise LogError(f"--out {out}: cannot create its directory: {exc.strerror or exc}") from None
    return out


def simulate_logged(scenario: Scenario, ctrl: CoordinatingController, out: Path, *, overwrite: bool,
                    backend: str, log_rate: float | None, cond_rate: float | None, compression: str,
                    live: bool, port: int, live_speed: float, live_wait: bool, allow_contact: bool,
                    progress: bool, say: Callable[[str], None], on_warning: Callable[[Warning], None],
                    cond_exact: bool = False, log_frames: str = "ends",
                    keep: int | None = None) -> tuple[Run, SingularityError | CollisionError | None, str, Any]:
    """Simulate ``scenario`` into the log ``out`` (and the live view); the log is closed with the outcome.

    Parameters
    ----------
    scenario : Scenario
        The scenario (with its overrides).
    ctrl : CoordinatingController
        Its controller.
    out : Path
        The MCAP log (see :func:`checked_log_path`).
    overwrite, allow_contact, progress : bool
        As for :func:`logged_run`.
    backend : {"auto", "compiled", "interpreted"}
        How the law runs.
    log_rate, cond_rate, cond_exact, keep : float or None, float or None, bool, int or None
        As for :func:`logged_run` [Hz].
    compression : str
        As for :func:`logged_run`.
    on_warning : callable
        As for :func:`logged_run`.
    live : bool
        Serve the run to Foxglove too.
    port : int
        Port of the live view (0 = any).
    live_speed : float
        Simulated seconds per wall-clock second on the live view [-].
    live_wait : bool
        Start once a live client subscribed and its subscriptions settled (see
        :meth:`~coordarm.simulation.live.LiveView.wait_for_client`).
    say : callable
        Gets the live view's address line.
    log_frames : {"ends", "all"}
        The frames of ``/tf`` (log and live view).

    Returns
    -------
    run : Run
        The run, up to the stop when a singularity or a collision stopped it.
    stopped : SingularityError or CollisionError or None
        What stopped it.
    backend : str
        The backend that ran.
    compiled : CompiledController or None
        The compiled law, with the compiled backend.

    Raises
    ------
    ConfigError
        A bad option, or a live port in use.
    LogError, BuildError, Interrupted
        As for :func:`logged_run`.
    """
    with ExitStack() as stack:
        view = None
        if live:                        # imported only for a live view (its server and scenes)
            from coordarm.simulation.live import LiveView

            view = stack.enter_context(LiveView(scenario, ctrl, port=port, speed=live_speed, cond_rate=cond_rate,
                                                frames=log_frames, cond_exact=cond_exact))
            say(f"live          {view.url} (Foxglove: Open connection, Foxglove WebSocket)")
            if live_wait:
                view.wait_for_client()
        if backend != "interpreted" and scenario.config.control.law == Law.DENSE and ctrl.chain.m > DENSE_NOTICE_LINKS:
            say(f"law           dense, {ctrl.chain.m} links: generating and compiling its C can take minutes "
                "(once: the library is cached)")
        holder: dict[str, Any] = {"backend": backend, "compiled": None}
        try:
            run = logged_run(scenario, ctrl, out, view, holder, overwrite=overwrite, log_rate=log_rate,
                             cond_rate=cond_rate, cond_exact=cond_exact, compression=compression, allow_contact=allow_contact,
                             progress=progress, on_warning=on_warning, log_frames=log_frames, keep=keep)
            stopped = None
        except (SingularityError, CollisionError, JointRateError) as err:
            run, stopped = err.run, err
    return run, stopped, holder["backend"], holder["compiled"]


def logged_run(scenario: Scenario, ctrl: CoordinatingController, out: Path, view: Any, holder: dict[str, Any], *,
               overwrite: bool, log_rate: float | None, cond_rate: float | None, compression: str,
               allow_contact: bool, progress: bool, on_warning: Callable[[Warning], None],
               cond_exact: bool = False, log_frames: str = "ends", keep: int | None = None) -> Run:
    """Build or load the law and simulate ``scenario`` into the log ``out``, closed with the outcome.

    Parameters
    ----------
    scenario : Scenario
        The scenario (with its overrides).
    ctrl : CoordinatingController
        Its controller.
    out : Path
        The MCAP log (see :func:`checked_log_path`).
    view : LiveView or None
        The live view that also gets every chunk.
    holder : dict
        ``{"backend": requested}`` in; ``backend`` (the one that ran) and ``compiled`` (the compiled
        law or None) are set in it as soon as known, so they survive a stop.
    overwrite, allow_contact, progress : bool
        Replace an existing ``out``; record contacts instead of stopping; show a progress bar on standard error.
    log_rate, cond_rate : float or None
        Log samples and condition number samples per simulated second [Hz] (None: the defaults).
    cond_exact : bool
        Log the exact 2-norm condition number (see :class:`~.mcap_writer.RunLogger`).
    compression : str
        Chunk compression of the log (zstd, lz4, none).
    on_warning : callable
        Gets each warning of building or loading the law.
    log_frames : {"ends", "all"}
        The frames of ``/tf``: ``base`` and ``tip``, or one per link.
    keep : int, optional
        Rows kept in memory, about (default :data:`~.limits.KEEP_ROWS`; the summary is of every step).

    Returns
    -------
    Run
        The completed run.

    Raises
    ------
    SingularityError, CollisionError
        The run stopped (the error holds the run so far).
    LogError
        The log cannot be written.
    BuildError
        ``backend="compiled"`` and the law cannot be built.
    Interrupted
        Ctrl-C or SIGTERM (the log is closed with outcome ``interrupted``).
    """
    from coordarm.simulation.limits import GainStepWarning, check_gain_step
    from coordarm.simulation.mcap_writer import RunLogger
    from coordarm.simulation.run import BackendFallbackWarning, check_stride, select_backend, simulate

    # The log is closed with its outcome however the run ends (singularity, collision, error, Ctrl-C).
    # With a second core, encoding and compression overlap the simulation (RESULTS_logging.md).
    with RunLogger(out, scenario, ctrl, log_rate=log_rate, cond_rate=cond_rate, cond_exact=cond_exact,
                   compression=compression, overwrite=overwrite, frames=log_frames,
                   threaded=(os.cpu_count() or 1) > 1, free_replaced_later=True) as logger:
        q0 = scenario.start(ctrl)
        with warnings.catch_warnings(record=True) as caught:   # builds or loads the library
            warnings.simplefilter("always", BackendFallbackWarning)
            check_gain_step(ctrl.gain, scenario.step)
            backend, compiled, _ = select_backend(ctrl, holder["backend"], progress=progress)
        holder.update(backend=backend, compiled=compiled)
        for w in caught:
            on_warning(w.message)
        logger.set_backend(backend, compiled.library.key if compiled else None)
        on_chunk = logger.on_chunk if view is None else both(logger.on_chunk, view.on_chunk)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", GainStepWarning)   # said above already
            run = simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend=backend,
                           thresholds=scenario.thresholds, progress=progress, on_chunk=on_chunk,
                           physical=scenario.physical(ctrl.chain),
                           check_every=check_stride(scenario.step),      # whatever the log's rate
                           allow_contact=allow_contact, keep=keep)
        logger.contacts, logger.joint_rates = run.info["contacts"], run.info.get("joint_rates")
    return run


def both(first: Callable[[Run], None], second: Callable[[Run], None]) -> Callable[[Run], None]:
    """One ``on_chunk`` that hands each block of steps to ``first`` then ``second``.

    Parameters
    ----------
    first, second : callable
        Receivers of a :class:`Run` block (the log, the live view).

    Returns
    -------
    callable
    """
    def on_chunk(part: Run) -> None:
        first(part)
        second(part)
    return on_chunk


def reissue(warning: Warning) -> None:
    """Issue ``warning`` again with :func:`warnings.warn` (the default ``on_warning`` of :func:`run_scenario`).

    Parameters
    ----------
    warning : Warning
        A warning caught while the law was built or loaded.
    """
    warnings.warn(warning, stacklevel=4)
