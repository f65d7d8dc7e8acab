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
                                   "Python or CasADi: coordarm_law.c/.h, a Makefile (targets libcoordarm_law.a, "
                                   "libcoordarm_law.so, example, example_rt; the compiled law's flags), "
                                   "example.c, a fixed-step loop, and example_rt.c, a fixed-rate real-time loop "
                                   "printing the law's time and wake-up latency (./example_rt CYCLES [RATE_HZ]).")
    p.add_argument("scenario", metavar="SCENARIO_OR_TOML")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--overwrite", action="store_true", help="replace the files of an earlier export in --out")
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
        A bad scenario or override, an empty ``--out``.
    LogError
        ``--out`` is a file, or holds an earlier export and ``--overwrite`` is not given.
    BuildError
        A non-diagonal ``B``, or the output directory cannot be written.
    """
    from coordarm.generated.export import export_law
    from coordarm.simulation.scenario import load_scenario
    out = checked_out(args.out, args.overwrite)
    scenario = load_scenario(args.scenario, links=args.links, duration=args.duration, step=args.step)
    ctrl = scenario.controller()
    result = export_law(ctrl, scenario.start(ctrl), out, step=scenario.step, duration=scenario.duration,
                        t0=scenario.t0, scenario=scenario.name, source=str(scenario.source))
    for path in result.files:
        print(f"wrote         {path}")
    print(f"build         make -C {result.directory}   (libcoordarm_law.a, libcoordarm_law.so, example, example_rt)")
    return 0


def checked_out(text: str, overwrite: bool) -> Path:
    """The output directory of ``--out``, refused when empty, a file, or holding an export without ``overwrite``.

    Parameters
    ----------
    text : str
        The ``--out`` argument.
    overwrite : bool
        Replace the files of an earlier export (``--overwrite``).

    Returns
    -------
    Path
        The directory (not created yet).

    Raises
    ------
    ConfigError
        An empty ``--out`` (it would write into the current directory).
    LogError
        ``--out`` is a file, or one of the exported files is there already and ``overwrite`` is False.
    """
    from coordarm.generated.export import FILES
    from coordarm.symbolic.errors import ConfigError, LogError, shown

    if not text.strip():
        raise ConfigError("--out: empty; name the output directory (e.g. --out law/)")
    out = Path(text)
    if out.exists() and not out.is_dir():
        raise LogError(f"--out {shown(text)}: is a file, not a directory")
    there = [name for name in FILES if (out / name).exists()]
    if there and not overwrite:
        raise LogError(f"--out {shown(text)}: {there[0]} exists (an earlier export); pass --overwrite to replace it")
    return out
