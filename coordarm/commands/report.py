"""``coordarm report``: singularity and condition report of a log or of a freshly simulated scenario."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from coordarm.analysis.report_outputs import SAMPLES_RANGE


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``report`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
    p = sub.add_parser("report", help="singularity/condition report of a log (.mcap) or a scenario",
                       description="Write a Markdown report with PNG plots of every singularity margin over a "
                                   "run: a log (LOG.mcap) or a scenario (preset or TOML), simulated first without "
                                   "stopping at singularities so that a blow-up is visible.")
    p.add_argument("source", metavar="LOG.mcap|SCENARIO")
    p.add_argument("--out", type=Path, help="output directory (default: <log folder>/<log name>_report for a log, "
                                            "logs/<scenario>_report for a scenario)")
    p.add_argument("--overwrite", action="store_true", help="replace the report in an existing --out")
    p.add_argument("--links", type=int, help="scenario only: override the number of links")
    p.add_argument("--duration", type=float, help="scenario only: override the duration [s]")
    p.add_argument("--samples", type=int,
                   help="margin samples over the run (default 1200 up to 64 links, then 1200 (64/m)^2, "
                        f"at least 100: each costs O(m^3); {SAMPLES_RANGE[0]} to {SAMPLES_RANGE[1]})")
    p.add_argument("--yes", action="store_true",
                   help="scenario only: simulate even when the estimated steps or memory are above the limits")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Write the report for ``args.source`` (:func:`~coordarm.analysis.report_outputs.report_of`); print where
    it went; return 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``report`` sub-command.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    ConfigError, LogError
        As :func:`~coordarm.analysis.report_outputs.report_of` raises them (a bad source, option or
        ``--samples``, an unreadable log, an unwritable output).
    """
    from coordarm.analysis.report_outputs import report_of

    result = report_of(args.source, args.out, links=args.links, duration=args.duration, samples=args.samples,
                       yes=args.yes, overwrite=args.overwrite,
                       on_problem=lambda text: print(f"coordarm report: {text}", file=sys.stderr),
                       on_note=lambda text: print(text, file=sys.stderr, flush=True))
    print(f"report        {result.path}", file=sys.stdout)
    for png in result.figures:
        print(f"figure        {png}")
    return 0
