"""``coordarm compare``: one scenario under the coordinating law and the classic baselines, side by side."""
from __future__ import annotations

import argparse
from pathlib import Path

from coordarm.simulation.choices import COMPARE_BACKENDS as BACKENDS
from coordarm.simulation.choices import COMPARE_METHODS as METHODS
from coordarm.simulation.choices import presets


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``compare`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
    p = sub.add_parser("compare", help="run a scenario under coordinating control and the baselines, score them",
                       description=f"Run a scenario (a preset: {', '.join(presets())}, or a TOML file; planar "
                                   "or spatial chain) under coordarm's coordinating law and the classic baselines "
                                   "(pinv: end-point resolved rate with the pseudoinverse and joint centering; "
                                   "dls: the same with damped least squares; ftl: follow-the-leader, rail robots "
                                   "only). Scores include the shape deviation in percent of the body length and "
                                   "the time per step. Prints a table and writes compare.md, compare.json and "
                                   "compare.png.")
    p.add_argument("scenario", metavar="SCENARIO_OR_TOML")
    p.add_argument("--methods", metavar="LIST",
                   help=f"comma-separated, from {','.join(METHODS)} (default: all that apply to the scenario)")
    p.add_argument("--out", type=Path, help="output directory (default: logs/<scenario>_compare)")
    p.add_argument("--duration", type=float, help="override the simulated duration [s]")
    p.add_argument("--backend", choices=BACKENDS, default="compiled",
                   help="every method as generated C (default; built or taken from the cache) or in CasADi's "
                        "virtual machine")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Compare the methods on ``args.scenario``; return 0.

    Prints the table and writes ``compare.md``, ``compare.json`` and ``compare.png`` to ``--out``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``compare`` sub-command.

    Returns
    -------
    int
        The exit status: 0.

    Raises
    ------
    ConfigError
        A bad scenario, override or ``--methods`` list.
    BuildError
        ``--backend compiled`` and a method cannot be built.
    """
    from coordarm.analysis.compare import compare, parse_methods, text_table, write_outputs
    from coordarm.simulation.scenario import load_scenario

    scenario = load_scenario(args.scenario, duration=args.duration)
    methods = parse_methods(args.methods, scenario)
    results = compare(scenario, methods, args.backend, progress=True)
    print(f"scenario {scenario.name} ({scenario.source}), {scenario.config.chain.links} links, "
          f"{scenario.duration:g} s")
    print(text_table(results))
    out = args.out or Path("logs") / f"{scenario.name}_compare"
    for kind, path in write_outputs(scenario, results, out, args.backend).items():
        print(f"{kind:<5} {path}")
    return 0
