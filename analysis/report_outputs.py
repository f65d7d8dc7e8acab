"""The singularity and condition report of a log or of a freshly simulated scenario (``coordarm report``
as a library call).

:func:`report_of` prints nothing: a cut-off or damaged log is described to ``on_problem``, the
notice of a long margin computation to ``on_note`` (see :mod:`coordarm.simulation.session` for why
callbacks).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, NamedTuple

from coordarm.symbolic.errors import ConfigError, LogError, shown

if TYPE_CHECKING:   # numpy, CasADi and matplotlib load only when a report is written
    from coordarm.simulation.run import Run
    from coordarm.simulation.scenario import Scenario

#: Allowed ``samples`` of the margins.
SAMPLES_RANGE = (2, 100_000)


# A NamedTuple, not a dataclass: the command line imports this module when it starts (for the option
# range above) and importing dataclasses costs about 10 ms there.
class ReportOutputs(NamedTuple):
    """What :func:`report_of` analysed and wrote.

    Parameters
    ----------
    scenario : Scenario
        The scenario of the report (rebuilt from the log, or as simulated).
    run : Run or Replay
        The run analysed.
    path : Path
        The Markdown report.
    figures : tuple of Path
        The PNG files in the report's directory, sorted.
    """

    scenario: Scenario
    run: Any
    path: Path
    figures: tuple[Path, ...]


def report_of(source: str | os.PathLike, out: str | os.PathLike | None = None, *, links: int | None = None,
              duration: float | None = None, samples: int | None = None, yes: bool = False,
              overwrite: bool = False, on_problem: Callable[[str], None] | None = None,
              on_note: Callable[[str], None] | None = None) -> ReportOutputs:
    """Write the singularity and condition report of a log (``*.mcap``) or of a scenario.

    A scenario (preset or TOML) is simulated first without singularity stops, so that a blow-up
    is visible (:func:`simulate_scenario`). A spatial chain (universal joints) gets the report of
    :func:`~coordarm.analysis.spatial_report.write_spatial_report` (its logged margins; ``samples`` unused).

    Parameters
    ----------
    source : str or path-like
        A log ``*.mcap``, a preset name or a TOML file.
    out : str or path-like, optional
        Output directory (created if missing). Default: ``<log's folder>/<log's stem>_report`` for a
        log, ``logs/<scenario>_report`` for a scenario; a default folder is replaced, a given one
        holding a ``report.md`` only with ``overwrite``.
    links, duration : optional
        Scenario only: overrides of the number of links and the duration [s].
    samples : int, optional
        Margin samples over the run, within :data:`SAMPLES_RANGE` (default
        :func:`~coordarm.analysis.report.default_samples`).
    yes : bool, optional
        Scenario only: simulate even when the estimated steps or memory are above the limits.
    overwrite : bool, optional
        Replace the report in a given ``out``.
    on_problem : callable, optional
        Gets ``"<log>: <what>"`` for a cut-off or damaged log and each problem met reading it.
    on_note : callable, optional
        Gets a notice before a long margin computation (more than 128 links).

    Returns
    -------
    ReportOutputs

    Raises
    ------
    ConfigError
        ``samples`` out of range, overrides given for a log, a bad scenario or a cost above the limits.
    LogError
        The log cannot be read or holds no samples, ``out`` cannot be made, or it holds a report
        and ``overwrite`` is False.
    """
    target = checked_arguments(str(source), out, links, duration, samples, overwrite)   # before the heavy imports
    import numpy as np

    from coordarm.analysis.report import default_samples, write_report
    from coordarm.analysis.replay_outputs import output_directory
    from coordarm.simulation.figure_files import writing

    run, scenario = source_run(str(source), links, duration, yes, on_problem)
    out = output_directory(Path("logs") / f"{scenario.name}_report" if target is None else target)
    if scenario.universal:     # a spatial chain: its logged margins, read as they are (``samples`` unused)
        from coordarm.analysis.spatial_report import write_spatial_report

        with writing(out / "report.md"):
            path = write_spatial_report(run, scenario, out)
        return ReportOutputs(scenario, run, path, tuple(sorted(path.parent.glob("*.png"))))
    m = np.shape(run.q)[1]
    if m > 128 and on_note is not None:  # about a second per 1000 samples at 64 links, a second per sample at 1024
        on_note(f"report: margins at {samples or default_samples(m)} samples of a {m}-link chain "
                "(an SVD and a QR of the m x m decoupling matrix each) ...")
    from coordarm.simulation.progress import Phase
    with Phase("report: margins along the run, stability, figures"), writing(out / "report.md"):
        # (a full disk names the report, not just "No space left")
        path = write_report(run, scenario, out, samples=samples)
    return ReportOutputs(scenario, run, path, tuple(sorted(path.parent.glob("*.png"))))


def checked_arguments(src: str, out: str | os.PathLike | None, links: int | None, duration: float | None,
                      samples: int | None, overwrite: bool) -> Path | None:
    """Check the arguments of :func:`report_of` that need no heavy import; the output folder if known.

    Parameters
    ----------
    src : str
        A log ``*.mcap``, a preset name or a TOML file.
    out : str or path-like or None
        The given output directory.
    links, duration : int or None, float or None
        Scenario only: overrides.
    samples : int or None
        Margin samples.
    overwrite : bool
        Replace a report in a given ``out``.

    Returns
    -------
    Path or None
        The output directory: ``out``, or for a log ``<folder>/<stem>_report``; None for a scenario
        without ``out`` (named after the scenario once it is read).

    Raises
    ------
    ConfigError
        ``samples`` out of range, overrides given for a log.
    LogError
        The log is not a file, ``out`` is a file, or ``out`` holds a report and ``overwrite`` is False.
    """
    if samples is not None and not SAMPLES_RANGE[0] <= samples <= SAMPLES_RANGE[1]:
        raise ConfigError(f"--samples: need {SAMPLES_RANGE[0]} to {SAMPLES_RANGE[1]}, got {shown(samples)}")
    if not src.endswith(".mcap"):
        return None if out is None else Path(out)
    if links is not None or duration is not None:
        raise ConfigError("--links/--duration: only for a scenario, not for a log")
    if not Path(src).is_file():
        raise LogError(f"{shown(src)}: no such log file")
    if out is None:
        return Path(src).with_name(Path(src).stem + "_report")
    target = Path(out)
    if target.exists() and not target.is_dir():
        raise LogError(f"--out {shown(str(target))}: is a file; need a directory for the figures")
    if (target / "report.md").exists() and not overwrite:
        raise LogError(f"--out {shown(str(target))}: holds a report already; pass --overwrite to replace it")
    return target


def source_run(src: str, links: int | None, duration: float | None, yes: bool,
               on_problem: Callable[[str], None] | None) -> tuple[Any, Scenario]:
    """The run to report on and its scenario: read from a log ``*.mcap``, else simulated.

    Parameters
    ----------
    src : str
        A log ``*.mcap``, a preset name or a TOML file.
    links, duration : int or None, float or None
        Scenario only: overrides of the number of links and the duration [s].
    yes : bool
        Simulate even above the cost limits.
    on_problem : callable or None
        Gets each problem of a cut-off or damaged log.

    Returns
    -------
    run : Replay or Run
    scenario : Scenario

    Raises
    ------
    ConfigError
        Overrides given for a log, a bad scenario or a cost above the limits.
    LogError
        The log cannot be read or holds no samples.
    """
    from coordarm.simulation.limits import check_cost, estimate
    from coordarm.simulation.scenario import load_scenario

    if src.endswith(".mcap"):
        if links is not None or duration is not None:
            raise ConfigError("--links/--duration: only for a scenario, not for a log")
        from coordarm.analysis.replay import load
        from coordarm.analysis.replay_outputs import condition_lines
        run = load(src)
        for problem in condition_lines(run):
            if on_problem is not None:
                on_problem(problem)
        if not len(run.t):
            raise LogError(f"{src}: the log holds no samples; nothing to report")
        return run, run.scenario
    scenario = load_scenario(src, links=links, duration=duration)
    check_cost(estimate(scenario.chain().m, scenario.step, scenario.duration, logged=False), yes)
    return simulate_scenario(scenario), scenario


def simulate_scenario(scenario: Scenario) -> Run:
    """Simulate ``scenario`` without singularity stops; a run ending in NaN is kept up to there.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its controller, start, duration [s], step [s] and start time [s]).

    Returns
    -------
    Run
    """
    from coordarm.analysis.report import simulate_through

    ctrl = scenario.controller()
    return simulate_through(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, scenario.t0, progress=True)
