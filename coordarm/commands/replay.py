"""``coordarm replay LOG.mcap``: re-draw a run's figures and an animation from its log alone."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from coordarm.commands.run import stage_list
from coordarm.symbolic.errors import ConfigError, LogError, shown

#: Allowed frames per second of the animation.
FPS_RANGE = (0.1, 60.0)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``replay`` sub-command."""
    p = sub.add_parser("replay", help="re-draw figures and an animation from a run log",
                       description="Read an MCAP run log (also one left by a killed run), print its summary, "
                                   "and write the stage and tracking figures and a GIF animation.")
    p.add_argument("log", type=Path, metavar="LOG.mcap")
    p.add_argument("--out", type=Path, help="directory for the figures (default: beside the log)")
    p.add_argument("--no-animation", action="store_true", help="do not write the GIF")
    p.add_argument("--fps", type=float, default=15.0,
                   help=f"frames per second of the GIF, {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g} (default 15)")
    p.add_argument("--stages", type=stage_list, metavar="T1,T2,...",
                   help="times [s] of the stage figure, e.g. 0,4,8,12 (default: the scenario's)")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Replay the log named in ``args``: summary, figures, animation; returns 0.

    Raises
    ------
    LogError
        The log cannot be read (named, with what could be recovered).
    ConfigError
        ``--fps`` outside :data:`FPS_RANGE`, or ``--out`` is a file.
    """
    from coordarm.analysis.replay import load
    from coordarm.simulation.figure_files import write_figures, writing
    from coordarm.simulation.summary import summary_lines

    if not FPS_RANGE[0] <= args.fps <= FPS_RANGE[1]:
        raise ConfigError(f"--fps: need {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g} frames per second, got {shown(args.fps)}")
    replay = load(args.log)
    out_dir = output_directory(args.out or args.log.parent)
    stem = out_dir / args.log.stem
    report_condition(replay, "coordarm replay")
    if not len(replay.t):
        print(f"outcome       {replay.outcome.get('status')}: the log holds no samples; nothing to draw")
        return 0
    run, ctrl = replay.to_run(), replay.controller()
    print("\n".join(summary_lines(run, replay.scenario)))
    print(f"outcome       {replay.outcome.get('status')}"
          + (f": {replay.outcome['message']}" if "message" in replay.outcome else ""))
    for p in write_figures(run, replay.scenario, ctrl, stem, args.stages, outcome=replay.outcome.get("status", "")):
        print(f"figure        {p}")
    if not args.no_animation:
        from coordarm.analysis.animation import animate
        gif = stem.with_name(stem.name + ".gif")
        with writing(gif):
            print(f"animation     {animate(replay, gif, fps=args.fps, ctrl=ctrl)}")
    return 0


def report_condition(replay, prefix: str) -> None:
    """Say on stderr when a log was cut off or damaged, and each problem met while reading it."""
    condition = replay.condition()
    if condition:
        print(f"{prefix}: {replay.path}: {condition}", file=sys.stderr)
    for problem in replay.problems:
        print(f"{prefix}: {replay.path}: {problem}", file=sys.stderr)


def output_directory(path: Path) -> Path:
    """``path`` created as a directory (a LogError if a file is in the way or it cannot be made)."""
    if path.exists() and not path.is_dir():
        raise LogError(f"--out {shown(str(path))}: is a file; need a directory for the figures")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise LogError(f"--out {shown(str(path))}: cannot create the directory: {exc.strerror or exc}") from None
    return path
