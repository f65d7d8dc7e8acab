"""``coordarm report``: singularity and condition report of a log or of a freshly simulated scenario."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from coordarm.symbolic.errors import ConfigError, LogError, shown

#: Allowed ``--samples``.
SAMPLES_RANGE = (2, 100_000)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``report`` sub-command."""
    p = sub.add_parser("report", help="singularity/condition report of a log (.mcap) or a scenario",
                       description="Write a Markdown report with PNG plots of every singularity margin over a "
                                   "run: a log (LOG.mcap) or a scenario (preset or TOML), simulated first without "
                                   "stopping at singularities so that a blow-up is visible.")
    p.add_argument("source", metavar="LOG.mcap|SCENARIO")
    p.add_argument("--out", type=Path, help="output directory (default: logs/<name>_report)")
    p.add_argument("--links", type=int, help="scenario only: override the number of links")
    p.add_argument("--duration", type=float, help="scenario only: override the duration [s]")
    p.add_argument("--samples", type=int,
                   help="margin samples over the run (default 1200 up to 64 links, then 1200 (64/m)^2, "
                        f"at least 100: each costs O(m^3); {SAMPLES_RANGE[0]} to {SAMPLES_RANGE[1]})")
    p.add_argument("--yes", action="store_true",
                   help="scenario only: simulate even when the estimated steps or memory are above the limits")
    p.set_defaults(func=main)


def simulate_scenario(scenario: Any) -> Any:
    """Simulate ``scenario`` without singularity stops; a run ending in NaN is kept up to there."""
    from coordarm.analysis.report import simulate_through

    ctrl = scenario.controller()
    return simulate_through(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, scenario.t0)


def main(args: argparse.Namespace) -> int:
    """Write the report for ``args.source``; print where it went; return 0."""
    import numpy as np

    from coordarm.simulation.limits import check_cost, estimate
    from coordarm.simulation.scenario import load_scenario

    from coordarm.analysis.report import default_samples, write_report

    from coordarm.commands.replay import output_directory, report_condition

    if args.samples is not None and not SAMPLES_RANGE[0] <= args.samples <= SAMPLES_RANGE[1]:
        raise ConfigError(f"--samples: need {SAMPLES_RANGE[0]} to {SAMPLES_RANGE[1]}, got {shown(args.samples)}")
    src = str(args.source)
    if src.endswith(".mcap"):
        if args.links is not None or args.duration is not None:
            raise ConfigError("--links/--duration: only for a scenario, not for a log")
        from coordarm.analysis.replay import load
        run = load(src)
        report_condition(run, "coordarm report")
        if not len(run.t):
            raise LogError(f"{src}: the log holds no samples; nothing to report")
        scenario = run.scenario
    else:
        scenario = load_scenario(src).with_overrides(args.links, args.duration)
        check_cost(estimate(scenario.chain().m, scenario.step, scenario.duration, logged=False), args.yes)
        run = simulate_scenario(scenario)
    out = output_directory(args.out or Path("logs") / f"{scenario.name}_report")
    m = np.shape(run.q)[1]
    if m > 128:  # about a second per 1000 samples at 64 links, a second per sample at 1024
        print(f"report: margins at {args.samples or default_samples(m)} samples of a {m}-link chain "
              "(an SVD and a QR of the m x m decoupling matrix each) ...", file=sys.stderr, flush=True)
    path = write_report(run, scenario, out, samples=args.samples)
    print(f"report        {path}", file=sys.stdout)
    for png in sorted(path.parent.glob("*.png")):
        print(f"figure        {png}")
    return 0
