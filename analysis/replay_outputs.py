"""A run's figures and animation redrawn from its log alone (``coordarm replay`` as a library call).

:func:`replay_log` prints nothing: the lines the command shows go to an ``echo`` callback as they
are known, what went wrong while reading the log to ``on_problem`` (see
:mod:`coordarm.simulation.session` for why callbacks).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Callable, NamedTuple, Sequence

from coordarm.symbolic.errors import ConfigError, LogError, shown

if TYPE_CHECKING:   # numpy, mcap and matplotlib load only when a log is replayed
    from coordarm.analysis.replay import Replay

#: Allowed frames per second of the animation.
FPS_RANGE = (0.1, 60.0)


# A NamedTuple, not a dataclass: the command line imports this module when it starts (for the option
# range above) and importing dataclasses costs about 10 ms there.
class ReplayOutputs(NamedTuple):
    """What :func:`replay_log` read and wrote.

    Parameters
    ----------
    replay : Replay
        The run read back from the log.
    figures : tuple of Path
        The stage (or panel) and tracking PNGs; empty when the log holds no samples.
    animation : Path or None
        The GIF, when one was asked for and the log holds samples.
    lines : tuple of str
        The lines ``coordarm replay`` prints on standard output, in order.
    """

    replay: Replay
    figures: tuple[Path, ...]
    animation: Path | None
    lines: tuple[str, ...]


def replay_log(log: str | os.PathLike, out: str | os.PathLike | None = None, *, stages: Sequence[float] | None = None,
               animation: bool = True, fps: float = 15.0, progress: bool = False,
               echo: Callable[[str], None] | None = None,
               on_problem: Callable[[str], None] | None = None) -> ReplayOutputs:
    """Read a run log (also one left by a killed run) and draw its figures and a GIF animation.

    Parameters
    ----------
    log : str or path-like
        The MCAP log.
    out : str or path-like, optional
        Directory of the figures (default: beside the log; created if missing).
    stages : sequence of float, optional
        Times [s] of the stage figure (default: the scenario's).
    animation : bool, optional
        Write ``<log stem>.gif`` too.
    fps : float, optional
        Frames per second of the GIF, within :data:`FPS_RANGE`.
    progress : bool, optional
        Show the animation's progress bar on standard error.
    echo : callable, optional
        Gets each line ``coordarm replay`` prints on standard output, once known.
    on_problem : callable, optional
        Gets ``"<log>: <what>"`` for a cut-off or damaged log and each problem met reading it.

    Returns
    -------
    ReplayOutputs

    Raises
    ------
    LogError
        The log cannot be read (named, with what could be recovered), ``out`` is a file, or a
        file cannot be written.
    ConfigError
        ``fps`` outside :data:`FPS_RANGE`.
    """
    from coordarm.analysis.replay import load
    from coordarm.simulation.figure_files import write_figures, writing
    from coordarm.simulation.summary import summary_lines

    lines: list[str] = []

    def say(line: str) -> None:
        lines.append(line)
        if echo is not None:
            echo(line)

    if not FPS_RANGE[0] <= fps <= FPS_RANGE[1]:
        raise ConfigError(f"--fps: need {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g} frames per second, got {shown(fps)}")
    replay = load(Path(log))
    stem = output_directory(Path(log).parent if out is None else Path(out)) / Path(log).stem
    for problem in condition_lines(replay):
        if on_problem is not None:
            on_problem(problem)
    if not len(replay.t):
        say(f"outcome       {replay.outcome.get('status')}: the log holds no samples; nothing to draw")
        return ReplayOutputs(replay, (), None, tuple(lines))
    run, ctrl = replay.to_run(), replay.controller()
    for line in summary_lines(run, replay.scenario):
        say(line)
    say(f"outcome       {replay.outcome.get('status')}"
        + (f": {replay.outcome['message']}" if "message" in replay.outcome else ""))
    figures = write_figures(run, replay.scenario, ctrl, stem, stages, outcome=replay.outcome.get("status", ""))
    for p in figures:
        say(f"figure        {p}")
    gif = None
    if animation:
        from coordarm.analysis.animation import animate
        from coordarm.analysis.animation3d import animate3d
        gif = stem.with_name(stem.name + ".gif")
        with writing(gif):       # a spatial run: the chain in a 3-D perspective view
            gif = (animate if run.layout.kind == "revolute" else animate3d)(replay, gif, fps=fps, ctrl=ctrl,
                                                                             progress=progress)
        say(f"animation     {gif}")
    return ReplayOutputs(replay, tuple(figures), gif, tuple(lines))


def condition_lines(replay: Replay) -> list[str]:
    """``"<log>: <what>"`` for a log that was cut off or damaged, then for each problem met reading it.

    Parameters
    ----------
    replay : Replay
        A run read back from its log.

    Returns
    -------
    list of str
        Empty for a complete, undamaged log.
    """
    condition = replay.condition()
    return ([f"{replay.path}: {condition}"] if condition else []) + [f"{replay.path}: {p}" for p in replay.problems]


def output_directory(path: Path) -> Path:
    """``path`` created as a directory (a LogError if a file is in the way or it cannot be made).

    Parameters
    ----------
    path : Path
        The directory for the outputs.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    LogError
        A file is in the way, or the directory cannot be created.
    """
    if path.exists() and not path.is_dir():
        raise LogError(f"--out {shown(str(path))}: is a file; need a directory for the figures")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise LogError(f"--out {shown(str(path))}: cannot create the directory: {exc.strerror or exc}") from None
    return path
