"""``coordarm replay LOG.mcap``: re-draw a run's figures and an animation from its log alone."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from coordarm.analysis.replay_outputs import FPS_RANGE
from coordarm.commands.run import stage_list


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``replay`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
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
    """Replay the log named in ``args`` (:func:`~coordarm.analysis.replay_outputs.replay_log`): summary, figures,
    animation; returns 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``replay`` sub-command.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    LogError
        The log cannot be read (named, with what could be recovered), ``--out`` is a file, or a
        file cannot be written.
    ConfigError
        ``--fps`` outside :data:`FPS_RANGE`.
    """
    from coordarm.analysis.replay_outputs import replay_log

    replay_log(args.log, args.out, stages=args.stages, animation=not args.no_animation, fps=args.fps, progress=True,
               echo=print, on_problem=lambda text: print(f"coordarm replay: {text}", file=sys.stderr))
    return 0
