"""``coordarm run``: simulate a scenario, print a summary, write the log and figures."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from coordarm.simulation.choices import BACKENDS, COMPRESSIONS, DEFAULT_COMPRESSION, DENSE_LINKS, presets
from coordarm.symbolic.laws import LAWS


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``run`` sub-command.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The sub-parsers of the ``coordarm`` parser; the added parser sets ``func`` to :func:`main`.
    """
    p = sub.add_parser("run", help="simulate a scenario (preset or TOML file)",
                       description=f"Simulate a scenario: a preset ({', '.join(presets())}) or a TOML file. "
                                   "Prints a summary and writes the log and PNG figures next to it.")
    p.add_argument("scenario", metavar="SCENARIO_OR_TOML")
    p.add_argument("--links", type=int, help="override the number of links")
    p.add_argument("--duration", type=float, help="override the simulated duration [s]")
    p.add_argument("--step", type=float, help="override the RK4 step [s]")
    p.add_argument("--law", choices=LAWS, help="form of the control law")
    p.add_argument("--governor", action="store_true",
                   help="slow the commanded speed smoothly near the longitudinal singularity instead of stopping "
                        "(same as [control] governor = true)")
    p.add_argument("--backend", choices=BACKENDS, default="auto",
                   help="compiled C (built or taken from the cache), interpreted CasADi, or auto (default: "
                        "compiled when a C compiler is found, else interpreted with a warning)")
    p.add_argument("--out", type=Path, help="log file (default: logs/<scenario>.mcap); figures go beside it; "
                                            "an existing file is refused unless --overwrite")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out log")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimate (steps, log size, memory) is above the limits, or the dense "
                        f"law has more than {DENSE_LINKS} links")
    p.add_argument("--log-rate", type=float, metavar="HZ",
                   help="samples per simulated second in the log (default: every step)")
    p.add_argument("--cond-rate", type=float, metavar="HZ",
                   help="samples per simulated second of cond, the 1-norm condition number of the decoupling "
                        "matrix (exact up to 256 joints at 1 Hz by default, above an O(m) lower-bound estimate at 0.5 Hz; 0 = off; "
                        "the exact 2-norm value: coordarm report)")
    p.add_argument("--cond-exact", action="store_true",
                   help="log the exact 2-norm condition number instead (an SVD per sample, O(m^3): slow above "
                        "a few hundred links; default rate then 1 Hz up to 64 links, falling as 1/m^2, off above 1024)")
    p.add_argument("--compression", choices=COMPRESSIONS, default=DEFAULT_COMPRESSION,
                   help="chunk compression of the log: lz4 (default, 2-3x faster to write than zstd), zstd (a "
                        "~1.4x smaller file) or none (the cheapest to write, ~2.6x larger than zstd)")
    p.add_argument("--live", action="store_true",
                   help="serve the run over the Foxglove WebSocket protocol while it is simulated (paced to "
                        "real time, see --live-speed), writing the log too; in Foxglove: Open connection, "
                        "Foxglove WebSocket, ws://127.0.0.1:PORT")
    p.add_argument("--port", type=int, default=8765, help="port of the live server (default 8765; 0 = any free port)")
    p.add_argument("--live-speed", type=float, default=1.0, metavar="X",
                   help="simulated seconds per wall-clock second on the live view (default 1)")
    p.add_argument("--live-wait", action="store_true",
                   help="with --live: start simulating only once a client has subscribed and its subscriptions "
                        "settled (1 s without a new one): import the layout first, then connect")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override a field of the scenario, e.g. --set control.speed=0.05 (dotted TOML name or a "
                        "sweep alias; one value, parsed as coordarm sweep --vary parses one; repeatable)")
    p.add_argument("--log-frames", choices=("ends", "all"), default="ends",
                   help="frames on /tf (log and live view): ends = base and tip (default), all = one per link")
    p.add_argument("--no-figures", action="store_true", help="do not draw figures")
    p.add_argument("--stages", type=stage_list, metavar="T1,T2,...",
                   help="times [s] of the stage figure, e.g. 0,4,8,12 (default: [figures] stages, else 5 evenly)")
    p.add_argument("--allow-contact", action="store_true",
                   help="keep going after a collision, self-collision or joint limit and record every contact")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=main)


