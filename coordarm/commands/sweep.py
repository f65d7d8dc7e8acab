"""``coordarm sweep``: run a scenario over a grid (or a Latin hypercube) of parameters on Dask."""
from __future__ import annotations

import argparse
from pathlib import Path

from coordarm.simulation.choices import SWEEP_ALIASES, presets
from coordarm.symbolic.errors import ConfigError


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``sweep`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
    p = sub.add_parser("sweep", help="run a scenario over a grid of parameters (Dask: all cores or a cluster)",
                       description=f"Run a scenario (a preset: {', '.join(presets())}, or a TOML file) at every "
                                   "point of a parameter grid, on a local Dask cluster (one worker process per "
                                   "core) or on an existing one (--scheduler). Writes results.parquet, "
                                   "results.csv and figures to --out; re-running skips the points already there.")
    p.add_argument("scenario", metavar="SCENARIO_OR_TOML")
    p.add_argument("--vary", action="append", required=True, metavar="NAME=VALUES",
                   help="a scalar field by its dotted TOML name (control.gain, chain.links, curve.radius, ...; "
                        f"aliases: {', '.join(sorted(SWEEP_ALIASES))}) and its values: a list v1,v2,... or a range "
                        "start:stop:count; repeat for more names (grid = every combination)")
    p.add_argument("--samples", type=int, metavar="N",
                   help="N Latin-hypercube points over each name's range instead of the grid")
    p.add_argument("--random", type=int, default=0, metavar="SEED", help="seed of --samples (default 0)")
    p.add_argument("--out", type=Path, help="results directory (default: logs/<scenario>_sweep)")
    p.add_argument("--workers", type=int, metavar="N", help="local worker processes (default: one per core)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="use the Dask cluster of this scheduler")
    p.add_argument("--batch", type=int, metavar="N", help="points per Dask task (default: about 4 tasks per worker)")
    p.add_argument("--logs", action="store_true", help="keep each point's MCAP log in OUT/logs/")
    p.add_argument("--no-figures", action="store_true", help="do not draw figures")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--yes", action="store_true",
                   help="run a sweep of more than 2e9 RK4 steps (summed over its points) anyway")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Run the sweep, print the outcome counts and where the results and figures went.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``sweep`` sub-command.

    Returns
    -------
    int
        The exit status: 0 once every point has a row, whatever its outcome.

    Raises
    ------
    ConfigError
        A ``--vary`` name given twice, ``--workers`` or ``--batch`` < 1, or what
        :func:`~coordarm.simulation.sweep.sweep` refuses before any work.
    KeyboardInterrupt
        Ctrl-C (every finished row is written first; ``coordarm`` then exits with 130).
    """
    from coordarm.simulation.sweep import RESULTS, RESULTS_CSV, as_scenario, sweep
    from coordarm.simulation.sweep_points import OUTCOMES, parse_vary

    vary = dict(parse_vary(v) for v in args.vary)
    if len(vary) != len(args.vary):
        raise ConfigError("--vary: a name is given twice")
    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers: need a positive integer, got {args.workers}")
    if args.batch is not None and args.batch < 1:
        raise ConfigError(f"--batch: need a positive integer, got {args.batch}")
    scenario = as_scenario(args.scenario)
    out = args.out or Path("logs") / f"{scenario.name}_sweep"
    df = sweep(scenario, vary, client=args.scheduler, samples=args.samples, seed=args.random, out=out,
               logs=args.logs, workers=args.workers, batch=args.batch, progress=not args.quiet,
               yes=args.yes)
    counts = df["outcome"].value_counts()
    print(f"sweep         {scenario.name}: {len(df)} points, "
          + ", ".join(f"{counts.get(o, 0)} {o}" for o in OUTCOMES))
    print(f"results       {out / RESULTS}, {out / RESULTS_CSV}")
    if args.logs:
        print(f"logs          {out / 'logs'}")
    if not args.no_figures:
        from coordarm.analysis.sweep_figures import plot_sweep

        for path in plot_sweep(df, list(vary), out):
            print(f"figure        {path}")
    return 0
