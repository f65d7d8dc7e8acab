"""``coordarm replay LOG.mcap``: re-draw a run's figures and an animation from its log alone."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from coordarm.commands.run import stage_list
from coordarm.symbolic.errors import ConfigError


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``replay`` sub-command."""
    p = sub.add_parser("replay", help="re-draw figures and an animation from a run log",
                       description="Read an MCAP run log (also one left by a killed run), print its summary, "
                                   "and write the stage and tracking figures and a GIF animation.")
    p.add_argument("log", type=Path, metavar="LOG.mcap")
    p.add_argument("--out", type=Path, help="directory for the figures (default: beside the log)")
    p.add_argument("--no-animation", action="store_true", help="do not write the GIF")
    p.add_argument("--fps", type=float, default=15.0, help="frames per second of the GIF (default 15)")
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
        A non-positive ``--fps``.
    """
    from coordarm.analysis.replay import load
    from coordarm.commands.run import print_summary, write_figures

    if not args.fps > 0:
        raise ConfigError(f"--fps: need a positive number, got {args.fps}")
    replay = load(args.log)
    out_dir = args.out or args.log.parent
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = out_dir / args.log.stem
    if replay.recovered:
        print(f"coordarm replay: {args.log}: the log breaks off (run killed?); recovered {len(replay.t)} samples "
              f"up to t = {replay.t[-1]:.3f} s", file=sys.stderr)
    for problem in replay.problems:
        print(f"coordarm replay: {args.log}: {problem}", file=sys.stderr)
    run, ctrl = replay.to_run(), replay.controller()
    print_summary(run, replay.scenario)
    print(f"outcome       {replay.outcome.get('status')}"
          + (f": {replay.outcome['message']}" if "message" in replay.outcome else ""))
    for p in write_figures(run, replay.scenario, ctrl, stem, args.stages, outcome=replay.outcome.get("status", "")):
        print(f"figure        {p}")
    if not args.no_animation:
        from coordarm.analysis.animation import animate
        print(f"animation     {animate(replay, stem.with_name(stem.name + '.gif'), fps=args.fps, ctrl=ctrl)}")
    return 0
