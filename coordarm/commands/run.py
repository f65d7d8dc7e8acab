"""``coordarm run``: simulate a scenario, print a summary, write the log and figures."""
from __future__ import annotations

import argparse
import os
import sys
import warnings
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator, TextIO

from coordarm.simulation.choices import BACKENDS, COMPRESSIONS, DENSE_LINKS, presets
from coordarm.symbolic.errors import LogError
from coordarm.symbolic.laws import LAWS

if TYPE_CHECKING:   # the simulation modules load numpy, CasADi, matplotlib: only when the command runs
    from coordarm.simulation.run import Run
    from coordarm.simulation.scenario import Scenario


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``run`` sub-command."""
    p = sub.add_parser("run", help="simulate a scenario (preset or TOML file)",
                       description=f"Simulate a scenario: a preset ({', '.join(presets())}) or a TOML file. "
                                   "Prints a summary and writes the log and PNG figures next to it.")
    p.add_argument("scenario", metavar="SCENARIO_OR_TOML")
    p.add_argument("--links", type=int, help="override the number of links")
    p.add_argument("--duration", type=float, help="override the simulated duration [s]")
    p.add_argument("--step", type=float, help="override the RK4 step [s]")
    p.add_argument("--law", choices=LAWS, help="form of the control law")
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
                   help="samples per simulated second of cond (an SVD each; default 5 Hz up to 64 links, "
                        "then falling as 1/m^2; 0 = off)")
    p.add_argument("--compression", choices=COMPRESSIONS, default="zstd",
                   help="chunk compression of the log: zstd (default, smaller) or lz4 (faster)")
    p.add_argument("--live", action="store_true",
                   help="serve the run over the Foxglove WebSocket protocol while it is simulated (paced to "
                        "real time, see --live-speed), writing the log too; in Foxglove: Open connection, "
                        "Foxglove WebSocket, ws://127.0.0.1:PORT")
    p.add_argument("--port", type=int, default=8765, help="port of the live server (default 8765; 0 = any free port)")
    p.add_argument("--live-speed", type=float, default=1.0, metavar="X",
                   help="simulated seconds per wall-clock second on the live view (default 1)")
    p.add_argument("--live-wait", action="store_true",
                   help="with --live: start simulating only once a client has subscribed")
    p.add_argument("--no-figures", action="store_true", help="do not draw figures")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=main)


def print_summary(run: Run, scenario: Scenario, out: TextIO | None = None) -> None:
    """Human-readable summary of a run (to ``out``, standard output by default)."""
    from coordarm.simulation.obstacles import clearance, wall_crossings

    out = sys.stdout if out is None else out
    s = run.summary()
    lines = [f"scenario      {scenario.name} ({scenario.source}), {run.q.shape[1]} links",
             f"simulated     {s['duration']:.3f} s in {s['steps']} steps ({run.info.get('stopped', '?')}, "
             f"backend {run.info.get('backend', '?')})",
             f"final max|e|  {s['final_max_abs_e']:.3e} m",
             f"s tracking    max |s - (s0 + ∫v*)| = {s['max_s_tracking_error']:.3e} m",
             f"link margin   min {s['min_link_margin']:.4f} (link {s['min_link_margin_link']}, "
             f"t = {s['min_link_margin_time']:.2f} s)",
             f"longitudinal  min {s['min_longitudinal_margin']:.4f} (t = {s['min_longitudinal_margin_time']:.2f} s)",
             f"max|u|        {s['max_abs_u']:.4g}"]
    if len(scenario.obstacles):
        joints = scenario.chain().joints_np(run.q) if run.q.shape[1] == scenario.chain().m else None
        if joints is not None:
            hits = wall_crossings(joints, scenario.obstacles)
            if len(hits):
                k, link, wall = hits[0]
                lines.append(f"walls         COLLISION: link {link} touches wall {wall} at t = {run.t[k]:.3f} s "
                             f"({len(hits)} contacts)")
            else:
                lines.append(f"walls         no link touches a wall (min clearance "
                             f"{clearance(joints, scenario.obstacles).min():.4f} m)")
    print("\n".join(lines), file=out)


def write_figures(run: Run, scenario: Scenario, ctrl, stem: Path) -> list[Path]:
    """Stage and tracking figures as ``<stem>_stages.png`` and ``<stem>_tracking.png``."""
    from coordarm.simulation.figures import plot_stages, plot_tracking

    title = f"{scenario.name}: {ctrl.chain.m} links"
    stages, tracking = stem.with_name(stem.name + "_stages.png"), stem.with_name(stem.name + "_tracking.png")
    with writing(stages):
        plot_stages(run, ctrl, stages, walls=scenario.obstacles,
                    title=f"{title}, stages of the motion (dashed: the curve at that time)")
    with writing(tracking):
        plot_tracking(run, ctrl.gain, tracking, thresholds=scenario.thresholds, title=title)
    return [stages, tracking]


@contextmanager
def writing(path: Path) -> Iterator[None]:
    """Turn an OSError while writing ``path`` (a full disk, a read-only file system) into a LogError naming it."""
    try:
        yield
    except OSError as exc:
        raise LogError(f"{path}: cannot write it: {exc.strerror or exc}") from None


def _both(first: Callable[[Run], None], second: Callable[[Run], None]) -> Callable[[Run], None]:
    """One ``on_chunk`` that hands each block to ``first`` then ``second``."""
    def on_chunk(part: Run) -> None:
        first(part)
        second(part)
    return on_chunk


def main(args: argparse.Namespace) -> int:
    """Run the scenario named in ``args``; return 0 (done), 3 (stopped ahead of a singularity).

    The log is opened as soon as the controller exists, so that however the run ends (an
    interrupt while compiling, a build error, a singularity) it is closed with its outcome.
    """
    from coordarm.simulation.limits import GainStepWarning, check_cost, check_gain_step, estimate
    from coordarm.simulation.live import LiveView
    from coordarm.simulation.mcap_writer import RunLogger
    from coordarm.simulation.run import BackendFallbackWarning, select_backend, simulate
    from coordarm.simulation.scenario import load_scenario
    from coordarm.symbolic.errors import ConfigError, SingularityError

    scenario = load_scenario(args.scenario).with_overrides(args.links, args.duration, args.step, law=args.law)
    check_cost(estimate(scenario.chain().m, scenario.step, scenario.duration, args.log_rate), args.yes)
    m = scenario.spec["chain"]["links"]
    if scenario.spec["control"]["law"] == "dense" and m > DENSE_LINKS and not args.yes:
        raise ConfigError(f"--law dense with {m} links: generating and compiling it takes many minutes "
                          f"(its size grows as m^2); use the structured law, or pass --yes")
    out = args.out or Path("logs") / f"{scenario.name}.mcap"
    overwrite = args.overwrite or args.out is None   # the default log is a scratch file
    if out.exists() and not out.is_file():
        raise LogError(f"--out {out}: not a regular file; choose a log file name")
    if not overwrite and out.exists():
        raise LogError(f"--out {out}: exists; choose another file or pass --overwrite")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise LogError(f"--out {out}: cannot create its directory: {exc.strerror or exc}") from None
    ctrl = scenario.controller()
    status = 0
    with ExitStack() as stack:
        live = None
        if args.live:
            live = stack.enter_context(LiveView(scenario, ctrl, port=args.port, speed=args.live_speed))
            print(f"live          {live.url} (Foxglove: Open connection, Foxglove WebSocket)", flush=True)
            if args.live_wait:
                live.wait_for_client()
        try:
            # The log is closed with its outcome however the run ends (singularity, error, Ctrl-C).
            # With a second core, encoding and compression overlap the simulation (RESULTS_logging.md).
            with RunLogger(out, scenario, ctrl, log_rate=args.log_rate, cond_rate=args.cond_rate,
                           compression=args.compression, overwrite=overwrite,
                           threaded=(os.cpu_count() or 1) > 1) as log:
                q0 = scenario.start(ctrl)
                with warnings.catch_warnings(record=True) as caught:   # builds or loads the library
                    warnings.simplefilter("always", BackendFallbackWarning)
                    check_gain_step(ctrl.gain, scenario.step)
                    backend, compiled, _ = select_backend(ctrl, args.backend)
                for w in caught:
                    print(f"coordarm run: warning: {w.message}", file=sys.stderr)
                log.set_backend(backend, compiled.library.key if compiled else None)
                on_chunk = log.on_chunk if live is None else _both(log.on_chunk, live.on_chunk)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", GainStepWarning)   # said above already
                    run = simulate(ctrl, q0, scenario.duration, scenario.step, scenario.t0, backend=backend,
                                   thresholds=scenario.thresholds, progress=not args.quiet, on_chunk=on_chunk)
        except SingularityError as err:
            print(f"coordarm run: {err}", file=sys.stderr)
            run, status = err.run, 3
    print_summary(run, scenario)
    if compiled:
        print(f"library       {compiled.library.path} ({'cache hit' if compiled.cache_hit else 'built now'})")
    print(f"log           {out}")
    if not args.no_figures:
        for p in write_figures(run, scenario, ctrl, out.with_suffix("")):
            print(f"figure        {p}")
    return status
