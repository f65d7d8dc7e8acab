"""``coordarm export``: a scenario's law as plain C (a static library and an example loop)."""
from __future__ import annotations

import argparse
from pathlib import Path

from coordarm.simulation.choices import presets


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``export`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
    p = sub.add_parser("export", help="write a scenario's law as standalone C",
                       description="Write the coordinating law of a scenario (a preset: "
                                   f"{', '.join(presets())}, or a TOML file) as plain C that needs nothing of "
                                   "Python or CasADi: coordarm_law.c/.h, a Makefile (target libcoordarm_law.a) "
                                   "and example.c, a fixed-step loop.")
    p.add_argument("scenario", metavar="SCENARIO_OR_TOML")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="output directory")
    p.add_argument("--links", type=int, help="override the number of links")
    p.add_argument("--duration", type=float, help="override the example's duration [s]")
    p.add_argument("--step", type=float, help="override the example's RK4 step [s]")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Export the law of the scenario named in ``args``; return 0.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``export`` sub-command.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    ConfigError
        A bad scenario or override.
    BuildError
        A non-diagonal ``B``, or the output directory cannot be written.
    """
    from coordarm.generated.export import export_law
    from coordarm.simulation.scenario import load_scenario
    scenario = load_scenario(args.scenario, links=args.links, duration=args.duration, step=args.step)
    ctrl = scenario.controller()
    result = export_law(ctrl, scenario.start(ctrl), args.out, step=scenario.step, duration=scenario.duration,
                        t0=scenario.t0, scenario=scenario.name, source=str(scenario.source))
    for path in result.files:
        print(f"wrote         {path}")
    print(f"build         make -C {result.directory}   (libcoordarm_law.a and example)")
    return 0