def stage_list(text: str) -> list[float]:
    """``"0,4,8,12"`` -> ``[0.0, 4.0, 8.0, 12.0]`` (argparse type of ``--stages``: finite times >= 0, sorted).

    Parameters
    ----------
    text : str
        Comma-separated times [s].

    Returns
    -------
    list of float
        The times [s], sorted.

    Raises
    ------
    argparse.ArgumentTypeError
        A value that is not a number, not finite or negative.
    """
    try:
        times = [float(v) for v in text.split(",")]
    except ValueError:
        times = []
    if not times or not all(math.isfinite(t) and t >= 0 for t in times):
        raise argparse.ArgumentTypeError(f"expected times in seconds >= 0 like 0,4,8,12, got {text!r}")
    return sorted(times)


def main(args: argparse.Namespace) -> int:
    """Run the scenario named in ``args``; return 0 (completed), 3 (singularity) or 4 (collision).

    The lines of :func:`~coordarm.simulation.session.run_scenario` are printed as they come
    (the live view's address before the run, the summary before the figures are drawn); its
    warnings and the reason of a stop go to standard error.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed options of the ``run`` sub-command.

    Returns
    -------
    int
        The exit status: 0 completed, 3 singularity, 4 collision.

    Raises
    ------
    ConfigError, LogError, BuildError, Interrupted
        As :func:`~coordarm.simulation.session.run_scenario` raises them.
    """
    from coordarm.simulation.session import run_scenario

    scenario = args.scenario
    if args.set:
        from coordarm.simulation.overrides import with_settings
        from coordarm.simulation.scenario import load_scenario

        scenario = with_settings(load_scenario(args.scenario), args.set)
    result = run_scenario(scenario, links=args.links, duration=args.duration, step=args.step, law=args.law,
                          governor=True if args.governor else None, backend=args.backend, log=args.out,
                          overwrite=args.overwrite, yes=args.yes, log_rate=args.log_rate, cond_rate=args.cond_rate,
                          cond_exact=args.cond_exact,
                          compression=args.compression, live=args.live, port=args.port, live_speed=args.live_speed,
                          live_wait=args.live_wait, figures=not args.no_figures, stages=args.stages,
                          allow_contact=args.allow_contact, progress=not args.quiet, echo=echo, on_warning=warn,
                          log_frames=args.log_frames)
    if result.stopped is not None:
        print(f"coordarm run: {result.stop_message()}", file=sys.stderr)
    late = [t for t in args.stages or () if len(result.run.t) and t > result.run.t[-1] + 1e-9]
    if late and not args.no_figures:
        end = "stop" if result.stopped is not None else "end"
        print(f"coordarm run: note: --stages {', '.join(f'{t:g}' for t in late)} s after the run's {end} "
              f"(t = {result.run.t[-1]:.2f} s): not drawn" + (" (the stop is)" if end == "stop" else ""),
              file=sys.stderr)
    return result.exit_status


def echo(line: str) -> None:
    """Print a line of the run on standard output at once (a live client waits for the address).

    Parameters
    ----------
    line : str
        A line of the run (``echo`` of :func:`~coordarm.simulation.session.run_scenario`).
        Once the reader of standard output has gone (``| head``), the run goes on silently.
    """
    from coordarm.symbolic.pipes import say

    say(line)


def warn(warning: Warning) -> None:
    """Print a warning of building or loading the law on standard error.

    Parameters
    ----------
    warning : Warning
        The warning (``on_warning`` of :func:`~coordarm.simulation.session.run_scenario`).
    """
    print(f"coordarm run: warning: {warning}", file=sys.stderr)
